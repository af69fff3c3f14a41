"""Compiled sums over the rotor's poles of a zonal kernel (numba): the direct evaluator's hot loop.

For each point ``x`` (a coil's direction in the rotor frame), with ``t_j = x · u_j``:

    F = Σ_j p_j h(t_j),   S = Σ_j p_j h'(t_j) u_j,   M = Σ_j p_j h''(t_j) u_j u_jᵀ,
    g = S − (S · x) x,    Hess F = P M P − (S · x) P,   P = I − x xᵀ,

exactly as :class:`spherestep.rotor_field.RotorField` defines them (same formulas as its NumPy direct sum, to
rounding). One flat float array ``params`` (:func:`kernel_params`: a header ``[kind, n, ...]`` then the data)
carries one of two kernel kinds — one argument of one type, so that a call costs one array's unboxing and
numba's on-disk cache holds every function:

* ``QUINTIC`` (``table (n, 6), inv_h``): ``h`` a uniform piecewise quintic in ``t`` on ``[−1, 1]``, interval
  ``k`` holding ``Σ_i c_i s^i`` in ``s = (t + 1) inv_h − k`` (the table of
  :class:`spherestep.potential.kernel.ZonalKernel`);
* ``ANGLE_SPLINE`` (``breaks, tau (4, n), energy (5, n), g_ends (2,)``): the magnets' pair
  torque ``τ(α)`` as a cubic spline in ``α = acos t`` and its antiderivative (SciPy ``PPoly`` coefficients),
  ``h = −∫τ``, ``h' = τ / sin α`` (the limits ``g_ends`` within 1e-6 rad of the ends), ``h'' = −(τ' sin α −
  τ cos α) / sin³ α`` with ``α`` kept 1e-3 rad from the ends — :meth:`spherestep.magnetics.TorqueMap._zonal`.

Why compiled: for the few points of one orientation (a simulation step, a Newton iteration) the NumPy form costs
~40 array operations whose fixed overhead (1–5 µs each) dominates; one compiled loop costs ~10–30 ns per
(point, pole) pair. numba compiles on first use (seconds), then loads from its on-disk cache.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .so3 import exp_entries


QUINTIC, ANGLE_SPLINE = 0, 1


def kernel_params(kind: str, arrays) -> np.ndarray:
    """``params`` of a ``"quintic"`` kernel from ``(table (n, 6), inv_h)``: ``[0, n, inv_h, table…]``, or of an
    ``"angle_spline"`` one from ``(breaks (n+1,), tau (4, n), energy (5, n), g_ends (2,))``: ``[1, n, breaks…,
    tau…, energy…, g_ends…]`` (row-major)."""
    if kind == "quintic":
        table, inv_h = arrays
        parts = [[QUINTIC, len(table), inv_h], table]
    else:
        breaks, tau, energy, ends = arrays
        parts = [[ANGLE_SPLINE, len(breaks) - 1], breaks, tau, energy, ends]
    return np.concatenate([np.ravel(np.asarray(a, dtype=float)) for a in parts])


@njit(cache=True)
def _unpack(params):
    """``(kind, table, inv_h, breaks, tau, energy, g_ends)`` views of ``params`` (:func:`kernel_params`)."""
    n = int(params[1])
    if params[0] == QUINTIC:
        empty = params[:0]
        return QUINTIC, params[3:].reshape(n, 6), params[2], empty, empty.reshape(0, n), empty.reshape(0, n), empty
    b = 2 + n + 1
    return (ANGLE_SPLINE, params[:0].reshape(0, 6), 0.0, params[2:b], params[b:b + 4 * n].reshape(4, n),
            params[b + 4 * n:b + 9 * n].reshape(5, n), params[b + 9 * n:b + 9 * n + 2])


@njit(cache=True)
def _quintic(table, inv_h, t):
    n = table.shape[0]
    t = min(max(t, -1.0), 1.0)
    s = (t + 1.0) * inv_h
    k = min(int(s), n - 1)
    u = s - k
    c0, c1, c2, c3, c4, c5 = table[k, 0], table[k, 1], table[k, 2], table[k, 3], table[k, 4], table[k, 5]
    h = c0 + u * (c1 + u * (c2 + u * (c3 + u * (c4 + u * c5))))
    d = (c1 + u * (2.0 * c2 + u * (3.0 * c3 + u * (4.0 * c4 + u * 5.0 * c5)))) * inv_h
    dd = (2.0 * c2 + u * (6.0 * c3 + u * (12.0 * c4 + u * 20.0 * c5))) * inv_h * inv_h
    return h, d, dd


@njit(cache=True)
def _ppoly(breaks, c, a, i, derivative):
    """A SciPy ``PPoly`` (``c (K, n)``, highest power first) or its first derivative at ``a`` in interval ``i``."""
    dx = a - breaks[i]
    K = c.shape[0]
    out = 0.0
    if derivative:
        for k in range(K - 1):
            out = out * dx + (K - 1 - k) * c[k, i]
    else:
        for k in range(K):
            out = out * dx + c[k, i]
    return out


@njit(cache=True)
def _interval(breaks, a):
    """The ``PPoly`` interval of ``a`` (the end intervals extrapolate)."""
    return min(max(np.searchsorted(breaks, a, side="right") - 1, 0), breaks.shape[0] - 2)


@njit(cache=True)
def _angle_spline(breaks, tau, energy, g_ends, t, order):
    alpha = math.acos(min(max(t, -1.0), 1.0))
    i = _interval(breaks, alpha)
    h = -_ppoly(breaks, energy, alpha, i, False)
    s = math.sin(alpha)
    if s < 1e-6:
        d = g_ends[0] if alpha < 1.0 else g_ends[1]
    else:
        d = _ppoly(breaks, tau, alpha, i, False) / s
    dd = 0.0
    if order >= 2:
        a = min(max(alpha, 1e-3), math.pi - 1e-3)
        j = _interval(breaks, a)
        s, c = math.sin(a), math.cos(a)
        dd = -(_ppoly(breaks, tau, a, j, True) * s - _ppoly(breaks, tau, a, j, False) * c) / s**3
    return h, d, dd


@njit(cache=True)
def zonal_fields(params, x, poles, polarity, order, F, g, lap, hess):
    """Fill ``F (P,)``, and for ``order ≥ 1`` ``g (P, 3)``, for ``order = 2`` ``lap (P,)`` and ``hess (P, 3, 3)``,
    at unit vectors ``x (P, 3)`` (module docstring)."""
    kind, table, inv_h, breaks, tau, energy, g_ends = _unpack(params)
    for p in range(x.shape[0]):
        x0, x1, x2 = x[p, 0], x[p, 1], x[p, 2]
        f = r = 0.0
        S = np.zeros(3)
        M = np.zeros((3, 3))
        for j in range(poles.shape[0]):
            u0, u1, u2 = poles[j, 0], poles[j, 1], poles[j, 2]
            t = x0 * u0 + x1 * u1 + x2 * u2
            if kind == QUINTIC:
                h, d, dd = _quintic(table, inv_h, t)
            else:
                h, d, dd = _angle_spline(breaks, tau, energy, g_ends, t, order)
            w = polarity[j]
            f += w * h
            if order >= 1:
                S[0] += w * d * u0
                S[1] += w * d * u1
                S[2] += w * d * u2
            if order >= 2:
                wdd = w * dd
                M[0, 0] += wdd * u0 * u0
                M[0, 1] += wdd * u0 * u1
                M[0, 2] += wdd * u0 * u2
                M[1, 1] += wdd * u1 * u1
                M[1, 2] += wdd * u1 * u2
                M[2, 2] += wdd * u2 * u2
        F[p] = f
        if order >= 1:
            r = S[0] * x0 + S[1] * x1 + S[2] * x2
            g[p, 0] = S[0] - r * x0
            g[p, 1] = S[1] - r * x1
            g[p, 2] = S[2] - r * x2
        if order >= 2:
            M[1, 0], M[2, 0], M[2, 1] = M[0, 1], M[0, 2], M[1, 2]
            P = -np.outer(x[p], x[p])
            for a in range(3):
                P[a, a] += 1.0
            H = P @ M @ P - r * P
            hess[p] = H
            lap[p] = H[0, 0] + H[1, 1] + H[2, 2]


@njit(cache=True)
def one_orientation(params, R, coils, c, poles, polarity, sign, torque):
    """``sign Σ_k c_k F(x_k)`` with ``x_k = Rᵀ v_k`` over the coils with ``c_k ≠ 0``, and the fixed-frame torque
    ``sign R Σ_k c_k x_k × g(x_k)`` written into ``torque (3,)``: one orientation ``R (3, 3)`` in one call."""
    energy = 0.0
    b0 = b1 = b2 = 0.0
    x = np.empty((1, 3))
    F = np.empty(1)
    g = np.empty((1, 3))
    lap = np.empty(0)
    hess = np.empty((0, 3, 3))
    for k in range(coils.shape[0]):
        ck = c[k]
        if ck == 0.0:
            continue
        for a in range(3):
            x[0, a] = R[0, a] * coils[k, 0] + R[1, a] * coils[k, 1] + R[2, a] * coils[k, 2]
        zonal_fields(params, x, poles, polarity, 1, F, g, lap, hess)
        energy += ck * F[0]
        b0 += ck * (x[0, 1] * g[0, 2] - x[0, 2] * g[0, 1])
        b1 += ck * (x[0, 2] * g[0, 0] - x[0, 0] * g[0, 2])
        b2 += ck * (x[0, 0] * g[0, 1] - x[0, 1] * g[0, 0])
    for a in range(3):
        torque[a] = sign * (R[a, 0] * b0 + R[a, 1] * b1 + R[a, 2] * b2)
    return sign * energy


@njit(cache=True)
def terms_torque(params, offsets, R, coils, C, poles, P, signs, torque):
    """Energy and torque (into ``torque (3,)``) of a sum of zonal terms at one orientation: term ``i`` has the
    kernel ``params[offsets[i]:offsets[i+1]]``, currents ``C[i]``, pole weights ``P[i]`` and sign ``signs[i]``
    (:func:`spherestep.rotor_field.pack_terms`)."""
    energy = 0.0
    part = np.empty(3)
    torque[:] = 0.0
    for i in range(signs.shape[0]):
        energy += one_orientation(params[offsets[i]:offsets[i + 1]], R, coils, C[i], poles, P[i], signs[i], part)
        torque += part
    return energy


_exp_entries = njit(cache=True)(exp_entries)


@njit(cache=True)
def _exp(v):
    """:func:`spherestep.so3.exp` of one rotation vector (its scalar formula, compiled)."""
    e = _exp_entries(v[0], v[1], v[2])
    E = np.empty((3, 3))
    E[0, 0], E[0, 1], E[0, 2] = e[0], e[1], e[2]
    E[1, 0], E[1, 1], E[1, 2] = e[3], e[4], e[5]
    E[2, 0], E[2, 1], E[2, 2] = e[6], e[7], e[8]
    return E


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
    """:meth:`spherestep.dynamics.Rotor.step` ``steps`` times under the torque of :func:`terms_torque` (constant
    currents), composition ``weights`` (Yoshida's); writes every ``record_every``-th step and the last into
    ``Rs, ws``; returns the final ``(R, ω)``."""
    tau = np.empty(3)
    terms_torque(params, offsets, R, coils, C, poles, P, signs, tau)
    k = 0
    for n in range(1, steps + 1):
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        for weight in weights:
            w = w + (0.5 * weight * h / inertia) * tau
            R = _exp(weight * h * w) @ R
            terms_torque(params, offsets, R, coils, C, poles, P, signs, tau)
            w = w + (0.5 * weight * h / inertia) * tau
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        if n % record_every == 0 or n == steps:
            Rs[k] = R
            ws[k] = w
            k += 1
    return R, w
