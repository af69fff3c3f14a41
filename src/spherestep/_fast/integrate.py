"""The rotor's Yoshida–Verlet steps under a packed model's torque, compiled (numba):
:meth:`spherestep.dynamics.Rotor.step` repeated, equal to it to rounding (``tests/test_fast_path.py``). The torque
is :func:`.terms.terms_evaluate`'s (tables on one grid summed per coil); numba caches this file's kernels with
that function inside, so a change there must touch this file too (:mod:`.compiling`).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .terms import _turn, terms_evaluate, workspace


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
    """:meth:`spherestep.dynamics.Rotor.step` ``steps`` times under the torque of :func:`terms_evaluate` (constant
    currents ``C (T, N)``), composition ``weights`` (Yoshida's); writes every ``record_every``-th step and the
    last into ``Rs, ws``; returns the final ``(R, ω)``."""
    tau = np.empty(3)
    H, turned = np.empty((3, 3)), np.empty((3, 3))
    work, near = workspace(poles)
    R = R.copy()
    terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
    k = 0
    for n in range(1, steps + 1):
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        stuck = friction > 0 and w[0] == 0.0 and w[1] == 0.0 and w[2] == 0.0 and \
            math.sqrt(tau[0] * tau[0] + tau[1] * tau[1] + tau[2] * tau[2]) <= friction  # static friction holds
        if not stuck:
            for weight in weights:
                w = w + (0.5 * weight * h / inertia) * tau
                _turn(weight * h * w, R, turned)
                R[:, :] = turned
                terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
                w = w + (0.5 * weight * h / inertia) * tau
            w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        if n % record_every == 0 or n == steps:
            Rs[k] = R
            ws[k] = w
            k += 1
    return R, w
