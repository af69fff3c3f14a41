"""spherestep.harmonics: Fourier transforms on S² (eq. (6)) and SO(3) (eqs. (13)–(14)) on exact grids.

Band-limited test functions come from random coefficients; tolerances are relative to the coefficient size.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherestep import so3
from spherestep.errors import InputError
from spherestep.harmonics import (
    s2_evaluate,
    s2_forward,
    s2_grid,
    s2_inverse,
    s2_rotate,
    so3_convolve,
    so3_evaluate,
    so3_forward,
    so3_grid,
    so3_inverse,
    sph_harm,
    wigner_U,
)


def random_flm(lmax, rng, batch=()):
    flm = rng.normal(size=batch + (lmax + 1, 2 * lmax + 1)) + 1j * rng.normal(size=batch + (lmax + 1, 2 * lmax + 1))
    flm[..., np.abs(np.arange(-lmax, lmax + 1))[None, :] > np.arange(lmax + 1)[:, None]] = 0
    return flm


def random_fhat(lmax, rng, batch=()):
    size = 2 * lmax + 1
    fhat = rng.normal(size=batch + (lmax + 1, size, size)) + 1j * rng.normal(size=batch + (lmax + 1, size, size))
    outside = np.maximum.outer(np.abs(np.arange(-lmax, lmax + 1)), np.abs(np.arange(-lmax, lmax + 1)))
    fhat[..., outside[None] > np.arange(lmax + 1)[:, None, None]] = 0
    return fhat


# ---------------------------------------------------------------- S²


@pytest.mark.parametrize("lmax", [0, 1, 6, 32, 64])
def test_s2_round_trip_and_plancherel(lmax):
    rng = np.random.default_rng(lmax)
    flm = random_flm(lmax, rng, (2,))
    f = s2_inverse(flm)
    assert f.shape == (2, lmax + 1, 2 * lmax + 1)
    scale = np.max(np.abs(flm))
    assert np.max(np.abs(s2_forward(f) - flm)) < 1e-12 * scale
    grid = s2_grid(lmax)
    energy = np.sum(grid.weights * np.abs(f) ** 2, axis=(-2, -1))  # ∫|f|² ds by the same exact quadrature
    assert np.allclose(energy, np.sum(np.abs(flm) ** 2, axis=(-2, -1)), rtol=1e-12)


def test_s2_forward_of_sampled_harmonics_and_of_a_polynomial():
    lmax = 9
    grid = s2_grid(lmax)
    t, p = np.meshgrid(grid.theta, grid.phi, indexing="ij")
    flm = s2_forward(sph_harm(7, -3, t, p))
    expected = np.zeros_like(flm)
    expected[7, lmax - 3] = 1.0
    assert np.max(np.abs(flm - expected)) < 1e-13
    z = grid.points()[..., 2]  # z = (4π/3)^½ Y_1^0
    expected = np.zeros_like(flm)
    expected[1, lmax] = np.sqrt(4 * np.pi / 3)
    assert np.max(np.abs(s2_forward(z) - expected)) < 1e-13
    real = s2_forward(z**3 + grid.points()[..., 0] * z)  # a real function: f̂(l, −m) = (−1)^m conj f̂(l, m)
    m = np.arange(-lmax, lmax + 1)
    assert np.max(np.abs(real[:, ::-1] - (-1.0) ** m * np.conj(real))) < 1e-13


def test_s2_grid_is_the_minimal_exact_one():
    """One degree more aliases: Y_(L+1)^(L+1) conj(Y_L^−L) has φ-frequency 2L+1, which 2L+1 samples take for 0."""
    lmax = 5
    grid = s2_grid(lmax)
    t, p = np.meshgrid(grid.theta, grid.phi, indexing="ij")
    Y = sph_harm(lmax + 1, lmax + 1, t, p)
    assert abs(np.sum(grid.weights * Y * sph_harm(lmax, -lmax, t, p).conj())) > 1e-2
    assert abs(np.sum(grid.weights) - 4 * np.pi) < 1e-13


def test_s2_evaluate_matches_inverse_on_the_grid():
    lmax = 12
    flm = random_flm(lmax, np.random.default_rng(1), (3,))
    values = s2_evaluate(flm, s2_grid(lmax).points())
    assert values.shape == (3, lmax + 1, 2 * lmax + 1)
    assert np.max(np.abs(values - s2_inverse(flm))) < 1e-12 * np.max(np.abs(flm))


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_s2_rotate_turns_the_function(seed):
    """Coefficients of f(Rᵀu) from s2_rotate (the corrected eq. (16)) against direct evaluation at Rᵀu."""
    rng = np.random.default_rng(seed)
    lmax = 8
    flm = random_flm(lmax, rng)
    R = so3.random(2, rng)
    u = rng.normal(size=(15, 3))
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    turned = s2_rotate(flm, R)  # (2, L+1, 2L+1)
    direct = np.stack([s2_evaluate(flm, u @ Rk) for Rk in R])  # u @ R = (Rᵀ u) as rows
    assert np.max(np.abs(s2_evaluate(turned, u) - direct)) < 1e-11 * np.sum(np.abs(flm))
    both = s2_rotate(s2_rotate(flm, R[1]), R[0])  # f((R0 R1)ᵀ u)
    assert np.max(np.abs(both - s2_rotate(flm, R[0] @ R[1]))) < 1e-11 * np.max(np.abs(flm))


# ---------------------------------------------------------------- SO(3)


@pytest.mark.parametrize("lmax", [0, 1, 4, 12])
def test_so3_round_trip_and_plancherel(lmax):
    rng = np.random.default_rng(lmax + 50)
    fhat = random_fhat(lmax, rng, (2,))
    f = so3_inverse(fhat)
    assert f.shape == (2, 2 * lmax + 1, lmax + 1, 2 * lmax + 1)
    assert np.max(np.abs(so3_forward(f) - fhat)) < 1e-12 * np.max(np.abs(fhat))
    grid = so3_grid(lmax)
    energy = np.sum(grid.weights * np.abs(f) ** 2, axis=(-3, -2, -1))
    l = np.arange(lmax + 1)[:, None, None]
    assert np.allclose(energy, np.sum((2 * l + 1) * np.abs(fhat) ** 2, axis=(-3, -2, -1)), rtol=1e-12)


def test_so3_inverse_uses_the_grid_rotations_and_eq13():
    lmax = 5
    fhat = random_fhat(lmax, np.random.default_rng(3))
    grid = so3_grid(lmax)
    assert np.max(np.abs(so3_evaluate(fhat, grid.rotations()) - so3_inverse(fhat))) < 1e-11 * np.max(np.abs(fhat))
    assert abs(np.sum(grid.weights) - 1.0) < 1e-14


def test_so3_forward_of_a_single_matrix_element():
    """f = U^l_pq sampled with wigner_U: eq. (13) gives f̂^l_qp = 1/(2l+1) and nothing else."""
    lmax, l, p, q = 6, 4, -2, 3
    grid = so3_grid(lmax)
    f = wigner_U(l, grid.rotations())[..., p + l, q + l]
    fhat = so3_forward(f)
    expected = np.zeros_like(fhat)
    expected[l, q + lmax, p + lmax] = 1.0 / (2 * l + 1)
    assert np.max(np.abs(fhat - expected)) < 1e-13


def test_convolution_theorem_against_brute_force_quadrature():
    """(f1 * f2)(R) = ∫ f1(Q) f2(Q⁻¹R) dμ(Q), summed exactly on the grid, equals eq. (13) with f̂2^l f̂1^l;
    the printed order f̂1^l f̂2^l does not."""
    lmax = 4
    rng = np.random.default_rng(9)
    fhat1, fhat2 = random_fhat(lmax, rng), random_fhat(lmax, rng)
    grid = so3_grid(lmax)
    Q = grid.rotations().reshape(-1, 3, 3)
    f1 = so3_inverse(fhat1).reshape(-1)
    R = so3.random(4, rng)
    f2 = so3_evaluate(fhat2, np.swapaxes(Q, -1, -2)[:, None] @ R[None])  # f2(Q⁻¹R): (points, 4)
    brute = np.einsum("k,k,kr->r", grid.weights.reshape(-1), f1, f2)
    theorem = so3_evaluate(so3_convolve(fhat1, fhat2), R)
    assert np.max(np.abs(theorem - brute)) < 1e-11 * np.max(np.abs(brute))
    assert np.allclose(so3_convolve(fhat1, fhat2), fhat2 @ fhat1)
    printed = so3_evaluate(fhat1 @ fhat2, R)
    assert np.max(np.abs(printed - brute)) > 1e-2 * np.max(np.abs(brute))


# ---------------------------------------------------------------- bad input


@pytest.mark.parametrize("call, name", [
    (lambda: s2_forward(np.zeros((3, 4))), "f"),
    (lambda: s2_inverse(np.zeros((3, 3))), "flm"),
    (lambda: s2_grid(-2), "lmax"),
    (lambda: s2_evaluate(np.zeros((2, 3)), np.zeros(3)), "u"),
    (lambda: so3_forward(np.zeros((5, 3, 4))), "f"),
    (lambda: so3_inverse(np.zeros((3, 5, 4))), "fhat"),
    (lambda: so3_convolve(np.zeros((2, 3, 3)), np.zeros((3, 5, 5))), "fhat2"),
    (lambda: so3_evaluate(np.zeros((2, 3, 3)), np.zeros((2, 2))), "R"),
])
def test_bad_input_raises_a_named_error(call, name):
    with pytest.raises(InputError, match=f"^{name} must be"):
        call()
