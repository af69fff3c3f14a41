"""A function on the unit sphere tabulated on an equiangular cubed sphere, cubic B-splines per face (numba).

Face ``f`` (0…5) is the cap where coordinate ``i = f // 2`` is the largest in size, with sign ``s = +1`` for even
``f``; with ``j, k = i + 1, i + 2 (mod 3)`` its coordinates are ``ξ = atan(x_j / (s x_i))``, ``η = atan(x_k /
(s x_i))`` in ``[−π/4, π/4]``. Each face holds the values at ``m = n + 1 + 2·halo`` equally spaced ``ξ`` (and
``η``), ``δ = (π/2)/n`` apart, the ``halo`` nodes beyond the face's edges being points of the sphere too (a
face's chart extends past its edges), turned into cubic B-spline coefficients (:func:`face_coefficients`), so a
point near an edge is interpolated from nodes on both sides and the faces agree there to the interpolation error.

For the torque models the table is a rotor function ``F(x)`` (:mod:`spherestep.rotor_field`): :func:`sphere_point`
returns ``F`` and fills the ambient gradient ``S`` and second derivative ``M`` of its 0-homogeneous extension
``F(y/|y|)`` — tangent by construction (``S·x = 0``, ``M x = −S``), so ``Hess F = P M P − (S·x) P`` of
:mod:`.kernels` holds as written. With ``a = y_j/(s y_i)``: ``∇a = (e_j − a s e_i)/(s y_i)``,
``∇²a = −(s/(s y_i))(e_i ∇aᵀ + ∇a e_iᵀ)``, ``∇ξ = ∇a/(1 + a²)``, ``∇²ξ = ∇²a/(1 + a²) − 2a ∇a∇aᵀ/(1 + a²)²``.
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

HALO = 8  # nodes beyond each face edge: the spline prefilter's boundary error decays as 0.268 per node


def face_nodes(n: int, halo: int = HALO) -> np.ndarray:
    """The unit vectors ``(6, m, m, 3)`` of the table's nodes (module docstring), ``m = n + 1 + 2 halo``."""
    delta = 0.5 * math.pi / n
    xi = -0.25 * math.pi + (np.arange(n + 1 + 2 * halo) - halo) * delta
    a, b = np.meshgrid(np.tan(xi), np.tan(xi), indexing="ij")
    out = np.empty((6,) + a.shape + (3,))
    for f in range(6):
        i, s = f // 2, 1.0 - 2.0 * (f % 2)
        y = np.empty(a.shape + (3,))
        y[..., i], y[..., (i + 1) % 3], y[..., (i + 2) % 3] = s, a, b
        out[f] = y / np.linalg.norm(y, axis=-1, keepdims=True)
    return out


def face_coefficients(values: np.ndarray) -> np.ndarray:
    """Cubic B-spline coefficients ``(6, m, m)`` interpolating ``values (6, m, m)`` at the nodes, face by face."""
    from scipy.ndimage import spline_filter

    return np.stack([spline_filter(np.asarray(v, dtype=float), order=3, mode="mirror") for v in values])


@njit(cache=True)
def _weights(t):
    """Cubic B-spline weights of the four nodes around fraction ``t``, and their first and second derivatives."""
    u = 1.0 - t
    t2, t3 = t * t, t * t * t
    w = (u * u * u / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0)
    d = (-0.5 * u * u, 1.5 * t2 - 2.0 * t, -1.5 * t2 + t + 0.5, 0.5 * t2)
    e = (u, 3.0 * t - 2.0, 1.0 - 3.0 * t, t)
    return w, d, e


_FAST = {"contract", "reassoc", "nsz", "arcp"}


@njit(cache=True, fastmath=_FAST)
def locate(m, inv_delta, halo, x0, x1, x2):
    """Where the unit vector ``x`` falls in a table of ``m × m`` nodes per face: ``(base, i, s, p, a, b, wu, du,
    eu, wv, dv, ev)`` — the flat index of the 4 × 4 block of coefficients around it, its face's axis ``i``, sign
    ``s`` and ``p = s x_i``, its chart coordinates ``a = x_j/p``, ``b = x_k/p`` and the B-spline weights (and
    their derivatives) of the block's rows and columns (module docstring). Tables with the same ``m, δ, halo``
    share it: each table is then one :func:`contract`."""
    ax0, ax1, ax2 = abs(x0), abs(x1), abs(x2)
    if ax0 >= ax1 and ax0 >= ax2:
        i, xi, xj, xk = 0, x0, x1, x2
    elif ax1 >= ax2:
        i, xi, xj, xk = 1, x1, x2, x0
    else:
        i, xi, xj, xk = 2, x2, x0, x1
    s = 1.0 if xi > 0.0 else -1.0
    f = 2 * i + (0 if xi > 0.0 else 1)
    p = s * xi
    a, b = xj / p, xk / p
    u = (math.atan(a) + 0.25 * math.pi) * inv_delta + halo
    v = (math.atan(b) + 0.25 * math.pi) * inv_delta + halo
    nu = min(max(int(u), 1), m - 3)
    nv = min(max(int(v), 1), m - 3)
    wu, du, eu = _weights(u - nu)
    wv, dv, ev = _weights(v - nv)
    return f * m * m + (nu - 1) * m + (nv - 1), i, s, p, a, b, wu, du, eu, wv, dv, ev


@njit(cache=True, fastmath=_FAST)
def contract(coef, start, m, where, order):
    """``(F, F_u, F_v, F_uu, F_uv, F_vv)`` (derivatives in node units, 0 beyond ``order``) of the table whose
    coefficients start at ``coef[start]``, at :func:`locate`'s ``where``."""
    base, wu, du, eu, wv, dv, ev = where[0], where[6], where[7], where[8], where[9], where[10], where[11]
    F = Fu = Fv = Fuu = Fuv = Fvv = 0.0
    for r in range(4):
        row = start + base + r * m
        c0, c1, c2, c3 = coef[row], coef[row + 1], coef[row + 2], coef[row + 3]
        cw = c0 * wv[0] + c1 * wv[1] + c2 * wv[2] + c3 * wv[3]
        F += wu[r] * cw
        if order >= 1:
            cd = c0 * dv[0] + c1 * dv[1] + c2 * dv[2] + c3 * dv[3]
            Fu += du[r] * cw
            Fv += wu[r] * cd
            if order >= 2:
                Fuu += eu[r] * cw
                Fuv += du[r] * cd
                Fvv += wu[r] * (c0 * ev[0] + c1 * ev[1] + c2 * ev[2] + c3 * ev[3])
    return F, Fu, Fv, Fuu, Fuv, Fvv


@njit(cache=True, fastmath=_FAST)
def chain(where, inv_delta, Fu, Fv, Fuu, Fuv, Fvv, order, S, M):
    """The ambient gradient into ``S (3,)`` (``order ≥ 1``) and the upper triangle of the ambient second
    derivative into ``M (6,)`` (``order = 2``; 00, 01, 02, 11, 12, 22) from :func:`contract`'s node-unit
    derivatives at :func:`locate`'s ``where`` (the module docstring's chain rule; scalar arithmetic, no
    temporaries)."""
    i, s, p, a, b = where[1], where[2], where[3], where[4], where[5]
    # u = (ξ + π/4)/δ + halo, ξ = atan(a), a = y_j/p (p = s y_i); the vectors in (i, j, k) order
    ka, kb = 1.0 / (1.0 + a * a), 1.0 / (1.0 + b * b)
    ga0, ga1 = -a * s / p, 1.0 / p  # ∇a = (ga0, ga1, 0)
    gb0, gb2 = -b * s / p, 1.0 / p  # ∇b = (gb0, 0, gb2)
    Fx, Fy = Fu * inv_delta, Fv * inv_delta  # ∂F/∂ξ, ∂F/∂η
    gx0, gx1 = ka * ga0, ka * ga1  # ∇ξ = (gx0, gx1, 0)
    gy0, gy2 = kb * gb0, kb * gb2  # ∇η = (gy0, 0, gy2)
    jj, kk = (i + 1) % 3, (i + 2) % 3
    S[i], S[jj], S[kk] = Fx * gx0 + Fy * gy0, Fx * gx1, Fy * gy2
    if order >= 2:
        Fxx, Fxy, Fyy = Fuu * inv_delta * inv_delta, Fuv * inv_delta * inv_delta, Fvv * inv_delta * inv_delta
        # ∇²a = −(s/p)(e_i ∇aᵀ + ∇a e_iᵀ); ∇²ξ = k_a ∇²a − 2 a k_a² ∇a ∇aᵀ (likewise η); local (i, j, k) entries
        q = -(s / p)
        ca, cb = 2.0 * a * ka * ka, 2.0 * b * kb * kb
        hx00, hx01, hx11 = ka * q * 2.0 * ga0 - ca * ga0 * ga0, ka * q * ga1 - ca * ga0 * ga1, -ca * ga1 * ga1
        hy00, hy02, hy22 = kb * q * 2.0 * gb0 - cb * gb0 * gb0, kb * q * gb2 - cb * gb0 * gb2, -cb * gb2 * gb2
        h00 = Fxx * gx0 * gx0 + 2.0 * Fxy * gx0 * gy0 + Fyy * gy0 * gy0 + Fx * hx00 + Fy * hy00
        h01 = Fxx * gx0 * gx1 + Fxy * gy0 * gx1 + Fx * hx01
        h02 = Fxy * gx0 * gy2 + Fyy * gy0 * gy2 + Fy * hy02
        h11 = Fxx * gx1 * gx1 + Fx * hx11
        h12 = Fxy * gx1 * gy2
        h22 = Fyy * gy2 * gy2 + Fy * hy22
        # to the fixed axes: local (r, c) is global ((i + r) % 3, (i + c) % 3)
        if i == 0:
            M[0], M[1], M[2], M[3], M[4], M[5] = h00, h01, h02, h11, h12, h22
        elif i == 1:  # local 0, 1, 2 = global 1, 2, 0
            M[0], M[1], M[2], M[3], M[4], M[5] = h22, h02, h12, h00, h01, h11
        else:  # local 0, 1, 2 = global 2, 0, 1
            M[0], M[1], M[2], M[3], M[4], M[5] = h11, h12, h01, h22, h02, h00


@njit(cache=True, fastmath=_FAST)
def sphere_point(coef, m, inv_delta, halo, x0, x1, x2, order, S, M):
    """``F`` at the unit vector ``x`` from the flat coefficients ``coef (6 m m,)``; for ``order ≥ 1`` the ambient
    gradient into ``S (3,)``, for ``order = 2`` the upper triangle of the ambient second derivative into ``M (6,)``
    (00, 01, 02, 11, 12, 22) — of ``F(y/|y|)`` (module docstring): :func:`locate`, :func:`contract`,
    :func:`chain`."""
    where = locate(m, inv_delta, halo, x0, x1, x2)
    F, Fu, Fv, Fuu, Fuv, Fvv = contract(coef, 0, m, where, order)
    if order >= 1:
        chain(where, inv_delta, Fu, Fv, Fuu, Fuv, Fvv, order, S, M)
    return F


@njit(cache=True)
def sphere_values(coef, m, inv_delta, halo, x, order, F, g, hess):
    """:func:`sphere_point` at the unit vectors ``x (P, 3)``: ``F (P,)``, the tangent gradient ``g (P, 3)``
    (``order ≥ 1``) and the ambient second derivative ``hess (P, 3, 3)`` (``order = 2``)."""
    S, M = np.empty(3), np.empty(6)
    for q in range(x.shape[0]):
        F[q] = sphere_point(coef, m, inv_delta, halo, x[q, 0], x[q, 1], x[q, 2], order, S, M)
        if order >= 1:
            g[q, 0], g[q, 1], g[q, 2] = S[0], S[1], S[2]
        if order >= 2:
            hess[q, 0, 0], hess[q, 0, 1], hess[q, 0, 2] = M[0], M[1], M[2]
            hess[q, 1, 0], hess[q, 1, 1], hess[q, 1, 2] = M[1], M[3], M[4]
            hess[q, 2, 0], hess[q, 2, 1], hess[q, 2, 2] = M[2], M[4], M[5]
