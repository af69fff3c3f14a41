"""A sum of zonal terms at one orientation: energy, fixed-frame torque and Hessian (numba).

A torque model whose energy is ``constant + Σ_i signs[i] Σ_k C[i, k] F_i(Rᵀ v_k)`` (``F_i`` one rotor function
per term, :mod:`.kernels`) hands it over as a :class:`~.packed.Packed` (built by :func:`spherestep.rotor_field.pack_terms`
from the model's :meth:`~spherestep.statics.TorqueModelBase.packed_terms`). :func:`terms_evaluate` evaluates it
at one orientation with the formulas of :mod:`spherestep.rotor_field`, :func:`batch_evaluate` over a batch;
``_turn`` (``exp(v̂) R``) and ``_rotate`` (``R A Rᵀ``) are the small rotations the descent, the integrator and the
synthesis glue share.
"""

from __future__ import annotations

import numpy as np
from .compiling import njit

from ..so3 import exp_entries
from .kernels import SPHERE_TABLE, _hessian_on_sphere, _point, _unpack
from .spheretable import chain, contract, locate


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
def workspace(poles):
    """Scratch for :func:`terms_evaluate`: ``(floats (30 + M,), ints (M,))`` for ``poles (3, M)``."""
    return np.empty(30 + poles.shape[1]), np.empty(poles.shape[1], dtype=np.int64)


@njit(cache=True)
def _shared_grid(params, offsets, terms):
    """``(m, 1/δ, halo)`` of the terms' tables when every term is a :data:`~.kernels.SPHERE_TABLE` on one grid
    (the coupled iron model's two), else ``(0, 0.0, 0)``: such terms share each coil's :func:`.spheretable.locate`."""
    o = offsets[0]
    m, inv_delta, halo = params[o + 1], params[o + 3], params[o + 4]
    for i in range(terms):
        o = offsets[i]
        if params[o] != SPHERE_TABLE or params[o + 1] != m or params[o + 3] != inv_delta or params[o + 4] != halo:
            return 0, 0.0, 0
    return int(m), inv_delta, int(halo)


@njit(cache=True)
def _add_coil(w, x0, x1, x2, S, M, order, body, Hb, hess):
    """One coil's body-frame torque ``w x × g`` into ``body`` and Hessian ``w (ΔF P − Hess F + ½(g xᵀ + x gᵀ))``
    into ``Hb`` (by ``order``) from its point's ``S`` and ``M`` (:mod:`.kernels`)."""
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


@njit(cache=True)
def terms_evaluate(params, offsets, R, coils, C, poles, P, signs, order, torque, H, work, near):
    """Energy (returned), fixed-frame torque (into ``torque (3,)``, ``order ≥ 1``) and Hessian (into ``H (3, 3)``,
    ``order = 2``) at one orientation ``R (3, 3)`` of the sum of zonal terms ``Σ_i signs[i] Σ_k C[i, k]
    F_i(Rᵀ v_k)``: term ``i`` has the kernel ``params[offsets[i]:offsets[i+1]]`` and pole weights ``P[i]``
    (:func:`spherestep.rotor_field.pack_terms`); coils with zero current are skipped. The torque is
    ``s R Σ c_k x_k × g_k`` and the Hessian ``s R [Σ c_k (ΔF P_k − Hess F + ½(g xᵀ + x gᵀ))] Rᵀ``
    (:mod:`spherestep.rotor_field`). Terms that are tables on one grid (:func:`_shared_grid`) are summed per
    coil before the derivatives: one :func:`.spheretable.locate` and chain rule per coil, one contraction per
    term (the spline is linear in its coefficients). ``work, near``: :func:`workspace`."""
    S, M, t = work[0:3], work[3:9], work[30:]
    hess, Hb = work[9:18].reshape(3, 3), work[18:27].reshape(3, 3)
    body = work[27:30]
    body[:] = 0.0
    Hb[:, :] = 0.0
    energy = 0.0
    terms = signs.shape[0]
    m, inv_delta, halo = _shared_grid(params, offsets, terms)
    if m > 0:
        for k in range(coils.shape[0]):
            live = False
            for i in range(terms):
                live = live or C[i, k] != 0.0
            if not live:
                continue
            v0, v1, v2 = coils[k, 0], coils[k, 1], coils[k, 2]
            x0 = R[0, 0] * v0 + R[1, 0] * v1 + R[2, 0] * v2
            x1 = R[0, 1] * v0 + R[1, 1] * v1 + R[2, 1] * v2
            x2 = R[0, 2] * v0 + R[1, 2] * v1 + R[2, 2] * v2
            where = locate(m, inv_delta, halo, x0, x1, x2)
            F = Fu = Fv = Fuu = Fuv = Fvv = 0.0
            for i in range(terms):
                ck = C[i, k]
                if ck == 0.0:
                    continue
                w = signs[i] * ck
                f, fu, fv, fuu, fuv, fvv = contract(params, offsets[i] + 5, m, where, order)
                F += w * f
                Fu += w * fu
                Fv += w * fv
                Fuu += w * fuu
                Fuv += w * fuv
                Fvv += w * fvv
            energy += F
            if order >= 1:
                chain(where, inv_delta, Fu, Fv, Fuu, Fuv, Fvv, order, S, M)
                _add_coil(1.0, x0, x1, x2, S, M, order, body, Hb, hess)
    else:
        for i in range(terms):
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
                    _add_coil(w, x0, x1, x2, S, M, order, body, Hb, hess)
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
