"""Points, arcs, great circles and caps on the unit sphere, and the inscribed-cap constructions (Sec. II).

Conventions
-----------
Points are unit 3-vectors, arrays of shape ``(..., 3)``. ``point(φ, θ) = (cos φ sin θ, sin φ sin θ, cos θ)``
with θ the polar and φ the azimuthal angle (the paper's footnote 1). A cap (a "circle" of the paper) is a
centre and an angular radius ``r`` measured on the sphere; two caps *kiss* when the arc between their
centres equals the sum of their radii. Every function is vectorised over leading axes.
"""

from __future__ import annotations

import math

import numpy as np

from .errors import bad_value

UNIT_TOL = 1e-9


def as_points(u, name: str = "u", *, min_ndim: int = 1) -> np.ndarray:
    """The one input contract for points on the sphere: ``u`` as a float array ``(..., 3)`` of finite unit
    vectors (``||u| − 1| ≤ UNIT_TOL = 1e-9``), any leading batch shape (at least ``min_ndim`` axes); otherwise
    the project's one-line :class:`~spherestep.errors.InputError` naming ``name``. Nothing is normalised
    silently: divide by the norm first if that is what is meant."""
    try:
        u = np.asarray(u, dtype=float)
    except (TypeError, ValueError):
        raise bad_value(name, "unit 3-vectors of shape (..., 3)", u) from None
    if u.ndim < min_ndim or u.shape[-1:] != (3,):
        raise bad_value(name, "unit 3-vectors of shape (..., 3)", f"an array of shape {u.shape}")
    if not np.all(np.isfinite(u)):
        raise bad_value(name, "finite unit 3-vectors", "NaN or infinite entries")
    norm = np.linalg.norm(u, axis=-1)
    if np.any(norm == 0):
        raise bad_value(name, "unit 3-vectors", "a zero vector")
    if np.any(np.abs(norm - 1.0) > UNIT_TOL):
        worst = norm.flat[np.argmax(np.abs(norm - 1.0))]
        raise bad_value(name, f"unit 3-vectors (|u| = 1 within {UNIT_TOL:g}; divide by the norm)",
                        f"a vector of norm {worst:.12g}")
    return u


def as_radii(r, name: str = "radius") -> np.ndarray:
    """``r`` as a float array of finite angular radii in ``[0, π]``; InputError naming ``name`` otherwise."""
    r = np.asarray(r, dtype=float)
    if not np.all(np.isfinite(r)) or np.any(r < 0) or np.any(r > np.pi):
        raise bad_value(name, "finite angular radii in [0, π] radians", r.tolist())
    return r


def normalize(v) -> np.ndarray:
    """``v / |v|`` along the last axis; raises when a vector is zero or not finite."""
    v = np.asarray(v, dtype=float)
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if not np.all(np.isfinite(v)) or np.any(norm == 0):
        raise bad_value("v", "finite non-zero 3-vectors", "a zero or non-finite vector")
    return v / norm


def point(phi, theta) -> np.ndarray:
    """``u(φ, θ) = (cos φ sin θ, sin φ sin θ, cos θ)``, shape ``broadcast(φ, θ).shape + (3,)``."""
    phi = np.asarray(phi, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if not (np.all(np.isfinite(phi)) and np.all(np.isfinite(theta))):
        raise bad_value("phi, theta", "finite angles in radians", "NaN or infinite angles")
    s = np.sin(theta)
    return np.stack(np.broadcast_arrays(np.cos(phi) * s, np.sin(phi) * s, np.cos(theta)), axis=-1)


def angles(u) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`point`: ``(φ ∈ (−π, π], θ ∈ [0, π])``; at the poles φ = 0."""
    u = as_points(u, "u")
    rho = np.hypot(u[..., 0], u[..., 1])
    theta = np.arctan2(rho, u[..., 2])
    phi = np.arctan2(u[..., 1], u[..., 0])
    phi = np.where(rho == 0, 0.0, np.where(phi == -np.pi, np.pi, phi))
    return phi, theta


def arc_distance(u1, u2) -> np.ndarray:
    """Great-arc distance of eq. (1), ``d = cos⁻¹(u1·u2) ∈ [0, π]``.

    Evaluated as ``atan2(|u1 × u2|, u1 · u2)``, which keeps full precision for nearly equal and nearly
    antipodal points where ``arccos`` loses half the digits.
    """
    u1 = as_points(u1, "u1")
    u2 = as_points(u2, "u2")
    return np.arctan2(np.linalg.norm(np.cross(u1, u2), axis=-1), np.sum(u1 * u2, axis=-1))


def great_circle_normal(p, q) -> np.ndarray:
    """Unit normal ``n = p × q / |p × q|`` of the great circle through ``p`` and ``q``."""
    p = as_points(p, "p")
    q = as_points(q, "q")
    cross = np.cross(p, q)
    norm = np.linalg.norm(cross, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise bad_value("p, q", "two distinct, non-antipodal points (they define no unique great circle)",
                        "equal or antipodal points")
    return cross / norm


def distance_to_great_circle(r, n) -> np.ndarray:
    """``d2(r, n) = cos⁻¹ √(1 − (r·n)²) = sin⁻¹ |r·n|``: arc from ``r`` to the great circle with normal ``n``."""
    r = as_points(r, "r")
    n = as_points(n, "n")
    return np.arctan2(np.abs(np.sum(r * n, axis=-1)), np.linalg.norm(np.cross(r, n), axis=-1))


def disc_angle(diameter: float, distance: float) -> float:
    """Angular radius (rad) of a disc of ``diameter`` facing the centre from ``distance``:
    ``atan(diameter / 2 / distance)`` (a magnet's face on the rotor, a coil's face across the air gap)."""
    return math.atan(0.5 * diameter / distance)


def cap_area(radius) -> np.ndarray:
    """Area ``2π(1 − cos r)`` of a cap of angular radius ``r`` on the unit sphere."""
    r = as_radii(radius)
    return 4.0 * np.pi * np.sin(0.5 * r) ** 2


def _inward_normals(vertices: np.ndarray, name: str = "vertices") -> np.ndarray:
    """Unit normals of the sides of a convex spherical polygon ``(..., k, 3)``, pointing inside.

    Side ``i`` joins vertex ``i`` and ``i+1``. Raises when two consecutive vertices coincide or a vertex
    lies on the great circle of a side (a degenerate polygon).
    """
    nxt = np.roll(vertices, -1, axis=-2)
    cross = np.cross(vertices, nxt)
    norm = np.linalg.norm(cross, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise bad_value(name, "distinct, non-antipodal consecutive vertices", "a degenerate side")
    normals = cross / norm
    centroid = np.sum(vertices, axis=-2, keepdims=True)
    side = np.sum(normals * centroid, axis=-1, keepdims=True)
    # every vertex not on side i must lie strictly on one side of its great circle
    heights = np.einsum("...ic,...jc->...ij", normals, vertices)
    k = vertices.shape[-2]
    off = ~(np.eye(k, dtype=bool) | np.roll(np.eye(k, dtype=bool), 1, axis=1))
    if np.any(np.abs(heights[..., off]) < 1e-12):
        raise bad_value(name, "a non-degenerate spherical polygon", "collinear vertices (on one great circle)")
    return np.where(side < 0, -normals, normals)


def triangle_incircle(p, q, r) -> tuple[np.ndarray, np.ndarray]:
    """Cap inscribed in the spherical triangle ``p, q, r`` (Sec. II-B-1): ``(center (..., 3), radius (...))``.

    The centre is equidistant from the three side great circles: with side normals ``n1, n2, n3`` all
    pointing into the triangle, ``(n1 − n2)·x = (n3 − n2)·x = 0``, so ``x ∝ (n1 − n2) × (n3 − n2)``, the
    sign chosen to put ``x`` inside (the paper's smaller of the two complementary caps). The radius is
    ``d2(x, n1) = sin⁻¹(x·n1)``. (The paper writes ``n2 = n(p, r)`` and ``n3 = n(r, q)``; orienting all three
    normals inwards is what makes the equidistance equations hold with equal signs.)
    """
    p = as_points(p, "p")
    q = as_points(q, "q")
    r = as_points(r, "r")
    p, q, r = np.broadcast_arrays(p, q, r)
    n = _inward_normals(np.stack([p, q, r], axis=-2), "p, q, r")
    x = np.cross(n[..., 0, :] - n[..., 1, :], n[..., 2, :] - n[..., 1, :])
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    x = x / norm
    x = np.where(np.sum(x * n[..., 0, :], axis=-1, keepdims=True) < 0, -x, x)
    return x, np.arcsin(np.clip(np.sum(x * n[..., 0, :], axis=-1), 0.0, 1.0))


def polygon_incircle(vertices, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Cap inscribed in a tangential convex spherical polygon ``(..., k, 3)`` (vertices in order).

    Used for the symmetric spherical quadrilateral of Sec. II-B-2 (a kite or rhombus, any polygon with
    an incircle). The centre solves ``(n_i − n_0)·x = 0`` for the inward side normals (least squares by
    SVD); the polygon has an incircle when the residual vanishes, otherwise an error is raised.
    """
    v = as_points(vertices, "vertices", min_ndim=2)
    if v.shape[-2] < 3:
        raise bad_value("vertices", "at least three vertices", f"{v.shape[-2]}")
    n = _inward_normals(v)
    diffs = n[..., 1:, :] - n[..., :1, :]
    _, s, vt = np.linalg.svd(diffs)
    x = vt[..., -1, :]
    x = np.where(np.sum(x * n[..., 0, :], axis=-1, keepdims=True) < 0, -x, x)
    heights = np.einsum("...kc,...c->...k", n, x)
    if np.any(np.ptp(heights, axis=-1) > tol) or np.any(heights <= 0):
        raise bad_value("vertices", "a polygon with an inscribed circle (e.g. a symmetric quadrilateral)",
                        f"sides at distances differing by {np.ptp(heights, axis=-1).max():.3g}")
    return x, np.arcsin(np.clip(heights.mean(axis=-1), 0.0, 1.0))


def circle_in_gap(centers, radii) -> tuple[np.ndarray, np.ndarray]:
    """Cap kissing three caps from outside, in the gap between them (eqs. (2)–(3)).

    ``centers (..., 3, 3)`` (rows ``p_i``), ``radii (..., 3)``. Taking the cosine of ``d(x, p_i) = r + r_i``
    gives ``P x = A (cos r, sin r)ᵀ`` with ``A_i = (cos r_i, −sin r_i)``; with ``M = P⁻¹A`` and
    ``B = MᵀM``, ``|x| = 1`` reads ``b11 cos² r + 2 b12 sin r cos r + b22 sin² r = 1``, which the
    substitutions of the paper (equivalently, dividing by ``cos² r``) turn into the quadratic
    ``(b22 − 1) z² + 2 b12 z + (b11 − 1) = 0`` in ``z = tan r``. The smallest positive root gives the radius
    of the cap in the gap on the side where the three caps bound a small region; back-substitution gives
    ``x``. Returns ``(center (..., 3), radius (...))``.
    """
    P = as_points(centers, "centers", min_ndim=2)
    if P.shape[-2:] != (3, 3):
        raise bad_value("centers", "three centres, shape (..., 3, 3)", f"shape {P.shape}")
    r = as_radii(radii, "radii")
    if r.shape[-1:] != (3,):
        raise bad_value("radii", "three radii, shape (..., 3)", f"shape {r.shape}")
    det = np.linalg.det(P)
    if np.any(np.abs(det) < 1e-12):
        raise bad_value("centers", "three centres not on one great circle", "collinear centres (det ≈ 0)")
    A = np.stack([np.cos(r), -np.sin(r)], axis=-1)
    M = np.linalg.solve(P, A)  # x = M (cos r, sin r)
    B = np.swapaxes(M, -1, -2) @ M
    a2, a1, a0 = B[..., 1, 1] - 1.0, 2.0 * B[..., 0, 1], B[..., 0, 0] - 1.0
    disc = a1 * a1 - 4.0 * a2 * a0
    if np.any(disc < -1e-12):
        raise bad_value("centers, radii", "three caps with a gap between them", "caps that leave no gap")
    sq = np.sqrt(np.maximum(disc, 0.0))
    # numerically stable roots of a2 z² + a1 z + a0
    qq = -0.5 * (a1 + np.copysign(sq, a1))
    with np.errstate(divide="ignore", invalid="ignore"):
        z1 = np.where(a2 != 0, qq / a2, -a0 / a1)
        z2 = np.where(qq != 0, a0 / qq, np.inf)
    z = np.stack([z1, z2], axis=-1)
    z = np.where(z > 0, z, np.inf)
    zmin = z.min(axis=-1)
    if np.any(~np.isfinite(zmin)):
        raise bad_value("centers, radii", "three caps with a gap between them", "no positive root")
    rad = np.arctan(zmin)
    x = np.einsum("...ij,...j->...i", M, np.stack([np.cos(rad), np.sin(rad)], axis=-1))
    return x / np.linalg.norm(x, axis=-1, keepdims=True), rad


def circle_in_ring(centers, radii, tol: float = 1e-9) -> tuple[np.ndarray, np.ndarray]:
    """Cap inscribed in a hole ringed by ``k ≥ 3`` caps with rotational symmetry (Sec. II-B-2).

    ``centers (..., k, 3)``, ``radii (..., k)``. A ring with a k-fold (or any non-trivial) rotational
    symmetry has its axis along the sum of its centres, so the inscribed cap is centred there with radius
    ``d(x, p_i) − r_i``; the caps must all be tangent to it within ``tol`` (else the ring is not symmetric
    and a ValueError is raised: use :func:`circle_in_gap` on three of them).
    """
    P = as_points(centers, "centers", min_ndim=2)
    r = as_radii(radii, "radii")
    if P.shape[-2] < 3 or r.shape != P.shape[:-1]:
        raise bad_value("centers, radii", "k >= 3 centres (..., k, 3) and k radii (..., k)",
                        f"shapes {P.shape} and {r.shape}")
    s = P.sum(axis=-2)
    norm = np.linalg.norm(s, axis=-1, keepdims=True)
    if np.any(norm < 1e-12):
        raise bad_value("centers", "a ring of caps around a hole (centres not summing to zero)",
                        "centres spread over the whole sphere")
    x = s / norm
    gaps = np.arctan2(np.linalg.norm(np.cross(x[..., None, :], P), axis=-1), np.einsum("...c,...kc->...k", x, P)) - r
    if np.any(np.ptp(gaps, axis=-1) > tol):
        raise bad_value("centers, radii", "a rotationally symmetric ring (all caps tangent to the inscribed cap)",
                        f"distances differing by {np.ptp(gaps, axis=-1).max():.3g} rad")
    if np.any(gaps.min(axis=-1) <= 0):
        raise bad_value("centers, radii", "a ring that leaves a hole", "caps that cover the ring's axis")
    return x, gaps.mean(axis=-1)


def circle_in_corner(p, q, r) -> tuple[np.ndarray, np.ndarray]:
    """Cap in the corner ``p`` of triangle ``p, q, r``, tangent to both sides at ``p`` and to the incircle.

    The third construction the paper says "follows similarly" (Sec. II-B-2). The cap's centre lies on the
    bisector from ``p`` to the incentre ``I`` at arc ``t`` from ``p``; a right spherical triangle gives its
    radius ``ρ`` from ``sin ρ = sin t sin(A/2)`` and ``sin(A/2) = sin r_in / sin t_I``; tangency to the incircle,
    ``t_I − t = ρ + r_in``, solves in closed form as ``tan t = sin D / (cos D + sin(A/2))`` with ``D = t_I − r_in``.
    """
    inc, r_in = triangle_incircle(p, q, r)
    p = np.broadcast_to(as_points(p, "p"), inc.shape)
    t_i = arc_distance(p, inc)
    half = np.sin(r_in) / np.sin(t_i)
    D = t_i - r_in
    t = np.arctan2(np.sin(D), np.cos(D) + half)
    rho = np.arcsin(np.sin(t) * half)
    # walk from p towards the incentre by arc t
    tangent = inc - np.sum(inc * p, axis=-1, keepdims=True) * p
    tangent /= np.linalg.norm(tangent, axis=-1, keepdims=True)
    center = np.cos(t)[..., None] * p + np.sin(t)[..., None] * tangent
    return center, rho


ORDER_TOL = 1e-7


def tolerant_ranks(values, tol: float = ORDER_TOL) -> np.ndarray:
    """Dense integer ranks of ``values`` (ascending) in which values closer than ``tol`` along a chain share a
    rank: sort, then start a new rank at every gap ``> tol``. Values equal in exact arithmetic but a few ulps apart
    (as another BLAS kernel computes them) get the same rank; the ranks depend neither on the input's order nor
    on its last bits, unless a true gap lies within rounding of ``tol`` itself."""
    v = np.asarray(values, dtype=float).ravel()
    order = np.argsort(v, kind="stable")
    ranks = np.empty(len(v), dtype=np.int64)
    ranks[order] = np.concatenate([[0], np.cumsum(np.diff(v[order]) > tol)]) if len(v) else []
    return ranks


def canonical_order(points, tol: float = ORDER_TOL) -> np.ndarray:
    """The project's one order for points on the sphere: indices that sort ``points (n, 3)`` from the north pole
    down in bands of height ``z`` (:func:`tolerant_ranks`, ``tol``), and within a band by azimuth
    ``φ = atan2(y, x)`` in ``(−π, π]`` from ``+x`` counter-clockwise seen from ``+z`` (``φ`` within ``tol`` of
    ``−π`` counts as ``π``; ``φ = 0`` at a pole). No rounding boundary is involved, so rounding differences of
    the inputs (another CPU's BLAS kernel) or a permutation of them cannot change the order of distinct points."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    band = tolerant_ranks(-p[:, 2], tol)
    phi = np.arctan2(p[:, 1], p[:, 0])
    phi = np.where(phi <= -np.pi + tol, phi + 2 * np.pi, phi)
    phi = np.where(np.hypot(p[:, 0], p[:, 1]) < tol, 0.0, phi)
    return np.lexsort((phi, band))


def shell_voxels(n: int, eps: float = 1e-12) -> np.ndarray:
    """Sorted ids ``(i n + j) n + k`` of the voxels of ``[−1, 1]³`` cut into ``n³`` that meet the unit sphere.

    Per column ``(i, j)`` with ``ρ²`` between ``r²_min`` and ``r²_max`` over its cross-section, a voxel meets
    the sphere when some point has ``|z| ≤ A = √(1 − r²_min)`` and some point ``|z| ≥ B = √(1 − r²_max)``: the
    voxels meeting ``|z| ≤ A`` less those wholly inside ``|z| < B``, at most two bands per column, so the work
    is ``O(n²)``, not ``O(n³)``.
    """
    h = 2.0 / n
    lo = -1.0 + np.arange(n) * h
    hi = lo + h
    amin = np.where((lo <= 0) & (hi >= 0), 0.0, np.minimum(np.abs(lo), np.abs(hi)))
    amax = np.maximum(np.abs(lo), np.abs(hi))
    rmin2 = (amin[:, None] ** 2 + amin[None, :] ** 2).ravel()
    rmax2 = (amax[:, None] ** 2 + amax[None, :] ** 2).ravel()
    cols = np.flatnonzero(rmin2 <= 1.0 + eps)
    A = np.sqrt(1.0 + eps - rmin2[cols])
    B = np.sqrt(np.maximum(1.0 - eps - rmax2[cols], 0.0))
    k_first = np.clip(np.floor((1.0 - A) / h).astype(np.int64), 0, n - 1)  # voxel k spans [lo_k, hi_k]
    k_last = np.clip(np.floor((1.0 + A) / h).astype(np.int64), 0, n - 1)
    k_in_first = np.floor((1.0 - B) / h).astype(np.int64) + 1  # wholly inside |z| < B
    k_in_last = np.ceil((1.0 + B) / h).astype(np.int64) - 2
    has_in = (B > 0) & (k_in_first <= k_in_last)
    starts = np.concatenate([k_first, np.where(has_in, np.maximum(k_in_last + 1, k_first), k_last + 1)])
    ends = np.concatenate([np.where(has_in, np.minimum(k_in_first - 1, k_last), k_last),
                           np.where(has_in, k_last, k_first - 1)])
    column = np.concatenate([cols, cols])
    count = np.maximum(ends - starts + 1, 0)
    rep = np.repeat(np.arange(len(count)), count)
    offset = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    return np.unique(column[rep] * n + starts[rep] + offset)


class NearestPointGrid:
    """Which of a fixed set of well-separated points lies within ``tol`` of a unit query, in O(log V).

    Space around the sphere is cut into cubic voxels of side ``h``; only the ``V ≈ 3πn²`` voxels that meet the
    unit sphere are kept (:func:`shell_voxels`), each with the point nearest its centre's projection. A unit
    query within ``tol`` of point ``p`` is at most ``tol + ρ`` from that projection (``ρ ≈ √3 h / 2`` the voxel's
    angular radius, bounded with margin below) and every other point at least ``s − tol − ρ`` (``s`` the
    smallest separation), so the stored point is ``p`` whenever ``ρ < s/2 − tol``; ``h`` is chosen so.
    Requires ``tol < s/2``.
    """

    def __init__(self, points, tol: float):
        from scipy.spatial import cKDTree

        self.points = as_points(points, "points", min_ndim=2)
        self.tol = float(tol)
        tree = cKDTree(self.points)
        dist, _ = tree.query(self.points, k=2)
        separation = 2.0 * np.arcsin(min(1.0, 0.5 * dist[:, 1].min()))
        if 0.5 * separation <= self.tol:
            raise bad_value("tol", f"under half the points' separation ({np.degrees(separation) / 2:.4g}°)",
                            f"{np.degrees(self.tol):.4g}°")
        self.n = self.side(separation, self.tol)
        self.ids = shell_voxels(self.n)
        h = 2.0 / self.n
        ijk = np.stack([self.ids // (self.n * self.n), (self.ids // self.n) % self.n, self.ids % self.n], axis=1)
        centres = -1.0 + (ijk + 0.5) * h
        norm = np.linalg.norm(centres, axis=1, keepdims=True)
        _, self.cell_point = tree.query(centres / np.maximum(norm, 1e-12))
        self.cos_tol = np.cos(self.tol)

    @staticmethod
    def side(separation: float, tol: float) -> int:
        """Voxels along each axis for points ``separation`` apart (rad): the voxel's angular radius, its
        half-diagonal ``√3h/2`` over the distance ``≥ 1 − √3h/2``, must stay under ``separation/2 − tol``
        (with 20 % to spare)."""
        margin = 0.5 * separation - tol
        return int(np.ceil(2.0 / (0.8 * margin / np.sqrt(3.0))))

    def cell(self, q: np.ndarray) -> np.ndarray:
        """Voxel id of each query ``q (..., 3)`` inside the cube ``[−1, 1]³``."""
        i = np.clip(((q + 1.0) * (0.5 * self.n)).astype(np.int64), 0, self.n - 1)
        return (i[..., 0] * self.n + i[..., 1]) * self.n + i[..., 2]

    def match(self, q: np.ndarray) -> np.ndarray:
        """Index of the point within ``tol`` of each unit query ``q (..., 3)``, or −1 where there is none."""
        cell = self.cell(q)
        slot = np.minimum(np.searchsorted(self.ids, cell), len(self.ids) - 1)
        idx = self.cell_point[slot]
        hit = (self.ids[slot] == cell) & (np.einsum("...c,...c->...", q, self.points[idx]) >= self.cos_tol)
        return np.where(hit, idx, -1)
