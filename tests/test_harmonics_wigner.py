"""spherestep.harmonics: the representation matrices U^l of eqs. (8)–(9) and the rotation of harmonics (16).

Tolerances are absolute; |U^l_mn| ≤ 1 and the spherical harmonics are O(√l).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherestep import so3
from spherestep.errors import InputError
from spherestep.harmonics import (
    legendre_P_matrix,
    so3_grid,
    sph_harm,
    sph_harm_u,
    wigner_D,
    wigner_U,
    wigner_U_zxz,
    wigner_U_zyz,
)

DEGREES = [0, 1, 2, 5, 12, 32]


def random_points(n, rng):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=-1, keepdims=True)


@pytest.mark.parametrize("l", DEGREES)
def test_homomorphism_and_unitarity(l):
    R = so3.random(40, np.random.default_rng(l))
    U1, U2, U12 = wigner_U(l, R[:20]), wigner_U(l, R[20:]), wigner_U(l, R[:20] @ R[20:])
    assert np.max(np.abs(U12 - U1 @ U2)) < 1e-10
    assert np.max(np.abs(U1 @ np.conj(np.swapaxes(U1, -1, -2)) - np.eye(2 * l + 1))) < 1e-10
    assert np.max(np.abs(wigner_U(l, np.swapaxes(R[:20], -1, -2)) - np.conj(np.swapaxes(U1, -1, -2)))) < 1e-10


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(0, 16))
def test_homomorphism_property_based(seed, l):
    R = so3.random(3, np.random.default_rng(seed))
    product = wigner_U(l, R[0]) @ wigner_U(l, R[1]) @ wigner_U(l, R[2])
    assert np.max(np.abs(wigner_U(l, R[0] @ R[1] @ R[2]) - product)) < 1e-11


def test_near_gimbal_lock_and_special_rotations():
    l = 20
    tiny = so3.rot([1.0, 2.0, 0.5], 1e-9)  # β ≈ 1e-9: elements ∝ β must not be lost
    R = so3.random(5, np.random.default_rng(3))
    for S in (np.eye(3), tiny, so3.rot([1.0, 0.0, 0.0], np.pi), so3.rot([0.3, -0.2, 0.0], np.pi)):
        assert np.max(np.abs(wigner_U(l, S @ R) - wigner_U(l, S) @ wigner_U(l, R))) < 1e-11
    assert np.max(np.abs(wigner_U(l, np.eye(3)) - np.eye(2 * l + 1))) < 1e-13


def test_eq8_form_and_shapes():
    l = 4
    angles = np.random.default_rng(8).uniform(-np.pi, np.pi, (6, 3))
    angles[:, 1] = np.abs(angles[:, 1])
    R = so3.from_euler_zxz(angles)
    m = np.arange(-l, l + 1)[:, None]
    n = np.arange(-l, l + 1)[None, :]
    a, b, g = (angles[:, i, None, None] for i in range(3))
    eq8 = 1j ** (m - n) * np.exp(-1j * (m * a + n * g)) * legendre_P_matrix(l, np.cos(angles[:, 1]))
    assert np.max(np.abs(wigner_U(l, R) - eq8)) < 1e-13
    assert np.max(np.abs(wigner_U_zxz(l, a[..., 0, 0], b[..., 0, 0], g[..., 0, 0]) - eq8)) < 1e-13
    assert wigner_U(l, R[0]).shape == (2 * l + 1, 2 * l + 1)
    assert wigner_U(l, R.reshape(2, 3, 3, 3)).shape == (2, 3, 2 * l + 1, 2 * l + 1)
    assert wigner_U_zxz(l, np.zeros((2, 1)), 0.3, np.zeros(5)).shape == (2, 5, 2 * l + 1, 2 * l + 1)


@pytest.mark.parametrize("l", [1, 6, 32])
def test_zyz_form_eq9(l):
    R = so3.random(10, np.random.default_rng(l + 100))
    zyz = so3.to_euler_zyz(R)
    # R_ZYZ(α, β, γ) = R_ZXZ(α + π/2, β, γ − π/2), the identity behind eq. (9)
    shifted = zyz + np.array([np.pi / 2, 0.0, -np.pi / 2])
    assert np.max(np.abs(so3.from_euler_zxz(shifted) - R)) < 1e-14
    assert np.max(np.abs(wigner_U_zyz(l, zyz[:, 0], zyz[:, 1], zyz[:, 2]) - wigner_U(l, R))) < 1e-11


@pytest.mark.parametrize("l", [1, 5, 20])
def test_euler_forms_accept_any_real_angles(l):
    """β outside [0, π] (and α, γ outside (−π, π]) still give U^l of the rotation the angles describe."""
    angles = np.random.default_rng(l).uniform(-7, 7, (40, 3))
    a, b, g = angles.T
    assert np.max(np.abs(wigner_U_zxz(l, a, b, g) - wigner_U(l, so3.from_euler_zxz(angles)))) < 1e-12
    assert np.max(np.abs(wigner_U_zyz(l, a, b, g) - wigner_U(l, so3.from_euler_zyz(angles)))) < 1e-12


@pytest.mark.parametrize("l", [1, 3, 8, 32])
def test_character_is_the_dirichlet_kernel(l):
    R = so3.random(50, np.random.default_rng(l + 7))
    theta = so3.angle(R)
    character = np.trace(wigner_U(l, R), axis1=-2, axis2=-1)
    assert np.max(np.abs(character - np.sin((2 * l + 1) * theta / 2) / np.sin(theta / 2))) < 1e-10


@pytest.mark.parametrize("l", [1, 4, 10])
def test_relations_to_spherical_harmonics_printed_before_eq15(l):
    """U^l_m0(R_ZYZ(α,β,γ)) = (−1)^m (4π/(2l+1))^½ conj Y_l^m(β, α), U^l_0n = (4π/(2l+1))^½ conj Y_l^n(β, γ)."""
    angles = np.random.default_rng(l).uniform(0, np.pi, (20, 3)) * [2, 1, 2]
    U = wigner_U_zyz(l, angles[:, 0], angles[:, 1], angles[:, 2])
    idx = np.arange(-l, l + 1)
    scale = np.sqrt(4 * np.pi / (2 * l + 1))
    Y_ba = sph_harm(l, idx, angles[:, 1, None], angles[:, 0, None])
    Y_bg = sph_harm(l, idx, angles[:, 1, None], angles[:, 2, None])
    assert np.max(np.abs(U[:, :, l] - (-1.0) ** idx * scale * np.conj(Y_ba))) < 1e-12
    assert np.max(np.abs(U[:, l, :] - scale * np.conj(Y_bg))) < 1e-12


@pytest.mark.parametrize("l", [1, 2, 7, 32])
def test_rotation_of_spherical_harmonics_corrected_eq16(l):
    """Y_l^n(Rᵀu) = Σ_m (−1)^(m−n) U^l_mn(R) Y_l^m(u) = Σ_m D^l_mn(R) Y_l^m(u); the printed index order fails."""
    rng = np.random.default_rng(l + 11)
    R = so3.random(6, rng)
    u = random_points(9, rng)
    idx = np.arange(-l, l + 1)
    Y = sph_harm_u(l, idx, u[:, None, :])  # (point, m)
    rotated = sph_harm_u(l, idx, np.einsum("kji,pj->kpi", R, u)[..., None, :])  # Y(Rᵀu): (rotation, point, n)
    U = wigner_U(l, R)
    signs = (-1.0) ** (idx[:, None] - idx[None, :])
    assert np.max(np.abs(rotated - np.einsum("kmn,pm->kpn", signs * U, Y))) < 1e-10
    assert np.max(np.abs(rotated - np.einsum("kmn,pm->kpn", wigner_D(l, R), Y))) < 1e-10
    if l >= 1:  # as printed, Y_l^n(Rᵀu) = Σ_m U^l_nm(R) Y_l^m(u), it does not hold
        assert np.max(np.abs(rotated - np.einsum("knm,pm->kpn", U, Y))) > 1e-2


def test_wigner_D_is_the_physicists_matrix():
    """D^l_mn(R_ZYZ(α,β,γ)) = e^(−imα) d^l_mn(β) e^(−inγ) with Wigner's explicit d (l = 1 closed form)."""
    angles = np.array([0.7, 1.1, -2.0])
    R = so3.from_euler_zyz(angles)
    a, b, g = angles
    c, s = np.cos(b), np.sin(b)
    d1 = np.array([[(1 + c) / 2, s / np.sqrt(2), (1 - c) / 2],
                   [-s / np.sqrt(2), c, s / np.sqrt(2)],
                   [(1 - c) / 2, -s / np.sqrt(2), (1 + c) / 2]])  # rows m = −1, 0, 1; d^1_10 = −sin β/√2
    idx = np.arange(-1, 2)
    expected = np.exp(-1j * idx[:, None] * a) * d1 * np.exp(-1j * idx[None, :] * g)
    assert np.max(np.abs(wigner_D(1, R) - expected)) < 1e-14


def test_eigenfunctions_of_the_laplacian_eq7():
    """∇² U^l_mn = −l(l+1) U^l_mn with the ZXZ Laplacian of eq. (7); β-derivatives by central differences."""
    l, h = 6, 1e-4
    alpha, gamma = 0.4, -1.3
    beta = np.array([0.5, 1.2, 2.4])
    m = np.arange(-l, l + 1)[:, None]
    n = np.arange(-l, l + 1)[None, :]
    U = wigner_U_zxz(l, alpha, beta, gamma)
    plus, minus = wigner_U_zxz(l, alpha, beta + h, gamma), wigner_U_zxz(l, alpha, beta - h, gamma)
    d_beta = (plus - minus) / (2 * h)
    d2_beta = (plus - 2 * U + minus) / h**2
    cot, sin2, cos = (1 / np.tan(beta))[:, None, None], (np.sin(beta) ** 2)[:, None, None], np.cos(beta)[:, None, None]
    # ∂α → −im, ∂γ → −in on e^(−i(mα+nγ))
    laplacian = d2_beta + cot * d_beta + (-(m**2) - 2 * cos * (-(m * n)) - n**2) / sin2 * U
    assert np.max(np.abs(laplacian + l * (l + 1) * U)) < 1e-5


def test_orthogonality_needs_a_conjugate():
    """∫ U^l_mn conj(U^s_pq) dμ = δ_ls δ_mp δ_nq / (2l+1), by exact quadrature; without the conjugate (as printed)
    the integral is not diagonal."""
    lmax = 3
    grid = so3_grid(lmax)
    R = grid.rotations().reshape(-1, 3, 3)
    w = grid.weights.reshape(-1)
    blocks = [wigner_U(l, R).reshape(len(R), -1) / np.sqrt(1.0 / (2 * l + 1)) for l in range(lmax + 1)]
    F = np.concatenate(blocks, axis=1)  # normalised: columns should be orthonormal
    gram = np.einsum("k,ka,kb->ab", w, F, F.conj())
    assert np.max(np.abs(gram - np.eye(F.shape[1]))) < 1e-12
    assert np.max(np.abs(np.einsum("k,ka,kb->ab", w, F, F) - np.eye(F.shape[1]))) > 0.5


@pytest.mark.parametrize("call, name", [
    (lambda: wigner_U(-1, np.eye(3)), "l"),
    (lambda: wigner_U(2, np.eye(4)), "R"),
    (lambda: wigner_U(2, np.full((3, 3), np.nan)), "R"),
    (lambda: wigner_U_zyz(2, 0.0, np.inf, 0.0), "beta"),
    (lambda: wigner_U_zxz(2.5, 0.0, 0.0, 0.0), "l"),
])
def test_bad_input_raises_a_named_error(call, name):
    with pytest.raises(InputError, match=f"^{name} must be"):
        call()
