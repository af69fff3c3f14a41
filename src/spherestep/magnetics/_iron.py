"""Soft-iron stator cores solved by the method of moments (magpylib-material-response): the core's geometry and
mesh, the factorised (and the saturating) solve, and the quadratures that turn the solved polarizations into
forces. What is computed with them lives beside: :mod:`._ironforce` (pair tables, Fig. 6, the full multi-body
solve, saturated torques), :mod:`._ironcoupling` (the cores' coupling of magnets), :mod:`._inductance`.

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
Each face is integrated by Gauss–Legendre in the radius × the trapezoidal rule in the angle. Conversely the
force of a magnet on the solved cells treats each cell as point dipoles ``J ΔV/μ0`` at its Gauss points
(:func:`cell_quadrature`, :func:`dipole_wrench`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import magpylib as magpy
import numpy as np
import scipy.linalg
from scipy.spatial.transform import Rotation

from .. import checks
from ..motor.design import ROTOR_SHELL  # noqa: F401 (the default shell; scripts read _iron.ROTOR_SHELL)
from ._direct import EPS
from ._model import MU0, z_to

IRON_LEVEL = 0  # default mesh level of the tables (see the convergence study in docs/magnetics.md)
FACE_RADIAL = 16  # Gauss–Legendre nodes over a magnet face's radius
FACE_ANGULAR = 48  # trapezoidal nodes over its angle
WINDING_GRID = (4, 8)  # winding loops across the groove's width × along its depth
NEAR_DEPTH = 4e-3  # m: cells starting this close to the face get the finer quadrature
NEAR_ORDER = 6  # Gauss points per direction in the cells within NEAR_DEPTH of the face


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
    level = checks.count(level, "level", minimum=0, maximum=6, expected="a mesh level from 0 (coarse) to 6 (fine)")
    s = 2.0 ** (-level / 4)
    return {"first": 0.57e-3 * s, "growth": 1.6, "largest": 11.3e-3 * s, "lateral": 7.1e-3 * s}


def core_cells(geom: CoreGeometry, level: int = IRON_LEVEL) -> list:
    """The core's cells (magpylib ``Cylinder``/``CylinderSegment``, unit-less polarization 0) in the coil frame."""
    from magpylib_material_response.meshing import mesh_Cylinder  # (imported on a solve only: 0.4 s)

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
        from magpylib_material_response.demag import demag_tensor

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
    inside the rotor's shell of thickness ``shell`` (default the design's ``rotor_shell``, by default
    :data:`ROTOR_SHELL`, 1/16 in), the rim of the flat face on its inner surface, ``√((R_s − t)² − r_m²)``.
    (With the face's centre on the ball, as the air-core model has it, the rim stands 0.53 mm proud of the ball
    and would cut into a core face 0.127 mm away as the rotor turns.)"""
    t = design.rotor_shell if shell is None else shell
    return math.sqrt((design.radius - t) ** 2 - (0.5 * design.magnet_diameter) ** 2)


def rotor_magnet(design, centres, axes, polarity: float = 1.0):
    """A rotor magnet with a path of poses: centres ``(K, 3)``, axes ``(K, 3)``."""
    return magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                 polarization=(0, 0, polarity * design.remanence),
                                 position=np.asarray(centres, dtype=float), orientation=z_to(axes))


def saturation_onset(material, mu_r: float) -> float:
    """``H`` (A/m) where the line ``B = μ0 μr H`` last crosses the material's B–H curve from below: beyond it the
    curve lies under the line (the iron saturates), and the saturating solve follows the curve."""
    H = np.geomspace(1.0, 1e7, 20001)
    below = MU0 * mu_r * H <= material.flux_density(H)
    return float(H[np.flatnonzero(below)[-1]]) if below.any() else 0.0
