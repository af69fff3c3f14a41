"""Forces and torques on rotor magnets from solved iron cores (:mod:`._iron`): the pair tables, the Fig. 6
experiment, the full multi-body solve and the saturating pair torque.

Force on a magnet. By Newton's third law the wrench on a magnet is minus the wrench of the magnet's field on the
core's cells (dipoles ``J_i ΔV/μ0`` at Gauss points, :func:`._iron.cell_quadrature`) and on the winding
(``getFT`` on its loops); the magnet is the only field needed there, so every pose is one vectorised magpylib
call.

Linearity. With a linear core every field is linear in its sources, so for one magnet of polarity ``p`` and one
coil at current ``c`` (per nominal) the wrench on the magnet is ``W = W_detent + p c W_linear`` with
``W_detent`` from the iron magnetised by the magnet itself (``p² = 1``: the same for both polarities) and
``W_linear`` from the winding plus the iron it magnetises; a ``c²`` term acts only inside the stator.
Saturating iron breaks that: :func:`saturated_pair_torque` solves each current on its own.
"""

from __future__ import annotations

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from ._iron import IRON_LEVEL, CoreGeometry, CoreSolver, cell_quadrature, core_solver, dipole_wrench, \
    magnet_face_radius, rotor_magnet
from ._model import MU0, z_to


def _reaction(solver: CoreSolver, J: np.ndarray, source, pivot, order: int):
    """Wrench (N, N·m about ``pivot``; ``(K, 3)`` each) of ``source``'s field on the cells polarised ``J``
    (``(n, 3)`` or ``(K, n, 3)``), each cell a set of dipoles ``J ΔV_q / μ0`` at its Gauss points."""
    pts, w, owner = cell_quadrature(solver.cells, order, near=solver.near)
    n = len(solver.cells)
    K = len(source.position) if np.ndim(source.position) == 2 else 1
    if isinstance(source, magpy.Collection):
        K = len(source.orientation.as_quat().reshape(-1, 4))
    J = np.broadcast_to(np.asarray(J, dtype=float).reshape(-1, n, 3), (K, n, 3))
    m = J[:, owner] * (w / MU0)[None, :, None]
    return dipole_wrench(pts, m, source, pivot)


def magnet_wrenches(design, coil, centres, axes, pivot, level: int = IRON_LEVEL, order: int = 3):
    """Force (N) and torque (N·m about ``pivot``) on one ``+1`` rotor magnet at ``K`` poses (``centres``,
    ``axes`` ``(K, 3)``, coil frame: axis ``+z``, face at ``z = 0``) from one iron-cored coil, split as
    ``(F_detent, T_detent, F_linear, T_linear)``, each ``(K, 3)``; ``linear`` per nominal current.

    Newton's third law: the wrench on the magnet is minus the wrench of the magnet's field on the core's cells
    (dipoles ``J_i ΔV/μ0`` at ``order³`` Gauss points per cell) and on the winding (``getFT`` on its loops).
    The magnet is the only field needed there, so every pose is one vectorised magpylib call.
    """
    solver = core_solver(CoreGeometry.of(design, coil), level)
    loops = solver.loops[0]
    J_coil = solver.polarization(magpy.getB(loops, solver.centroids, sumup=True))
    magnet = rotor_magnet(design, centres, axes)
    K = len(magnet.position) if np.ndim(magnet.position) == 2 else 1
    J_mag = solver.polarization(magpy.getB(magnet, solver.centroids, squeeze=False).reshape(K, -1, 3))
    Fd, Td = _reaction(solver, J_mag, magnet, pivot, order)
    Fi, Ti = _reaction(solver, J_coil, magnet, pivot, order)
    Fw, Tw = magpy.getFT(magnet, loops, pivot=np.asarray(pivot, dtype=float), meshing=64, squeeze=False)[:2]
    Fw = Fw[0].sum(axis=1)  # (1 source, K, n_loops, 3) → (K, 3)
    Tw = Tw[0].sum(axis=1)
    return -Fd, -Td, -(Fi + Fw), -(Ti + Tw)


def pole_poses(design, alpha, phi=0.0, shell: float | None = None) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Rotor magnets at angles ``alpha`` (rad) from a coil's axis and azimuths ``phi`` (rad; broadcast) about it,
    in the coil's frame (axis ``+z``, face at ``z = 0``): centres ``(K, 3)``, radial axes ``(K, 3)``, and the
    sphere's centre ``(0, 0, −R_s − g)`` as the pivot; ``shell`` the rotor's wall (m, default
    the design's ``rotor_shell``, see :func:`magnet_face_radius`)."""
    a, p = np.broadcast_arrays(np.atleast_1d(np.asarray(alpha, dtype=float)), np.asarray(phi, dtype=float))
    face = design.radius + design.air_gap
    w = np.stack([np.sin(a) * np.cos(p), np.sin(a) * np.sin(p), np.cos(a)], axis=-1).reshape(-1, 3)
    centres = (magnet_face_radius(design, shell) - 0.5 * design.magnet_length) * w - [0.0, 0.0, face]
    return centres, w, (0.0, 0.0, -face)


def pair_tables(design, coil, alpha, level: int = IRON_LEVEL, order: int = 3,
                shell: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(detent, linear)`` torques ``τ(α)`` (N·m) on one ``+1`` pole at angles ``alpha`` (rad) from an iron-cored
    coil's axis, about the sphere's centre, positive away from the axis (the convention of ``pair_torque``);
    ``linear`` per nominal current. The torque at current ``c`` on a pole of polarity ``p`` is
    ``detent + p c linear``. The magnet's face is at :func:`magnet_face_radius` (of ``shell``, m)."""
    centres, w, pivot = pole_poses(design, alpha, shell=shell)
    _, Td, _, Tl = magnet_wrenches(design, coil, centres, w, pivot, level, order)
    return Td[:, 1], Tl[:, 1]


def fig6_forces(design, coil, displacements, gap: float | None = None, level: int = IRON_LEVEL,
                order: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """The Fig. 6 experiment with the iron core: force (N) on one ``+1`` magnet translated by ``displacements``
    (m) along ``x`` at ``gap`` (m; default the on-axis face gap of the ball, ``R_s + g − √(R_s² − r_m²)``) below
    the face, axis parallel to the coil's: ``(detent, linear)``, each ``(len(x), 3)``; the force at current ``c``
    is ``detent + c linear``."""
    g = design.radius + design.air_gap - magnet_face_radius(design) if gap is None else float(gap)
    x = np.atleast_1d(np.asarray(displacements, dtype=float))
    centres = np.stack([x, np.zeros_like(x), np.full_like(x, -g - 0.5 * design.magnet_length)], 1)
    axes = np.tile([0.0, 0.0, 1.0], (len(x), 1))
    Fd, _, Fl, _ = magnet_wrenches(design, coil, centres, axes, (0.0, 0.0, 0.0), level, order)
    return Fd, Fl


def rotor_iron_torque(design, coil, coils, R, currents, level: int = 0, order: int = 3) -> np.ndarray:
    """Full multi-body solve: torque (N·m, fixed frame, about the centre) on the whole rotor at orientations
    ``R (K, 3, 3)`` from the iron-cored coils ``coils`` (indices into ``design.stator``) solved together, with
    currents ``currents (len(coils),)`` per nominal; every rotor magnet drives every core. The reference the
    pairwise model is checked against."""
    geom = CoreGeometry.of(design, coil)
    face = design.radius + design.air_gap
    v = design.stator.centers[np.asarray(coils, dtype=int)]
    rots = z_to(v)
    solver = CoreSolver(geom, level, [(rots[i], face * v[i]) for i in range(len(v))])
    R = np.asarray(R, dtype=float).reshape(-1, 3, 3)
    u = design.rotor.centers
    r_c = magnet_face_radius(design) - 0.5 * design.magnet_length
    rotor = magpy.Collection(*[rotor_magnet(design, r_c * uj[None], uj[None], float(p))
                               for uj, p in zip(u, design.polarity)])
    rotor.orientation = Rotation.from_matrix(R)
    c = np.asarray(currents, dtype=float)
    loops = [lp for k, group in enumerate(solver.loops) for lp in group if c[k] != 0]
    B_src = magpy.getB(rotor, solver.centroids, squeeze=False).reshape(len(R), -1, 3)
    if loops:
        for k, group in enumerate(solver.loops):
            for lp in group:
                lp.current = c[k] * geom.NI / len(group)
        B_src = B_src + magpy.getB(loops, solver.centroids, sumup=True)[None]
    J = solver.polarization(B_src)
    _, T = _reaction(solver, J, rotor, (0.0, 0.0, 0.0), order)
    if loops:
        _, Tw = magpy.getFT(rotor, loops, pivot=(0.0, 0.0, 0.0), meshing=64, squeeze=False)[:2]
        T = T + Tw[0].sum(axis=1)
    return -T



def saturated_pair_torque(design, coil, alpha: float, current: float, level: int = IRON_LEVEL,
                          order: int = 3) -> tuple[float, float, float]:
    """Torque (N·m about the sphere's centre, positive away from the axis, as :func:`pair_tables`) on one ``+1``
    pole at ``alpha`` (rad) from one iron-cored coil at ``current`` (per nominal), with the iron saturating
    (:meth:`CoreSolver.saturated_polarization`, ``coil.material``'s B–H curve); returns ``(torque, largest |B| in
    a cell (T), iterations)``. Not linear in the current: each current is its own solve."""
    geom = CoreGeometry.of(design, coil)
    solver = core_solver(geom, level)
    centre, w, pivot = pole_poses(design, alpha)
    magnet = rotor_magnet(design, centre, w)
    B = magpy.getB(magnet, solver.centroids)
    loops = solver.loops[0]
    if current:
        B = B + current * magpy.getB(loops, solver.centroids, sumup=True)
    J, flux, iterations = solver.saturated_polarization(B, coil.material)
    _, T = _reaction(solver, J, magnet, pivot, order)
    torque = -T[0]
    if current:
        Tw = magpy.getFT(magnet, loops, pivot=np.asarray(pivot, dtype=float), meshing=64, squeeze=False)[1]
        torque = torque - current * Tw[0].sum(axis=1)[0]
    return float(torque[1]), float(flux.max()), iterations
