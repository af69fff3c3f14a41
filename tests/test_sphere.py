"""Tests of ``spherestep.sphere`` (Sec. II-A, II-B-1, II-B-2).

Every expected value comes from an independent route: a closed form the library does not use, exact
rational arithmetic, a brute-force numerical solve (SciPy ``brentq`` / ``least_squares``) or a configuration
built so that its answer is known. Tolerances are stated in each assertion (1e-10 rad for geometry unless a
comment says why).
"""

from __future__ import annotations

import math
import re
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from scipy.integrate import quad
from scipy.optimize import brentq, least_squares, minimize_scalar

from spherestep import sphere as S
from spherestep.errors import InputError

GEOM = 1e-10  # default tolerance for geometry (radians)
HYP = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# --------------------------------------------------------------------------------------------------
# independent helpers (plain NumPy, none of them calls the module under test)
# --------------------------------------------------------------------------------------------------
def unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def arc(a, b):
    """Reference arc: atan2 of |a×b| and a·b (robust, but written independently of the library)."""
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def exact_arc(a, b) -> float:
    """Angle between two float vectors from exact rational cross and dot products.

    The only roundings are the final conversions to float of ``|a×b|²`` and ``a·b`` and the correctly
    rounded ``sqrt``/``atan2``: relative accuracy a few ulps for every configuration, including nearly
    equal and nearly antipodal points. (mpmath is not a dependency of the project.)
    """
    a = [Fraction(float(x)) for x in a]
    b = [Fraction(float(x)) for x in b]
    c = (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    c2 = sum(x * x for x in c)
    d = sum(x * y for x, y in zip(a, b))
    return math.atan2(math.sqrt(float(c2)), float(d))


def rodrigues(axis, angle):
    """Rotation matrix about a unit axis (own implementation, not spherestep.so3.rot)."""
    k = unit(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def random_rotation(rng):
    q = unit(rng.normal(size=4))
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def sph(phi, theta):
    return np.array([math.cos(phi) * math.sin(theta), math.sin(phi) * math.sin(theta), math.cos(theta)])


def side_normal(a, b):
    return unit(np.cross(a, b))


def dist_to_circle(x, n):
    """Arc from x to the great circle with unit normal n, by the paper's construction (Sec. II-A):
    intersect with the perpendicular great circle w = x × n and take the nearer of ±(w × n)."""
    w = unit(np.cross(x, n))
    p = unit(np.cross(w, n))
    return min(arc(x, p), arc(x, -p))


def barycentric(x, a, b, c):
    """Coefficients (α, β, γ) with x = αa + βb + γc."""
    return np.linalg.solve(np.column_stack([a, b, c]), x)


unit_vectors = st.tuples(*[st.floats(-1, 1, allow_nan=False)] * 3).map(np.array).filter(
    lambda v: np.linalg.norm(v) > 0.2).map(unit)


@st.composite
def triangles(draw, min_side=0.05, min_height=0.05):
    """Three unit vectors forming a non-degenerate spherical triangle (sides and heights >= 0.05 rad)."""
    a, b, c = draw(unit_vectors), draw(unit_vectors), draw(unit_vectors)
    assume(min(arc(a, b), arc(b, c), arc(c, a)) > min_side)
    assume(max(arc(a, b), arc(b, c), arc(c, a)) < math.pi - min_side)
    for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
        assume(abs(math.asin(np.clip(np.dot(r, side_normal(p, q)), -1, 1))) > min_height)
    return a, b, c


# --------------------------------------------------------------------------------------------------
# points and angles
# --------------------------------------------------------------------------------------------------
@HYP
@given(phi=st.floats(-3.1, 3.1), theta=st.floats(1e-3, math.pi - 1e-3))
def test_point_polar_angle_is_distance_to_north_pole_and_angles_round_trip(phi, theta):
    u = S.point(phi, theta)
    assert abs(np.linalg.norm(u) - 1) <= 1e-15
    # the paper's example after eq. (1): d(e3, u(φ, θ)) = θ
    assert abs(exact_arc(np.array([0.0, 0.0, 1.0]), u) - theta) <= 1e-12
    # azimuth: the projection on the equator points at angle φ
    assert abs(math.atan2(u[1], u[0]) - phi) <= 1e-12
    phi2, theta2 = S.angles(u)
    assert abs(phi2 - phi) <= 1e-12 and abs(theta2 - theta) <= 1e-12


def test_angles_at_the_poles_and_on_the_equator():
    phi, theta = S.angles(np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]))
    np.testing.assert_allclose(theta, [0.0, math.pi, math.pi / 2, math.pi / 2], atol=1e-15)
    np.testing.assert_allclose(phi, [0.0, 0.0, math.pi, -math.pi / 2], atol=1e-15)


def test_angles_sign_of_zero_respects_documented_range():
    phi, _ = S.angles(S.point(math.pi, 0.0))  # the north pole; point() writes x = -0.0 here
    assert phi == 0.0
    phi, _ = S.angles(np.array([-1.0, -0.0, 0.0]))
    assert -math.pi < phi <= math.pi


# --------------------------------------------------------------------------------------------------
# arc distance, eq. (1)
# --------------------------------------------------------------------------------------------------
@HYP
@given(a=unit_vectors, b=unit_vectors)
def test_arc_distance_matches_exact_reference(a, b):
    d = S.arc_distance(a, b)
    assert 0.0 <= d <= math.pi
    assert abs(d - exact_arc(a, b)) <= 1e-15 * 4  # a few ulps of π
    assert abs(S.arc_distance(b, a) - d) <= 0.0  # symmetric, bit for bit


@pytest.mark.parametrize("delta", [1e-15, 1e-13, 1e-10, 1e-8, 1e-6, 1e-4, 1e-2])
def test_arc_distance_nearly_equal_and_nearly_antipodal(delta):
    rng = np.random.default_rng(int(-math.log10(delta)))
    for _ in range(20):
        a = unit(rng.normal(size=3))
        axis = unit(np.cross(a, rng.normal(size=3)))
        b = rodrigues(axis, delta) @ a
        # the reference is the exact angle between the two float vectors; arccos(a·b) would be off by
        # up to ~1e-8 here, atan2 keeps absolute accuracy ~1e-16
        assert abs(S.arc_distance(a, b) - exact_arc(a, b)) <= 2e-16
        assert abs(S.arc_distance(a, -b) - exact_arc(a, -b)) <= 1e-15  # near π: an ulp of π is 4.4e-16
        # and the construction itself was exact to ~1e-16 absolute
        assert abs(exact_arc(a, b) - delta) <= 1e-15
    # axis-aligned case: relative accuracy
    a = np.array([1.0, 0.0, 0.0])
    b = np.array([math.cos(delta), math.sin(delta), 0.0])
    assert abs(S.arc_distance(a, b) / delta - 1) <= 1e-14


def test_arc_distance_broadcasts():
    rng = np.random.default_rng(0)
    a = unit(rng.normal(size=(4, 1, 3)))
    b = unit(rng.normal(size=(5, 3)))
    d = S.arc_distance(a, b)
    assert d.shape == (4, 5)
    for i in range(4):
        for j in range(5):
            assert abs(d[i, j] - exact_arc(a[i, 0], b[j])) <= 1e-15


# --------------------------------------------------------------------------------------------------
# great circles
# --------------------------------------------------------------------------------------------------
@HYP
@given(p=unit_vectors, q=unit_vectors)
def test_great_circle_normal_is_unit_orthogonal_and_right_handed(p, q):
    assume(1e-3 < arc(p, q) < math.pi - 1e-3)
    n = S.great_circle_normal(p, q)
    assert abs(np.linalg.norm(n) - 1) <= 1e-15
    assert abs(np.dot(n, p)) <= 1e-12 and abs(np.dot(n, q)) <= 1e-12
    assert np.linalg.det(np.column_stack([p, q, n])) > 0  # n = p × q / |p × q|, not its negative


@HYP
@given(r=unit_vectors, p=unit_vectors, q=unit_vectors)
def test_distance_to_great_circle_matches_paper_construction_and_brute_force(r, p, q):
    assume(1e-2 < arc(p, q) < math.pi - 1e-2)
    n = side_normal(p, q)
    assume(abs(np.dot(r, n)) < 1 - 1e-6)  # r not at a pole of the circle, where w is undefined
    d = S.distance_to_great_circle(r, n)
    assert abs(d - dist_to_circle(r, n)) <= GEOM
    # brute force: the minimum over a dense sampling of the circle, polished by a local search
    e1 = unit(p - np.dot(p, n) * n)
    e2 = np.cross(n, e1)
    t = np.linspace(0, 2 * math.pi, 2001)
    samples = np.cos(t)[:, None] * e1 + np.sin(t)[:, None] * e2
    k = int(np.argmax(samples @ r))
    res = minimize_scalar(lambda s: arc(r, math.cos(s) * e1 + math.sin(s) * e2),
                          bounds=(t[k] - 0.01, t[k] + 0.01), method="bounded", options={"xatol": 1e-12})
    # Brent's minimiser locates the argmin to ~1e-8; away from d = 0 the minimum is quadratic, so the
    # value is then accurate to ~1e-15 (at d = 0 the distance is V-shaped: checked exactly below)
    if abs(np.dot(r, n)) > 1e-3:
        assert abs(d - res.fun) <= 1e-12
    # a point moved off the circle along the perpendicular great circle by a known arc
    s = math.atan2(np.dot(r, e2), np.dot(r, e1))
    on = math.cos(s) * e1 + math.sin(s) * e2
    for h in (0.0, 1e-9, 0.3, math.pi / 2 - 1e-3):
        moved = math.cos(h) * on + math.sin(h) * n
        assert abs(S.distance_to_great_circle(moved, n) - h) <= 1e-15 + 1e-15 * h


def test_cap_area_against_quadrature():
    for r in [0.0, 1e-6, 0.3, math.pi / 2, 2.0, math.pi]:
        ref, _ = quad(lambda t: 2 * math.pi * math.sin(t), 0, r, epsabs=0, epsrel=1e-13)
        assert abs(S.cap_area(r) - ref) <= 1e-12
    assert abs(S.cap_area(math.pi) - 4 * math.pi) <= 1e-14  # the whole sphere
    np.testing.assert_allclose(S.cap_area([0.1, 0.2]), [2 * math.pi * (1 - math.cos(0.1)),
                                                        2 * math.pi * (1 - math.cos(0.2))], rtol=1e-13)


# --------------------------------------------------------------------------------------------------
# inscribed cap of a triangle (Sec. II-B-1)
# --------------------------------------------------------------------------------------------------
@HYP
@given(tri=triangles())
def test_triangle_incircle_equidistant_closed_form_and_inside(tri):
    A, B, C = tri
    x, r = S.triangle_incircle(A, B, C)
    # equidistant from the three side great circles, at the returned radius
    for p, q in ((A, B), (B, C), (C, A)):
        assert abs(dist_to_circle(x, side_normal(p, q)) - r) <= GEOM
    # the independent closed form x ∝ sin(a) A + sin(b) B + sin(c) C, side a opposite A
    a, b, c = arc(B, C), arc(C, A), arc(A, B)
    ref = unit(math.sin(a) * A + math.sin(b) * B + math.sin(c) * C)
    assert np.linalg.norm(x - ref) <= GEOM
    # inside: a positive combination of the vertices
    assert np.all(barycentric(x, A, B, C) > 0)
    # vertex order and orientation do not matter
    x2, r2 = S.triangle_incircle(C, B, A)
    assert np.linalg.norm(x2 - x) <= GEOM and abs(r2 - r) <= GEOM


def test_triangle_incircle_of_the_octant():
    x, r = S.triangle_incircle([1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0])
    np.testing.assert_allclose(x, np.ones(3) / math.sqrt(3), atol=1e-15)
    assert abs(r - math.asin(1 / math.sqrt(3))) <= 1e-15  # 35.26°: the height of x above the plane z = 0


def test_triangle_incircle_vectorised():
    rng = np.random.default_rng(7)
    tris = unit(rng.normal(size=(10, 3, 3)) * [1, 1, 0.2] + [0, 0, 1])  # small triangles near the pole
    x, r = S.triangle_incircle(tris[:, 0], tris[:, 1], tris[:, 2])
    assert x.shape == (10, 3) and r.shape == (10,)
    for k in range(10):
        x1, r1 = S.triangle_incircle(*tris[k])
        assert np.linalg.norm(x1 - x[k]) <= 1e-15 and abs(r1 - r[k]) <= 1e-15


# --------------------------------------------------------------------------------------------------
# inscribed cap of a tangential polygon
# --------------------------------------------------------------------------------------------------
def frame(rng):
    R = random_rotation(rng)
    return R[:, 0], R[:, 1], R[:, 2]  # c, e1, e2


@pytest.mark.parametrize("a, b", [(0.3, 0.3), (0.3, 0.7), (1.2, 0.2), (0.05, 1.4)])
def test_polygon_incircle_of_a_rhombus_closed_form(a, b):
    """A spherical rhombus with half-diagonals a, b about c: the incentre is c, and the inradius is the
    altitude of the right triangle with legs a, b: cot²h = cot²a + cot²b."""
    rng = np.random.default_rng(int(100 * a + 10 * b))
    c, e1, e2 = frame(rng)
    verts = np.array([math.cos(a) * c + math.sin(a) * e1, math.cos(b) * c + math.sin(b) * e2,
                      math.cos(a) * c - math.sin(a) * e1, math.cos(b) * c - math.sin(b) * e2])
    x, r = S.polygon_incircle(verts)
    h = math.atan(1 / math.sqrt(1 / math.tan(a) ** 2 + 1 / math.tan(b) ** 2))
    assert np.linalg.norm(x - c) <= GEOM
    assert abs(r - h) <= GEOM
    x2, r2 = S.polygon_incircle(verts[::-1])  # clockwise order too
    assert np.linalg.norm(x2 - c) <= GEOM and abs(r2 - h) <= GEOM


@pytest.mark.parametrize("a, a2, b", [(0.3, 0.8, 0.4), (0.2, 1.0, 0.6), (0.9, 0.25, 0.35)])
def test_polygon_incircle_of_a_kite_matches_a_one_dimensional_solve(a, a2, b):
    """A kite A, B, C, D symmetric about the great circle through A, C: the incentre lies on the axis A–C,
    at the point where the distances to the sides AB and BC agree (found with brentq)."""
    rng = np.random.default_rng(3)
    c, e1, e2 = frame(rng)
    A = math.cos(a) * c + math.sin(a) * e1
    C = math.cos(a2) * c - math.sin(a2) * e1
    B = math.cos(b) * c + math.sin(b) * e2
    D = math.cos(b) * c - math.sin(b) * e2
    x, r = S.polygon_incircle(np.array([A, B, C, D]))
    n_ab, n_bc = side_normal(A, B), side_normal(B, C)

    def on_axis(s):  # the point at arc s from A towards C
        t = unit(C - np.dot(C, A) * A)
        return math.cos(s) * A + math.sin(s) * t

    s = brentq(lambda s: dist_to_circle(on_axis(s), n_ab) - dist_to_circle(on_axis(s), n_bc),
               1e-9, arc(A, C) - 1e-9, xtol=1e-15)
    assert np.linalg.norm(x - on_axis(s)) <= GEOM
    for p, q in ((A, B), (B, C), (C, D), (D, A)):
        assert abs(dist_to_circle(x, side_normal(p, q)) - r) <= GEOM


@HYP
@given(tri=triangles())
def test_polygon_incircle_with_three_vertices_is_the_triangle_incircle(tri):
    x, r = S.polygon_incircle(np.array(tri))
    x3, r3 = S.triangle_incircle(*tri)
    assert np.linalg.norm(x - x3) <= GEOM and abs(r - r3) <= GEOM


def test_polygon_incircle_rejects_a_polygon_without_incircle():
    # a spherical "rectangle" with unequal sides has no inscribed circle
    rng = np.random.default_rng(0)
    c, e1, e2 = frame(rng)
    verts = np.array([unit(c + 0.6 * e1 + 0.2 * e2), unit(c - 0.6 * e1 + 0.2 * e2),
                      unit(c - 0.6 * e1 - 0.2 * e2), unit(c + 0.6 * e1 - 0.2 * e2)])
    with pytest.raises(ValueError, match=r"^vertices must be a polygon with an inscribed circle"):
        S.polygon_incircle(verts)


# --------------------------------------------------------------------------------------------------
# cap in the gap between three kissing caps, eqs. (2)-(3)
# --------------------------------------------------------------------------------------------------
def kissing_triple(r1, r2, r3, R):
    """Three mutually kissing caps: cap 1 at the pole, cap 2 at arc r1 + r2, and cap 3 on the circle at
    arc r1 + r3 from cap 1 at the azimuth where it kisses cap 2 (brentq). Then rotated by R."""
    p1 = np.array([0.0, 0.0, 1.0])
    p2 = sph(0.0, r1 + r2)
    phi = brentq(lambda f: arc(p2, sph(f, r1 + r3)) - (r2 + r3), 1e-12, math.pi, xtol=1e-15, rtol=1e-15)
    return np.array([p1, p2, sph(phi, r1 + r3)]) @ R.T


def solve_gap(P, radii, start):
    """Brute-force solve of eq. (2) by least squares from a starting guess (x, r)."""
    def residual(v):
        x = v[:3]
        return np.concatenate([[np.dot(x, x) - 1],
                               [arc(unit(x), P[i]) - v[3] - radii[i] for i in range(3)]])

    sol = least_squares(residual, np.concatenate([start, [0.01]]), xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return unit(sol.x[:3]), sol.x[3], np.abs(sol.fun).max()


radius = st.floats(0.02, 0.9)


@HYP
@given(r1=radius, r2=radius, r3=radius, seed=st.integers(0, 2**32 - 1))
def test_circle_in_gap_kisses_three_kissing_caps_and_matches_numeric_solve(r1, r2, r3, seed):
    radii = np.array([r1, r2, r3])
    P = kissing_triple(r1, r2, r3, random_rotation(np.random.default_rng(seed)))
    for i, j in ((0, 1), (1, 2), (0, 2)):  # the construction really kisses
        assert abs(arc(P[i], P[j]) - radii[i] - radii[j]) <= 1e-13
    x, r = S.circle_in_gap(P, radii)
    assert r > 0
    for i in range(3):
        assert abs(exact_arc(x, P[i]) - (r + radii[i])) <= GEOM
    # the cap lies inside the triangle of the three centres (the small interstice)
    assert np.all(barycentric(x, *P) > 0)
    # a brute-force solve of eq. (2) started at the centroid finds the same cap
    xs, rs, res = solve_gap(P, radii, unit(P.sum(axis=0)))
    assert res <= 1e-12
    assert np.linalg.norm(x - xs) <= 1e-9 and abs(r - rs) <= 1e-9  # least_squares converges to ~1e-12
    # the other solution of eq. (2) (the cap in the region on the far side) is not smaller
    xo, ro, res_o = solve_gap(P, radii, -unit(P.sum(axis=0)))
    if res_o <= 1e-12 and np.linalg.norm(xo - x) > 1e-6:
        assert ro >= r - 1e-12
    # the order of the three caps does not matter
    x2, r2_ = S.circle_in_gap(P[[2, 0, 1]], radii[[2, 0, 1]])
    assert np.linalg.norm(x2 - x) <= GEOM and abs(r2_ - r) <= GEOM


def test_circle_in_gap_exact_octant_case():
    """Caps of radius π/4 at e1, e2, e3 kiss pairwise; the gap cap is centred at (1,1,1)/√3 with radius
    arccos(1/√3) − π/4 ≈ 9.7356°."""
    x, r = S.circle_in_gap(np.eye(3), np.full(3, math.pi / 4))
    np.testing.assert_allclose(x, np.ones(3) / math.sqrt(3), atol=1e-15)
    assert abs(r - (math.acos(1 / math.sqrt(3)) - math.pi / 4)) <= 1e-14


def test_circle_in_gap_is_vectorised():
    rng = np.random.default_rng(11)
    Ps, Rs = [], []
    for _ in range(6):
        rr = rng.uniform(0.05, 0.5, 3)
        Ps.append(kissing_triple(*rr, random_rotation(rng)))
        Rs.append(rr)
    x, r = S.circle_in_gap(np.array(Ps), np.array(Rs))
    assert x.shape == (6, 3) and r.shape == (6,)
    for k in range(6):
        x1, r1 = S.circle_in_gap(Ps[k], Rs[k])
        assert np.linalg.norm(x1 - x[k]) <= 1e-15 and abs(r1 - r[k]) <= 1e-15


# --------------------------------------------------------------------------------------------------
# cap in a symmetric ring of k caps
# --------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("k", [3, 4, 5, 6, 7, 8])
@pytest.mark.parametrize("alpha, rho", [(0.5, 0.3), (1.0, 0.2), (0.35, 0.33)])
def test_circle_in_ring_symmetric_ring(k, alpha, rho):
    """k caps of radius rho at arc alpha around a random axis: the inscribed cap is on the axis with radius
    alpha − rho (by construction)."""
    rng = np.random.default_rng(k)
    R = random_rotation(rng)
    phi0 = rng.uniform(0, 2 * math.pi)
    P = np.array([sph(phi0 + 2 * math.pi * i / k, alpha) for i in range(k)]) @ R.T
    x, r = S.circle_in_ring(P, np.full(k, rho))
    assert np.linalg.norm(x - R[:, 2]) <= GEOM
    assert abs(r - (alpha - rho)) <= GEOM


@pytest.mark.parametrize("k", [4, 6, 8])
def test_circle_in_ring_alternating_radii(k):
    """A ring with k/2-fold symmetry: two radii alternating, all tangent to a cap of radius 0.2 on the axis."""
    rng = np.random.default_rng(k + 1)
    R = random_rotation(rng)
    rho = np.array([0.3 if i % 2 == 0 else 0.15 for i in range(k)])
    P = np.array([sph(2 * math.pi * i / k, 0.2 + rho[i]) for i in range(k)]) @ R.T
    x, r = S.circle_in_ring(P, rho)
    assert np.linalg.norm(x - R[:, 2]) <= GEOM
    assert abs(r - 0.2) <= GEOM


def test_circle_in_ring_kissing_pentagon_of_the_icosahedron():
    """The five neighbours of the icosahedron's north-pole vertex (polar angle arctan 2), with kissing caps
    of half their spacing, ring a hole centred on the pole of radius arctan 2 − (their radius)."""
    beta = math.atan(2.0)
    ring = np.array([sph(2 * math.pi * i / 5, beta) for i in range(5)])
    rho = 0.5 * arc(ring[0], ring[1])
    x, r = S.circle_in_ring(ring, np.full(5, rho))
    np.testing.assert_allclose(x, [0, 0, 1], atol=1e-15)
    assert abs(r - (beta - rho)) <= 1e-14


def test_circle_in_ring_rejects_an_asymmetric_ring():
    P = np.array([sph(0.0, 0.5), sph(1.5, 0.5), sph(3.0, 0.7), sph(4.5, 0.5)])
    with pytest.raises(ValueError, match=r"^centers, radii must be a rotationally symmetric ring"):
        S.circle_in_ring(P, np.full(4, 0.2))


# --------------------------------------------------------------------------------------------------
# cap in a corner of a triangle, tangent to the incircle
# --------------------------------------------------------------------------------------------------
@HYP
@given(tri=triangles(min_side=0.1, min_height=0.1))
def test_circle_in_corner_tangent_to_both_sides_and_the_incircle(tri):
    A, B, C = tri
    inc, r_in = S.triangle_incircle(A, B, C)
    for p, q, r in ((A, B, C), (B, C, A), (C, A, B)):
        x, rho = S.circle_in_corner(p, q, r)
        assert rho > 0
        assert abs(dist_to_circle(x, side_normal(p, q)) - rho) <= GEOM
        assert abs(dist_to_circle(x, side_normal(p, r)) - rho) <= GEOM
        assert abs(exact_arc(x, inc) - (rho + r_in)) <= GEOM
        # between the corner and the incircle, inside the triangle
        assert np.all(barycentric(x, p, q, r) > 0)
        assert exact_arc(x, p) < exact_arc(inc, p)


def test_circle_in_corner_of_the_octant():
    """Octant triangle, corner e3: the bisector is the arc from e3 to (1,1,1)/√3. Solve tangency with brentq."""
    inc, r_in = S.triangle_incircle([0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0])
    x, rho = S.circle_in_corner([0, 0, 1.0], [1.0, 0, 0], [0, 1.0, 0])

    def cap_at(t):  # centre at arc t from the pole along azimuth 45°: distance to the side x = 0 is its radius
        c = sph(math.pi / 4, t)
        return c, dist_to_circle(c, np.array([1.0, 0, 0]))

    t = brentq(lambda t: arc(cap_at(t)[0], inc) - cap_at(t)[1] - r_in, 1e-9, arc([0, 0, 1.0], inc), xtol=1e-15)
    c, rr = cap_at(t)
    assert np.linalg.norm(x - c) <= GEOM and abs(rho - rr) <= GEOM


# --------------------------------------------------------------------------------------------------
# bad input: ValueError whose message starts with the argument's name
# --------------------------------------------------------------------------------------------------
GOOD = np.array([0.0, 0.0, 1.0])
BAD_POINTS = {
    "non-unit": np.array([0.0, 0.0, 1.1]),
    "zero": np.zeros(3),
    "NaN": np.array([np.nan, 0.0, 1.0]),
    "inf": np.array([np.inf, 0.0, 0.0]),
    "wrong shape": np.array([1.0, 0.0]),
}


@pytest.mark.parametrize("kind", list(BAD_POINTS))
@pytest.mark.parametrize("func, args, position, name", [
    (S.arc_distance, (GOOD, GOOD), 0, "u1"),
    (S.arc_distance, (GOOD, GOOD), 1, "u2"),
    (S.angles, (GOOD,), 0, "u"),
    (S.great_circle_normal, (GOOD, np.array([1.0, 0, 0])), 0, "p"),
    (S.great_circle_normal, (GOOD, np.array([1.0, 0, 0])), 1, "q"),
    (S.distance_to_great_circle, (GOOD, GOOD), 0, "r"),
    (S.distance_to_great_circle, (GOOD, GOOD), 1, "n"),
    (S.triangle_incircle, (np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]), 1, "q"),
    (S.circle_in_corner, (np.eye(3)[0], np.eye(3)[1], np.eye(3)[2]), 2, "r"),
])
def test_bad_points_raise_value_error_naming_the_argument(kind, func, args, position, name):
    args = list(args)
    args[position] = BAD_POINTS[kind]
    with pytest.raises(ValueError) as info:
        func(*args)
    assert isinstance(info.value, InputError)
    assert re.match(rf"^{re.escape(name)} must be ", str(info.value)), str(info.value)


@pytest.mark.parametrize("kind", ["non-unit", "zero", "NaN"])
def test_bad_centres_of_gap_ring_polygon(kind):
    P = np.eye(3).copy()
    P[1] = BAD_POINTS[kind]
    for func in (S.circle_in_gap, S.circle_in_ring):
        with pytest.raises(ValueError, match=r"^centers must be "):
            func(P, np.full(3, 0.3))
    with pytest.raises(ValueError, match=r"^vertices must be "):
        S.polygon_incircle(P)


@pytest.mark.parametrize("bad", [-0.1, np.nan, np.inf, 4.0])
def test_bad_radii_raise(bad):
    with pytest.raises(ValueError, match=r"^radii must be finite angular radii"):
        S.circle_in_gap(np.eye(3), [0.3, bad, 0.3])
    with pytest.raises(ValueError, match=r"^radii must be "):
        S.circle_in_ring(np.eye(3), [0.3, bad, 0.3])
    with pytest.raises(ValueError, match=r"^radius must be "):
        S.cap_area(bad)


def test_point_rejects_nan_angles_and_normalize_rejects_zero():
    with pytest.raises(ValueError, match=r"^phi, theta must be finite"):
        S.point(np.nan, 0.3)
    with pytest.raises(ValueError, match=r"^v must be finite non-zero"):
        S.normalize([0.0, 0.0, 0.0])
    np.testing.assert_allclose(S.normalize([3.0, 0.0, 4.0]), [0.6, 0.0, 0.8], atol=1e-16)


def test_great_circle_normal_rejects_equal_and_antipodal_points():
    for q in (GOOD, -GOOD):
        with pytest.raises(ValueError, match=r"^p, q must be two distinct, non-antipodal points"):
            S.great_circle_normal(GOOD, q)


def test_circle_in_gap_rejects_collinear_centres():
    P = np.array([sph(0.0, math.pi / 2), sph(0.7, math.pi / 2), sph(1.4, math.pi / 2)])  # all on the equator
    with pytest.raises(ValueError, match=r"^centers must be three centres not on one great circle"):
        S.circle_in_gap(P, [0.35, 0.35, 0.35])


DEGENERATE = {
    "collinear": (sph(0.0, math.pi / 2), sph(0.5, math.pi / 2), sph(1.0, math.pi / 2)),
    "repeated": (sph(0.0, 1.0), sph(0.0, 1.0), sph(1.0, 1.0)),
    "antipodal side": (np.array([0, 0, 1.0]), np.array([0, 0, -1.0]), np.array([1.0, 0, 0])),
}


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_degenerate_triangles_raise_value_error(case):
    for func in (S.triangle_incircle, S.circle_in_corner):
        with pytest.raises(ValueError):
            func(*DEGENERATE[case])
    with pytest.raises(ValueError, match=r"^vertices must be "):
        S.polygon_incircle(np.array(DEGENERATE[case]))


@pytest.mark.parametrize("case", list(DEGENERATE))
def test_degenerate_triangle_message_names_p_q_r(case):
    for func in (S.triangle_incircle, S.circle_in_corner):
        with pytest.raises(ValueError, match=r"^(p, q, r|p|q|r) must be "):
            func(*DEGENERATE[case])


def test_shell_voxels_against_brute_force():
    """The voxels meeting the unit sphere, by their two z-bands per column, equal a brute-force test of
    every voxel (nearest and farthest point of the box from the origin straddle radius 1)."""
    from spherestep.sphere import shell_voxels

    for n in (1, 2, 3, 4, 7, 10, 17, 30, 31):
        h = 2 / n
        lo = -1 + np.arange(n) * h
        hi = lo + h
        near = np.where((lo <= 0) & (hi >= 0), 0.0, np.minimum(abs(lo), abs(hi)))
        far = np.maximum(abs(lo), abs(hi))
        I, J, K = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
        d_min = near[I] ** 2 + near[J] ** 2 + near[K] ** 2
        d_max = far[I] ** 2 + far[J] ** 2 + far[K] ** 2
        expected = np.flatnonzero(((d_min <= 1 + 1e-12) & (d_max >= 1 - 1e-12)).ravel())
        assert np.array_equal(shell_voxels(n), expected)


def test_nearest_point_grid_against_a_kd_tree():
    """Every unit query within tol of a point gets that point; every other query gets -1."""
    from scipy.spatial import cKDTree

    from spherestep.packing import by_name, refine
    from spherestep.sphere import NearestPointGrid

    pts = refine(by_name("truncated-icosahedron"), levels=2).centers
    tol = 0.02
    grid = NearestPointGrid(pts, tol)
    rng = np.random.default_rng(8)
    near = pts[rng.integers(len(pts), size=20000)] + rng.normal(scale=0.012, size=(20000, 3))
    q = np.vstack([near, rng.normal(size=(20000, 3))])
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    dist, idx = cKDTree(pts).query(q)
    expected = np.where(2 * np.arcsin(dist / 2) <= tol, idx, -1)
    assert np.array_equal(grid.match(q), expected)
    assert (expected >= 0).sum() > 5000


# --------------------------------------------------------------------------------------------------
# the public input contract for points
# --------------------------------------------------------------------------------------------------
def test_as_points_keeps_batches_and_values():
    u = S.point(np.linspace(0, 3, 24).reshape(2, 3, 4), 1.0)
    assert S.as_points(u).shape == (2, 3, 4, 3) and np.array_equal(S.as_points(u), u)
    assert S.as_points([0, 0, 1]).dtype == float


@pytest.mark.parametrize("bad, words", [
    ([0, 0, 2], "norm 2"), ([0, 0, 1 + 2e-9], "within 1e-09"), ([0, 0, 0], "zero vector"),
    ([0, np.nan, 1], "finite"), ([1, 0], "shape (2,)"), ("xyz", "unit 3-vectors"), ([[1, 0, 0], [0, 3, 0]], "norm 3"),
])
def test_as_points_refuses_what_is_not_a_unit_vector_naming_the_argument(bad, words):
    with pytest.raises(InputError) as err:
        S.as_points(bad, "axis")
    assert err.value.field == "axis" and str(err.value).startswith("axis must be ") and words in str(err.value)


def test_disc_angle_is_the_half_angle_seen_from_the_centre():
    # a 2-in disc 6 in away: tan θ = 1/6
    assert math.isclose(S.disc_angle(2.0, 6.0), math.atan(1 / 6), rel_tol=1e-15)
    assert math.isclose(math.tan(S.disc_angle(0.3, 0.15)), 1.0, rel_tol=1e-15)
