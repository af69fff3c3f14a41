"""The rotor released under a relay mask, integrated until it is trapped in a well or the dwell ends (numba): the
iron planner's settling check (:meth:`spherestep.commutation.iron_planner._Landscape.settles`).

The steps are :func:`.integrate.integrate`'s (:meth:`spherestep.dynamics.Rotor.step`, Yoshida's composition);
after each, the rotor is *trapped* when it lies within ``radius`` of the minimum ``R_min`` and its energy above
the minimum, ``½ I|ω|² + E(R) − E(R_min)``, is at most ``bound``: damping and friction only take energy away, so
it stays in that sublevel set of the well (the caller chooses ``bound`` so the set lies within ``radius`` where
the well is quadratic). The energy and torque are :func:`.terms.terms_evaluate`'s (numba caches this file's
kernels with it inside, so a change there must touch this file too: :mod:`.compiling`).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit

from .integrate import _dissipate
from .terms import _turn, terms_evaluate, workspace


@njit(cache=True)
def _angle(A, B):
    """Park's distance ``θ(Aᵀ B)`` (:func:`spherestep.so3.distance`'s formula) of two ``3 × 3`` rotations."""
    m = np.zeros((3, 3))
    for a in range(3):
        for b in range(3):
            m[a, b] = A[0, a] * B[0, b] + A[1, a] * B[1, b] + A[2, a] * B[2, b]
    x, y, z = m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]
    return math.atan2(0.5 * math.sqrt(x * x + y * y + z * z), 0.5 * (m[0, 0] + m[1, 1] + m[2, 2] - 1.0))


@njit(cache=True)
def settle(params, offsets, R, coils, C, poles, P, signs, inertia, damping, friction, h, steps, weights, R_min,
           radius, bound):
    """From ``R`` at rest under the packed terms (:func:`.terms.terms_evaluate`'s arguments, currents ``C (T,
    N)``), at most ``steps`` steps of ``h`` s (composition ``weights``), stopping after the first step that leaves
    the rotor trapped about ``R_min`` (module docstring); returns ``(R, ω, steps taken, trapped)``."""
    tau = np.empty(3)
    H, turned = np.empty((3, 3)), np.empty((3, 3))
    work, near = workspace(poles)
    floor = terms_evaluate(params, offsets, R_min, coils, C, poles, P, signs, 0, tau, H, work, near)
    R = R.copy()
    w = np.zeros(3)
    energy = terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
    for n in range(1, steps + 1):
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        for weight in weights:
            w = w + (0.5 * weight * h / inertia) * tau
            _turn(weight * h * w, R, turned)
            R[:, :] = turned
            energy = terms_evaluate(params, offsets, R, coils, C, poles, P, signs, 1, tau, H, work, near)
            w = w + (0.5 * weight * h / inertia) * tau
        w = _dissipate(w, inertia, damping, friction, 0.5 * h)
        above = 0.5 * inertia * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) + energy - floor
        if above <= bound and _angle(R, R_min) <= radius:
            return R, w, n, True
    return R, w, steps, False
