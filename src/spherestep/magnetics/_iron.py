"""Soft-iron stator cores solved by the method of moments (magpylib-material-response).

Geometry. A coil is a pot core (:class:`spherestep.motor.coil.CoilSpec`): in its own frame the axis is ``z``, the
face towards the rotor at ``z = 0`` and the body in ``0 ≤ z ≤ l_c``: a centre pole (radius ``r_p``, full height),
the outer wall (``r_w ≤ r ≤ d_c/2``, down to the back plate) and the back plate (``r_p ≤ r ≤ d_c/2``, thickness
``t_b``). The winding fills the groove ``r_p ≤ r ≤ r_w``, ``0 ≤ z ≤ l_c − t_b`` and is a grid of
:class:`magpylib.current.Circle` loops sharing the ampere-turns: the solver sees the solenoid's real field inside
the groove, so the centre pole magnetises along the winding's ``H`` (a uniformly magnetised "coil" cylinder has the
same ``B`` but, inside its body, ``H = B/μ0 − M`` pointing backwards, and would magnetise the pole backwards:
docs/magnetics.md, "Why the winding is a current here, not a magnetised cylinder").

Solve. The iron is cut into cells (:func:`magpylib_material_response.meshing.mesh_Cylinder` on slabs that thin
geometrically towards the face, where the rotor magnet sits 0.127 mm away) and each cell's polarization ``J_i``
satisfies the point-matched moment equations of ``apply_demag``, ``(I − χ T) J = χ B_src`` (``χ = μr − 1``,
``T`` the cells' demagnetisation tensor from :func:`magpylib_material_response.demag.demag_tensor`, ``B_src`` the
field of the magnets and the winding at the cells' centroids). ``T`` does not depend on the rotor, so the matrix
is factorised once per mesh (LU) and every magnet position and current is one back-substitution: that is the
whole speed-up over calling ``apply_demag`` per position, which gives the same polarizations (checked in the
tests to 1e-9).

Force on a magnet. An axially polarised magnet is two sheets of magnetic charge ``σ = ±J/μ0`` on its end
faces; the force and torque (about the pivot, the sphere's centre) from an external field ``B_ext`` are
``F = ∮ σ B_ext dA`` and ``T = ∮ σ (x − x0) × B_ext dA`` (equal to ``getFT``'s ``∫ (M·∇)B + M × B`` for a
curl-free ``B_ext`` such as the iron's and the winding's field in the magnet; checked against ``getFT``).
Each face is integrated by Gauss–Legendre in the radius × the trapezoidal rule in the angle.

Linearity. With a linear core every field is linear in its sources, so for one magnet of polarity ``p`` and one
coil at current ``c`` (per nominal) the wrench on the magnet is ``W = W_detent + p c W_linear`` with
``W_detent`` from the iron magnetised by the magnet itself (``p² = 1``: the same for both polarities) and
``W_linear`` from the winding plus the iron it magnetises; a ``c²`` term acts only inside the stator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import magpylib as magpy
import numpy as np
import scipy.linalg
from magpylib_material_response.demag import demag_tensor
from magpylib_material_response.meshing import mesh_Cylinder
from scipy.spatial.transform import Rotation

from ..errors import bad_value
from ._direct import EPS
from ._model import MU0, z_to

IRON_LEVEL = 0  # default mesh level of the tables (see the convergence study in docs/magnetics.md)
FACE_RADIAL = 16  # Gauss–Legendre nodes over a magnet face's radius
FACE_ANGULAR = 48  # trapezoidal nodes over its angle
ROTOR_SHELL = 1.0 / 16.0 * 0.0254  # m: wall of the plastic ball in front of the magnets (the paper gives none)
WINDING_GRID = (4, 8)
NEAR_DEPTH = 4e-3  # m: cells starting this close to the face get the finer quadrature
NEAR_ORDER = 6  # winding loops across the groove's width × along its depth


@dataclass(frozen=True)
class CoreGeometry:
    """The pot core and winding of one coil (m): outer radius ``R``, height ``L``, pole radius ``r_p``, groove
    outer radius ``r_w``, groove depth ``depth`` (``L − t_b``), nominal ampere-turns ``NI``, ``mu_r``."""

    R: float
    L: float
    r_p: float
    r_w: float
    depth: float
    NI: float
    mu_r: float

    @classmethod
    def of(cls, design, coil) -> CoreGeometry:
        r_p, r_w, depth = coil.groove(design.coil_diameter, design.coil_length)
        return cls(0.5 * design.coil_diameter, design.coil_length, r_p, r_w, depth,
                   coil.nominal_ampere_turns(design.coil_diameter, design.coil_length),
                   float(coil.material.relative_permeability))

    def parts(self) -> list[tuple[float, float, float, float]]:
        """The iron as annuli ``(r_in, r_out, z0, z1)``: centre pole, outer wall, back plate (empty ones left out)."""
        out = [(0.0, self.r_p, 0.0, self.L), (self.r_w, self.R, 0.0, self.depth), (self.r_p, self.R, self.depth, self.L)]
        return [p for p in out if p[1] - p[0] > 1e-9 and p[3] - p[2] > 1e-9]


def _layers(z0: float, z1: float, first: float, growth: float, largest: float) -> np.ndarray:
    """Slab boundaries on ``[z0, z1]``: thickness ``first`` at ``z = 0`` growing by ``growth`` up to ``largest``."""
    edges = [z0]
    while edges[-1] < z1 - 1e-12:
        t = min(largest, first * growth ** max(0.0, math.log(max(edges[-1], first) / first, growth))
                if edges[-1] > 0 else first)
        edges.append(min(z1, edges[-1] + max(t, first)))
    if len(edges) > 2 and edges[-1] - edges[-2] < 0.3 * (edges[-2] - edges[-3]):
        edges.pop(-2)
    return np.asarray(edges)


def mesh_parameters(level: int) -> dict:
    """Mesh of level ``level`` (0 coarse … 6 fine; each level divides the sizes by 2^(1/4)): first slab (m), growth, largest slab (m), lateral cell size (m)."""
    if isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= level <= 6:
        raise bad_value("level", "a mesh level from 0 (coarse) to 6 (fine)", level)
    s = 2.0 ** (-level / 4)
    return {"first": 0.57e-3 * s, "growth": 1.6, "largest": 11.3e-3 * s, "lateral": 7.1e-3 * s}


def core_cells(geom: CoreGeometry, level: int = IRON_LEVEL) -> list:
    """The core's cells (magpylib ``Cylinder``/``CylinderSegment``, unit-less polarization 0) in the coil frame."""
    p = mesh_parameters(level)
    cells = []
    for r0, r1, z0, z1 in geom.parts():
        edges = _layers(z0, z1, p["first"], p["growth"], p["largest"])
        nr = max(1, round((r1 - r0) / p["lateral"]))
        nphi = max(6, round(math.pi * (r0 + r1) / p["lateral"]))
        for a, b in zip(edges[:-1], edges[1:]):
            if r0 == 0.0:
                slab = magpy.magnet.Cylinder(dimension=(2 * r1, b - a), polarization=(0, 0, 0),
                                             position=(0, 0, 0.5 * (a + b)))
            else:
                slab = magpy.magnet.CylinderSegment(dimension=(r0, r1, b - a, 0, 360), polarization=(0, 0, 0),
                                                    position=(0, 0, 0.5 * (a + b)))
            cells.extend(mesh_Cylinder(slab, (nphi, max(nr, 3) if r0 == 0.0 else nr, 1)).sources_all)
    for c in cells:  # detach from the meshing collections
        if c.parent is not None:
            c.parent = None
    return cells


def winding_loops(geom: CoreGeometry, ampere_turns: float, grid=WINDING_GRID) -> list:
    """The winding as ``nr × nz`` coaxial ``Circle`` loops at the centres of a grid over the groove, each carrying
    ``ampere_turns / (nr nz)`` amperes, coil frame (positive current: field along ``+z`` inside)."""
    nr, nz = grid
    radii = geom.r_p + (np.arange(nr) + 0.5) / nr * (geom.r_w - geom.r_p)
    heights = (np.arange(nz) + 0.5) / nz * geom.depth
    amps = ampere_turns / (nr * nz)
    return [magpy.current.Circle(diameter=2 * r, current=amps, position=(0, 0, h)) for r in radii for h in heights]


class CoreSolver:
    """Cores, meshed and factorised: :meth:`polarization` maps a source field at the cells' centroids to the
    cells' polarizations; :meth:`field` gives the solved cores' field at points.

    ``placements``: one ``(rotation, offset)`` per core taking the coil frame to the fixed frame (default one core
    in its own frame); all cores are solved together, so they magnetise each other.
    """

    def __init__(self, geom: CoreGeometry, level: int = IRON_LEVEL, placements=None):
        self.geom = geom
        self.level = level
        placements = [(Rotation.identity(), np.zeros(3))] if placements is None else placements
        self.cells = []
        for rot, offset in placements:
            for c in core_cells(geom, level):
                c.orientation = rot * c.orientation
                c.position = rot.apply(c.position) + np.asarray(offset, dtype=float)
                self.cells.append(c)
        self.loops = [[(rot, offset, lp) for lp in winding_loops(geom, geom.NI)] for rot, offset in placements]
        for group in self.loops:
            for rot, offset, lp in group:
                lp.orientation = rot * lp.orientation
                lp.position = rot.apply(lp.position) + np.asarray(offset, dtype=float)
        self.loops = [[lp for _, _, lp in group] for group in self.loops]
        self.centroids = np.array([c.centroid for c in self.cells])
        depth = np.array([c.position[2] - 0.5 * c.dimension[-1 if isinstance(c, magpy.magnet.Cylinder) else 2]
                          for c in core_cells(geom, level)])
        self.near = np.tile(depth < NEAR_DEPTH, len(placements))
        n = len(self.cells)
        T = demag_tensor(self.cells) * MU0
        self.T = T.swapaxes(2, 3).reshape((3 * n, 3 * n)).T  # the layout of apply_demag: x1..xn, y1..yn, z1..zn
        self.chi = geom.mu_r - 1.0
        self._lu = scipy.linalg.lu_factor(np.eye(3 * n) - self.chi * self.T, check_finite=False)

    def polarization(self, B_src: np.ndarray) -> np.ndarray:
        """Cell polarizations ``J (…, n, 3)`` (T) for source fields ``B_src (…, n, 3)`` (T) at the centroids."""
        B = np.asarray(B_src, dtype=float)
        n = len(self.cells)
        rhs = self.chi * np.moveaxis(B.reshape(-1, n, 3), 2, 1).reshape(-1, 3 * n).T  # (3n, m)
        J = scipy.linalg.lu_solve(self._lu, rhs, check_finite=False)
        return np.moveaxis(J.T.reshape(-1, 3, n), 1, 2).reshape(B.shape)

    def saturated_polarization(self, B_src: np.ndarray, material, tol: float = 1e-4, max_iter: int = 300,
                               relax: float = 0.5) -> tuple[np.ndarray, np.ndarray, int]:
        """Cell polarizations ``J (n, 3)`` (T) for one source field ``B_src (n, 3)`` with saturating iron: the
        linear solve's line ``B = μ0 μr H`` up to where it meets the material's B–H curve above the knee
        (:func:`saturation_onset`), the curve beyond — so that only saturation differs from the linear solve. Each
        cell's susceptibility is the secant ``χ_i = B(H_i)/(μ0 H_i) − 1`` at its own ``|H_i|`` (``μ0 H = B_src +
        T J``); fixed-point iteration on the ``χ_i`` (geometric relaxation ``relax``), a dense solve of
        ``(I − diag(χ) T) J = diag(χ) B_src`` each time, until no ``χ_i`` moves by more than ``tol`` relative.
        Returns ``(J, |B| per cell (T), iterations)``; raises ComputationError if it does not converge."""
        from ..errors import ComputationError

        n = len(self.cells)
        b = np.moveaxis(np.asarray(B_src, dtype=float).reshape(n, 3), 1, 0).reshape(3 * n)
        onset = saturation_onset(material, self.chi + 1.0)
        chi = np.full(n, self.chi)
        for it in range(1, max_iter + 1):
            c3 = np.tile(chi, 3)
            J = np.linalg.solve(np.eye(3 * n) - c3[:, None] * self.T, c3 * b)
            H = np.linalg.norm((b + self.T @ J).reshape(3, n), axis=0) / MU0  # A/m
            target = np.where(H > onset, material.flux_density(H) / (MU0 * np.maximum(H, onset)) - 1.0, self.chi)
            done = np.max(np.abs(target - chi) / chi) <= tol
            chi = chi * (target / chi) ** relax
            if done:
                Jc = J.reshape(3, n).T
                return Jc, np.linalg.norm(Jc, axis=1) + MU0 * H, it
        raise ComputationError(f"the saturating iron solve did not converge in {max_iter} iterations")

    def field(self, J: np.ndarray, points: np.ndarray) -> np.ndarray:
        """``B`` (T) at ``points (P, 3)`` of the cells polarised ``J (n, 3)``."""
        for c, j in zip(self.cells, J):
            c.polarization = c.orientation.inv().apply(j)
        return magpy.getB(self.cells, points, sumup=True).reshape(-1, 3)

    def flux_density(self, J: np.ndarray) -> np.ndarray:
        """``|B|`` (T) in each cell: ``B = J + μ0 H`` with ``μ0 H = J / χ`` for a linear cell."""
        return np.linalg.norm(J, axis=-1) * (1.0 + 1.0 / self.chi)


@lru_cache(maxsize=8)
def core_solver(geom: CoreGeometry, level: int = IRON_LEVEL) -> CoreSolver:
    """The factorised :class:`CoreSolver` of a geometry (cached)."""
    return CoreSolver(geom, level)


def face_quadrature(radius: float, n_r: int = FACE_RADIAL, n_phi: int = FACE_ANGULAR):
    """Nodes ``(P, 2)`` (x, y) and weights ``(P,)`` (m²) integrating over a disc of ``radius``: Gauss–Legendre in
    the radius × the trapezoidal rule in the angle."""
    x, w = np.polynomial.legendre.leggauss(n_r)
    r = 0.5 * radius * (x + 1.0)
    wr = 0.5 * radius * w * r
    phi = 2 * math.pi * np.arange(n_phi) / n_phi
    pts = np.stack([np.outer(r, np.cos(phi)).ravel(), np.outer(r, np.sin(phi)).ravel()], axis=1)
    return pts, np.repeat(wr, n_phi) * (2 * math.pi / n_phi)


def magnet_faces(centre, axis, diameter: float, length: float, polarization: float, n_r: int = FACE_RADIAL,
                 n_phi: int = FACE_ANGULAR):
    """Charge points of an axially polarised cylinder: positions ``(2P, 3)`` and ``σ dA`` (A·m) for ``σ = ±J/μ0``
    on its ``+axis`` and ``−axis`` faces."""
    pts, w = face_quadrature(0.5 * diameter, n_r, n_phi)
    rot = z_to(np.asarray(axis, dtype=float)[None])[0]
    local = np.concatenate([np.c_[pts, np.full(len(pts), 0.5 * length)],
                            np.c_[pts, np.full(len(pts), -0.5 * length)]])
    q = polarization / MU0 * np.concatenate([w, -w])
    return rot.apply(local) + np.asarray(centre, dtype=float), q


def charge_wrench(points: np.ndarray, charges: np.ndarray, B: np.ndarray, pivot=(0.0, 0.0, 0.0)):
    """Force (N) and torque (N·m about ``pivot``) on magnetic charges ``charges`` (A·m) at ``points`` in ``B``
    (the field of everything but the magnet itself): ``F = Σ q B``, ``T = Σ q (x − x0) × B``."""
    F = np.einsum("p,pi->i", charges, B)
    T = np.einsum("p,pi->i", charges, np.cross(points - np.asarray(pivot, dtype=float), B))
    return F, T


def cell_quadrature(cells, order: int = 3, near_order: int = NEAR_ORDER, near=None) -> tuple[np.ndarray, np.ndarray]:
    """Gauss points ``(P, 3)`` and volume weights ``(P,)`` (m³) of ``Cylinder``/``CylinderSegment`` cells, ``order``
    points per direction in ``r``, ``φ``, ``z`` (``near_order`` for the cells flagged in ``near``, the layers at
    the face where the magnets' field varies fastest); weights ``r dr dφ dz``; and each point's cell index."""
    pts, wts, owner = [], [], []
    near = np.zeros(len(cells), dtype=bool) if near is None else near
    for i, c in enumerate(cells):
        x, w = np.polynomial.legendre.leggauss(near_order if near[i] else order)
        if isinstance(c, magpy.magnet.Cylinder):
            r0, r1, h, p0, p1 = 0.0, 0.5 * c.dimension[0], c.dimension[1], 0.0, 360.0
        else:
            r0, r1, h, p0, p1 = c.dimension
        p0, p1 = math.radians(p0), math.radians(p1)
        r = r0 + 0.5 * (r1 - r0) * (x + 1)
        phi = p0 + 0.5 * (p1 - p0) * (x + 1)
        z = 0.5 * h * x
        R_, P_, Z_ = np.meshgrid(r, phi, z, indexing="ij")
        W = np.einsum("i,j,k->ijk", w * 0.5 * (r1 - r0) * r, w * 0.5 * (p1 - p0), w * 0.5 * h)
        local = np.stack([R_ * np.cos(P_), R_ * np.sin(P_), Z_], axis=-1).reshape(-1, 3)
        pts.append(c.orientation.apply(local) + c.position)
        wts.append(W.ravel())
        owner.append(np.full(W.size, i))
    return np.concatenate(pts), np.concatenate(wts), np.concatenate(owner)


def dipole_wrench(points: np.ndarray, moments: np.ndarray, source, pivot) -> tuple[np.ndarray, np.ndarray]:
    """Force (N) and torque (N·m about ``pivot``, ``(K, 3)``) on point dipoles ``moments (K, P, 3)`` (A·m²) at
    ``points (P, 3)`` in the field of ``source`` (a magpylib object with a path of ``K`` poses):
    ``F = Σ (m·∇)B``, ``T = Σ m × B + (x − x0) × F`` (∇B by central differences of ``EPS``)."""
    steps = np.concatenate([np.zeros((1, 3)), EPS * np.eye(3), -EPS * np.eye(3)])
    obs = (points[None] + steps[:, None]).reshape(-1, 3)
    B = magpy.getB(source, obs, squeeze=False).reshape(-1, 7, len(points), 3)  # (K, 7, P, 3)
    grad = (B[:, 1:4] - B[:, 4:7]) / (2 * EPS)  # grad[k, a, p, i] = ∂B_i/∂x_a
    F = np.einsum("kpa,kapi->kpi", moments, grad)
    T = np.cross(moments, B[:, 0]) + np.cross(points - np.asarray(pivot), F)
    return F.sum(axis=1), T.sum(axis=1)


def magnet_face_radius(design, shell: float = None) -> float:
    """Distance (m) from the sphere's centre to a rotor magnet's outer face in the iron model: the magnets sit
    inside the rotor's shell of thickness ``shell`` (default :data:`ROTOR_SHELL`), the rim of the flat face on
    its inner surface, ``√((R_s − t)² − r_m²)``. (With the face's centre on the ball, as the air-core model has
    it, the rim stands 0.53 mm proud of the ball and would cut into a core face 0.127 mm away as the rotor
    turns.)"""
    t = ROTOR_SHELL if shell is None else shell
    return math.sqrt((design.radius - t) ** 2 - (0.5 * design.magnet_diameter) ** 2)


def _magnet(design, centres, axes, polarity: float = 1.0):
    """A rotor magnet with a path of poses: centres ``(K, 3)``, axes ``(K, 3)``."""
    return magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                 polarization=(0, 0, polarity * design.remanence),
                                 position=np.asarray(centres, dtype=float), orientation=z_to(axes))


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
    magnet = _magnet(design, centres, axes)
    K = len(magnet.position) if np.ndim(magnet.position) == 2 else 1
    J_mag = solver.polarization(magpy.getB(magnet, solver.centroids, squeeze=False).reshape(K, -1, 3))
    Fd, Td = _reaction(solver, J_mag, magnet, pivot, order)
    Fi, Ti = _reaction(solver, J_coil, magnet, pivot, order)
    Fw, Tw = magpy.getFT(magnet, loops, pivot=np.asarray(pivot, dtype=float), meshing=64, squeeze=False)[:2]
    Fw = Fw[0].sum(axis=1)  # (1 source, K, n_loops, 3) → (K, 3)
    Tw = Tw[0].sum(axis=1)
    return -Fd, -Td, -(Fi + Fw), -(Ti + Tw)


def pole_poses(design, alpha, phi=0.0) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Rotor magnets at angles ``alpha`` (rad) from a coil's axis and azimuths ``phi`` (rad; broadcast) about it,
    in the coil's frame (axis ``+z``, face at ``z = 0``): centres ``(K, 3)``, radial axes ``(K, 3)``, and the
    sphere's centre ``(0, 0, −R_s − g)`` as the pivot."""
    a, p = np.broadcast_arrays(np.atleast_1d(np.asarray(alpha, dtype=float)), np.asarray(phi, dtype=float))
    face = design.radius + design.air_gap
    w = np.stack([np.sin(a) * np.cos(p), np.sin(a) * np.sin(p), np.cos(a)], axis=-1).reshape(-1, 3)
    centres = (magnet_face_radius(design) - 0.5 * design.magnet_length) * w - [0.0, 0.0, face]
    return centres, w, (0.0, 0.0, -face)


def pair_tables(design, coil, alpha, level: int = IRON_LEVEL, order: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """``(detent, linear)`` torques ``τ(α)`` (N·m) on one ``+1`` pole at angles ``alpha`` (rad) from an iron-cored
    coil's axis, about the sphere's centre, positive away from the axis (the convention of ``pair_torque``);
    ``linear`` per nominal current. The torque at current ``c`` on a pole of polarity ``p`` is
    ``detent + p c linear``. The magnet's face is at :func:`magnet_face_radius`."""
    centres, w, pivot = pole_poses(design, alpha)
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
    rotor = magpy.Collection(*[_magnet(design, r_c * uj[None], uj[None], float(p))
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


def saturation_onset(material, mu_r: float) -> float:
    """``H`` (A/m) where the line ``B = μ0 μr H`` last crosses the material's B–H curve from below: beyond it the
    curve lies under the line (the iron saturates), and the saturating solve follows the curve."""
    H = np.geomspace(1.0, 1e7, 20001)
    below = MU0 * mu_r * H <= material.flux_density(H)
    return float(H[np.flatnonzero(below)[-1]]) if below.any() else 0.0


def saturated_pair_torque(design, coil, alpha: float, current: float, level: int = IRON_LEVEL,
                          order: int = 3) -> tuple[float, float, float]:
    """Torque (N·m about the sphere's centre, positive away from the axis, as :func:`pair_tables`) on one ``+1``
    pole at ``alpha`` (rad) from one iron-cored coil at ``current`` (per nominal), with the iron saturating
    (:meth:`CoreSolver.saturated_polarization`, ``coil.material``'s B–H curve); returns ``(torque, largest |B| in
    a cell (T), iterations)``. Not linear in the current: each current is its own solve."""
    geom = CoreGeometry.of(design, coil)
    solver = core_solver(geom, level)
    centre, w, pivot = pole_poses(design, alpha)
    magnet = _magnet(design, centre, w)
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
    magnets = [_magnet(design, r_c * w[:, j][None], w[:, j][None], float(design.polarity[j])) for j in near]
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
    magnets = [_magnet(design, c[None], wi[None]) for c, wi in zip(centres, w)]
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


def coil_inductance(design, coil, level: int = IRON_LEVEL, samples: int = 24) -> float:
    """Self-inductance (H) of one coil, rotor absent: ``L = λ / I`` with the flux linkage
    ``λ = Σ_loops (N / n_loops) Φ(r_loop, z_loop)`` of the winding's loops, ``Φ(r, z) = ∫_0^r B_z(ρ, z) 2πρ dρ``
    (Gauss–Legendre, ``samples`` nodes along a radius; the solved core is axisymmetric to its mesh), ``B`` from
    the winding and, for an iron core, the core it magnetises (linear iron, MoM)."""
    geom = CoreGeometry.of(design, coil)
    turns = coil.turns(design.coil_diameter, design.coil_length)
    current = geom.NI / turns
    nr, nz = WINDING_GRID
    loops = winding_loops(geom, geom.NI)
    radii = geom.r_p + (np.arange(nr) + 0.5) / nr * (geom.r_w - geom.r_p)
    heights = (np.arange(nz) + 0.5) / nz * geom.depth
    x, w = np.polynomial.legendre.leggauss(samples)
    lam = 0.0
    for r in radii:
        rho = 0.5 * r * (x + 1.0)
        pts = np.array([[p, 0.0, h] for h in heights for p in rho])
        B = magpy.getB(loops, pts, sumup=True)
        if coil.core == "iron":
            solver = core_solver(geom, level)
            B = B + solver.field(solver.polarization(magpy.getB(loops, solver.centroids, sumup=True)), pts)
        Bz = B[:, 2].reshape(nz, samples)
        phi = (Bz * (0.5 * r * w * 2 * math.pi * rho)[None]).sum(axis=1)
        lam += (turns / (nr * nz)) * phi.sum()
    return float(lam / current)
