"""Feedback on SO(3): a geometric PD law on the log-map error with feed-forward, and an orientation observer.

Controller. With the desired motion ``(R_d, ω_d, α_d)`` and the estimate ``(R̂, ω̂)`` (fixed-frame angular
velocities), the error is the rotation vector that turns the estimate onto the target,
``e = log(R_d R̂ᵀ)`` (fixed frame, ``|e|`` the Park distance), and the commanded torque

    τ = I (α_d + k_p e + k_d (ω_d − ω̂)) − τ_known,    k_p = ω_c²,  k_d = 2 ζ ω_c,

with ``τ_known`` the torques the model knows apart from the coils (the rotor's viscous damping ``−b ω̂``; a
bias or detent torque of the motor is taken care of by the allocation, which solves ``b(R) + K c = τ``). Near the
target the closed loop is ``ë + 2ζω_c ė + ω_c² e = 0`` per axis (isotropic inertia). Run at the control rate
(1 kHz by default; ``ω_c`` well below it).

Observer. The sensor gives orientations only (noisy, late, at its own rate); the observer predicts with the
commanded torque, ``ω̂ ← ω̂ + h τ/I``, ``R̂ ← exp(h ω̂) R̂``, and corrects with the residual
``ε = log(R_meas R̂(t_m)ᵀ)`` against its own estimate at the measurement's time ``t_m`` (kept in a short history,
so a known latency is compensated): ``R̂ ← exp(l₁ ε) R̂``, ``ω̂ ← ω̂ + l₂ ε`` with ``l₁ = 2 ω_o h_s``,
``l₂ = ω_o² h_s`` (``h_s`` the sensor's period): a critically damped second-order filter of bandwidth ``ω_o``.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value

CONTROL_RATE = 1000.0  # Hz
BANDWIDTH = 30.0  # rad/s, closed-loop natural frequency
OBSERVER_BANDWIDTH = 120.0  # rad/s


@dataclass(frozen=True)
class GeometricPD:
    """The control law of the module for a rotor of ``inertia`` (kg·m²): ``bandwidth`` ``ω_c`` (rad/s),
    ``damping_ratio`` ``ζ``, ``rate`` (Hz), ``damping`` the rotor's known viscous damping (N·m·s/rad)."""

    inertia: float
    bandwidth: float = BANDWIDTH
    damping_ratio: float = 1.0
    rate: float = CONTROL_RATE
    damping: float = 0.0

    def __post_init__(self):
        for name in ("inertia", "bandwidth", "damping_ratio", "rate"):
            checks.positive(getattr(self, name), name)
        checks.non_negative(self.damping, "damping", "a finite non-negative damping (N·m·s/rad)")
        if self.bandwidth > 0.2 * 2 * math.pi * self.rate:
            raise bad_value("bandwidth", f"at most a fifth of the control rate ({0.4 * math.pi * self.rate:.0f} rad/s)",
                            self.bandwidth)

    def torque(self, R_est, w_est, R_d, w_d, a_d) -> np.ndarray:
        """Commanded torque (N·m, fixed frame) for the estimate ``(R̂ (3, 3), ω̂ (3,))`` and the desired
        ``(R_d, ω_d, α_d)``."""
        e = so3.log_single(R_d @ R_est.T)
        kp, kd = self.bandwidth ** 2, 2.0 * self.damping_ratio * self.bandwidth
        return self.inertia * (a_d + kp * e + kd * (w_d - w_est)) + self.damping * w_est


class Observer:
    """The orientation observer of the module (mutable state ``R``, ``w`` and the unmodelled torque ``d``, N·m,
    fixed frame). ``d`` enters the prediction, ``ω̂ ← ω̂ + h (τ + d)/I``, and is corrected with gain ``l3``
    (N·m per rad of residual): zero here, so ``d`` stays 0 — the place of the disturbance observer.

    The gains are for the interval ``Δ`` since the previous measurement (``sensor_period`` while measurements
    arrive on schedule, to 1 ppm): ``l₁ = min(2ω_oΔ, 1)``, ``l₂ = min(ω_o²Δ, 1/Δ)``. The caps keep the error
    dynamics stable for any ``Δ`` (a loop that misses deadlines): with ``l₂Δ ≤ 1`` and ``l₁ ≤ 1`` the error
    matrix ``[[1 − l₁, Δ(1 − l₁)], [−l₂, 1 − l₂Δ]]`` meets Jury's conditions (det ``1 − l₁``,
    ``1 − tr + det = l₂Δ > 0``, ``1 + tr + det = 4 − 2l₁ − l₂Δ ≥ 1``); ``ω_o = 1/Δ`` is the deadbeat observer."""

    def __init__(self, R0, w0=None, *, inertia: float, bandwidth: float = OBSERVER_BANDWIDTH,
                 sensor_period: float = 1.0 / CONTROL_RATE, history: float = 0.05):
        self.R = so3.as_rotations(R0, "R0").copy()
        self.w = np.zeros(3) if w0 is None else np.array(w0, dtype=float)
        self.d = np.zeros(3)
        self.inertia = checks.positive(inertia, "inertia")
        h = checks.positive(sensor_period, "sensor_period")
        wo = checks.positive(bandwidth, "bandwidth")
        self.bandwidth, self.sensor_period = wo, h
        (self.l1, self.l2), self.l3 = self.gains(h), 0.0
        self.t = 0.0
        self._measured: float | None = None  # time of the last measurement
        self._past = deque(maxlen=max(2, int(math.ceil(history / h)) * 4))
        self._past.append((0.0, self.R.copy()))

    def restart(self, R) -> None:
        """Start again from the orientation ``R (3, 3)`` now (the velocity kept), forgetting the history."""
        self.R = np.array(R, dtype=float)
        self._past.clear()
        self._past.append((self.t, self.R.copy()))
        self._measured = None

    def gains(self, interval: float) -> tuple[float, float]:
        """``(l₁, l₂)`` for measurements ``interval`` s apart (see the class)."""
        wo = self.bandwidth
        return min(2.0 * wo * interval, 1.0), min(wo * wo * interval, 1.0 / interval)

    def predict(self, torque, h: float) -> None:
        """Advance by ``h`` s under ``torque`` (N·m, what the drive is believed to apply)."""
        self.w = self.w + (h / self.inertia) * (np.asarray(torque, dtype=float) + self.d)
        self.R = so3.exp(h * self.w) @ self.R
        self.t += h
        self._past.append((self.t, self.R.copy()))

    def correct(self, R_meas, t_meas: float | None = None) -> None:
        """Blend in a measurement ``R_meas`` taken at ``t_meas`` (default now). A late measurement is compared with
        the estimate of its time ``t_k`` (the history), the correction made there and carried to every later
        estimate as the prediction would have: ``R̂(t) ← exp((l₁ + l₂ (t − t_k)) ε) R̂(t)`` for ``t ≥ t_k`` (the
        velocity correction ``l₂ε`` acting since ``t_k``), so a known latency costs no stability."""
        ref, k = self.R, None
        if t_meas is not None and t_meas < self.t - 1e-12:
            times = [p[0] for p in self._past]
            k = int(np.clip(np.searchsorted(times, t_meas), 0, len(times) - 1))
            ref = self._past[k][1]
        now = self.t if t_meas is None else t_meas
        interval = self.sensor_period if self._measured is None else now - self._measured
        self._measured = now
        l1, l2 = self.l1, self.l2
        if not abs(interval - self.sensor_period) <= 1e-6 * self.sensor_period and interval > 0:
            l1, l2 = self.gains(interval)
        eps = so3.log_single(R_meas @ ref.T)
        if k is not None:  # re-propagate the history from t_k
            t_k = self._past[k][0]
            for j in range(k, len(self._past)):
                t_j, R_j = self._past[j]
                self._past[j] = (t_j, so3.exp((l1 + l2 * (t_j - t_k)) * eps) @ R_j)
            self.R = so3.exp((l1 + l2 * (self.t - t_k)) * eps) @ self.R
        else:
            self.R = so3.exp(l1 * eps) @ self.R
        self.w = self.w + l2 * eps
        if self.l3:
            self.d = self.d + self.l3 * eps
