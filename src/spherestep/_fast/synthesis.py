"""Glue around ducc0's spherical-harmonic syntheses (large batches of :mod:`spherestep.rotor_field`): positions
in, energies, torques and ``K(R)`` out (numba).

ducc0 evaluates ``F`` and its spin-weighted derivatives at points ``(θ, φ)``; :func:`pair_locations` (or
:func:`locations`) computes those points, :func:`synthesis_fields` turns the syntheses into ``g`` and ``Hess F``,
:func:`synthesis_sums` and :func:`synthesis_columns` sum them into energies, torques, Hessians and ``K(R)``.
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .terms import _rotate


@njit(cache=True, inline="always")
def _location(x0, x1, x2):
    """``(θ, φ, ρ, cos φ, sin φ)`` of the unit vector ``x``: ``θ = atan2(ρ, z)`` (``ρ = sin θ`` from ``x, y``,
    accurate near the axis), ``φ ∈ [0, 2π)``, ``φ = 0`` on the axis."""
    rho = math.sqrt(x0 * x0 + x1 * x1)
    phi = math.atan2(x1, x0)
    if phi < 0.0:
        phi += 2.0 * math.pi
    if rho == 0.0:
        return math.atan2(rho, x2), phi, rho, 1.0, 0.0
    return math.atan2(rho, x2), phi, rho, x0 / rho, x1 / rho


@njit(cache=True)
def locations(x, loc):
    """``loc[p] = (θ, φ)`` of ``x[p]``: ducc0's positions (:func:`_location`)."""
    for p in range(x.shape[0]):
        theta, phi, _, _, _ = _location(x[p, 0], x[p, 1], x[p, 2])
        loc[p, 0], loc[p, 1] = theta, phi


@njit(cache=True)
def pair_locations(R, coils, rows, cols, x, loc):
    """``x[p] = R[rows[p]]ᵀ v[cols[p]]`` (coil ``cols[p]``'s direction in orientation ``rows[p]``'s body frame)
    and its ``(θ, φ)`` into ``loc`` (:func:`_location`)."""
    for p in range(rows.shape[0]):
        q, k = rows[p], cols[p]
        v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
        x0 = R[q, 0, 0] * v0 + R[q, 1, 0] * v1 + R[q, 2, 0] * v2
        x1 = R[q, 0, 1] * v0 + R[q, 1, 1] * v1 + R[q, 2, 1] * v2
        x2 = R[q, 0, 2] * v0 + R[q, 1, 2] * v1 + R[q, 2, 2] * v2
        x[p, 0], x[p, 1], x[p, 2] = x0, x1, x2
        theta, phi, _, _, _ = _location(x0, x1, x2)
        loc[p, 0], loc[p, 1] = theta, phi


@njit(cache=True)
def _spin_fields(x0, x1, x2, d_theta, d_phi, lap, q, u, spin2_sign, order, g, hess):
    """``g = g_θ θ̂ + g_φ φ̂`` into ``g (3,)`` from ducc0's spin-1 ``DERIV1`` pair (``g_φ = ∂_φF / sin θ``), and for
    ``order = 2`` ``Hess F = ½ΔF (θ̂θ̂ᵀ + φ̂φ̂ᵀ) + σ½Q (θ̂θ̂ᵀ − φ̂φ̂ᵀ) + σ½U (θ̂φ̂ᵀ + φ̂θ̂ᵀ)`` into ``hess (3, 3)`` from
    the spin-0 ``ΔF`` and spin-2 ``(Q, U)`` (``σ = spin2_sign``, ducc0's sign: :mod:`spherestep.rotor_field`).
    The tangent basis at ``x``: ``θ̂ = (z cos φ, z sin φ, −ρ)``, ``φ̂ = (−sin φ, cos φ, 0)`` (:func:`_location`)."""
    _, _, rho, c, s = _location(x0, x1, x2)
    th = (x2 * c, x2 * s, -rho)
    ph = (-s, c, 0.0)
    for a in range(3):
        g[a] = d_theta * th[a] + d_phi * ph[a]
    if order >= 2:
        half_lap, half_q, half_u = 0.5 * lap, 0.5 * spin2_sign * q, 0.5 * spin2_sign * u
        for a in range(3):
            for b in range(3):
                tt, pp = th[a] * th[b], ph[a] * ph[b]
                hess[a, b] = half_lap * (tt + pp) + half_q * (tt - pp) + half_u * (th[a] * ph[b] + ph[a] * th[b])


@njit(cache=True)
def synthesis_fields(x, d_theta, d_phi, lap, q, u, spin2_sign, order, g, hess):
    """:func:`_spin_fields` at every ``x[p]``: ``g (P, 3)``, and for ``order = 2`` ``hess (P, 3, 3)`` (``lap, q,
    u`` unused below)."""
    scratch = np.empty((3, 3))
    for p in range(x.shape[0]):
        if order >= 2:
            _spin_fields(x[p, 0], x[p, 1], x[p, 2], d_theta[p], d_phi[p], lap[p], q[p], u[p], spin2_sign, 2, g[p],
                         hess[p])
        else:
            _spin_fields(x[p, 0], x[p, 1], x[p, 2], d_theta[p], d_phi[p], 0.0, 0.0, 0.0, spin2_sign, 1, g[p],
                         scratch)


@njit(cache=True)
def synthesis_sums(R, x, rows, w, F, d_theta, d_phi, lap, q, u, spin2_sign, sign, order, E, torque, H):
    """Add ``sign Σ w_p F_p`` to ``E[r]`` over the pairs ``p`` of orientation ``r = rows[p]`` (``F`` unused when
    empty); for ``order ≥ 1`` set ``torque[r] = sign R_r Σ w_p x_p × g_p``; for ``order = 2``
    ``H[r] = sign R_r [Σ w_p (ΔF P − Hess F + ½(g xᵀ + x gᵀ))_p] R_rᵀ`` (:mod:`spherestep.rotor_field`), with
    ``g`` and ``Hess F`` from ducc0's syntheses (:func:`_spin_fields`)."""
    body = np.zeros((R.shape[0], 3))
    Hb = np.zeros((R.shape[0] if order >= 2 else 0, 3, 3))
    g, hess = np.empty(3), np.empty((3, 3))
    for p in range(rows.shape[0]):
        r = rows[p]
        wp = w[p]
        if F.shape[0] > 0:
            E[r] += sign * wp * F[p]
        if order >= 1:
            x0, x1, x2 = x[p, 0], x[p, 1], x[p, 2]
            lap_p = lap[p] if order >= 2 else 0.0
            _spin_fields(x0, x1, x2, d_theta[p], d_phi[p], lap_p, q[p] if order >= 2 else 0.0,
                         u[p] if order >= 2 else 0.0, spin2_sign, order, g, hess)
            body[r, 0] += wp * (x1 * g[2] - x2 * g[1])
            body[r, 1] += wp * (x2 * g[0] - x0 * g[2])
            body[r, 2] += wp * (x0 * g[1] - x1 * g[0])
            if order >= 2:
                xs = (x0, x1, x2)
                for a in range(3):
                    for b in range(3):
                        P = (1.0 if a == b else 0.0) - xs[a] * xs[b]
                        Hb[r, a, b] += wp * (lap_p * P - hess[a, b] + 0.5 * (g[a] * xs[b] + xs[a] * g[b]))
    if order >= 1:
        for r in range(R.shape[0]):
            for a in range(3):
                torque[r, a] = sign * (R[r, a, 0] * body[r, 0] + R[r, a, 1] * body[r, 1] + R[r, a, 2] * body[r, 2])
            if order >= 2:
                _rotate(R[r], Hb[r], H[r])
                for a in range(3):
                    for b in range(3):
                        H[r, a, b] *= sign


@njit(cache=True)
def synthesis_columns(R, x, rows, cols, d_theta, d_phi, sign, K):
    """``K[r, :, k] = sign R_r (x × g)`` for each pair ``p`` (``r = rows[p]``, ``k = cols[p]``; ``g`` by
    :func:`_spin_fields`)."""
    g, unused = np.empty(3), np.empty((3, 3))
    for p in range(rows.shape[0]):
        r, k = rows[p], cols[p]
        x0, x1, x2 = x[p, 0], x[p, 1], x[p, 2]
        _spin_fields(x0, x1, x2, d_theta[p], d_phi[p], 0.0, 0.0, 0.0, 1.0, 1, g, unused)
        t0, t1, t2 = x1 * g[2] - x2 * g[1], x2 * g[0] - x0 * g[2], x0 * g[1] - x1 * g[0]
        for a in range(3):
            K[r, a, k] = sign * (R[r, a, 0] * t0 + R[r, a, 1] * t1 + R[r, a, 2] * t2)
