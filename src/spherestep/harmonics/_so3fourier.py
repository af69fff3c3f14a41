"""Fourier series on SO(3), eqs. (13)–(14), on an exact grid in ZXZ Euler angles.

Coefficients of a function band-limited to degree ``L`` are stored padded as ``fhat[..., l, m+L, n+L] = f̂^l_mn``,
shape ``(..., L+1, 2L+1, 2L+1)``, zero where ``|m| > l`` or ``|n| > l``; block ``l`` is the matrix ``f̂^l``, and
products of padded blocks are the padded products.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import so3
from ..errors import bad_value
from . import _checks
from ._legendre import matrix_of_beta
from ._s2 import _gauss_legendre
from ._wigner import i_power, wigner_U


@dataclass(frozen=True)
class SO3Grid:
    """The sampling grid of :func:`so3_forward` for band limit ``lmax = L``, axes ordered ``(α, β, γ)``.

    ``alpha = gamma = 2πk/(2L+1)`` (``2L+1`` each), ``beta``: ``L+1`` Gauss–Legendre nodes in ``cos β``
    (ascending ``β``); ``weights`` ``(2L+1, L+1, 2L+1)``: ``∫ f dμ = Σ weights · f`` for the normalised Haar
    measure, exact for band limit ``2L``.
    """

    lmax: int
    alpha: np.ndarray
    beta: np.ndarray
    gamma: np.ndarray
    weights: np.ndarray

    def angles(self) -> np.ndarray:
        """ZXZ Euler angles of the grid points, ``(2L+1, L+1, 2L+1, 3)``."""
        return np.stack(np.meshgrid(self.alpha, self.beta, self.gamma, indexing="ij"), axis=-1)

    def rotations(self) -> np.ndarray:
        """The grid's rotations ``R3(α) R1(β) R3(γ)``, ``(2L+1, L+1, 2L+1, 3, 3)``."""
        return so3.from_euler_zxz(self.angles())


def so3_grid(lmax) -> SO3Grid:
    """The exact grid for band limit ``lmax``: ``(2L+1) × (L+1) × (2L+1)`` points in ``(α, β, γ)``."""
    lmax = _checks.degree(lmax, "lmax")
    x, w = _gauss_legendre(lmax + 1)
    size = 2 * lmax + 1
    angles = 2.0 * np.pi * np.arange(size) / size
    weights = np.broadcast_to((0.5 * w / size**2)[None, :, None], (size, lmax + 1, size)).copy()
    return SO3Grid(lmax, angles, np.arccos(x), angles.copy(), weights)


def so3_forward(f) -> np.ndarray:
    """Eq. (14): ``f̂^l_mn = ∫ f(R) U^l_mn(R⁻¹) dμ(R)`` from samples ``(..., 2L+1, L+1, 2L+1)`` on :func:`so3_grid`.

    With ``U^l_mn(R⁻¹) = conj U^l_nm(R) = i^(m−n) e^(i(nα + mγ)) P^l_nm(cos β)``: a 2-D FFT over ``(α, γ)`` (exact for
    frequencies up to ``2L``), then Gauss–Legendre in ``cos β`` (the products ``P^l_mn P^l'_mn`` are polynomials of
    degree ``l + l' ≤ 2L``). Returns ``(..., L+1, 2L+1, 2L+1)``.
    """
    f, lmax = _checks.samples_so3(f)
    size = 2 * lmax + 1
    _, w = _gauss_legendre(lmax + 1)
    averages = np.fft.fftshift(np.fft.ifft2(f, axes=(-3, -1)), axes=(-3, -1))  # [..., n, i, m]
    averages = np.moveaxis(averages, -3, -1)  # [..., i, m, n]
    out = np.zeros(f.shape[:-3] + (lmax + 1, size, size), dtype=complex)
    for l in range(lmax + 1):
        block = slice(lmax - l, lmax + l + 1)
        kernel = 0.5 * w[:, None, None] * np.swapaxes(matrix_of_beta(l, _beta(lmax)), -1, -2) * i_power(l)
        out[..., l, block, block] = np.einsum("imn,...imn->...mn", kernel, averages[..., :, block, block])
    return out


def so3_inverse(fhat) -> np.ndarray:
    """Eq. (13): ``f(R) = Σ_l (2l+1) trace(f̂^l U^l(R))`` sampled on :func:`so3_grid`, ``(..., 2L+1, L+1, 2L+1)``."""
    fhat, lmax = _checks.coefficients_so3(fhat)
    size = 2 * lmax + 1
    gathered = np.zeros(fhat.shape[:-3] + (lmax + 1, size, size), dtype=complex)  # [..., i, m, n]
    for l in range(lmax + 1):
        block = slice(lmax - l, lmax + l + 1)
        kernel = (2 * l + 1) * matrix_of_beta(l, _beta(lmax)) * i_power(l)
        gathered[..., :, block, block] += kernel * np.swapaxes(fhat[..., l, block, block], -1, -2)[..., None, :, :]
    spectrum = np.swapaxes(gathered, -3, -2)  # [..., m, i, n]
    return np.fft.fft2(np.fft.ifftshift(spectrum, axes=(-3, -1)), axes=(-3, -1))


def so3_evaluate(fhat, R) -> np.ndarray:
    """Eq. (13) at rotations ``R`` ``(K..., 3, 3)``: ``f(R) = Σ_l (2l+1) Σ_mn f̂^l_nm U^l_mn(R)``, ``(B..., K...)``."""
    fhat, lmax = _checks.coefficients_so3(fhat)
    R = so3.as_rotations(R, "R")
    out = 0.0
    for l in range(lmax + 1):
        block = slice(lmax - l, lmax + l + 1)
        U = wigner_U(l, R).reshape(-1, 2 * l + 1, 2 * l + 1)
        out = out + (2 * l + 1) * np.einsum("...nm,kmn->...k", fhat[..., l, block, block], U)
    return np.asarray(out).reshape(fhat.shape[:-3] + R.shape[:-2])


def so3_convolve(fhat1, fhat2) -> np.ndarray:
    """Coefficients of ``(f1 * f2)(R) = ∫ f1(Q) f2(Q⁻¹R) dμ(Q)``: ``(f1 * f2)^l = f̂2^l f̂1^l`` for each ``l``.

    The order is the reverse of the one printed in Sec. III-B-2: with eq. (14) and ``U^l(R1 R2) = U^l(R1) U^l(R2)``,
    substituting ``R = Q S`` gives ``∫∫ f1(Q) f2(S) U^l(S⁻¹) U^l(Q⁻¹) = f̂2^l f̂1^l`` (see docs/harmonics.md).
    """
    fhat1, lmax1 = _checks.coefficients_so3(fhat1, "fhat1")
    fhat2, lmax2 = _checks.coefficients_so3(fhat2, "fhat2")
    if lmax1 != lmax2:
        raise bad_value("fhat2", f"the band limit of fhat1 (L = {lmax1})", f"L = {lmax2}")
    return fhat2 @ fhat1


def _beta(lmax: int) -> np.ndarray:
    return np.arccos(_gauss_legendre(lmax + 1)[0])

