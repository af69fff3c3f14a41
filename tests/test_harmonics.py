"""spherestep.harmonics: spherical harmonics (eq. (5)) and the generalized Legendre functions (eqs. (10)–(12)).

Exact references are computed here with integers and fractions only: the Rodrigues formula (10) at dyadic or
Pythagorean rational points and Wigner's explicit sum for the small d, each kept as sign · √(rational) so that
comparisons between them are exact; rounded to float only to compare with the code.
Tolerances are absolute (every P^l_mn lies in [−1, 1]).
"""

from __future__ import annotations

from decimal import Decimal, localcontext
from fractions import Fraction
from math import comb, factorial

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import assoc_legendre_p, eval_legendre, sph_harm_y

from spherestep.errors import InputError
from spherestep.harmonics import (
    half_pi_matrix,
    legendre_P,
    legendre_P_matrix,
    s2_grid,
    sph_harm,
    sph_harm_u,
)

# ---------------------------------------------------------------- exact references


def _poly_mul(a, b):
    out = [0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b):
            out[i + j] += x * y
    return out


def parity(k: int) -> int:
    """(−1)^k as an int, for any integer k."""
    return 1 - 2 * (k % 2)


class Root:
    """An exact real ``sign · √square`` with a rational ``square``: equality is exact, ``float()`` is rounded."""

    def __init__(self, sign: int, square: Fraction):
        self.sign, self.square = (sign, square) if square else (0, Fraction(0))

    def __mul__(self, k: int):  # k = ±1
        return Root(self.sign * k, self.square)

    __rmul__ = __mul__

    def __eq__(self, other):
        return (self.sign, self.square) == (other.sign, other.square)

    def __float__(self):
        with localcontext() as ctx:
            ctx.prec = 40
            root = Decimal(self.square.numerator).sqrt() / Decimal(self.square.denominator).sqrt()
        return float(self.sign * root)


def rodrigues_exact(l: int, m: int, n: int, x: Fraction) -> Root:
    """Eq. (10) at a rational ``x`` in (−1, 1): the derivative taken on integer coefficients, exactly."""
    poly = [1]
    for _ in range(l - n):
        poly = _poly_mul(poly, [1, -1])
    for _ in range(l + n):
        poly = _poly_mul(poly, [1, 1])
    for _ in range(l - m):
        poly = [i * c for i, c in enumerate(poly)][1:] or [0]
    q = sum(Fraction(c) * x**i for i, c in enumerate(poly))
    factor = Fraction(factorial(l + m), factorial(l - n) * factorial(l + n) * factorial(l - m))
    square = factor * q * q * (1 + x) ** (-(m + n)) * (1 - x) ** (n - m) / 4**l
    return Root(parity(l - m) * (1 if q > 0 else -1), square)


def wigner_d_exact(l: int, m: int, n: int, c: Fraction, s: Fraction) -> Root:
    """Wigner's explicit sum for ``d^l_mn(β)`` with rational ``cos(β/2) = c``, ``sin(β/2) = s``."""
    total = Fraction(0)
    for k in range(max(0, n - m), min(l + n, l - m) + 1):
        total += Fraction(parity(m - n + k), factorial(l + n - k) * factorial(k) * factorial(m - n + k)
                          * factorial(l - m - k)) * c ** (2 * l + n - m - 2 * k) * s ** (m - n + 2 * k)
    square = total * total * factorial(l + m) * factorial(l - m) * factorial(l + n) * factorial(l - n)
    return Root(1 if total > 0 else -1, square)


# (cos β/2, sin β/2) from Pythagorean triples, so cos β = c² − s² is rational too.
HALF_ANGLES = [(Fraction(3, 5), Fraction(4, 5)), (Fraction(12, 13), Fraction(5, 13)),
               (Fraction(8, 17), Fraction(15, 17)), (Fraction(24, 25), Fraction(7, 25))]

dyadic = st.integers(-1023, 1023).map(lambda k: Fraction(k, 1024))  # exactly representable in binary


@st.composite
def lmn(draw, lmax=12):
    l = draw(st.integers(0, lmax))
    return l, draw(st.integers(-l, l)), draw(st.integers(-l, l))


# ---------------------------------------------------------------- P^l_mn against eq. (10)


@settings(max_examples=150, deadline=None)
@given(lmn(), dyadic)
def test_legendre_P_matches_rodrigues_formula_exactly_evaluated(index, x):
    l, m, n = index
    assert abs(legendre_P(l, m, n, float(x)) - float(rodrigues_exact(l, m, n, x))) < 1e-13


@pytest.mark.parametrize("x", [Fraction(-1021, 1024), Fraction(-3, 8), Fraction(0), Fraction(5, 16),
                               Fraction(1023, 1024)])
def test_legendre_P_matrix_matches_rodrigues_formula_for_all_orders(x):
    for l in range(0, 11):
        exact = np.array([[float(rodrigues_exact(l, m, n, x)) for n in range(-l, l + 1)] for m in range(-l, l + 1)])
        assert np.max(np.abs(legendre_P_matrix(l, float(x)) - exact)) < 1e-13


@pytest.mark.parametrize("c, s", HALF_ANGLES)
def test_relation_to_wigner_small_d_is_exact(c, s):
    """P^l_mn(cos β) = (−1)^(m−n) d^l_mn(β), in exact arithmetic (sign and rational square), then the code."""
    x = c * c - s * s
    beta = 2.0 * np.arctan2(float(s), float(c))
    for l in range(0, 7):
        code = legendre_P_matrix(l, np.cos(beta))
        for m in range(-l, l + 1):
            for n in range(-l, l + 1):
                d = wigner_d_exact(l, m, n, c, s)
                assert rodrigues_exact(l, m, n, x) == parity(m - n) * d
                assert abs(code[m + l, n + l] - parity(m - n) * float(d)) < 1e-13


@pytest.mark.parametrize("l", [32, 64])
def test_both_algorithms_against_exact_values_at_high_degree(l):
    """Wigner's sum in exact arithmetic at Pythagorean angles, for 60 (m, n) per angle: absolute error < 1e-12."""
    rng = np.random.default_rng(l)
    for c, s in HALF_ANGLES:
        x = float(c * c - s * s)
        matrix = legendre_P_matrix(l, x)
        m, n = rng.integers(-l, l + 1, (2, 60))
        exact = np.array([parity(i - j) * float(wigner_d_exact(l, int(i), int(j), c, s))
                          for i, j in zip(m, n, strict=True)])
        assert np.max(np.abs(matrix[m + l, n + l] - exact)) < 1e-12
        assert np.max(np.abs(legendre_P(l, m, n, x) - exact)) < 1e-12


@pytest.mark.parametrize("x", [Fraction(-7, 25), Fraction(3, 8), Fraction(119, 169)])
def test_symmetry_relations_11_12_hold_for_the_exact_formula(x):
    for l in range(0, 8):
        for m in range(-l, l + 1):
            for n in range(-l, l + 1):
                p = rodrigues_exact(l, m, n, x)
                assert p == parity(m + n) * rodrigues_exact(l, n, m, x)
                assert p == parity(m - n) * rodrigues_exact(l, -m, -n, x)
                assert p == rodrigues_exact(l, -n, -m, x)
                assert p == parity(l + n) * rodrigues_exact(l, -m, n, -x)


# ---------------------------------------------------------------- the two algorithms, large l


@pytest.mark.parametrize("l", [16, 32, 64])
def test_recurrence_in_l_and_trapani_navaza_agree(l):
    x = np.concatenate([[-1.0, -1 + 1e-12, 0.0, 1 - 1e-12, 1.0], np.random.default_rng(l).uniform(-1, 1, 20)])
    m, n = np.meshgrid(np.arange(-l, l + 1), np.arange(-l, l + 1), indexing="ij")
    elementwise = legendre_P(l, m, n, x[:, None, None])
    assert np.max(np.abs(legendre_P_matrix(l, x) - elementwise)) < 1e-12


@pytest.mark.parametrize("l", [1, 7, 32, 64])
def test_matrix_is_orthogonal_and_satisfies_symmetries_11_12(l):
    x = np.random.default_rng(l).uniform(-1, 1, 30)
    P = legendre_P_matrix(l, x)
    assert np.max(np.abs(P @ np.swapaxes(P, -1, -2) - np.eye(2 * l + 1))) < 1e-12
    idx = np.arange(-l, l + 1)
    sign_sum = (-1.0) ** (idx[:, None] + idx[None, :])
    assert np.max(np.abs(P - sign_sum * np.swapaxes(P, -1, -2))) < 1e-12  # (11) P_mn = (−1)^(m+n) P_nm
    assert np.max(np.abs(P - sign_sum * P[:, ::-1, ::-1])) < 1e-12  # (11) (−1)^(m−n) P_−m,−n
    assert np.max(np.abs(P - np.swapaxes(P[:, ::-1, ::-1], -1, -2))) < 1e-12  # (12) P_mn = P_−n,−m
    reflected = legendre_P_matrix(l, -x)[:, ::-1, :]  # P_−m,n(−x)
    assert np.max(np.abs(P - (-1.0) ** (l + idx)[None, None, :] * reflected)) < 1e-12  # (12)


@pytest.mark.parametrize("l", [3, 20, 64])
def test_the_three_printed_recurrences(l):
    """Sec. III-B-2 (after footnote 5), with c^l_n = [(l+n)(l−n+1)]^½; sin β multiplied through."""
    x = np.random.default_rng(l).uniform(-0.999, 0.999, 25)[:, None, None]
    sin_b = np.sqrt(1 - x * x)
    below = np.pad(legendre_P_matrix(l - 1, x[:, 0, 0]), [(0, 0), (1, 1), (1, 1)])  # P^(l−1) = 0 at |m| = l
    here = legendre_P_matrix(l, x[:, 0, 0])
    above = legendre_P_matrix(l + 1, x[:, 0, 0])[:, 1:-1, 1:-1]
    m = np.arange(-l, l + 1)[:, None].astype(float)
    n = np.arange(-l, l + 1)[None, :].astype(float)
    lhs = x * here
    rhs = (np.sqrt((l * l - m * m) * (l * l - n * n)) / (l * (2 * l + 1)) * below + m * n / (l * (l + 1)) * here
           + np.sqrt(((l + 1) ** 2 - m * m) * ((l + 1) ** 2 - n * n)) / ((l + 1) * (2 * l + 1)) * above)
    assert np.max(np.abs(lhs - rhs)) < 1e-12

    def c(k):
        return np.sqrt(np.maximum((l + k) * (l - k + 1), 0.0))

    padded = np.pad(here, [(0, 0), (1, 1), (1, 1)])
    right, left = padded[:, 1:-1, 2:], padded[:, 1:-1, :-2]  # P_m,n+1 and P_m,n−1
    assert np.max(np.abs(sin_b * (0.5 * c(-n) * right + 0.5 * c(n) * left) - (m - n * x) * here)) < 1e-12
    down, up = padded[:, :-2, 1:-1], padded[:, 2:, 1:-1]  # P_m−1,n and P_m+1,n
    assert np.max(np.abs(sin_b * (-0.5 * c(m) * down - 0.5 * c(-m) * up) - (n - m * x) * here)) < 1e-12


def test_half_pi_matrix_is_P_at_zero_and_stays_orthogonal_beyond_64():
    for l in (0, 1, 4, 7):
        exact = [[float(rodrigues_exact(l, m, n, Fraction(0))) for n in range(-l, l + 1)] for m in range(-l, l + 1)]
        assert np.max(np.abs(half_pi_matrix(l) - np.array(exact))) < 1e-14
    m, n = np.meshgrid(np.arange(-64, 65), np.arange(-64, 65), indexing="ij")
    assert np.max(np.abs(half_pi_matrix(64) - legendre_P(64, m, n, 0.0))) < 1e-12
    for l in (64, 128, 200):
        pi_mat = half_pi_matrix(l)
        assert np.max(np.abs(pi_mat @ pi_mat.T - np.eye(2 * l + 1))) < 1e-12
    # top row from eq. (10) with no derivative left: 2^−l C(2l, l+n)^½
    assert np.allclose(half_pi_matrix(5)[-1], [np.sqrt(comb(10, 5 + n)) / 32 for n in range(-5, 6)], atol=1e-15)


def test_special_values():
    l = 9
    assert np.allclose(legendre_P_matrix(l, 1.0), np.eye(2 * l + 1), atol=1e-14)
    idx = np.arange(-l, l + 1)
    assert np.allclose(legendre_P_matrix(l, -1.0), np.diag((-1.0) ** (l + idx))[::-1], atol=1e-14)
    x = np.linspace(-1, 1, 101)
    for k in range(0, 40, 7):
        assert np.max(np.abs(legendre_P(k, 0, 0, x) - eval_legendre(k, x))) < 1e-13  # P_l = P^l_00


def test_associated_legendre_relation_uses_the_condon_shortley_phase_for_every_order():
    """P_l^n = [(l+n)!/(l−n)!]^½ P^l_(−n),0 equals SciPy's (Condon–Shortley) P_l^n for all n: the printed
    C_n = (−1)^n for n < 0 would flip the odd negative orders."""
    x = np.linspace(-0.95, 0.95, 9)
    for l in range(0, 12):
        for n in range(-l, l + 1):
            ours = np.sqrt(factorial(l + n) / factorial(l - n)) * legendre_P(l, -n, 0, x)
            scipy_value = np.asarray(assoc_legendre_p(l, n, x)).reshape(x.shape)
            assert np.allclose(ours, scipy_value, rtol=1e-12, atol=1e-12 * factorial(l + abs(n)) ** 0.5)
            if n < 0 and n % 2 and l >= 1 and np.any(np.abs(scipy_value) > 1e-6):
                assert not np.allclose((-1) ** n * ours, scipy_value, rtol=1e-6)


# ---------------------------------------------------------------- Y_l^m


def test_sph_harm_is_eq5_built_from_P_lmn_and_equals_scipy():
    rng = np.random.default_rng(5)
    theta, phi = rng.uniform(0, np.pi, 40), rng.uniform(-np.pi, 2 * np.pi, 40)
    for l in range(0, 10):
        for m in range(-l, l + 1):
            # eq. (5) with P_l^m = [(l+m)!/(l−m)!]^½ P^l_(−m),0: Y = [(2l+1)/4π]^½ P^l_(−m),0(cos θ) e^(imφ)
            eq5 = np.sqrt((2 * l + 1) / (4 * np.pi)) * legendre_P(l, -m, 0, np.cos(theta)) * np.exp(1j * m * phi)
            assert np.max(np.abs(sph_harm(l, m, theta, phi) - eq5)) < 1e-13
            assert np.max(np.abs(sph_harm(l, m, theta, phi) - sph_harm_y(l, m, theta, phi))) == 0.0
            assert np.allclose(sph_harm(l, -m, theta, phi), (-1) ** m * np.conj(sph_harm(l, m, theta, phi)),
                               atol=1e-14)


def test_sph_harm_broadcasts_and_matches_the_point_form():
    rng = np.random.default_rng(6)
    u = rng.normal(size=(7, 3))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    theta, phi = np.arccos(u[:, 2]), np.arctan2(u[:, 1], u[:, 0])
    l = np.arange(6)[:, None, None]
    m = np.arange(-2, 3)[None, :, None]
    m = np.where(np.abs(m) <= l, m, 0)
    assert sph_harm(l, m, theta, phi).shape == (6, 5, 7)
    assert np.max(np.abs(sph_harm_u(l, m, u) - sph_harm(l, m, theta, phi))) < 1e-14
    with pytest.raises(InputError, match="^u must be unit 3-vectors"):  # the sphere's contract: no silent rescaling
        sph_harm_u(2, 1, 3.0 * u)


def test_sph_harm_orthonormal_by_exact_quadrature():
    lmax = 12
    grid = s2_grid(lmax)
    t, p = np.meshgrid(grid.theta, grid.phi, indexing="ij")
    ls = np.concatenate([[l] * (2 * l + 1) for l in range(lmax // 2 + 1)])
    ms = np.concatenate([np.arange(-l, l + 1) for l in range(lmax // 2 + 1)])
    Y = sph_harm(ls[:, None, None], ms[:, None, None], t, p)  # products have degree ≤ lmax: exact
    gram = np.einsum("aij,bij,ij->ab", Y, Y.conj(), grid.weights)
    assert np.max(np.abs(gram - np.eye(len(ls)))) < 1e-13


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("call, name", [
    (lambda: legendre_P(-1, 0, 0, 0.5), "l"),
    (lambda: legendre_P(1.5, 0, 0, 0.5), "l"),
    (lambda: legendre_P(2, 3, 0, 0.5), "m"),
    (lambda: legendre_P(2, 0, -3, 0.5), "n"),
    (lambda: legendre_P(2, 0, 0, 1.5), "x"),
    (lambda: legendre_P(2, 0, 0, np.nan), "x"),
    (lambda: legendre_P_matrix([1, 2], 0.5), "l"),
    (lambda: legendre_P_matrix(True, 0.5), "l"),
    (lambda: sph_harm(2, 0, 4.0, 0.0), "theta"),
    (lambda: sph_harm(2, 0, 1.0, np.inf), "phi"),
    (lambda: sph_harm_u(2, 0, [0.0, 0.0, 0.0]), "u"),
])
def test_bad_input_raises_a_named_error(call, name):
    with pytest.raises(InputError, match=f"^{name} must be"):
        call()
