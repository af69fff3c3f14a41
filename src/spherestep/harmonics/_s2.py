"""Spherical harmonics (eq. (5)) and the spherical Fourier transform (eq. (6)) on an exact grid.

Coefficients of a function band-limited to degree ``L`` are stored as ``flm[..., l, m + L]``, shape
``(..., L+1, 2L+1)``, zero where ``|m| > l``: ``f = Σ_l Σ_m flm[l, m+L] Y_l^m``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy.special import sph_harm_y, sph_legendre_p_all

from ..so3 import as_rotations
from ..sphere import as_points
from . import _checks
from ._wigner import wigner_D


def sph_harm(l, m, theta, phi) -> np.ndarray:
    """``Y_l^m(θ, φ)`` of eq. (5), broadcasting ``l, m, theta, phi``; ``θ ∈ [0, π]`` polar, ``φ`` azimuth.

    ``Y_l^m(θ, φ) = [(2l+1)(l−m)! / (4π (l+m)!)]^½ P_l^m(cos θ) e^(imφ)`` where ``P_l^m`` is the Ferrers
    function *with* the Condon–Shortley phase, ``P_l^m(x) = (−1)^m (1−x²)^(m/2) d^m P_l/dx^m`` for ``m ≥ 0`` and
    ``P_l^(−m) = (−1)^m (l−m)!/(l+m)! P_l^m``. This is exactly ``scipy.special.sph_harm_y(l, m, θ, φ)`` (it is
    computed by it), gives ``Y_l^(−m) = (−1)^m conj(Y_l^m)``, and is the only phase with which the relations
    printed before eq. (15) hold (see docs/harmonics.md). In the paper's notation
    ``P_l^n = [(l+n)!/(l−n)!]^½ P^l_(−n),0`` for every ``n`` (the printed ``C_n = (−1)^n`` for ``n < 0`` would
    contradict those relations). Footnote 3's other convention, ``(−1)^m Y_l^m``, is the one without the phase.

    >>> bool(np.isclose(sph_harm(1, 0, 0.0, 0.0), np.sqrt(3 / (4 * np.pi))))
    True
    """
    l = _checks.degrees(l)
    m = _checks.orders(m, l, "m")
    theta = _checks.polar(theta)
    phi = _checks.angles(phi, "phi")
    return np.asarray(sph_harm_y(l, m, theta, phi))


def sph_harm_u(l, m, u) -> np.ndarray:
    """``Y_l^m(u)`` at unit vectors ``u`` ``(..., 3)`` (``u = (cos φ sin θ, sin φ sin θ, cos θ)``); broadcasts."""
    u = as_points(u, "u")
    theta, phi = _polar_azimuth(u)
    l = _checks.degrees(l)
    return np.asarray(sph_harm_y(l, _checks.orders(m, l, "m"), theta, phi))


@dataclass(frozen=True)
class S2Grid:
    """The sampling grid of :func:`s2_forward` for band limit ``lmax = L``.

    ``theta``: ``L+1`` Gauss–Legendre nodes in ``cos θ`` (ascending ``θ``); ``phi``: ``2L+1`` equispaced azimuths
    ``2πk/(2L+1)``; ``weights``: ``(L+1, 2L+1)`` area weights, ``∫ f ds = Σ weights · f`` exactly for band limit
    ``2L`` (so for ``|f|²`` and for ``f · conj(Y_l^m)``).
    """

    lmax: int
    theta: np.ndarray
    phi: np.ndarray
    weights: np.ndarray

    def points(self) -> np.ndarray:
        """The grid's unit vectors, ``(L+1, 2L+1, 3)``."""
        t, p = np.meshgrid(self.theta, self.phi, indexing="ij")
        return np.stack([np.cos(p) * np.sin(t), np.sin(p) * np.sin(t), np.cos(t)], axis=-1)


def s2_grid(lmax) -> S2Grid:
    """The exact grid for band limit ``lmax``: ``(L+1)`` Gauss–Legendre ``θ`` × ``(2L+1)`` equispaced ``φ``."""
    lmax = _checks.degree(lmax, "lmax")
    x, w = _gauss_legendre(lmax + 1)
    n_phi = 2 * lmax + 1
    phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
    weights = np.repeat((w * 2.0 * np.pi / n_phi)[:, None], n_phi, axis=1)
    return S2Grid(lmax, np.arccos(x), phi, weights)


def s2_forward(f) -> np.ndarray:
    """Eq. (6): ``f̂(l, m) = ∫ f conj(Y_l^m) ds`` from samples on :func:`s2_grid`, ``(..., L+1, 2L+1)``.

    ``L`` is read from the trailing shape ``(L+1, 2L+1)`` of ``f``. Exact (to rounding) when ``f`` has degree
    ``≤ L``: an FFT over ``φ`` (exact for ``|m − m'| ≤ 2L``), then Gauss–Legendre over ``cos θ`` (exact for
    polynomials of degree ``≤ 2L+1``). Returns ``flm[..., l, m+L]``.
    """
    f, lmax = _checks.samples_s2(f)
    lead = f.shape[:-2]
    n_phi = 2 * lmax + 1
    spectrum = np.fft.fftshift(np.fft.fft(f, axis=-1), axes=-1) * (2.0 * np.pi / n_phi)  # (..., j, m)
    table = _legendre_table(lmax) * _gauss_legendre(lmax + 1)[1]  # (m, l, j)
    columns = np.ascontiguousarray(spectrum.reshape(-1, lmax + 1, n_phi).transpose(2, 1, 0))  # (m, j, B)
    out = _real_matmul(table, columns)  # (m, l, B)
    return out.transpose(2, 1, 0).reshape(lead + (lmax + 1, n_phi))


def s2_inverse(flm) -> np.ndarray:
    """Samples ``f(θ_j, φ_k) = Σ_l Σ_m f̂(l, m) Y_l^m(θ_j, φ_k)`` on :func:`s2_grid`, ``(..., L+1, 2L+1)`` complex."""
    flm, lmax = _checks.coefficients_s2(flm)
    lead = flm.shape[:-2]
    n_phi = 2 * lmax + 1
    table = np.ascontiguousarray(_legendre_table(lmax).transpose(0, 2, 1))  # (m, j, l)
    columns = np.ascontiguousarray(flm.reshape(-1, lmax + 1, n_phi).transpose(2, 1, 0))  # (m, l, B)
    spectrum = _real_matmul(table, columns).transpose(2, 1, 0)  # (B, j, m)
    f = np.fft.ifft(np.fft.ifftshift(spectrum, axes=-1), axis=-1) * n_phi
    return f.reshape(lead + (lmax + 1, n_phi))


def s2_evaluate(flm, u) -> np.ndarray:
    """``f(u) = Σ_l Σ_m f̂(l, m) Y_l^m(u)`` at unit vectors ``u`` ``(P..., 3)``: result ``(B..., P...)``.

    Direct summation, memory ``~ (L+1)(2L+1)`` floats per point.
    """
    flm, lmax = _checks.coefficients_s2(flm)
    u = as_points(u, "u")
    theta, phi = _polar_azimuth(u)
    table = np.fft.fftshift(sph_legendre_p_all(lmax, lmax, theta.ravel())[0], axes=1)  # (l, m, P)
    by_m = np.einsum("lmp,...lm->...mp", table, flm)
    waves = np.exp(1j * np.multiply.outer(np.arange(-lmax, lmax + 1), phi.ravel()))  # (m, P)
    values = np.einsum("...mp,mp->...p", by_m, waves)
    return values.reshape(flm.shape[:-2] + u.shape[:-1])


def s2_rotate(flm, R) -> np.ndarray:
    """Coefficients of ``g(u) = f(Rᵀ u)`` (``f`` turned by ``R``): ``ĝ^l = D^l(R) f̂^l`` for each degree.

    ``D^l_mn = (−1)^(m−n) U^l_mn`` (:func:`wigner_D`), from the corrected eq. (16)
    ``Y_l^n(Rᵀ u) = Σ_m D^l_mn(R) Y_l^m(u)``. ``R`` ``(..., 3, 3)`` broadcasts against ``flm``'s leading axes.
    """
    flm, lmax = _checks.coefficients_s2(flm)
    R = as_rotations(R, "R")
    lead = np.broadcast_shapes(flm.shape[:-2], R.shape[:-2])
    out = np.zeros(lead + flm.shape[-2:], dtype=complex)
    for l in range(lmax + 1):
        block = slice(lmax - l, lmax + l + 1)
        out[..., l, block] = np.einsum("...mn,...n->...m", wigner_D(l, R), flm[..., l, block])
    return out


def _polar_azimuth(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    theta = np.arctan2(np.hypot(u[..., 0], u[..., 1]), u[..., 2])
    phi = np.arctan2(u[..., 1], u[..., 0])
    return theta, phi


@functools.lru_cache(maxsize=32)
def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes (descending, so that ``θ = arccos x`` ascends) and weights on ``[−1, 1]``."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = x[::-1].copy(), w[::-1].copy()
    x.flags.writeable = w.flags.writeable = False
    return x, w


@functools.lru_cache(maxsize=16)
def _legendre_table(lmax: int) -> np.ndarray:
    """``λ_l^m(θ_j)`` with ``Y_l^m = λ_l^m(θ) e^(imφ)`` at the grid's ``θ_j``, as ``(m, l, j)`` (centred ``m``)."""
    x, _ = _gauss_legendre(lmax + 1)
    table = sph_legendre_p_all(lmax, lmax, np.arccos(x))[0]  # (l, m wrapped, j)
    out = np.ascontiguousarray(np.fft.fftshift(table, axes=1).transpose(1, 0, 2))
    out.flags.writeable = False
    return out


def _real_matmul(real: np.ndarray, cplx: np.ndarray) -> np.ndarray:
    """``real @ cplx`` for a real ``(…, a, b)`` and a C-contiguous complex ``(…, b, c)`` without complex BLAS."""
    pairs = cplx.view(float)  # (…, b, 2c): real and imaginary parts interleaved
    return np.ascontiguousarray(real @ pairs).view(complex)
