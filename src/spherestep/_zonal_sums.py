"""Compiled sums over the rotor's poles of a zonal kernel (numba): the fast path's hot loops.

For each point ``x`` (a coil's direction in the rotor frame), with ``t_j = x · u_j``:

    F = Σ_j p_j h(t_j),   S = Σ_j p_j h'(t_j) u_j,   M = Σ_j p_j h''(t_j) u_j u_jᵀ,
    g = S − (S · x) x,    Hess F = P M P − (S · x) P,   P = I − x xᵀ,

exactly as :class:`spherestep.rotor_field.RotorField` defines them. One flat float array ``params``
(:func:`kernel_params`: a header ``[kind, n, cut, ...]`` then the data) carries one kernel — one argument of one
type, so that a call costs one array's unboxing and numba's on-disk cache holds every function:

* ``QUINTIC`` (``table (n, 6), inv_h``): ``h`` a uniform piecewise quintic in ``t`` on ``[−1, 1]``, interval
  ``k`` holding ``Σ_i c_i s^i`` in ``s = (t + 1) inv_h − k`` (the table of
  :class:`spherestep.potential.kernel.ZonalKernel`);
* ``ANGLE_SPLINE`` (``breaks, tau (4, n), energy (5, n), g_ends (2,)``): the magnets' pair
  torque ``τ(α)`` as a cubic spline in ``α = acos t`` and its antiderivative (SciPy ``PPoly`` coefficients,
  stored interval by interval), ``h = −∫τ``, ``h' = τ / sin α`` (the limits ``g_ends`` within 1e-6 rad of the
  ends), ``h'' = −(τ' sin α − τ cos α) / sin³ α`` with ``α`` kept 1e-3 rad from the ends —
  :meth:`spherestep.magnetics.TorqueMap._zonal`. An interval is found from a uniform look-up table over
  ``[0, π]`` finer than the shortest interval, then at most a step or two (no search).

``cut``: poles with ``t < cut`` are left out of the sums — the kernel's tail beyond the cut-off angle, below a
stated bound (:func:`spherestep.rotor_field.cutoff`; ``cut = −2`` keeps every pole). The poles inside are found
by one pass of dot products, compacted without branches, then evaluated.

The rest builds on :func:`zonal_fields`: :func:`terms_evaluate` gives the energy, fixed-frame torque and Hessian
of a sum of zonal terms at one orientation (the formulas of :mod:`spherestep.rotor_field`),
:func:`batch_evaluate` over a batch, :func:`integrate` the rotor's Yoshida–Verlet steps and :func:`descend` the
safeguarded Newton descent of :func:`spherestep.statics.equilibrium`, step for step. For large batches, where
ducc0's syntheses evaluate ``F`` and its gradient, :func:`pair_locations` and :func:`synthesis_sums` /
:func:`synthesis_columns` are the loops around them (positions in, energies, torques and ``K(R)`` out).

Why compiled: for the few points of one orientation (a simulation step, a Newton iteration) the NumPy form costs
~40 array operations whose fixed overhead (1–5 µs each) dominates; the compiled loops cost ~5–12 ns per
(point, pole) pair (``fastmath``: sums may be reassociated, which changes results at rounding level only).
numba compiles on first use (seconds), then loads from its on-disk cache.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .so3 import exp_entries


QUINTIC, ANGLE_SPLINE = 0, 1
NO_CUT = -2.0
_FAST = {"contract", "reassoc", "nsz", "arcp"}  # no "nnan"/"ninf": the clamps of t keep their meaning


def kernel_params(kind: str, arrays, cut: float = NO_CUT) -> np.ndarray:
    """``params`` of a ``"quintic"`` kernel from ``(table (n, 6), inv_h)``: ``[0, n, cut, inv_h, table…]``, or of
    an ``"angle_spline"`` one from ``(breaks (n+1,), tau (4, n), energy (5, n), g_ends (2,))``: ``[1, n, cut,
    1/δ, m, breaks…, τ (n, 4)…, e (n, 5)…, g_ends…, lut (m)…]`` (row-major), ``lut[i]`` the interval holding
    ``α = i δ``, ``δ`` half the shortest interval."""
    if kind == "quintic":
        table, inv_h = arrays
        parts = [[QUINTIC, len(table), cut, inv_h], table]
    else:
        breaks, tau, energy, ends = (np.asarray(a, dtype=float) for a in arrays)
        delta = 0.5 * float(np.min(np.diff(breaks)))
        grid = np.arange(int(math.pi / delta) + 2) * delta
        lut = np.clip(np.searchsorted(breaks, grid, side="right") - 1, 0, len(breaks) - 2)
        parts = [[ANGLE_SPLINE, len(breaks) - 1, cut, 1.0 / delta, len(lut)], breaks, tau.T, energy.T, ends, lut]
    return np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in parts])


@njit(cache=True)
def _unpack(params):
    """``(kind, cut, table, inv_h, breaks, tau, energy, g_ends, lut)`` views of ``params`` (:func:`kernel_params`;
    ``inv_h`` is ``1/δ`` for a spline)."""
    n = int(params[1])
    empty = params[:0]
    if params[0] == QUINTIC:
        return (QUINTIC, params[2], params[4:].reshape(n, 6), params[3], empty, empty.reshape(0, 4),
                empty.reshape(0, 5), empty, empty)
    m = int(params[4])
    b = 5 + n + 1
    e = b + 4 * n
    g = e + 5 * n
    return (ANGLE_SPLINE, params[2], empty.reshape(0, 6), params[3], params[5:b], params[b:e].reshape(n, 4),
            params[e:g].reshape(n, 5), params[g:g + 2], params[g + 2:g + 2 + m])


@njit(cache=True, fastmath=_FAST)
def _quintic(table, inv_h, t, order):
    n = table.shape[0]
    t = min(max(t, -1.0), 1.0)
    s = (t + 1.0) * inv_h
    k = min(int(s), n - 1)
    u = s - k
    c0, c1, c2, c3, c4, c5 = table[k, 0], table[k, 1], table[k, 2], table[k, 3], table[k, 4], table[k, 5]
    h = c0 + u * (c1 + u * (c2 + u * (c3 + u * (c4 + u * c5))))
    d = (c1 + u * (2.0 * c2 + u * (3.0 * c3 + u * (4.0 * c4 + u * 5.0 * c5)))) * inv_h if order >= 1 else 0.0
    dd = (2.0 * c2 + u * (6.0 * c3 + u * (12.0 * c4 + u * 20.0 * c5))) * inv_h * inv_h if order >= 2 else 0.0
    return h, d, dd


@njit(cache=True)
def _interval(breaks, lut, inv_delta, a):
    """The spline interval of ``a`` (the end intervals extrapolate): the look-up table's, stepped forward."""
    i = int(lut[min(max(int(a * inv_delta), 0), lut.shape[0] - 1)])
    last = breaks.shape[0] - 2
    while i < last and breaks[i + 1] <= a:
        i += 1
    return i


@njit(cache=True)
def _angle_spline(breaks, lut, inv_delta, tau, energy, g_ends, t, order):
    alpha = math.acos(min(max(t, -1.0), 1.0))
    i = _interval(breaks, lut, inv_delta, alpha)
    x = alpha - breaks[i]  # (no row views: each would cost a reference count)
    h = -((((energy[i, 0] * x + energy[i, 1]) * x + energy[i, 2]) * x + energy[i, 3]) * x + energy[i, 4])
    s = math.sin(alpha)
    if s < 1e-6:
        d = g_ends[0] if alpha < 1.0 else g_ends[1]
    else:
        d = (((tau[i, 0] * x + tau[i, 1]) * x + tau[i, 2]) * x + tau[i, 3]) / s
    dd = 0.0
    if order >= 2:
        a = min(max(alpha, 1e-3), math.pi - 1e-3)
        j = _interval(breaks, lut, inv_delta, a)
        x = a - breaks[j]
        value = ((tau[j, 0] * x + tau[j, 1]) * x + tau[j, 2]) * x + tau[j, 3]
        slope = (3.0 * tau[j, 0] * x + 2.0 * tau[j, 1]) * x + tau[j, 2]
        s, co = math.sin(a), math.cos(a)
        dd = -(slope * s - value * co) / s**3
    return h, d, dd


@njit(cache=True, fastmath=_FAST)
def _near(cut, x0, x1, x2, poles, t, near):
    """All ``t_j = x · u_j`` into ``t`` (one vectorised pass), then the indices of the poles with ``t_j ≥ cut`` into
    ``near`` without branches; returns their count."""
    n = poles.shape[1]
    for j in range(n):
        t[j] = x0 * poles[0, j] + x1 * poles[1, j] + x2 * poles[2, j]
    count = 0
    for j in range(n):
        near[count] = j
        count += t[j] >= cut
    return count


@njit(cache=True, fastmath=_FAST)
def _accumulate(w, h, d, dd, u0, u1, u2, order, S, M):
    """``S += w h' u`` and ``M += w h'' u uᵀ`` (upper triangle) for one pole, by ``order``."""
    if order >= 1:
        wd = w * d
        S[0] += wd * u0
        S[1] += wd * u1
        S[2] += wd * u2
        if order >= 2:
            wdd = w * dd
            M[0] += wdd * u0 * u0
            M[1] += wdd * u0 * u1
            M[2] += wdd * u0 * u2
            M[3] += wdd * u1 * u1
            M[4] += wdd * u1 * u2
            M[5] += wdd * u2 * u2


@njit(cache=True, fastmath=_FAST)
def _point(kernel, x0, x1, x2, poles, polarity, order, S, M, t, near):
    """``F`` at ``x`` for the unpacked ``kernel`` (:func:`_unpack`) and ``poles (3, P)`` (columns ``u_j``);
    ``S (3,)`` and the upper triangle of ``M`` (``M[0..5]`` = 00, 01, 02, 11, 12, 22) filled for ``order ≥ 1, 2``
    (module docstring). ``t, near``: scratch of the poles' length. One loop per kernel kind."""
    kind, cut, table, inv_h, breaks, tau, energy, g_ends, lut = kernel
    count = _near(cut, x0, x1, x2, poles, t, near)
    f = 0.0
    S[:] = 0.0
    M[:] = 0.0
    if kind == QUINTIC and order <= 1:  # the hot case, branch-free: value and gradient
        s0 = s1 = s2 = 0.0
        for i in range(count):
            j = near[i]
            h, d, _ = _quintic(table, inv_h, t[j], 1)
            w = polarity[j]
            f += w * h
            wd = w * d
            s0 += wd * poles[0, j]
            s1 += wd * poles[1, j]
            s2 += wd * poles[2, j]
        S[0], S[1], S[2] = s0, s1, s2
    elif kind == QUINTIC:
        for i in range(count):
            j = near[i]
            h, d, dd = _quintic(table, inv_h, t[j], 2)
            w = polarity[j]
            f += w * h
            _accumulate(w, h, d, dd, poles[0, j], poles[1, j], poles[2, j], 2, S, M)
    else:
        for i in range(count):
            j = near[i]
            h, d, dd = _angle_spline(breaks, lut, inv_h, tau, energy, g_ends, t[j], order)
            w = polarity[j]
            f += w * h
            _accumulate(w, h, d, dd, poles[0, j], poles[1, j], poles[2, j], order, S, M)
    return f


@njit(cache=True)
def _hessian_on_sphere(x0, x1, x2, S, M, hess):
    """``Hess F = P M P − (S·x) P`` into ``hess (3, 3)`` from ``M``'s upper triangle (``P M P = M − x (Mx)ᵀ −
    (Mx) xᵀ + (x·Mx) x xᵀ``, scalar arithmetic); returns ``S · x``."""
    r = S[0] * x0 + S[1] * x1 + S[2] * x2
    m = ((M[0], M[1], M[2]), (M[1], M[3], M[4]), (M[2], M[4], M[5]))
    x = (x0, x1, x2)
    Mx = (m[0][0] * x0 + m[0][1] * x1 + m[0][2] * x2, m[1][0] * x0 + m[1][1] * x1 + m[1][2] * x2,
          m[2][0] * x0 + m[2][1] * x1 + m[2][2] * x2)
    xMx = x0 * Mx[0] + x1 * Mx[1] + x2 * Mx[2]
    for a in range(3):
        for b in range(3):
            P = (1.0 if a == b else 0.0) - x[a] * x[b]
            hess[a, b] = m[a][b] - x[a] * Mx[b] - Mx[a] * x[b] + xMx * x[a] * x[b] - r * P
    return r


@njit(cache=True)
def _rotate(R, A, out):
    """``out = R A Rᵀ`` for ``3 × 3`` arrays, scalar arithmetic (no temporaries)."""
    for a in range(3):
        for b in range(3):
            total = 0.0
            for i in range(3):
                Ri = R[a, i]
                for j in range(3):
                    total += Ri * A[i, j] * R[b, j]
            out[a, b] = total


_exp_entries = njit(cache=True)(exp_entries)


@njit(cache=True)
def _turn(v, R, out):
    """``out = exp(v̂) R`` (:func:`spherestep.so3.exp`'s scalar formula, compiled), scalar arithmetic."""
    e = _exp_entries(v[0], v[1], v[2])
    for a in range(3):
        for b in range(3):
            out[a, b] = e[3 * a] * R[0, b] + e[3 * a + 1] * R[1, b] + e[3 * a + 2] * R[2, b]


@njit(cache=True)
def zonal_fields(params, x, poles, polarity, order, F, g, lap, hess):
    """Fill ``F (P,)``, and for ``order ≥ 1`` ``g (P, 3)``, for ``order = 2`` ``lap (P,)`` and ``hess (P, 3, 3)``,
    at unit vectors ``x (P, 3)``, ``poles (3, M)`` (module docstring)."""
    S, M = np.empty(3), np.empty(6)
    t, near = np.empty(poles.shape[1]), np.empty(poles.shape[1], dtype=np.int64)
    kernel = _unpack(params)
    for p in range(x.shape[0]):
        x0, x1, x2 = x[p, 0], x[p, 1], x[p, 2]
        F[p] = _point(kernel, x0, x1, x2, poles, polarity, order, S, M, t, near)
        if order >= 1:
            r = S[0] * x0 + S[1] * x1 + S[2] * x2
            g[p, 0] = S[0] - r * x0
            g[p, 1] = S[1] - r * x1
            g[p, 2] = S[2] - r * x2
        if order >= 2:
            _hessian_on_sphere(x0, x1, x2, S, M, hess[p])
            lap[p] = hess[p, 0, 0] + hess[p, 1, 1] + hess[p, 2, 2]


@njit(cache=True)
def workspace(poles):
    """Scratch for :func:`terms_evaluate`: ``(floats (30 + M,), ints (M,))`` for ``poles (3, M)``."""
    return np.empty(30 + poles.shape[1]), np.empty(poles.shape[1], dtype=np.int64)


@njit(cache=True)
def terms_evaluate(params, offsets, R, coils, C, poles, P, signs, order, torque, H, work, near):
    """Energy (returned), fixed-frame torque (into ``torque (3,)``, ``order ≥ 1``) and Hessian (into ``H (3, 3)``,
    ``order = 2``) at one orientation ``R (3, 3)`` of the sum of zonal terms ``Σ_i signs[i] Σ_k C[i, k]
    F_i(Rᵀ v_k)``: term ``i`` has the kernel ``params[offsets[i]:offsets[i+1]]`` and pole weights ``P[i]``
    (:func:`spherestep.rotor_field.pack_terms`); coils with zero current are skipped. The torque is
    ``s R Σ c_k x_k × g_k`` and the Hessian ``s R [Σ c_k (ΔF P_k − Hess F + ½(g xᵀ + x gᵀ))] Rᵀ``
    (:mod:`spherestep.rotor_field`). ``work, near``: :func:`workspace`."""
    S, M, t = work[0:3], work[3:9], work[30:]
    hess, Hb = work[9:18].reshape(3, 3), work[18:27].reshape(3, 3)
    body = work[27:30]
    body[:] = 0.0
    Hb[:, :] = 0.0
    energy = 0.0
    for i in range(signs.shape[0]):
        kernel = _unpack(params[offsets[i]:offsets[i + 1]])
        polarity = P[i]
        s = signs[i]
        for k in range(coils.shape[0]):
            ck = C[i, k]
            if ck == 0.0:
                continue
            v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
            x0 = R[0, 0] * v0 + R[1, 0] * v1 + R[2, 0] * v2
            x1 = R[0, 1] * v0 + R[1, 1] * v1 + R[2, 1] * v2
            x2 = R[0, 2] * v0 + R[1, 2] * v1 + R[2, 2] * v2
            w = s * ck
            energy += w * _point(kernel, x0, x1, x2, poles, polarity, order, S, M, t, near)
            if order >= 1:
                r = S[0] * x0 + S[1] * x1 + S[2] * x2
                g0, g1, g2 = S[0] - r * x0, S[1] - r * x1, S[2] - r * x2
                body[0] += w * (x1 * g2 - x2 * g1)
                body[1] += w * (x2 * g0 - x0 * g2)
                body[2] += w * (x0 * g1 - x1 * g0)
                if order >= 2:
                    _hessian_on_sphere(x0, x1, x2, S, M, hess)
                    lap = hess[0, 0] + hess[1, 1] + hess[2, 2]
                    x = (x0, x1, x2)
                    g = (g0, g1, g2)
                    for a in range(3):
                        for b in range(3):
                            per = (lap * ((1.0 if a == b else 0.0) - x[a] * x[b]) - hess[a, b]
                                   + 0.5 * (g[a] * x[b] + x[a] * g[b]))
                            Hb[a, b] += w * per
    if order >= 1:
        for a in range(3):
            torque[a] = R[a, 0] * body[0] + R[a, 1] * body[1] + R[a, 2] * body[2]
    if order >= 2:
        _rotate(R, Hb, H)
    return energy


@njit(cache=True)
def batch_evaluate(params, offsets, R, coils, C, poles, P, signs, order, E, torque, H):
    """:func:`terms_evaluate` for ``R (B, 3, 3)`` and ``C (B, T, N)`` into ``E (B,)``, ``torque (B, 3)``, ``H (B, 3,
    3)`` (the last two unused below their order)."""
    tau, h = np.empty(3), np.empty((3, 3))
    work, near = workspace(poles)
    for b in range(R.shape[0]):
        E[b] = terms_evaluate(params, offsets, R[b], coils, C[b], poles, P, signs, order, tau, h, work, near)
        if order >= 1:
            torque[b] = tau
        if order >= 2:
            H[b] = h


# --- glue of ducc0's syntheses (spherestep.rotor_field's large batches): positions in, torques out ---------
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


@njit(cache=True)
def _norm(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@njit(cache=True)
def newton_direction(H, tau, max_step):
    """``ω = Σ_i (e_i·τ/|h_i|) e_i`` over the eigenpairs of ``H`` (``|h_i|`` floored at ``1e-8 max|h|``), shortened
    to ``|ω| ≤ max_step`` — :func:`spherestep.statics.equilibrium`'s step."""
    h, e = np.linalg.eigh(H)
    floor = 1e-8 * max(abs(h[0]), abs(h[1]), abs(h[2])) + 2.2250738585072014e-308
    omega = np.zeros(3)
    for i in range(3):
        coeff = (e[0, i] * tau[0] + e[1, i] * tau[1] + e[2, i] * tau[2]) / max(abs(h[i]), floor)
        for a in range(3):
            omega[a] += coeff * e[a, i]
    length = _norm(omega)
    return omega * min(1.0, max_step / max(length, 2.2250738585072014e-308))


@njit(cache=True)
def descend(params, offsets, R0, coils, C, poles, P, signs, constant, tol, max_iter, max_step, R, E, torque, H,
            iterations, converged):
    """:func:`spherestep.statics.equilibrium`'s descent, row by row, on the zonal terms (:func:`batch_evaluate`'s
    arguments) plus the model's ``constant (B,)`` (it sets the rounding level of the line search): from ``R0 (B,
    3, 3)`` with torque tolerances ``tol (B,)``; writes the end points' ``R, E, torque, H``, ``iterations`` and
    ``converged``."""
    tau_t, H_t, Rt = np.empty(3), np.empty((3, 3)), np.empty((3, 3))
    work, near = workspace(poles)
    for b in range(R0.shape[0]):
        Rb = R0[b].copy()
        Cb = C[b]
        tau, Hb = torque[b], H[b]
        offset = constant[b]
        Eb = offset + terms_evaluate(params, offsets, Rb, coils, Cb, poles, P, signs, 2, tau, Hb, work, near)
        done = _norm(tau) <= tol[b]
        count = 0
        for _ in range(max_iter):
            if done:
                break
            omega = newton_direction(Hb, tau, max_step)
            slope = tau[0] * omega[0] + tau[1] * omega[1] + tau[2] * omega[2]
            step = 1.0
            accepted = False
            for _ in range(40):
                _turn(step * omega, Rb, Rt)
                Et = offset + terms_evaluate(params, offsets, Rt, coils, Cb, poles, P, signs, 2, tau_t, H_t, work,
                                              near)
                armijo = Et <= Eb - 1e-4 * step * slope
                flat = abs(Et - Eb) <= 1e-13 * max(abs(Eb), 1.0) and _norm(tau_t) < _norm(tau)
                if armijo or flat:
                    accepted = True
                    break
                step *= 0.5
            if not accepted:
                break
            Rb[:, :] = Rt
            Eb = Et
            tau[:] = tau_t
            Hb[:, :] = H_t
            count += 1
            done = _norm(tau) <= tol[b]
        R[b] = Rb
        E[b] = Eb
        iterations[b] = count
        converged[b] = done


@njit(cache=True)
def _dissipate(w, inertia, damping, friction, t):
    """:meth:`spherestep.dynamics.Rotor.dissipate` of one angular velocity."""
    if damping:
        w = w * math.exp(-damping * t / inertia)
    if friction:
        speed = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        w = w * (max(speed - friction * t / inertia, 0.0) / speed) if speed > 0 else w * 0.0
    return w


@njit(cache=True)
def integrate(params, offsets, R, w, coils, C, poles, P, signs, inertia, damping, friction, h, steps, record_every,
              weights, Rs, ws):
    """:meth:`spherestep.dynamics.Rotor.step` ``steps`` times under the torque of :func:`terms_evaluate` (constant
    currents ``C (T, N)``), composition ``weights`` (Yoshida's); writes every ``record_every``-th step and the
    last into ``Rs, ws``; returns the final ``(R, ω)``."""
    tau = np.empty(3)
    H, turned = np.empty((3, 3)), np.empty((3, 3))
    work, near = workspace(poles)
    R = R.copy()
    terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
    k = 0
    for n in range(1, steps + 1):
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        for weight in weights:
            w = w + (0.5 * weight * h / inertia) * tau
            _turn(weight * h * w, R, turned)
            R[:, :] = turned
            terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
            w = w + (0.5 * weight * h / inertia) * tau
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        if n % record_every == 0 or n == steps:
            Rs[k] = R
            ws[k] = w
            k += 1
    return R, w
