"""A packed model's torque as an affine map of the currents at one orientation: ``K(R)`` and the bias ``b(R)``
in one compiled call (numba).

A model whose energy is ``constant + Σ_i s_i Σ_k C_ik(c) F_i(Rᵀ v_k)`` with each term's currents affine in the
coil's own current, ``C_ik(c) = C⁰_ik + D_ik c_k`` (the torque map: ``C = c``; the iron model: the detent's
``C = 1`` and the winding's ``C = c``), has the torque ``τ(R, c) = b(R) + K(R) c`` with

    b(R) = R Σ_ik s_i C⁰_ik (x_k × g_i(x_k)),    K(R)[:, k] = R Σ_i s_i D_ik (x_k × g_i(x_k)),    x_k = Rᵀ v_k,

the formulas of :mod:`spherestep.rotor_field` (``x × g = x × S``, ``S = Σ_j p_j h'(x·u_j) u_j``: the radial part
of the ambient gradient drops out). :func:`affine_call` picks the evaluator once per model:

* :func:`spline_affine` when every term is a magnets' angle spline (:mod:`.kernels`, ``ANGLE_SPLINE``) on the
  same breaks (the torque map; the iron model's detent and winding tables): one ``acos`` and one interval look-up
  per (coil, pole) pair for all the terms, ``sin α`` as ``√(1 − t²)``, no energy — 29 coils × 92 poles in
  ~30 µs (the general :func:`~.terms.terms_evaluate` takes ~160 µs per term). Equal to the model's
  ``torque_matrix``/``torque`` to ~1e-15 of the largest column (``√(1 − t²)`` and ``sin(acos t)`` differ by
  rounding of ``t``, relative ``1e-16/α²`` within ``α`` of the axis);
* :func:`torque_affine` otherwise (any kernel, :func:`.kernels._point`; a sphere table through
  :func:`.spheretable.sphere_point`).

What the servo loop's :class:`spherestep.control.ModelCache` and the simulation's plant need when the orientation
has moved; :func:`first_order` carries a cached ``K``, ``b`` to a nearby orientation with their derivatives (the
law's cache at rest).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .kernels import ANGLE_SPLINE, _point, _unpack


@njit(cache=True)
def torque_affine(params, offsets, R, coils, C0, D, poles, P, signs, K, bias, work, near):
    """``K (3, N)`` and ``bias (3,)`` (written in place) at one orientation ``R (3, 3)`` for the terms of a
    :class:`~.packed.Packed` model with currents ``C⁰ (T, N)`` at zero current and slopes ``D (T, N)`` (module
    docstring); pairs with ``C⁰ = D = 0`` are skipped. ``work, near``: :func:`.terms.workspace`."""
    S, M, t = work[0:3], work[3:9], work[30:]
    K[:, :] = 0.0
    b0 = b1 = b2 = 0.0
    for i in range(signs.shape[0]):
        kernel = _unpack(params[offsets[i]:offsets[i + 1]])
        polarity = P[i]
        s = signs[i]
        for k in range(coils.shape[0]):
            c0, dk = C0[i, k], D[i, k]
            if c0 == 0.0 and dk == 0.0:
                continue
            v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
            x0 = R[0, 0] * v0 + R[1, 0] * v1 + R[2, 0] * v2
            x1 = R[0, 1] * v0 + R[1, 1] * v1 + R[2, 1] * v2
            x2 = R[0, 2] * v0 + R[1, 2] * v1 + R[2, 2] * v2
            _point(kernel, x0, x1, x2, poles, polarity, 1, S, M, t, near)
            r = S[0] * x0 + S[1] * x1 + S[2] * x2
            g0, g1, g2 = S[0] - r * x0, S[1] - r * x1, S[2] - r * x2
            y0, y1, y2 = x1 * g2 - x2 * g1, x2 * g0 - x0 * g2, x0 * g1 - x1 * g0  # x × g, body frame
            f0 = s * (R[0, 0] * y0 + R[0, 1] * y1 + R[0, 2] * y2)
            f1 = s * (R[1, 0] * y0 + R[1, 1] * y1 + R[1, 2] * y2)
            f2 = s * (R[2, 0] * y0 + R[2, 1] * y1 + R[2, 2] * y2)
            if dk != 0.0:
                K[0, k] += dk * f0
                K[1, k] += dk * f1
                K[2, k] += dk * f2
            if c0 != 0.0:
                b0 += c0 * f0
                b1 += c0 * f1
                b2 += c0 * f2
    bias[0], bias[1], bias[2] = b0, b1, b2


@njit(cache=True)
def scratch(poles):
    """``(work, near)`` for :func:`torque_affine` (:func:`.terms.workspace`'s layout)."""
    return np.empty(30 + poles.shape[1]), np.empty(poles.shape[1], dtype=np.int64)


@njit(cache=True, fastmath={"contract", "reassoc", "nsz", "arcp"})
def spline_affine(breaks, lut, inv_delta, tau, g_ends, R, coils, C0, D, poles, P, signs, K, bias):
    """:func:`torque_affine` for terms that are all angle splines on the same ``breaks (n + 1,)`` (with ``lut``,
    ``inv_delta`` as in :func:`.kernels.kernel_params`): ``tau (T, n, 4)`` each term's ``τ(α)`` coefficients,
    ``g_ends (T, 2)`` the limits of ``τ/sin α`` at the ends."""
    T, M = signs.shape[0], poles.shape[1]
    last, top = breaks.shape[0] - 2, lut.shape[0] - 1
    b0 = b1 = b2 = 0.0
    for k in range(coils.shape[0]):
        v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
        x0 = R[0, 0] * v0 + R[1, 0] * v1 + R[2, 0] * v2
        x1 = R[0, 1] * v0 + R[1, 1] * v1 + R[2, 1] * v2
        x2 = R[0, 2] * v0 + R[1, 2] * v1 + R[2, 2] * v2
        kk = bb = 0.0
        for i in range(T):
            kk += abs(D[i, k])
            bb += abs(C0[i, k])
        sk0 = sk1 = sk2 = sb0 = sb1 = sb2 = 0.0
        if kk != 0.0 or bb != 0.0:
            for j in range(M):
                u0, u1, u2 = poles[0, j], poles[1, j], poles[2, j]
                t = min(max(x0 * u0 + x1 * u1 + x2 * u2, -1.0), 1.0)
                a = math.acos(t)
                n = lut[min(max(int(a * inv_delta), 0), top)]
                while n < last and breaks[n + 1] <= a:
                    n += 1
                y = a - breaks[n]
                s = math.sqrt(1.0 - t * t)
                wk = wb = 0.0
                for i in range(T):
                    if s < 1e-6:
                        d = g_ends[i, 0] if a < 1.0 else g_ends[i, 1]
                    else:
                        d = (((tau[i, n, 0] * y + tau[i, n, 1]) * y + tau[i, n, 2]) * y + tau[i, n, 3]) / s
                    w = signs[i] * P[i, j] * d
                    wk += D[i, k] * w
                    wb += C0[i, k] * w
                sk0 += wk * u0
                sk1 += wk * u1
                sk2 += wk * u2
                sb0 += wb * u0
                sb1 += wb * u1
                sb2 += wb * u2
        # x × S in the body frame, then R (...) in the fixed frame
        y0, y1, y2 = x1 * sk2 - x2 * sk1, x2 * sk0 - x0 * sk2, x0 * sk1 - x1 * sk0
        K[0, k] = R[0, 0] * y0 + R[0, 1] * y1 + R[0, 2] * y2
        K[1, k] = R[1, 0] * y0 + R[1, 1] * y1 + R[1, 2] * y2
        K[2, k] = R[2, 0] * y0 + R[2, 1] * y1 + R[2, 2] * y2
        y0, y1, y2 = x1 * sb2 - x2 * sb1, x2 * sb0 - x0 * sb2, x0 * sb1 - x1 * sb0
        b0 += R[0, 0] * y0 + R[0, 1] * y1 + R[0, 2] * y2
        b1 += R[1, 0] * y0 + R[1, 1] * y1 + R[1, 2] * y2
        b2 += R[2, 0] * y0 + R[2, 1] * y1 + R[2, 2] * y2
    bias[0], bias[1], bias[2] = b0, b1, b2


@njit(cache=True)
def first_order(R, A, K, dK, bias, dbias, K1, bias1):
    """``K1 = K + Σ_j ε_j dK[:, :, j]`` and ``bias1 = bias + dbias ε`` (written in place): ``K (3, N)`` and
    ``bias (3,)`` evaluated at ``A (3, 3)``, their derivatives ``dK (3, N, 3)``, ``dbias (3, 3)`` per rad about
    the fixed axes, carried to ``R (3, 3)`` near ``A`` with ``ε = vee(M − Mᵀ)/2``, ``M = R Aᵀ`` (``sin θ`` times
    the axis of ``R Aᵀ``: its rotation vector to ``θ³/6``)."""
    e0 = 0.5 * (R[2, 0] * A[1, 0] + R[2, 1] * A[1, 1] + R[2, 2] * A[1, 2]
                - R[1, 0] * A[2, 0] - R[1, 1] * A[2, 1] - R[1, 2] * A[2, 2])
    e1 = 0.5 * (R[0, 0] * A[2, 0] + R[0, 1] * A[2, 1] + R[0, 2] * A[2, 2]
                - R[2, 0] * A[0, 0] - R[2, 1] * A[0, 1] - R[2, 2] * A[0, 2])
    e2 = 0.5 * (R[1, 0] * A[0, 0] + R[1, 1] * A[0, 1] + R[1, 2] * A[0, 2]
                - R[0, 0] * A[1, 0] - R[0, 1] * A[1, 1] - R[0, 2] * A[1, 2])
    for i in range(3):
        for k in range(K.shape[1]):
            K1[i, k] = K[i, k] + dK[i, k, 0] * e0 + dK[i, k, 1] * e1 + dK[i, k, 2] * e2
        bias1[i] = bias[i] + dbias[i, 0] * e0 + dbias[i, 1] * e1 + dbias[i, 2] * e2


def affine_call(packed, C0: np.ndarray, D: np.ndarray):
    """``call(R, K, bias)`` filling ``K (3, N)`` and ``bias (3,)`` at ``R (3, 3)`` (C-contiguous) for the terms of
    ``packed`` (a :class:`~.packed.Packed`; its currents ignored) with currents ``C⁰ + D c`` (module docstring):
    :func:`spline_affine` when every term is an angle spline on shared breaks, else :func:`torque_affine`."""
    params, offsets = packed.params, packed.offsets
    coils = np.ascontiguousarray(packed.coils, dtype=float)
    C0, D = np.ascontiguousarray(C0, dtype=float), np.ascontiguousarray(D, dtype=float)
    P, signs = np.ascontiguousarray(packed.P, dtype=float), np.ascontiguousarray(packed.signs, dtype=float)
    poles = np.ascontiguousarray(packed.poles, dtype=float)
    kernels = [_unpack(params[offsets[i]:offsets[i + 1]]) for i in range(len(signs))]
    if all(k[0] == ANGLE_SPLINE and np.array_equal(k[4], kernels[0][4]) for k in kernels):
        _, _, _, inv_delta, breaks, _, _, _, lut = kernels[0]
        breaks, lut = np.ascontiguousarray(breaks), np.ascontiguousarray(lut, dtype=np.int64)
        tau = np.ascontiguousarray(np.stack([k[5] for k in kernels]))
        ends = np.ascontiguousarray(np.stack([k[7] for k in kernels]))
        inv_delta = float(inv_delta)

        def call(R, K, bias):
            spline_affine(breaks, lut, inv_delta, tau, ends, R, coils, C0, D, poles, P, signs, K, bias)
        return call
    work, near = scratch(poles)

    def call(R, K, bias):
        torque_affine(params, offsets, R, coils, C0, D, poles, P, signs, K, bias, work, near)
    return call
