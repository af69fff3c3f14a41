"""Force and torque on the rotor straight from ``magpylib.getFT`` (the reference the torque map is checked
against).

``getFT`` cuts each target magnet into about ``meshing`` cylindrical cells, treats each cell as a dipole of
moment ``m = M ΔV`` and sums ``F = (m · ∇) B`` (central differences with step ``eps``) and
``T = m × B + (r − r0) × F`` about the pivot ``r0``, here the sphere's centre. The rotor is the target (a
``Collection`` with a path of orientations, which magpylib vectorises), the coils are the sources (one per
coil at unit current), so one call gives the wrench of every coil at every orientation; currents enter
afterwards by superposition, ``T(R, c) = Σ_k c_k T_k(R)``, exact because ``B`` is linear in the coil
polarization and the force linear in ``B``.

Mesh convergence (prototype, one pole and one coil, largest error over 0.5°–30°, always where the magnet's
rim passes under the coil's, against 8000 cells): 1 cell 38 %, 8 cells 4.2 %, 27 cells 1.6 %, 64 cells 2.0 %,
216 cells 0.64 %, 1000 cells 0.10 %, 3000 cells 0.017 % of the peak pair torque (0.414 N·m at 8°); roughly
1/cells from 64 cells on. Results are in the fixed frame, N and N·m.
"""

from __future__ import annotations

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from ..errors import bad_value
from ._model import (as_meshing, as_rotations, currents_for, rotor_collection, rotor_magnets, stator_coils,
                     unflatten, z_to)

MESHING = 216  # default cells per magnet for direct evaluation (0.6 % of the peak pair torque)
EPS = 1e-6  # finite-difference step (m) for ∇B; 1e-5 and 1e-7 agree to 1e-7 of the peak torque
LOOPS = 32  # current loops per coil in :func:`reaction`
SEGMENTS = 64  # straight pieces per loop in :func:`reaction`
BUDGET = 3_000_000  # source × observer evaluations per getFT call (bounds memory to ~0.5 GB)


def _chunks(K: int, per_orientation: int):
    step = max(1, BUDGET // max(per_orientation, 1))
    return [slice(s, min(K, s + step)) for s in range(0, K, step)]


def _coil_indices(design, coils) -> np.ndarray:
    N = len(design.stator)
    if coils is None:
        return np.arange(N)
    idx = np.asarray(coils)
    if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer) or np.any((idx < 0) | (idx >= N)):
        raise bad_value("coils", f"coil indices in 0..{N - 1}", np.asarray(coils).tolist())
    return idx.astype(int)


def coil_wrenches(design, R, coils=None, meshing: int = MESHING) -> tuple[np.ndarray, np.ndarray]:
    """Force ``F_k(R)`` (N) and torque ``T_k(R)`` (N·m, about the sphere's centre) on the rotor from each coil
    ``k`` in ``coils`` (default all) at unit current, shapes ``(K, n, 3)``, fixed frame.

    The torque of any drive is then ``T(R, c) = Σ_k c_k T_k(R)``.
    """
    R, _ = as_rotations(R)
    idx = _coil_indices(design, coils)
    meshing = as_meshing(meshing)
    K, n = len(R), len(idx)
    F = np.zeros((K, n, 3))
    T = np.zeros((K, n, 3))
    if K == 0 or n == 0:
        return F, T
    sources = stator_coils(design, idx)
    for sl in _chunks(K, n * len(design.rotor) * meshing * 7):
        rotor = rotor_collection(design, R[sl])
        f, t = magpy.getFT(sources, rotor, pivot=(0.0, 0.0, 0.0), meshing=meshing, eps=EPS, squeeze=False)
        F[sl] = np.swapaxes(f[:, :, 0, :], 0, 1)  # (n_src, p, 1 target, 3) -> (p, n_src, 3)
        T[sl] = np.swapaxes(t[:, :, 0, :], 0, 1)
    return F, T


def force_torque(design, R, currents, meshing: int = MESHING) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and torque (N·m) on the rotor about the sphere's centre, fixed frame, by ``magpylib.getFT``.

    ``R``: rotor orientation ``(3, 3)`` or ``(K, 3, 3)``; ``currents``: one per coil, ``(N,)`` or ``(K, N)``,
    nominal ``±1`` (``coil_ampere_turns`` ampere-turns; ``+1`` attracts a north-out pole), 0 off. Returns
    arrays of shape ``(3,)`` for one orientation, else ``(K, 3)``. Only coils with some current are
    evaluated; ``meshing`` is the number of cells per rotor magnet (see the module's convergence notes).
    """
    R, batch = as_rotations(R)
    c = currents_for(currents, len(design.stator), design.failed_coils, batch)
    active = np.nonzero(np.any(c != 0, axis=0))[0]
    Fk, Tk = coil_wrenches(design, R, active, meshing)
    F = np.einsum("kn,kni->ki", c[:, active], Fk)
    T = np.einsum("kn,kni->ki", c[:, active], Tk)
    return unflatten(F, batch), unflatten(T, batch)


def torque(design, R, currents, meshing: int = MESHING) -> np.ndarray:
    """Torque (N·m) on the rotor about the sphere's centre, fixed frame; see :func:`force_torque`."""
    return force_torque(design, R, currents, meshing)[1]


def force(design, R, currents, meshing: int = MESHING) -> np.ndarray:
    """Net force (N) on the rotor (what the bearings carry), fixed frame; see :func:`force_torque`."""
    return force_torque(design, R, currents, meshing)[0]


def reaction(design, R, currents, loops: int = LOOPS, segments: int = SEGMENTS) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and torque (N·m, about the sphere's centre) on the stator coils from the rotor's magnets.

    An independent computation of the same interaction as :func:`force_torque`, seen from the other side:
    here the coils are the targets and the rotor magnets the sources, so by Newton's third law the result
    is minus :func:`force_torque`'s. Each coil is taken as its Amperian equivalent, ``loops`` coaxial
    :class:`magpylib.current.Circle` loops of the coil's diameter at the mid-points of ``loops`` equal
    slices of its length, each carrying ``c_k NI / loops`` amperes (the same moment and, outside, the same
    field as the uniformly magnetised cylinder), and ``getFT`` sums ``I dl × B`` over ``segments`` straight
    pieces per loop. A surface integral of ``B`` converges much faster here than a volume mesh of the
    coil, whose face sits 0.13 mm from magnets of 1.3 T (loops 16 → 48 changes the force by 0.3 %).

    For speed the computation runs in the rotor's frame, where the rotor stands still and the loops move
    along target paths ``Rᵀ x`` (vectorised by magpylib); results are turned back with ``R``.
    """
    R, batch = as_rotations(R)
    c = currents_for(currents, len(design.stator), design.failed_coils, batch)
    loops = as_meshing(loops, "loops")
    segments = as_meshing(segments, "segments")
    if segments < 4:
        raise bad_value("segments", "at least 4 straight pieces per loop (magpylib's minimum)", segments)
    active = np.nonzero(np.any(c != 0, axis=0))[0]
    K = len(R)
    F = np.zeros((K, 3))
    T = np.zeros((K, 3))
    if len(active) and K:
        magnets = rotor_magnets(design)
        v = design.stator.centers[active]
        base = z_to(v)
        heights = design.radius + design.air_gap + (np.arange(loops) + 0.5) / loops * design.coil_length
        amps = design.coil_ampere_turns / loops
        for sl in _chunks(K, len(magnets) * len(active) * loops * segments):
            Rt = np.swapaxes(R[sl], 1, 2)
            body = Rotation.from_matrix(Rt)
            targets = [magpy.Collection(*[magpy.current.Circle(diameter=design.coil_diameter, current=amps,
                                                               position=h * (Rt @ vk), orientation=body * base[i])
                                          for h in heights])
                       for i, vk in enumerate(v)]
            f, t = magpy.getFT(magnets, targets, pivot=(0.0, 0.0, 0.0), meshing=segments, squeeze=False)
            f = f.sum(axis=0)  # (p, n_coils, 3) in the rotor frame
            t = t.sum(axis=0)
            cf = c[sl][:, active]
            F[sl] = np.einsum("kij,kj->ki", R[sl], np.einsum("kn,kni->ki", cf, f))
            T[sl] = np.einsum("kij,kj->ki", R[sl], np.einsum("kn,kni->ki", cf, t))
    return unflatten(F, batch), unflatten(T, batch)
