"""The iron cores' field at the sensors: the stator cores magnetised by the rotor's magnets and by the coils.

Linear soft iron makes every core's polarization linear in its sources, so the cores' field at sensor ``s`` is a
sum over the rotor's magnets of one function of the magnet's direction:

    B_core,s(R) = Σ_j p_j H_s(w_j),    w_j = R u_j ,

``H_s(w)`` the field at ``x_s`` of all the cores magnetised by one ``+1`` magnet whose axis is ``w`` (at the iron
model's radius, :func:`spherestep.magnetics.magnet_face_radius`). ``H_s`` is one smooth function on the sphere per
sensor; it is tabulated on an equiangular ``(ϑ, φ)`` grid of ``step`` (1°) in a frame whose poles lie between
the cores, and interpolated by the tensor cubic B-spline that interpolates the nodes (periodic in ``φ``; in ``ϑ``
the grid continues over the pole, ``(−ϑ, φ) ≡ (ϑ, φ + π)``). A small turn ``R → exp(δ̂) R`` moves a pole by
``dw = δ × w = −[w]× δ``, so

    ∂B_core,s/∂δ = −Σ_j p_j (∂H_s/∂w)(w_j) [w_j]× ,    ∂H/∂w = H_ϑ ê_ϑᵀ + (H_φ / sin ϑ) ê_φᵀ .

Building ``H_s`` (:func:`core_response`). Each core is the iron room's pot core (:class:`magnetics.CoreGeometry`,
its method-of-moments mesh and factorised solve :func:`magnetics.core_solver`), solved on its own, and the cores
magnetise each other: core ``k``'s polarization, its cells taken as point dipoles ``J ΔV/μ0``, magnetises the
cores within :data:`COUPLING_REACH_DEG`, whose response magnetises their neighbours in turn, to convergence
(block Jacobi; what is left against one moment system of two cores is in docs/sensing.md). For one core the field at a point ``y`` is ``G(y) J`` and
``J = (I − χT)⁻¹ χ b`` for the source ``b`` at the cells' centroids, so the field at all the sensors is ``A b``
with the adjoint ``A = χ G (I − χT)⁻¹``, one transposed back-substitution for every sensor seen from every core;
with the coupling core ``k``'s adjoint solves ``Â_k = A_k + Σ_l Â_l C_lk (I − χT)⁻¹ χ`` (``C_lk`` the dipoles'
field at core ``l``'s centroids). The magnet's field at the cells, for every grid direction, comes from one 1-D table in the angle
between the magnet's axis and the cell per distinct cell radius (the magnet is axisymmetric, as in
:mod:`.field`): the build is a table look-up and one matrix product per core.

The coils (:class:`IronCoilField`): coil ``k`` at unit current magnetises its own core; the sensors see the
winding (the iron room's current loops) plus that core, ``B = Σ_k c_k G_k``, a known field.
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass, replace
from importlib import resources

import magpylib as magpy
import numpy as np
import scipy.linalg
from scipy.interpolate import CubicSpline
from scipy.ndimage import spline_filter1d

from .. import checks
from .._fast.ironfield import POLE_CLIP, core_field, source_fields  # noqa: F401  (POLE_CLIP: documented here)
from ..errors import ComputationError, bad_value
from ..magnetics import CoreGeometry, core_solver, magnet_face_radius
from .field import FieldTable

DATA_FILE = "sensing_iron_cores.npz"  # the prototype's default array (scripts/sensing_iron_table.py)
SENSING_LEVEL = 2  # the moment mesh (562 cells per core): 2.4 % of the cores' field off the converged level-4 solve, level 0
# (the torque tables') 5.9 % (docs/sensing.md, data/sensing_iron_mmr.csv)
GRID_STEP_DEG = 1.0  # the H_s grid (interpolation error measured in docs/sensing.md)
MAGNET_NODES = 1801  # nodes in the angle α ∈ [0, π] of the magnet's field table at each cell radius (0.1°)
CHUNK = 4096  # grid directions per block in the build
COUPLING_REACH_DEG = 50.0  # neighbours (angle between core axes) whose coupling is included
COUPLING_SWEEPS = 30  # block-Jacobi sweeps at most
COUPLING_TOL = 1e-5  # ... until no adjoint entry moves by this much of the largest


def core_frames(design) -> np.ndarray:
    """``Q (N, 3, 3)``: rotation taking each core's own frame (axis ``+z``, face at the origin) to the fixed frame,
    the core's axis ``v_k`` as third column (any turn about the axis: the core is axisymmetric)."""
    v = design.stator.centers
    e = np.eye(3)[np.argmin(np.abs(v), axis=1)]
    x = np.cross(e, v)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    return np.stack([x, np.cross(v, x), v], axis=2)


def grid_frame(design) -> np.ndarray:
    """``E (3, 3)``: the table's frame; its polar axis (third column) is the direction perpendicular to the stator
    axis farthest, with its antipode, from every core's axis (the interpolant's ``1/sin ϑ`` lies where ``H`` is
    small and smooth)."""
    a = np.asarray(design.stator_axis, dtype=float)
    e = np.eye(3)[np.argmin(np.abs(a))]
    b1 = np.cross(a, e)
    b1 /= np.linalg.norm(b1)
    b2 = np.cross(a, b1)
    psi = np.linspace(0.0, math.pi, 181)[:-1]
    cand = np.cos(psi)[:, None] * b1 + np.sin(psi)[:, None] * b2
    score = np.abs(cand @ design.stator.centers.T).max(axis=1)  # cos of the nearest core to ±p
    p = cand[np.argmin(score)]
    x = np.cross(a, p)
    return np.stack([x / np.linalg.norm(x), a - (a @ p) * p, p], axis=1)


def _magnet_centre(design) -> float:
    """Distance (m) from the sphere's centre to a rotor magnet's centre in the iron model."""
    return magnet_face_radius(design) - 0.5 * design.magnet_length


def _magnet_table(design, radii: np.ndarray, nodes: int = MAGNET_NODES):
    """Cubic pieces ``(n, nodes − 1, 4, 2)`` (highest power first) of ``(B_∥, B_⊥)`` (T) of one ``+1`` iron-model
    magnet on the ``z`` axis seen at ``r_i (sin α, 0, cos α)`` (``B_∥`` along the magnet's axis, ``B_⊥`` along
    ``x``), in ``α`` on ``nodes`` even steps over ``[0, π]``; and the step (rad)."""
    alpha = np.linspace(0.0, math.pi, nodes)
    magnet = magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                   polarization=(0.0, 0.0, design.remanence),
                                   position=(0.0, 0.0, _magnet_centre(design)))
    pts = radii[None, :, None] * np.stack([np.sin(alpha), np.zeros_like(alpha), np.cos(alpha)], axis=1)[:, None, :]
    B = np.asarray(magnet.getB(pts.reshape(-1, 3))).reshape(nodes, len(radii), 3)
    c = CubicSpline(alpha, np.stack([B[..., 2], B[..., 0]], axis=-1), axis=0).c  # (4, nodes − 1, n, 2)
    return np.ascontiguousarray(np.transpose(c, (2, 1, 0, 3))), float(alpha[1] - alpha[0])


def _unit_fields(solver, points: np.ndarray) -> np.ndarray:
    """``G (P, 3, 3n)``: the field (T, core frame) at ``points (P, 3)`` (core frame) of each cell polarised 1 T
    along ``x``, ``y``, ``z`` (columns in the solver's layout ``x1..xn, y1..yn, z1..zn``)."""
    n = len(solver.cells)
    G = np.empty((len(points), 3, 3 * n))
    for a in range(3):
        for cell in solver.cells:
            cell.polarization = cell.orientation.inv().apply(np.eye(3)[a])
        Ga = np.asarray(magpy.getB(solver.cells, points, sumup=False)).reshape(n, len(points), 3)
        G[:, :, a * n:(a + 1) * n] = Ga.transpose(1, 2, 0)
    return G


def _dipole_coupling(centroids: np.ndarray, volumes: np.ndarray, points: np.ndarray) -> np.ndarray:
    """``C (P, 3, 3n)``: the field (T) at ``points (P, 3)`` of cells at ``centroids (n, 3)`` (same frame) polarised
    1 T along ``x``, ``y``, ``z`` (solver layout), each cell a point dipole of moment ``J ΔV / μ0``:
    ``B = ΔV (3 r̂ r̂ᵀ − I) J / (4π r³)``."""
    r = points[:, None, :] - centroids[None]  # (P, n, 3)
    d = np.linalg.norm(r, axis=-1)
    u = r / d[..., None]
    K = (3.0 * u[..., :, None] * u[..., None, :] - np.eye(3)) * (volumes / (4.0 * math.pi * d ** 3))[..., None, None]
    return np.transpose(K, (0, 2, 3, 1)).reshape(len(points), 3, -1)  # [p, i, a·n + j]


def coupling_matrix(design, solver, l: int, k: int) -> np.ndarray:
    """``C_lk (3n, 3n)``: the field (T) at core ``l``'s centroids (its frame, solver layout) per unit polarization of
    core ``k``'s cells (its frame), the cells as point dipoles (:func:`_dipole_coupling`)."""
    Q, v, face = core_frames(design), design.stator.centers, design.radius + design.air_gap
    volumes = np.array([cell.volume for cell in solver.cells])
    Z = (solver.centroids @ Q[l].T + face * (v[l] - v[k])) @ Q[k]  # l's centroids in k's frame
    C = np.einsum("ij,pjc->ipc", Q[l].T @ Q[k], _dipole_coupling(solver.centroids, volumes, Z))
    return C.reshape(3 * len(volumes), 3 * len(volumes))


def coupled_pairs(design, cores) -> list[tuple[int, int]]:
    """Ordered pairs ``(l, k)`` of ``cores`` whose axes are within :data:`COUPLING_REACH_DEG` (``l ≠ k``)."""
    v, reach = design.stator.centers, math.cos(math.radians(COUPLING_REACH_DEG))
    return [(int(l), int(k)) for l in cores for k in cores if l != k and v[l] @ v[k] >= reach]


def _coupled(design, solver, A: np.ndarray, idx, respond) -> np.ndarray:
    """The cores' adjoints with their coupling (module doc), ``Â_k = A_k + Σ_l Â_l C_lk (I − χT)⁻¹ χ`` for the
    pairs of :func:`coupled_pairs`, by block Jacobi from ``Â = A`` (the first sweep is the first order) until no
    entry moves by :data:`COUPLING_TOL` of ``max |A|``."""
    where = {int(k): i for i, k in enumerate(idx)}
    pairs = coupled_pairs(design, idx)
    hat = A
    for _ in range(COUPLING_SWEEPS):
        X = np.zeros_like(A)
        for l, k in pairs:
            X[where[k]] += hat[where[l]] @ coupling_matrix(design, solver, l, k)
        new = A + np.array([respond(x) for x in X])
        change = np.abs(new - hat).max() / np.abs(A).max()
        hat = new
        if change < COUPLING_TOL:
            return hat
    raise ComputationError(f"the cores' coupling did not settle in {COUPLING_SWEEPS} sweeps (change {change:.2g})")


def grid_directions(step_deg: float, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The table's nodes: ``ϑ`` in ``[0, π]`` and ``φ`` in ``[0, 2π)`` at ``step_deg``, and their unit vectors
    ``(nϑ, nφ, 3)`` in the fixed frame (``frame`` columns: the grid's x, y and polar axis)."""
    n = round(180.0 / step_deg)
    th = np.linspace(0.0, math.pi, n + 1)
    ph = np.arange(2 * n) * (math.pi / n)
    local = np.stack([np.outer(np.sin(th), np.cos(ph)), np.outer(np.sin(th), np.sin(ph)),
                      np.outer(np.cos(th), np.ones_like(ph))], axis=-1)
    return th, local @ frame.T


def core_response(design, positions, step_deg: float = GRID_STEP_DEG, level: int = SENSING_LEVEL, cores=None,
                  coupling: bool = True, progress=None) -> np.ndarray:
    """``H (nϑ, nφ, S, 3)`` (T): the field at ``positions (S, 3)`` of the cores ``cores`` (indices, default all)
    magnetised by one ``+1`` magnet along each grid direction (:func:`grid_directions` of :func:`grid_frame`):
    each core solved on its own and (``coupling``) the cores within :data:`COUPLING_REACH_DEG` of each other
    among ``cores`` magnetising each other (module doc). ``progress(done, total)`` is called after each core."""
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    solver = core_solver(CoreGeometry.of(design, design.coil), level)
    n = len(solver.cells)
    lu = scipy.linalg.lu_factor(np.eye(3 * n) - solver.chi * solver.T, check_finite=False)

    def respond(X):  # X M, M = (I − χT)⁻¹ χ: per unit source field at the centroids, through the core's solve
        return solver.chi * scipy.linalg.lu_solve(lu, X.T, trans=1, check_finite=False).T

    face = design.radius + design.air_gap
    Q = core_frames(design)
    v = design.stator.centers
    idx = np.arange(len(v)) if cores is None else np.asarray(cores, dtype=int)
    Y = np.einsum("kji,ksj->ksi", Q[idx], p[None] - face * v[idx][:, None])  # sensors in each core's frame
    A = respond(_unit_fields(solver, Y.reshape(-1, 3)).reshape(-1, 3 * n)).reshape(len(idx), len(p), 3, 3 * n)
    A = np.einsum("kij,ksjc->ksic", Q[idx], A).reshape(len(idx), 3 * len(p), 3 * n)  # fixed-frame components
    radii = np.linalg.norm(solver.centroids + [0.0, 0.0, face], axis=1)
    coef, h = _magnet_table(design, radii)
    _, W = grid_directions(step_deg, grid_frame(design))
    shape = W.shape[:2]
    W = W.reshape(-1, 3)
    H = np.zeros((len(W), len(p), 3))
    if coupling:
        A = _coupled(design, solver, A, idx, respond)
    for done, k in enumerate(idx):
        Ak = A[done]
        cells = solver.centroids @ Q[k].T + face * v[k]  # fixed frame
        for s in range(0, len(W), CHUNK):
            F = source_fields(coef, h, cells, W[s:s + CHUNK], Q[k]) @ Ak.T  # (D, 3S), fixed frame
            H[s:s + CHUNK] += F.reshape(len(F), len(p), 3)
        if progress is not None:
            progress(done + 1, len(idx))
    return H.reshape(*shape, len(p), 3)


def _prefilter(values: np.ndarray, axis: int) -> np.ndarray:
    """Periodic cubic B-spline coefficients along ``axis``: ``(c_{i−1} + 4 c_i + c_{i+1}) / 6 = v_i``."""
    return spline_filter1d(values, 3, axis=axis, mode="grid-wrap", output=np.float32)


@dataclass(frozen=True, eq=False)
class CoreField:
    """The cores' field at the sensors for any orientation (module doc): ``field(R)``, ``field_and_jacobian(R)``.

    ``coefficients (nϑ + 3, nφ + 3, S, 3)``: B-spline coefficients with one ghost row before and two after in
    ``ϑ`` (continued over the poles) and the same in ``φ`` (wrapped); ``frame (3, 3)`` the grid's frame;
    ``step`` (rad); ``poles (M, 3)``, ``polarity (M,)`` the rotor's."""

    coefficients: np.ndarray
    frame: np.ndarray
    step: float
    poles: np.ndarray
    polarity: np.ndarray

    @classmethod
    def from_nodes(cls, design, H: np.ndarray, step_deg: float = GRID_STEP_DEG) -> CoreField:
        """From node values ``H (nϑ, nφ, S, 3)`` of :func:`core_response`."""
        nt, nphi = H.shape[:2]
        if nphi != 2 * (nt - 1):
            raise bad_value("H", "node values on the (ϑ, φ) grid of core_response, shape (n + 1, 2n, S, 3)",
                            f"shape {H.shape}")
        half = nphi // 2
        back = np.roll(H[-2:0:-1], -half, axis=1)  # ϑ = π + i h  ≡  (π − i h, φ + π)
        ring = _prefilter(_prefilter(np.concatenate([H, back], axis=0).astype(np.float32), 0), 1)  # (2(nt − 1), nφ, S, 3)
        rows = np.arange(-1, nt + 2) % len(ring)
        cols = np.arange(-1, nphi + 2) % nphi
        coef = np.ascontiguousarray(ring[rows][:, cols], dtype=np.float32)
        return cls(coef, grid_frame(design), math.radians(step_deg), design.rotor.centers.copy(),
                   design.polarity.astype(float))

    def field(self, R) -> np.ndarray:
        """The cores' field ``(..., S, 3)`` (T, fixed frame) for rotations ``R (..., 3, 3)``."""
        R = np.asarray(R, dtype=float)
        W = np.ascontiguousarray(np.swapaxes(R.reshape(-1, 3, 3) @ self.poles.T, 1, 2))  # (K, M, 3)
        B, _ = core_field(self.coefficients, self.frame, self.step, W, self.polarity, False)
        return B.reshape(R.shape[:-2] + B.shape[1:])

    def field_and_jacobian(self, R):
        """``(B (S, 3), J (S, 3, 3))`` for one rotation, ``J = ∂B_core/∂δ`` (module doc)."""
        W = np.ascontiguousarray((np.asarray(R, dtype=float).reshape(3, 3) @ self.poles.T).T)[None]
        B, J = core_field(self.coefficients, self.frame, self.step, W, self.polarity, True)
        return B[0], J[0]


@dataclass(frozen=True, eq=False)
class IronFieldTable:
    """What the sensors see of the rotor on the iron motor: its own field (:class:`FieldTable`) plus the cores it
    magnetises (:class:`CoreField`); the same ``field`` / ``field_and_jacobian`` / ``positions`` as a table."""

    rotor: FieldTable
    cores: CoreField

    @property
    def positions(self) -> np.ndarray:
        return self.rotor.positions

    def field(self, R) -> np.ndarray:
        return self.rotor.field(R) + self.cores.field(R)

    def field_and_jacobian(self, R):
        B, J = self.rotor.field_and_jacobian(R)
        Bc, Jc = self.cores.field_and_jacobian(R)
        return B + Bc, J + Jc


@dataclass(frozen=True, eq=False)
class IronCoilField:
    """The iron-cored coils' field at the sensors, linear in the currents: ``B = Σ_k c_k G_k``, ``G_k`` coil
    ``k``'s winding (the iron room's loops) plus its own core magnetised by it, at unit (nominal) current."""

    per_coil: np.ndarray

    @classmethod
    def build(cls, design, positions, level: int = SENSING_LEVEL) -> IronCoilField:
        p = np.asarray(positions, dtype=float).reshape(-1, 3)
        solver = core_solver(CoreGeometry.of(design, design.coil), level)
        loops = solver.loops[0]
        J = solver.polarization(magpy.getB(loops, solver.centroids, sumup=True))
        Q = core_frames(design)
        face = design.radius + design.air_gap
        Y = np.einsum("kji,ksj->ksi", Q, p[None] - face * design.stator.centers[:, None]).reshape(-1, 3)
        B = solver.field(J, Y) + np.asarray(magpy.getB(loops, Y, sumup=True)).reshape(-1, 3)
        G = np.einsum("kij,ksj->ksi", Q, B.reshape(len(Q), len(p), 3))
        return cls(G)

    def field(self, currents) -> np.ndarray:
        c = np.asarray(currents, dtype=float)
        if c.shape[-1:] != (self.per_coil.shape[0],):
            raise bad_value("currents", f"one current per coil ({self.per_coil.shape[0]})", f"shape {c.shape}")
        return np.einsum("...k,ksi->...si", c, self.per_coil)


def design_key(design, level: int = SENSING_LEVEL) -> bytes:
    """What the cores' response to one magnet depends on (the magnet and where it sits, the stator, the core, the
    mesh), as bytes; not the rotor's layout or polarities, which only weight the table's values
    (:meth:`CoreField.from_nodes`), so a rotor re-marked or re-laid over the same stator shares the table."""
    parts = [np.array([design.radius, design.air_gap, design.rotor_shell, design.magnet_diameter,
                       design.magnet_length, design.remanence, level]).round(12),
             design.stator.centers.round(12), np.asarray(design.stator_axis, dtype=float).round(12),
             np.array(astuple(CoreGeometry.of(design, design.coil)), dtype=float).round(12)]
    return b"".join(np.ascontiguousarray(a, dtype=float).tobytes() for a in parts)


def _stored(key: bytes, positions: np.ndarray, step_deg: float):
    """The stored node values and coils' field for ``key`` at ``positions`` (:data:`DATA_FILE`; any subset of its
    sensors, e.g. the first 8 of the default 24 a hardware session reads), else ``None``."""
    path = resources.files("spherestep.data") / DATA_FILE
    if not path.is_file():
        return None
    with path.open("rb") as f, np.load(f) as z:
        if z["key"].tobytes() != key or float(z["step_deg"]) != step_deg:
            return None
        gap = np.abs(positions[:, None, :] - z["positions"][None]).max(axis=2)  # (S, stored)
        rows = np.argmin(gap, axis=1)
        if gap[np.arange(len(rows)), rows].max() > 1e-12:
            return None
        return z["H"][:, :, rows] * z["scale"][rows].astype(np.float32), z["coils"][:, rows]


_CACHE: dict = {}  # (design key, positions, step, level) -> (CoreField, IronCoilField), for the process
CACHE_SIZE = 4


def iron_fields(design, positions, step_deg: float = GRID_STEP_DEG,
                level: int = SENSING_LEVEL) -> tuple[CoreField, IronCoilField]:
    """``(CoreField, IronCoilField)`` of ``design``'s cores at ``positions (S, 3)``: read from
    :data:`DATA_FILE` for the prototype's default array (or some of its sensors), else built on first use (about a minute) and kept for
    the process."""
    checks.positive(step_deg, "step_deg", "a grid step in degrees dividing 180")
    if abs(180.0 / step_deg - round(180.0 / step_deg)) > 1e-9:
        raise bad_value("step_deg", "a grid step in degrees dividing 180", step_deg)
    p = np.ascontiguousarray(np.asarray(positions, dtype=float).reshape(-1, 3))
    level = checks.count(level, "level", minimum=0, maximum=6, expected="a mesh level from 0 to 6")
    key = (design_key(design, level), p.tobytes(), float(step_deg), level)
    if key not in _CACHE:
        stored = _stored(key[0], p, step_deg) if level == SENSING_LEVEL else None
        if stored is None:
            stored = (core_response(design, p, step_deg, level), IronCoilField.build(design, p, level).per_coil)
        if len(_CACHE) >= CACHE_SIZE:
            _CACHE.pop(next(iter(_CACHE)))
        _CACHE[key] = (CoreField.from_nodes(design, stored[0], step_deg), IronCoilField(stored[1]))
    cores, coils = _CACHE[key]  # the table is the stator's; the rotor's poles and polarities are this design's
    return replace(cores, poles=design.rotor.centers.copy(), polarity=design.polarity.astype(float)), coils


def rotor_and_cores(design, positions, step_deg: float = GRID_STEP_DEG) -> IronFieldTable:
    """:class:`IronFieldTable` of ``design`` at ``positions``."""
    return IronFieldTable(FieldTable.build(design, positions), iron_fields(design, positions, step_deg)[0])


__all__ = ["CoreField", "DATA_FILE", "IronCoilField", "IronFieldTable", "core_frames", "core_response", "design_key",
           "grid_directions", "grid_frame", "iron_fields", "rotor_and_cores"]
