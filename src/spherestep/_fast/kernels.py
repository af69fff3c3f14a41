"""The zonal kernels ``h`` and their sums over the rotor's poles at one point (numba).

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

* ``SPHERE_TABLE`` (``coef (6, m, m), n, halo``): not a zonal kernel but ``F`` itself on a cubed sphere
  (:mod:`.spheretable`; the coupled iron model), ``S`` and ``M`` those of its 0-homogeneous extension; the poles
  are not visited (:func:`.spheretable.sphere_point`: ``locate``, ``contract``, ``chain``; several tables on one
  grid share ``locate``, :func:`.terms.terms_evaluate`).

``cut``: poles with ``t < cut`` are left out of the sums — the kernel's tail beyond the cut-off angle, below a
stated bound (:func:`spherestep.rotor_field.cutoff`; ``cut = −2`` keeps every pole). The poles inside are found
by one pass of dot products, compacted without branches, then evaluated.

``fastmath``: sums may be reassociated, which changes results at rounding level only.
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .spheretable import sphere_point


QUINTIC, ANGLE_SPLINE, SPHERE_TABLE = 0, 1, 2
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
    elif kind == "sphere_table":  # a whole rotor function, not a zonal kernel (:mod:`.spheretable`)
        coef, n, halo = arrays
        coef = np.asarray(coef, dtype=float)
        parts = [[SPHERE_TABLE, coef.shape[1], NO_CUT, 2.0 * n / math.pi, halo], coef]
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
    if params[0] == SPHERE_TABLE:  # (m, 1/δ, halo) in g_ends' place, the coefficients in breaks'
        return (SPHERE_TABLE, params[2], empty.reshape(0, 6), params[3], params[5:], empty.reshape(0, 4),
                empty.reshape(0, 5), params[1:5], empty)
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
    if kind == SPHERE_TABLE:  # the rotor function itself, tabulated: no sum over the poles
        return sphere_point(breaks, int(g_ends[0]), inv_h, int(g_ends[3]), x0, x1, x2, order, S, M)
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
