"""The allocation's semismooth Newton on the dual, compiled (numba): :func:`spherestep.control.allocation.
least_power_box` (the NumPy reference, kept there) step for step, equal to it to rounding
(``tests/test_control.py``).

``argmin ½‖c‖²`` s.t. ``K c = t``, ``l ≤ c ≤ u`` (per-coil bounds, ``l_k ≤ u_k``; ``l = −u`` the symmetric
box): ``λ ← λ + (K_F K_Fᵀ)⁻¹ (t − K c(λ))`` over the free coils ``F = {k : l_k < K_kᵀλ < u_k}``,
``c = clip(Kᵀλ, l, u)``, backtracking on the dual ``g(λ) = λ·t − Σ_k φ_k(K_kᵀλ)``, ``φ_k(s) = s c_k − ½c_k²`` at
``c_k = clip(s, l_k, u_k)`` (see :mod:`spherestep.control.allocation`). One call costs a few µs for 29 coils where
the NumPy loop costs ~30 µs of call overhead. :func:`voltage_box` gives the servo's per-period bounds (supply
voltage against the back-EMF and the coil's slew).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit


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
def _dual(K, t, lo, hi, lam):
    """``g(λ) = λ·t − Σ_k φ_k(K_kᵀλ)``, ``φ_k(s) = s c − ½c²`` at ``c = clip(s, l_k, u_k)``."""
    total = 0.0
    for k in range(K.shape[1]):
        s = K[0, k] * lam[0] + K[1, k] * lam[1] + K[2, k] * lam[2]
        c = min(max(s, lo[k]), hi[k])
        total += s * c - 0.5 * c * c
    return lam[0] * t[0] + lam[1] * t[1] + lam[2] * t[2] - total


@njit(cache=True)
def _primal(K, t, lo, hi, lam, c, s, r):
    """``s = Kᵀλ``, ``c = clip(s, l, u)``, ``r = t − K c``; returns ``‖r‖²``."""
    r[0], r[1], r[2] = t[0], t[1], t[2]
    for k in range(K.shape[1]):
        sk = K[0, k] * lam[0] + K[1, k] * lam[1] + K[2, k] * lam[2]
        s[k] = sk
        ck = min(max(sk, lo[k]), hi[k])
        c[k] = ck
        r[0] -= K[0, k] * ck
        r[1] -= K[1, k] * ck
        r[2] -= K[2, k] * ck
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]


@njit(cache=True)
def _scales(K, lo, hi, t):
    """``(‖K‖²_F, Σ max(|l_k|, |u_k|)², ‖t‖)``: the scales the tolerances of both solvers are relative to."""
    kk = 0.0
    uu = 0.0
    for k in range(K.shape[1]):
        kk += K[0, k] * K[0, k] + K[1, k] * K[1, k] + K[2, k] * K[2, k]
        m = max(abs(lo[k]), abs(hi[k]))
        uu += m * m
    return kk, uu, math.sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2])


@njit(cache=True)
def least_power_box(K, t, lo, hi, lam0, warm, max_iter, c, lam):
    """The reference's iteration within ``lo ≤ c ≤ hi``: fills ``c (N,)`` and ``λ (3,)``, returns whether it
    converged (``‖K c − t‖ ≤ 1e-11 (‖K‖ ‖u‖ + ‖t‖)``). ``warm``: start from ``lam0``, else from ``(KKᵀ)⁻¹ t``."""
    N = K.shape[1]
    kk, uu, tn = _scales(K, lo, hi, t)
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
        if _primal(K, t, lo, hi, lam, c, s, r) <= tol2:
            return True
        for k in range(N):
            free[k] = lo[k] < s[k] < hi[k]
        _gram(K, free, A)
        if not np.any(free) or not _solve3(A, r, d):
            return False
        if not have_g:
            g = _dual(K, t, lo, hi, lam)
            have_g = True
        step = 1.0
        accepted = False
        gt = 0.0
        for _ in range(40):
            for i in range(3):
                trial[i] = lam[i] + step * d[i]
            gt = _dual(K, t, lo, hi, trial)
            if gt >= g - 1e-15 * max(abs(g), 1.0):
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return False
        lam[:] = trial
        g = gt
    return _primal(K, t, lo, hi, lam, c, s, r) <= tol2


@njit(cache=True)
def _tikhonov(K, t, lo, hi, mu, nu, c, s, r, tol2, max_iter):
    """``argmin ½‖K c − t‖² + ½μ‖c‖²`` over the box ``l ≤ c ≤ u`` (``μ > 0``): semismooth Newton on
    ``F(ν) = t − μν − K clip(Kᵀν, l, u) = 0`` (the gradient of the strongly concave dual
    ``g(ν) − ½μ‖ν‖²``), ``ν ← ν + (K_F K_Fᵀ + μI)⁻¹ F`` with backtracking; ``c = clip(Kᵀν)``. ``ν`` in (start)
    and out; returns ``‖F‖²`` at the end (converged when ``≤ tol2``; the iteration stops there, after
    ``max_iter`` steps, or where the line search cannot improve the dual any more — rounding)."""
    N = K.shape[1]
    A = np.empty((3, 3))
    d, trial = np.empty(3), np.empty(3)
    free = np.empty(N, dtype=np.bool_)
    g = _dual(K, t, lo, hi, nu) - 0.5 * mu * (nu[0] * nu[0] + nu[1] * nu[1] + nu[2] * nu[2])
    r2 = 0.0
    for _ in range(max_iter):
        _primal(K, t, lo, hi, nu, c, s, r)
        for i in range(3):
            r[i] -= mu * nu[i]
        r2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
        if r2 <= tol2:
            return r2
        for k in range(N):
            free[k] = lo[k] < s[k] < hi[k]
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
            gt = _dual(K, t, lo, hi, trial) - 0.5 * mu * (trial[0] * trial[0] + trial[1] * trial[1] + trial[2] * trial[2])
            if gt >= g - 1e-15 * max(abs(g), 1.0):
                accepted = True
                break
            step *= 0.5
        if not accepted:
            return r2
        nu[:] = trial
        g = gt
    _primal(K, t, lo, hi, nu, c, s, r)
    for i in range(3):
        r[i] -= mu * nu[i]
    return r[0] * r[0] + r[1] * r[1] + r[2] * r[2]


@njit(cache=True)
def closest_reachable(K, t, lower, upper, rho, c):
    """``argmin ‖K c − t‖²`` over ``lower ≤ c ≤ upper``, ``‖c‖ ≤ ρ`` into ``c``; returns whether it converged
    (``False`` also when the box misses the ball). The ball's multiplier ``μ ≥ 0``: ``c(μ)`` minimises
    ``½‖K c − t‖² + ½μ‖c‖²`` over the box (:func:`_tikhonov`) and ``‖c(μ)‖`` falls with ``μ`` (``‖c(μ)‖ ≤
    ‖t‖/√μ`` for a box that holds 0: ``μ = (‖t‖/ρ)²`` is feasible; see the code for one that does not). The root of
    ``‖c(μ)‖ = ρ`` is bisected in ``log μ`` to 1e-13, warm-started from the feasible side, and the feasible end
    returned; below ``μ = 1e-13 ‖K‖²`` the ball does not bind (``μ = 0``, taken there). The same KKT point
    :func:`spherestep.control.allocation.closest_reachable` finds with Clarabel."""
    N = K.shape[1]
    kk, uu, tn = _scales(K, lower, upper, t)
    tol = 1e-12 * (math.sqrt(kk * uu) + tn) + 1e-300  # each step's KKT residual aimed at ...
    tol2 = tol * tol
    loose2 = 1e8 * tol2  # ... and accepted (1e-8 of the scale: far below what the torque needs) where rounding stops it
    floor = 1e-13 * kk
    if not floor > 0.0 or not rho > 0.0:
        c[:] = 0.0
        return rho >= 0.0 and floor >= 0.0
    nu, nu_hi, s, r = np.zeros(3), np.zeros(3), np.empty(N), np.empty(3)
    c_hi = np.empty(N)
    # the box's least-norm point c₀ = clip(0, l, u) (0 when the box holds it): comparing with c₀,
    # ‖c(μ)‖² ≤ ‖c₀‖² + ‖K c₀ − t‖²/μ, so μ = ‖K c₀ − t‖²/(ρ² − ‖c₀‖²) is feasible
    c0n = 0.0
    for i in range(3):
        r[i] = -t[i]
    for k in range(N):
        ck = min(max(0.0, lower[k]), upper[k])
        c0n += ck * ck
        for i in range(3):
            r[i] += K[i, k] * ck
    if c0n >= rho * rho:
        c[:] = 0.0
        return False
    hi = max((r[0] * r[0] + r[1] * r[1] + r[2] * r[2]) / (rho * rho - c0n) * 1.0001, 2.0 * floor)
    if _tikhonov(K, t, lower, upper, hi, nu_hi, c_hi, s, r, tol2, 100) > loose2 or math.sqrt(np.dot(c_hi, c_hi)) > rho:
        return False
    # bracket the root stepping down by tenths (ν scaled along: μν = t − K c stays about the same), then bisect
    # in log μ, each solve warm-started from the feasible end the same way
    lo = hi
    while True:
        lo = max(hi * 0.1, floor)
        for i in range(3):
            nu[i] = nu_hi[i] * (hi / lo)
        if _tikhonov(K, t, lower, upper, lo, nu, c, s, r, tol2, 100) > loose2:
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
        if _tikhonov(K, t, lower, upper, mid, nu, c, s, r, tol2, 100) > loose2:
            return False
        if math.sqrt(np.dot(c, c)) > rho:
            lo = mid
        else:
            hi = mid
            nu_hi[:] = nu
            c_hi[:] = c
    c[:] = c_hi
    return True


@njit(cache=True)
def voltage_box(K, w, previous, bound, volts, slew, lower, upper):
    """The servo's per-coil current bounds (per unit) for one period, into ``lower``/``upper (N,)``: the current
    bound ``±bound``, the supply against the back-EMF, ``|c_k + e_k| ≤ volts`` with ``e_k = K_k·ω`` already in
    per-unit volts (the caller scales ``K`` or ``ω`` by ``1/(R I_n²)``), and, when ``slew > 0``, the coil's slew
    from the ``previous`` command: ``c_k`` within ``(1 − slew)`` of the way from ``previous_k`` to the ends the
    full supply drives it to, ``c_∞± = ±volts − e_k`` (``slew = e^{−h/T}`` of one period ``h``, ``T = L/R``).
    A box need not hold 0: a coil whose back-EMF exceeds the supply, ``|e_k| > volts``, carries a current of the
    sign that brakes the motion whatever the bridge does, and the allocation counts its torque. Where the
    voltage box misses the current bound (``|e_k| > volts + bound``) the coil is pinned at the bound nearest."""
    for k in range(K.shape[1]):
        e = K[0, k] * w[0] + K[1, k] * w[1] + K[2, k] * w[2]
        hi = volts - e
        lo = -volts - e
        if slew > 0.0:
            p = previous[k]
            hi = hi + (p - hi) * slew
            lo = lo + (p - lo) * slew
        hi = min(bound, hi)
        lo = max(-bound, lo)
        if hi < lo:  # pinned: the bound nearest the box
            hi = lo = bound if lo > 0.0 else -bound
        upper[k] = hi
        lower[k] = lo


# -- the entry points control.allocation.allocate_matrix calls (plain Python around the kernels) -----------------
def solve_box(K: np.ndarray, t: np.ndarray, u: np.ndarray, lam0: np.ndarray | None = None, max_iter: int = 40,
              lower: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, bool]:
    """:func:`spherestep.control.allocation.least_power_box` compiled (:func:`least_power_box`, the same
    iteration, equal to it to rounding): ``(c, λ, converged)``. ``K (3, N)``, ``t (3,)``, ``u (N,)`` and
    ``lower (N,)`` (default ``−u``) float arrays (trusted)."""
    c, lam = np.empty(K.shape[1]), np.empty(3)
    warm = lam0 is not None
    ok = least_power_box(K if K.flags.c_contiguous else np.ascontiguousarray(K), t, _lower(u, lower), u,
                         lam0 if warm else _NO_LAM, warm, max_iter, c, lam)
    return c, lam, bool(ok)


def solve_reachable(K: np.ndarray, t: np.ndarray, u: np.ndarray, rho: float,
                    lower: np.ndarray | None = None) -> np.ndarray | None:
    """:func:`spherestep.control.allocation.closest_reachable` by a compiled bisection on the power ball's
    multiplier (:func:`closest_reachable`: the same KKT point to ~1e-9 of the torque, in ~0.1 ms where Clarabel
    takes 1.5–4 ms); ``None`` when it does not converge (then Clarabel decides)."""
    c = np.empty(K.shape[1])
    ok = closest_reachable(K if K.flags.c_contiguous else np.ascontiguousarray(K), t, _lower(u, lower), u,
                           float(rho), c)
    return c if ok else None


def _lower(u: np.ndarray, lower: np.ndarray | None) -> np.ndarray:
    """``lower``, or ``−u`` with ``u``'s writeability (the compiled kernels' signature: both alike)."""
    if lower is not None:
        return lower
    lo = -u
    lo.flags.writeable = u.flags.writeable
    return lo


_NO_LAM = np.zeros(3)
_WARM: list[bool] = []


def warm(fallback) -> None:
    """Load both compiled solvers (numba's on-disk cache, every signature the servo uses) and the conic
    ``fallback`` (``closest_reachable(K, t, u, rho)``: Clarabel's imports) once, on the first allocation — tens of
    ms each — so that a control loop never meets that cost in a period: its law allocates once when built."""
    if _WARM:
        return
    _WARM.append(True)
    K, u = np.eye(3, 4), np.ones(4)
    fixed = u.copy()
    fixed.flags.writeable = False  # the cached bounds are read-only: numba compiles that signature apart
    for t in (np.array([0.1, 0.0, 0.0]), np.array([9.0, 0.0, 0.0])):
        for bounds in (u, fixed):
            solve_box(K, t, bounds)
            solve_box(K, t, bounds, np.zeros(3))
            solve_reachable(K, t, bounds, 1.0)
        lower = -0.5 * u  # the servo's per-period asymmetric box
        solve_box(K, t, u, np.zeros(3), lower=lower)
        solve_reachable(K, t, u, 1.0, lower=lower)
    fallback(K, np.array([9.0, 0.0, 0.0]), u, 1.0)
