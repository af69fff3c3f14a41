"""The safeguarded Newton descent of :func:`spherestep.statics.equilibrium`, compiled, row by row (numba).

Step ``ω = Σ_i (e_i·τ/|h_i|) e_i`` over the Hessian's eigenpairs, at most ``max_step`` long, halved until the
Armijo condition holds (or the decrease is at rounding level and the torque falls); the iteration of the NumPy
reference in :mod:`spherestep.statics`, step for step, on a :class:`~.terms.Packed` model, evaluated by
:func:`.terms.terms_evaluate` (tables on one grid summed per coil; numba caches this file's kernels with that
function inside, so a change there must touch this file too: :mod:`.compiling`).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .terms import _turn, terms_evaluate, workspace


@njit(cache=True)
def _norm(v):
    return math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])


@njit(cache=True)
def newton_direction(H, tau, max_step):
    """``ω = Σ_i (e_i·τ/|h_i|) e_i`` over the eigenpairs of ``H`` (``|h_i|`` floored at ``1e-8 max|h|``), shortened
    to ``|ω| ≤ max_step`` — :func:`spherestep.statics.equilibrium`'s step. Where ``H`` (its lower triangle, as
    ``eigh`` reads it) is positive definite with ``det H / ‖adj H‖_F ≥ 1e-8 tr H`` — a lower bound of its
    smallest eigenvalue against an upper bound of its largest, so no floor acts — the sum is ``H⁻¹ τ``, taken
    as ``adj(H) τ / det H`` (no eigen-decomposition: a descent's iterations near a minimum); else by ``eigh``."""
    a, b, c, d, e_, f = H[0, 0], H[1, 0], H[2, 0], H[1, 1], H[2, 1], H[2, 2]
    A00, A01, A02 = d * f - e_ * e_, c * e_ - b * f, b * e_ - c * d
    A11, A12, A22 = a * f - c * c, b * c - a * e_, a * d - b * b
    det = a * A00 + b * A01 + c * A02
    adj = math.sqrt(A00 * A00 + A11 * A11 + A22 * A22 + 2.0 * (A01 * A01 + A02 * A02 + A12 * A12))
    omega = np.zeros(3)
    if a > 0.0 and A22 > 0.0 and det > 0.0 and det >= 1e-8 * (a + d + f) * adj:
        omega[0] = (A00 * tau[0] + A01 * tau[1] + A02 * tau[2]) / det
        omega[1] = (A01 * tau[0] + A11 * tau[1] + A12 * tau[2]) / det
        omega[2] = (A02 * tau[0] + A12 * tau[1] + A22 * tau[2]) / det
    else:
        h, e = np.linalg.eigh(H)
        floor = 1e-8 * max(abs(h[0]), abs(h[1]), abs(h[2])) + 2.2250738585072014e-308
        for i in range(3):
            coeff = (e[0, i] * tau[0] + e[1, i] * tau[1] + e[2, i] * tau[2]) / max(abs(h[i]), floor)
            for k in range(3):
                omega[k] += coeff * e[k, i]
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
