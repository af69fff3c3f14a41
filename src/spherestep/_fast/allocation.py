"""The allocation's semismooth Newton on the dual, compiled (numba): :func:`spherestep.control.allocation.
least_power_box` (the NumPy reference, kept there) step for step, equal to it to rounding
(``tests/test_control.py``).

``argmin ½‖c‖²`` s.t. ``K c = t``, ``|c| ≤ u``: ``λ ← λ + (K_F K_Fᵀ)⁻¹ (t − K c(λ))`` over the free coils
``F = {k : |K_kᵀλ| < u_k}``, ``c = clip(Kᵀλ, −u, u)``, backtracking on the dual
``g(λ) = λ·t − Σ_k φ_k(K_kᵀλ)`` (see :mod:`spherestep.control.allocation`). One call costs a few µs for 29
coils where the NumPy loop costs ~30 µs of call overhead.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _solve3(A, r, out):
    """``out = A⁻¹ r`` for a symmetric 3 × 3 ``A`` by the adjugate; ``False`` when ``A`` is singular to rounding
    (the reference's test)."""
    a, b, c, d, e, f = A[0, 0], A[0, 1], A[0, 2], A[1, 1], A[1, 2], A[2, 2]
    m00, m01, m02 = d * f - e * e, c * e - b * f, b * e - c * d
    det = a * m00 + b * m01 + c * m02
    if not abs(det) > 1e-300 or abs(det) <= 1e-14 * abs(a * d * f):
        return False
    m11, m12, m22 = a * f - c * c, b * c - a * e, a * d - b * b
    x, y, z = r[0], r[1], r[2]
    out[0] = (m00 * x + m01 * y + m02 * z) / det
    out[1] = (m01 * x + m11 * y + m12 * z) / det
    out[2] = (m02 * x + m12 * y + m22 * z) / det
    return True


@njit(cache=True)
def _gram(K, free, A):
    """``A = K_F K_Fᵀ`` over the columns where ``free`` (all when ``free`` is empty)."""
    A[:, :] = 0.0
    every = free.shape[0] == 0
    for k in range(K.shape[1]):
        if every or free[k]:
            for i in range(3):
                for j in range(i, 3):
                    A[i, j] += K[i, k] * K[j, k]
    A[1, 0], A[2, 0], A[2, 1] = A[0, 1], A[0, 2], A[1, 2]


@njit(cache=True)
def _dual(K, t, u, lam):
    """``g(λ) = λ·t − Σ_k φ_k(K_kᵀλ)``."""
    total = 0.0
    for k in range(K.shape[1]):
        s = K[0, k] * lam[0] + K[1, k] * lam[1] + K[2, k] * lam[2]
        a = abs(s)
        total += 0.5 * s * s if a <= u[k] else u[k] * a - 0.5 * u[k] * u[k]
    return lam[0] * t[0] + lam[1] * t[1] + lam[2] * t[2] - total


@njit(cache=True)
def _primal(K, t, u, lam, c, s, r):
    """``s = Kᵀλ``, ``c = clip(s, −u, u)``, ``r = t − K c``; returns ``‖r‖²``."""
    r[0], r[1], r[2] = t[0], t[1], t[2]
    for k in range(K.shape[1]):
        sk = K[0, k] * lam[0] + K[1, k] * lam[1] + K[2, k] * lam[2]
        s[k] = sk
        ck = min(max(sk, -u[k]), u[k])
        c[k] = ck
        r[0] -= K[0, k] * ck
        r[1] -= K[1, k] * ck
        r[2] -= K[2, k] * ck
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]


@njit(cache=True)
def _scales(K, u, t):
    """``(‖K‖²_F, ‖u‖², ‖t‖)``: the scales the tolerances of both solvers are relative to."""
    kk = 0.0
    uu = 0.0
    for k in range(K.shape[1]):
        kk += K[0, k] * K[0, k] + K[1, k] * K[1, k] + K[2, k] * K[2, k]
        uu += u[k] * u[k]
    return kk, uu, math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])


@njit(cache=True)
def least_power_box(K, t, u, lam0, warm, max_iter, c, lam):
    """The reference's iteration: fills ``c (N,)`` and ``λ (3,)``, returns whether it converged
    (``‖K c − t‖ ≤ 1e-11 (‖K‖ ‖u‖ + ‖t‖)``). ``warm``: start from ``lam0``, else from ``(KKᵀ)⁻¹ t``."""
    N = K.shape[1]
    kk, uu, tn = _scales(K, u, t)
    tol = 1e-11 * (math.sqrt(kk * uu) + tn) + 1e-300
    tol2 = tol * tol
    A = np.empty((3, 3))
    s, r, d, trial = np.empty(N), np.empty(3), np.empty(3), np.empty(3)
    free = np.empty(N, dtype=np.bool_)
    if warm:
        lam[:] = lam0
    else:
        _gram(K, free[:0], A)
        if not _solve3(A, t, lam):
            c[:] = 0.0
            lam[:] = 0.0
            return False
    have_g = False
    g = 0.0
    for _ in range(max_iter):
        if _primal(K, t, u, lam, c, s, r) <= tol2:
            return True
        for k in range(N):
            free[k] = abs(s[k]) < u[k]
        _gram(K, free, A)
        if not np.any(free) or not _solve3(A, r, d):
            return False
        if not have_g:
            g = _dual(K, t, u, lam)
            have_g = True
        step = 1.0
        accepted = False
        gt = 0.0
        for _ in range(40):
            for i in range(3):
                trial[i] = lam[i] + step * d[i]
            gt = _dual(K, t, u, trial)
            if gt >= g - 1e-15 * max(abs(g), 1.0):
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return False
        lam[:] = trial
        g = gt
    return _primal(K, t, u, lam, c, s, r) <= tol2


@njit(cache=True)
def _tikhonov(K, t, u, mu, nu, c, s, r, tol2, max_iter):
    """``argmin ½‖K c − t‖² + ½μ‖c‖²`` over the box ``|c| ≤ u`` (``μ > 0``): semismooth Newton on
    ``F(ν) = t − μν − K clip(Kᵀν, −u, u) = 0`` (the gradient of the strongly concave dual
    ``g(ν) − ½μ‖ν‖²``), ``ν ← ν + (K_F K_Fᵀ + μI)⁻¹ F`` with backtracking; ``c = clip(Kᵀν)``. ``ν`` in (start)
    and out; returns ``‖F‖²`` at the end (converged when ``≤ tol2``; the iteration stops there, after
    ``max_iter`` steps, or where the line search cannot improve the dual any more — rounding)."""
    N = K.shape[1]
    A = np.empty((3, 3))
    d, trial = np.empty(3), np.empty(3)
    free = np.empty(N, dtype=np.bool_)
    g = _dual(K, t, u, nu) - 0.5 * mu * (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2])
    r2 = 0.0
    for _ in range(max_iter):
        _primal(K, t, u, nu, c, s, r)
        for i in range(3):
            r[i] -= mu * nu[i]
        r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
        if r2 <= tol2:
            return r2
        for k in range(N):
            free[k] = abs(s[k]) < u[k]
        _gram(K, free, A)
        for i in range(3):
            A[i, i] += mu
        if not _solve3(A, r, d):
            return r2
        step = 1.0
        accepted = False
        gt = 0.0
        for _ in range(60):
            for i in range(3):
                trial[i] = nu[i] + step * d[i]
            gt = _dual(K, t, u, trial) - 0.5 * mu * (trial[0] * trial[0] + trial[1] * trial[1] + trial[2] * trial[2])
            if gt >= g - 1e-15 * max(abs(g), 1.0):
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return r2
        nu[:] = trial
        g = gt
    _primal(K, t, u, nu, c, s, r)
    for i in range(3):
        r[i] -= mu * nu[i]
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]


@njit(cache=True)
def closest_reachable(K, t, u, rho, c):
    """``argmin ‖K c − t‖²`` over ``|c| ≤ u``, ``‖c‖ ≤ ρ`` into ``c``; returns whether it converged. The ball's
    multiplier ``μ ≥ 0``: ``c(μ)`` minimises ``½‖K c − t‖² + ½μ‖c‖²`` over the box (:func:`_tikhonov`) and
    ``‖c(μ)‖`` falls with ``μ`` (``‖c(μ)‖ ≤ ‖t‖/√μ``: ``μ = (‖t‖/ρ)²`` is feasible). The root of
    ``‖c(μ)‖ = ρ`` is bisected in ``log μ`` to 1e-13, warm-started from the feasible side, and the feasible end
    returned; below ``μ = 1e-13 ‖K‖²`` the ball does not bind (``μ = 0``, taken there). The same KKT point
    :func:`spherestep.control.allocation.closest_reachable` finds with Clarabel."""
    N = K.shape[1]
    kk, uu, tn = _scales(K, u, t)
    tol = 1e-12 * (math.sqrt(kk * uu) + tn) + 1e-300  # each step's KKT residual aimed at ...
    tol2 = tol * tol
    loose2 = 1e8 * tol2  # ... and accepted (1e-8 of the scale: far below what the torque needs) where rounding stops it
    floor = 1e-13 * kk
    if not floor > 0.0 or not rho > 0.0:
        c[:] = 0.0
        return rho >= 0.0 and floor >= 0.0
    nu, nu_hi, s, r = np.zeros(3), np.zeros(3), np.empty(N), np.empty(3)
    c_hi = np.empty(N)
    hi = max((tn / rho) ** 2 * 1.0001, 2.0 * floor)
    if _tikhonov(K, t, u, hi, nu_hi, c_hi, s, r, tol2, 100) > loose2 or math.sqrt(np.dot(c_hi, c_hi)) > rho:
        return False
    # bracket the root stepping down by tenths (ν scaled along: μν = t − K c stays about the same), then bisect
    # in log μ, each solve warm-started from the feasible end the same way
    lo = hi
    while True:
        lo = max(hi * 0.1, floor)
        for i in range(3):
            nu[i] = nu_hi[i] * (hi / lo)
        if _tikhonov(K, t, u, lo, nu, c, s, r, tol2, 100) > loose2:
            if lo < 1e-9 * kk:  # the ball is not binding: c(hi) is within rounding of the answer
                c[:] = c_hi
                return True
            return False
        if math.sqrt(np.dot(c, c)) > rho:
            break
        hi = lo
        nu_hi[:] = nu
        c_hi[:] = c
        if lo <= floor:  # feasible down to μ ≈ 0: the ball does not bind
            return True
    for _ in range(60):
        if hi <= lo * (1.0 + 1e-13):
            break
        mid = math.sqrt(lo * hi)
        for i in range(3):
            nu[i] = nu_hi[i] * (hi / mid)
        if _tikhonov(K, t, u, mid, nu, c, s, r, tol2, 100) > loose2:
            return False
        if math.sqrt(np.dot(c, c)) > rho:
            lo = mid
        else:
            hi = mid
            nu_hi[:] = nu
            c_hi[:] = c
    c[:] = c_hi
    return True
