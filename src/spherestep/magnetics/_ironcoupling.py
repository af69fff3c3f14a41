"""The coupling the pair tables leave out: the energy of one rotor magnet in the iron another magnet
magnetises, through the cores solved together (:mod:`._iron`), and its torque; the per-core table
(:func:`cross_energy_table`) the model :class:`._coupling.CoreCoupling` interpolates.
"""

from __future__ import annotations

import math
from functools import lru_cache

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from ._iron import IRON_LEVEL, CoreGeometry, CoreSolver, cell_quadrature, core_solver, magnet_face_radius, \
    rotor_magnet
from ._ironforce import pole_poses
from ._model import MU0, z_to


COUPLING_REACH = math.radians(40.0)  # magnets farther than this from every core are left out of the coupling
COUPLING_STEP = 1e-4  # rad: central differences of the coupling energy


def coupling_energy(design, coil, coils, R, level: int = 0, reach: float = COUPLING_REACH, order: int = 3):
    """The energy (J) the pair tables leave out, coils off: magnet ``q`` in the iron that magnet ``p ≠ q``
    magnetises, with the cores ``coils`` solved together (so they also magnetise each other) at orientation
    ``R (3, 3)``. For linear iron the energy of the polarised cores in the magnets' field is
    ``W = −(1/2μ0) Σ_pq s_p s_q ∫ J_p · B_q dV`` (``J_p`` the polarization the solve gives for magnet ``p`` alone,
    the integral by the cells' Gauss points); the pair tables hold the ``p = q`` terms, this returns the rest,
    symmetrised (``∫ J_p·B_q`` and ``∫ J_q·B_p`` agree only to the discretisation), over the magnets within
    ``reach`` of a core."""
    geom = CoreGeometry.of(design, coil)
    face = design.radius + design.air_gap
    v = design.stator.centers[np.asarray(coils, dtype=int)]
    solver = _placed_solver(geom, level, tuple(map(tuple, v)), face)
    w = np.asarray(R, dtype=float) @ design.rotor.centers.T  # (3, M): the poles' directions
    near = np.flatnonzero(np.max(v @ w, axis=0) > math.cos(reach))
    r_c = magnet_face_radius(design) - 0.5 * design.magnet_length
    magnets = [rotor_magnet(design, r_c * w[:, j][None], w[:, j][None], float(design.polarity[j])) for j in near]
    J, B = polarized_and_integrated(solver, magnets, order)
    G = np.einsum("pic,qic->pq", J, B) / MU0
    G = 0.5 * (G + G.T)
    return float(-0.5 * (G.sum() - np.trace(G)))


def polarized_and_integrated(solver: CoreSolver, magnets, order: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """For each magnet alone: the cells' polarization ``J (m, n, 3)`` (T) and the magnet's field integrated over
    each cell ``(m, n, 3)`` (T·m³, the cells' Gauss points): ``−(1/μ0) Σ_i J_p,i · B_q,i`` is the energy of magnet
    ``q`` in the iron magnet ``p`` polarises."""
    pts, wts, owner = cell_quadrature(solver.cells, order, near=solver.near)
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    J = solver.polarization(np.array([magpy.getB(m, solver.centroids) for m in magnets]))
    B = np.array([np.add.reduceat(magpy.getB(m, pts) * wts[:, None], starts) for m in magnets])
    return J, B


def cross_energy_table(design, coil, alpha, dphi, level: int = IRON_LEVEL) -> np.ndarray:
    """``X (A, A, D)`` (J): the coupling energy of two ``+1`` poles over one iron core, at angles ``alpha[a]``,
    ``alpha[b]`` (rad) from its axis and azimuths ``dphi[d]`` (rad) apart, ``−(1/μ0) ∫ J_p·B_q`` symmetrised in
    the two poles (the core's own mesh, coils off; :func:`coupling_energy` for one core)."""
    solver = core_solver(CoreGeometry.of(design, coil), level)
    a, p = np.meshgrid(np.asarray(alpha, dtype=float), np.asarray(dphi, dtype=float), indexing="ij")
    centres, w, _ = pole_poses(design, a, p)
    magnets = [rotor_magnet(design, c[None], wi[None]) for c, wi in zip(centres, w)]
    J, B = polarized_and_integrated(solver, magnets)
    J = J.reshape(a.shape + J.shape[1:])[:, 0]  # the first pole at azimuth 0
    B = B.reshape(a.shape + B.shape[1:])
    X = -np.einsum("aic,bdic->abd", J, B) / MU0
    return 0.5 * (X + X.transpose(1, 0, 2))


@lru_cache(maxsize=4)
def _placed_solver(geom: CoreGeometry, level: int, axes: tuple, face: float) -> CoreSolver:
    """The cores along the unit vectors ``axes``, faces at ``face`` from the centre, solved together (cached)."""
    v = np.array(axes)
    rots = z_to(v)
    return CoreSolver(geom, level, [(rots[i], face * v[i]) for i in range(len(v))])


def coupling_torque(design, coil, coils, R, level: int = 0, step: float = COUPLING_STEP) -> np.ndarray:
    """Torque (N·m, fixed frame, about the centre) of :func:`coupling_energy` at ``R (3, 3)``: ``−∂W/∂θ`` by
    central differences of ``step`` rad about each fixed axis."""
    out = np.empty(3)
    for a in range(3):
        turn = Rotation.from_rotvec(step * np.eye(3)[a]).as_matrix()
        out[a] = -(coupling_energy(design, coil, coils, turn @ R, level)
                   - coupling_energy(design, coil, coils, turn.T @ R, level)) / (2 * step)
    return out
