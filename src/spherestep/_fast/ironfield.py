"""The iron cores' field at the magnetometers, compiled: what :mod:`spherestep.sensing.iron` builds its tables with
(:func:`source_fields`: a magnet's field at the cores' cells) and evaluates them by (:func:`core_field`: the
cubic B-spline table of the cores' response summed over the rotor's poles, and its Jacobian)."""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

POLE_CLIP = 1e-6  # sin ϑ is clipped here in H_φ / sin ϑ (the grid's poles lie between the cores)


@njit(cache=True)
def source_fields(coef, h, cells, W, Q):  # pragma: no cover - compiled
    """``b (D, 3n)``: the field (T, core frame ``Q``, layout ``x1..xn, y1..yn, z1..zn``) at ``cells (n, 3)``
    (fixed frame) of a ``+1`` magnet along each of ``W (D, 3)``, from :func:`spherestep.sensing.iron._magnet_table`."""
    n = cells.shape[0]
    last = coef.shape[1] - 1
    out = np.empty((W.shape[0], 3 * n))
    for i in range(n):
        r = math.sqrt(cells[i, 0] ** 2 + cells[i, 1] ** 2 + cells[i, 2] ** 2)
        x0, x1, x2 = cells[i, 0] / r, cells[i, 1] / r, cells[i, 2] / r
        for d in range(W.shape[0]):
            w0, w1, w2 = W[d, 0], W[d, 1], W[d, 2]
            c = min(1.0, max(-1.0, x0 * w0 + x1 * w1 + x2 * w2))
            a = math.acos(c)
            k = min(int(a / h), last)
            t = a - k * h
            q = coef[i, k]
            par = ((q[0, 0] * t + q[1, 0]) * t + q[2, 0]) * t + q[3, 0]
            perp = ((q[0, 1] * t + q[1, 1]) * t + q[2, 1]) * t + q[3, 1]
            e0, e1, e2 = x0 - c * w0, x1 - c * w1, x2 - c * w2
            m = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            if m > 1e-300:
                perp = perp / m
            b0, b1, b2 = par * w0 + perp * e0, par * w1 + perp * e1, par * w2 + perp * e2
            for a3 in range(3):
                out[d, a3 * n + i] = Q[0, a3] * b0 + Q[1, a3] * b1 + Q[2, a3] * b2
    return out




@njit(cache=True)
def spline_weights(t, out, derivative):  # pragma: no cover - compiled
    """Uniform cubic B-spline weights at fraction ``t`` (or their ``d/dt``) into ``out (4,)``."""
    s = 1.0 - t
    if derivative:
        out[0], out[1], out[2], out[3] = -0.5 * s * s, 1.5 * t * t - 2.0 * t, -1.5 * t * t + t + 0.5, 0.5 * t * t
    else:
        t2, t3 = t * t, t * t * t
        out[0], out[1] = s * s * s / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0
        out[2], out[3] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0


@njit(cache=True)
def core_field(coef, frame, step, W, polarity, jacobian):  # pragma: no cover - compiled
    """``B (K, S, 3)`` and (``jacobian``) ``J (K, S, 3, 3)`` of :class:`spherestep.sensing.iron.CoreField` for pole directions
    ``W (K, M, 3)`` (module doc: ``J = Σ_j p_j (H_ϑ ê_φ − H_φ / sin ϑ ê_ϑ)_c`` row by row, ``= −Σ p ∂H/∂w [w]×``)."""
    K, M = W.shape[0], W.shape[1]
    S = coef.shape[2]
    last_i, last_j = coef.shape[0] - 4, coef.shape[1] - 4
    B = np.zeros((K, S, 3))
    J = np.zeros((K if jacobian else 1, S, 3, 3))
    wu, wv, du, dv = np.empty(4), np.empty(4), np.empty(4), np.empty(4)
    HT, HP = np.zeros((S, 3)), np.zeros((S, 3))  # Σ p H_ϑ and Σ p H_φ / sin ϑ over one pole's nodes
    et, ep = np.empty(3), np.empty(3)  # ê_ϑ and ê_φ in the fixed frame (frame columns: the grid's axes)
    two_pi = 2.0 * math.pi
    for k in range(K):
        for m in range(M):
            w0, w1, w2 = W[k, m, 0], W[k, m, 1], W[k, m, 2]
            l0 = w0 * frame[0, 0] + w1 * frame[1, 0] + w2 * frame[2, 0]
            l1 = w0 * frame[0, 1] + w1 * frame[1, 1] + w2 * frame[2, 1]
            l2 = w0 * frame[0, 2] + w1 * frame[1, 2] + w2 * frame[2, 2]
            th = math.acos(min(1.0, max(-1.0, l2)))
            ph = math.atan2(l1, l0)
            if ph < 0.0:
                ph += two_pi
            u, v = th / step, ph / step
            i, j = min(int(u), last_i), min(int(v), last_j)
            spline_weights(u - i, wu, False)
            spline_weights(v - j, wv, False)
            if jacobian:
                spline_weights(u - i, du, True)
                spline_weights(v - j, dv, True)
            p = polarity[m]
            st, ct, sp, cp = math.sin(th), math.cos(th), math.sin(ph), math.cos(ph)
            inv = 1.0 / max(st, POLE_CLIP)
            for a in range(3):
                et[a] = ct * cp * frame[a, 0] + ct * sp * frame[a, 1] - st * frame[a, 2]
                ep[a] = -sp * frame[a, 0] + cp * frame[a, 1]
            for a in range(4):
                for b in range(4):
                    wab = p * wu[a] * wv[b]
                    if not jacobian:
                        for s in range(S):
                            for c in range(3):
                                B[k, s, c] += wab * coef[i + a, j + b, s, c]
                        continue
                    tab, pab = p * du[a] * wv[b] / step, p * wu[a] * dv[b] / step * inv
                    for s in range(S):
                        for c in range(3):
                            x = coef[i + a, j + b, s, c]
                            B[k, s, c] += wab * x
                            HT[s, c] += tab * x
                            HP[s, c] += pab * x
            if jacobian:
                for s in range(S):
                    for c in range(3):
                        for e in range(3):
                            J[k, s, c, e] += HT[s, c] * ep[e] - HP[s, c] * et[e]
                        HT[s, c], HP[s, c] = 0.0, 0.0
    return B, J
