"""The iron model's rotor functions at many points, compiled (numba): the values a cubed-sphere table
(:mod:`.spheretable`) is built from.

:func:`zonal_energies`: ``F_t(x) = Σ_j P[t, j] h_t(x · u_j)`` for terms whose ``h_t = −∫τ_t`` are angle splines on
shared breaks (the pair tables' detent and linear parts). :func:`coupling_energies`: the coupling through one
core at ``x`` (:mod:`spherestep.magnetics._coupling`),

    G(x) = Σ_{p<q} s_p s_q w_p w_q Σ_m c_m(α_p, α_q) cos m(φ_q − φ_p),

``α_p, φ_p`` pole ``p``'s polar angle and azimuth about ``x``, ``w_p`` the taper of the reach, ``c_m`` bicubic
B-splines ``Σ_ab C[m, a, b] B_a(α_p) B_b(α_q)`` (``C[m]`` symmetric). With ``A_m[a] = Σ_p s_p w_p B_a(α_p)
e^{i m φ_p}`` the double sum is ``½ (Σ_m Re A_mᴴ C_m A_m − Σ_p w_p² Σ_m c_m(α_p, α_p))`` — a quadratic form per
harmonic instead of a sum over pole pairs.

Both release the GIL: :func:`in_threads` runs one over slices of the points in :func:`table_threads` threads
(each point's value is computed alone, so the result does not depend on the split).
"""

from __future__ import annotations

import math
import os

import numpy as np
from .compiling import njit


def table_threads() -> int:
    """Threads building a table: ``SPHERESTEP_TABLE_THREADS`` or the CPUs this process may use, at most 4."""
    value = os.environ.get("SPHERESTEP_TABLE_THREADS", "")
    if value.isdigit() and int(value) > 0:
        return int(value)
    return max(1, min(4, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1))


def in_threads(kernel, x, *args, out) -> None:
    """``kernel(x, *args, out)`` over slices of the points ``x (Q, 3)`` (and of ``out``'s last axis) in
    :func:`table_threads` threads; ``kernel`` one of this module's (``nogil``) functions."""
    threads = min(table_threads(), max(1, len(x) // 4096))
    if threads == 1:
        kernel(x, *args, out)
        return
    from concurrent.futures import ThreadPoolExecutor

    edges = np.linspace(0, len(x), threads + 1).astype(int)
    parts = [np.empty(out.shape[:-1] + (b - a,)) for a, b in zip(edges[:-1], edges[1:])]
    with ThreadPoolExecutor(threads) as pool:
        for f in [pool.submit(kernel, np.ascontiguousarray(x[a:b]), *args, part)
                  for a, b, part in zip(edges[:-1], edges[1:], parts)]:
            f.result()
    for a, b, part in zip(edges[:-1], edges[1:], parts):
        out[..., a:b] = part


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "nsz", "arcp"})
def zonal_energies(x, poles, P, breaks, energy, out):
    """``out[t, q] = Σ_j P[t, j] h_t(x_q · u_j)`` with ``h_t(t) = −Σ_i energy[t, n, i] (α − breaks[n])^(4 − i)``,
    ``α = acos t`` in interval ``n`` (SciPy's antiderivative coefficients) at ``x (Q, 3)``, ``poles (3, M)``."""
    last = breaks.shape[0] - 2
    T, M = P.shape[0], poles.shape[1]
    step = math.pi  # the narrowest interval: a uniform look-up of the interval, then at most a step or two
    for i in range(last + 1):
        step = min(step, breaks[i + 1] - breaks[i])
    inv = 1.0 / step
    cells = int(breaks[last + 1] * inv) + 2
    lut = np.empty(cells, dtype=np.int64)
    lo = 0
    for i in range(cells):
        while lo < last and breaks[lo + 1] <= i * step:
            lo += 1
        lut[i] = lo
    alpha, interval = np.empty(M), np.empty(M, dtype=np.int64)
    for q in range(x.shape[0]):
        x0, x1, x2 = x[q, 0], x[q, 1], x[q, 2]
        for j in range(M):
            c = x0 * poles[0, j] + x1 * poles[1, j] + x2 * poles[2, j]
            alpha[j] = math.acos(min(max(c, -1.0), 1.0))
        for j in range(M):  # the interval holding alpha[j]: breaks[lo] <= a < breaks[lo + 1] (lo <= last)
            a = alpha[j]
            lo = lut[min(int(a * inv), cells - 1)]
            while lo > 0 and breaks[lo] > a:
                lo -= 1
            while lo < last and breaks[lo + 1] <= a:
                lo += 1
            interval[j] = lo
        for t in range(T):
            s = 0.0
            for j in range(M):
                lo = interval[j]
                y = alpha[j] - breaks[lo]
                s += P[t, j] * ((((energy[t, lo, 0] * y + energy[t, lo, 1]) * y + energy[t, lo, 2]) * y
                                 + energy[t, lo, 3]) * y + energy[t, lo, 4])
            out[t, q] = -s


@njit(cache=True, nogil=True)
def _basis(knots, ncoef, a, N, left, right):
    """The four cubic B-splines nonzero at ``a`` (clamped into the knots' range) into ``N``; returns the index of
    the first (de Boor's recursion)."""
    lo_end, hi_end = knots[3], knots[ncoef]
    a = min(max(a, lo_end), hi_end)
    span, hi = 3, ncoef - 1  # the last knot span starting at or below a (bisection)
    while span < hi:
        mid = (span + hi + 1) // 2
        if knots[mid] <= a:
            span = mid
        else:
            hi = mid - 1
    N[0] = 1.0
    for j in range(1, 4):
        left[j] = a - knots[span + 1 - j]
        right[j] = knots[span + j] - a
        saved = 0.0
        for r in range(j):
            temp = N[r] / (right[r + 1] + left[j - r])
            N[r] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        N[j] = saved
    return span - 3


@njit(cache=True, nogil=True, fastmath={"contract", "reassoc", "nsz", "arcp"})
def coupling_energies(x, poles, polarity, reach, taper, knots, C, out):
    """``G(x_q)`` (module docstring) into ``out (Q,)`` at unit vectors ``x (Q, 3)``: ``poles (3, M)``,
    ``polarity (M,)``; poles beyond ``reach`` (rad) left out, the weight ``w = ½(1 + cos π(α − taper)/(reach −
    taper))`` between ``taper`` and ``reach``; ``knots`` of the cubic B-splines in ``α`` and ``C (D, n, n)`` the
    coefficients of ``c_m``, ``m = 0 … D − 1``."""
    D, n = C.shape[0], C.shape[1]
    Ar, Ai = np.empty((D, n)), np.empty((D, n))
    Csum = np.zeros((n, n))  # Σ_m C[m]: the p = q terms
    for m in range(D):
        Csum += C[m]
    N, left, right = np.empty(4), np.zeros(4), np.zeros(4)
    cos_reach = math.cos(reach)
    span = reach - taper
    for q in range(x.shape[0]):
        x0, x1, x2 = x[q, 0], x[q, 1], x[q, 2]
        # a frame (e1, e2) about x for the azimuths
        if abs(x0) < 0.9:
            e0, e1_, e2_ = 0.0, -x2, x1  # x × (1, 0, 0) direction
        else:
            e0, e1_, e2_ = x2, 0.0, -x0  # x × (0, 1, 0) direction
        norm = math.sqrt(e0 * e0 + e1_ * e1_ + e2_ * e2_)
        e0, e1_, e2_ = e0 / norm, e1_ / norm, e2_ / norm
        f0, f1, f2 = x1 * e2_ - x2 * e1_, x2 * e0 - x0 * e2_, x0 * e1_ - x1 * e0
        Ar[:, :] = 0.0
        Ai[:, :] = 0.0
        diag = 0.0
        for j in range(poles.shape[1]):
            u0, u1, u2 = poles[0, j], poles[1, j], poles[2, j]
            c = x0 * u0 + x1 * u1 + x2 * u2
            if c < cos_reach:
                continue
            alpha = math.acos(min(c, 1.0))
            w = 1.0
            if alpha > taper:
                w = 0.5 * (1.0 + math.cos(math.pi * (alpha - taper) / span))
            px, py = e0 * u0 + e1_ * u1 + e2_ * u2, f0 * u0 + f1 * u1 + f2 * u2  # the azimuth φ's cos, sin × ρ
            rho = math.sqrt(px * px + py * py)
            first = _basis(knots, n, alpha, N, left, right)
            sw = polarity[j] * w
            c1, s1 = (px / rho, py / rho) if rho > 0.0 else (1.0, 0.0)  # on the axis: φ = 0 (its terms vanish)
            cm, sm = 1.0, 0.0
            for m in range(D):
                for a in range(4):
                    Ar[m, first + a] += sw * N[a] * cm
                    Ai[m, first + a] += sw * N[a] * sm
                cm, sm = cm * c1 - sm * s1, sm * c1 + cm * s1
            self_term = 0.0
            for a in range(4):
                for b in range(4):
                    self_term += Csum[first + a, first + b] * N[a] * N[b]
            diag += sw * sw * self_term
        total = 0.0
        for m in range(D):  # Re Aᴴ C A over every coefficient (zeros outside the poles' spans): fixed loop
            r, i_, Cm = Ar[m], Ai[m], C[m]  # bounds and rows let the compiler vectorise (4x faster than a band)
            for a in range(n):
                ra, ia, row = r[a], i_[a], Cm[a]
                acc = 0.0
                for b in range(n):
                    acc += row[b] * (ra * r[b] + ia * i_[b])
                total += acc
        out[q] = 0.5 * (total - diag)
