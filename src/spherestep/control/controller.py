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

from .. import so3
from ..errors import bad_value

CONTROL_RATE = 1000.0  # Hz
BANDWIDTH = 30.0  # rad/s, closed-loop natural frequency
OBSERVER_BANDWIDTH = 120.0  # rad/s


def rotation_error(M: np.ndarray) -> np.ndarray:
    """``log(M)`` of one rotation ``M (3, 3)`` as a rotation vector: ``θ/sin θ · vect(M)`` with
    ``θ = atan2(|vect M|, (tr M − 1)/2)`` in Python floats (the control loop's hot path; full precision for
    ``θ < 2.5`` rad), :func:`spherestep.so3.log` beyond, where that quotient loses digits."""
    (a, b, c), (d, e, f), (g, h, i) = M.tolist()
    x, y, z = 0.5 * (h - f), 0.5 * (c - g), 0.5 * (d - b)
    s = math.sqrt(x * x + y * y + z * z)
    theta = math.atan2(s, 0.5 * (a + e + i - 1.0))
    if theta >= 2.5:
        return so3.log(M)
    k = 1.0 + theta * theta / 6.0 if s < 1e-8 else theta / s
    return np.array([k * x, k * y, k * z])


def _positive(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not math.isfinite(value) \
            or value <= 0:
        raise bad_value(name, "a finite positive number", value)
    return float(value)


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
            _positive(getattr(self, name), name)
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise bad_value("damping", "a finite non-negative damping (N·m·s/rad)", self.damping)
        if self.bandwidth > 0.2 * 2 * math.pi * self.rate:
            raise bad_value("bandwidth", f"at most a fifth of the control rate ({0.4 * math.pi * self.rate:.0f} rad/s)",
                            self.bandwidth)

    def torque(self, R_est, w_est, R_d, w_d, a_d) -> np.ndarray:
        """Commanded torque (N·m, fixed frame) for the estimate ``(R̂ (3, 3), ω̂ (3,))`` and the desired
        ``(R_d, ω_d, α_d)``."""
        e = rotation_error(R_d @ R_est.T)
        kp, kd = self.bandwidth ** 2, 2.0 * self.damping_ratio * self.bandwidth
        return self.inertia * (a_d + kp * e + kd * (w_d - w_est)) + self.damping * w_est


class Observer:
    """The orientation observer of the module (mutable state ``R``, ``w``)."""

    def __init__(self, R0, w0=None, *, inertia: float, bandwidth: float = OBSERVER_BANDWIDTH,
                 sensor_period: float = 1.0 / CONTROL_RATE, history: float = 0.05):
        self.R = so3.as_rotations(R0, "R0").copy()
        self.w = np.zeros(3) if w0 is None else np.array(w0, dtype=float)
        self.inertia = _positive(inertia, "inertia")
        h = _positive(sensor_period, "sensor_period")
        wo = _positive(bandwidth, "bandwidth")
        self.l1, self.l2 = min(2.0 * wo * h, 1.0), wo * wo * h
        self.t = 0.0
        self._past = deque(maxlen=max(2, int(math.ceil(history / h)) * 4))
        self._past.append((0.0, self.R.copy()))

    def predict(self, torque, h: float) -> None:
        """Advance by ``h`` s under ``torque`` (N·m, what the drive is believed to apply)."""
        self.w = self.w + (h / self.inertia) * np.asarray(torque, dtype=float)
        self.R = so3.exp(h * self.w) @ self.R
        self.t += h
        self._past.append((self.t, self.R.copy()))

    def correct(self, R_meas, t_meas: float | None = None) -> None:
        """Blend in a measurement ``R_meas`` taken at ``t_meas`` (default now)."""
        ref = self.R
        if t_meas is not None and t_meas < self.t - 1e-12:
            times = [p[0] for p in self._past]
            k = int(np.clip(np.searchsorted(times, t_meas), 0, len(times) - 1))
            ref = self._past[k][1]
        eps = rotation_error(R_meas @ ref.T)
        self.R = so3.exp(self.l1 * eps) @ self.R
        self.w = self.w + self.l2 * eps
