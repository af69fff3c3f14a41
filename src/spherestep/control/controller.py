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

Disturbance observer. With ``disturbance_bandwidth`` ``ω_d > 0`` (the default) the observer is extended by the
torque ``d`` (N·m, fixed frame) that the model gets wrong, taken as constant between measurements:
``ω̂ ← ω̂ + h (τ + d̂)/I`` and ``d̂ ← d̂ + l₃ ε``. Per axis the error ``(θ, ω, d/I)`` of ``n`` predictions of
``h = Δ/n`` and a correction is ``e ← (1 − L C) A e`` with ``A = [[1, Δ, gΔ²], [0, 1, Δ], [0, 0, 1]]``,
``g = (n + 1)/(2n)``, ``C = [1, 0, 0]``; the gains put its three poles at ``p_o, p_o, p_d``
(``p = exp(−ωΔ)``, exactly, for any ``Δ``): with ``σ₁ = Σp``, ``σ₂ = Σ pᵢpⱼ``, ``σ₃ = Πp``,

    l₁ = 1 − σ₃,   l₂ = (2 − g − (1 − g)σ₁ − gσ₂ + (1 + g)σ₃)/Δ,   l₃ = I (1 − p_o)² (1 − p_d)/Δ²

(``≈ 2ω_o + ω_d``, ``ω_o² + 2ω_oω_d`` and ``I ω_o² ω_d`` times ``Δ`` for small ``ωΔ``). The feedback cancels
``d̂`` (:class:`~spherestep.control.servo.ServoLaw` asks the allocation for ``τ* − d̂``), so a constant torque
error is removed with the error dynamics' poles and a varying one is followed with bandwidth ``~ω_d``.
Tuning (the servo law's default, :func:`disturbance_bandwidths`): a triple pole at rest at ``1/T`` (the coils'
``L/R``) within ``[10/3 ω_c, 10 ω_c]`` for a model with a detent (128 rad/s for the iron prototype's coil), at
``10/3 ω_c`` (100 rad/s) without one, rising with the trajectory's speed as ``|ω_d|/0.01 rad`` to ``10 ω_c`` (300
rad/s at 1 kHz; ``20/3 ω_c``, 200 rad/s, with a detent unless the rest pole is higher); off when the sensor is slower than ``10/3 ω_c/0.3``. The sensor's noise and the coils' lag set
the rest value (0.02° at 1 kHz: ``d̂`` ≈ 0.9 N·m rms at 300 rad/s, 0.1 at 100), a position-dependent error
the value in motion (docs/control.md, "Robust to model error").
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
DISTURBANCE_RATIO = 10.0 / 3.0  # the servo law's extended observer at rest: a triple pole at ω_c·10/3 (100 rad/s)
MOTION_RATIO = 10.0  # ... rising with the speed to 10 ω_c (300 rad/s) in motion
BIAS_MOTION_RATIO = 20.0 / 3.0  # ... to 20/3 ω_c (200 rad/s) for a model with a bias (the sensor's noise near the
# back-EMF-limited supply box; disturbance_bandwidths)
SPEED_SCALE = 0.01  # rad: the poles rise by speed/SPEED_SCALE (a position-dependent torque error changes that fast)
SPEED_MEMORY = 0.3  # s: the servo law holds the trajectory's speed peaks this long (decaying) for the poles
DISTURBANCE_POLE = 0.3  # every pole at most this far from z = 1 per measurement: ω ≤ 0.3 × the sensor rate
DISTURBANCE_BANDWIDTH = DISTURBANCE_RATIO * BANDWIDTH  # rad/s: 100 at the default ω_c
MOTION_BANDWIDTH = MOTION_RATIO * BANDWIDTH  # rad/s: 300 at the default ω_c


def disturbance_bandwidths(sensor_rate: float, bandwidth: float = BANDWIDTH, bias: bool = True,
                           time_constant: float = 0.0) -> tuple[float, float]:
    """The servo law's default ``(ω_d, ω_m)`` (rad/s): the extended observer's triple pole at rest and its cap
    in motion, for measurements at ``sensor_rate`` (Hz), the feedback's ``bandwidth`` ``ω_c``, a model with
    (``bias``) or without a bias torque and coils of electrical ``time_constant`` ``T = L/R`` (s; 0: not
    known): ``ω_m = min(10 ω_c, 0.3 f_s)``; with a bias ``ω_d = min(ω_m, max(10/3 ω_c, 1/T))`` (``ω_m`` when
    ``T`` is 0): the estimate at rest no faster than the coil's current follows near its bound, where the sensor's
    noise that ``d̂`` carries (∝ ``ω_d^{5/2}``) is rectified into a torque shortfall — the current rises at most
    at ``(u − c)/T`` and falls at ``(u + c)/T`` (the iron prototype's 0.65 H coil, ``T`` = 7.8 ms: 128 rad/s; its
    holds near the bound missed 0.05° by up to 0.09° at 300), and in motion ``max(ω_d, min(ω_m, 20/3 ω_c))`` (200
    rad/s): at the turn's top speed the back-EMF leaves the coils little of the 24 V, and the noise ``d̂`` carries
    at 300 rad/s (~0.9 N·m rms; ~0.3 at 200) pushes the request out of the supply box, one-sidedly (the ×0.85
    winding, ×1.2 detent plant under the coupled model: 6 % of the periods out of reach, tracking 0.83–0.88°
    against 0.32° at 200; docs/control.md, "Tuning"); else ``10/3 ω_c`` (the error of coils alone is
    proportional to the torque they give, and the lower pole keeps the sensor's noise out of the currents:
    holding the air-core prototype costs 1.3 W instead of 32 W); ``(0, 0)`` (no disturbance estimate) when
    ``10/3 ω_c > 0.3 f_s``: a sensor too slow for an estimate well above the loop's bandwidth, whose lag costs
    more than it removes (the 200 Hz hardware loop). The detent's own stiffness (up to ~230 N·m/rad, above the
    loop's ``I ω_c²``) is the model's business, not the estimate's: the law takes ``K`` and ``b`` to first order
    about its cache's anchor at rest (:meth:`~spherestep.control.ModelCache.at`)."""
    wc = checks.positive(bandwidth, "bandwidth")
    top = DISTURBANCE_POLE * checks.positive(sensor_rate, "sensor_rate")
    T = checks.non_negative(time_constant, "time_constant", "a non-negative time constant in seconds (0: unknown)")
    if DISTURBANCE_RATIO * wc > top + 1e-9:
        return 0.0, 0.0
    wm = min(MOTION_RATIO * wc, top)
    if not bias:
        return DISTURBANCE_RATIO * wc, wm
    wd = min(wm, max(DISTURBANCE_RATIO * wc, 1.0 / T)) if T > 0 else wm
    return wd, max(wd, min(wm, BIAS_MOTION_RATIO * wc))


def observer_gains(interval: float, bandwidth: float, disturbance_bandwidth: float, inertia: float,
                   predictions: int = 1) -> tuple[float, float, float]:
    """``(l₁, l₂, l₃)`` of the extended observer (module docstring) for a measurement ``interval`` ``Δ`` s after
    the previous one and ``predictions`` ``n`` prediction steps between them: the poles of the per-axis error
    map ``(1 − L C) A`` at ``exp(−ω_oΔ)`` (twice) and ``exp(−ω_dΔ)``. From ``det(z − (1 − LC)A) = z³ + a₁z² +
    a₂z + a₃``: ``l₁ = 1 + a₃``, ``l₂ = ((1 − g)a₁ − g a₂ − (1 + g)a₃ + 2 − g)/Δ``, ``l₃ = I(1 + a₁ + a₂ +
    a₃)/Δ²`` with ``g = (n + 1)/(2n)``."""
    po, pd = math.exp(-bandwidth * interval), math.exp(-disturbance_bandwidth * interval)
    a1 = -(2.0 * po + pd)
    a2 = po * po + 2.0 * po * pd
    a3 = -po * po * pd
    g = 0.5 * (predictions + 1) / predictions
    qo, qd = -math.expm1(-bandwidth * interval), -math.expm1(-disturbance_bandwidth * interval)  # 1 − p
    return (-math.expm1(-(2.0 * bandwidth + disturbance_bandwidth) * interval),
            ((1.0 - g) * a1 - g * a2 - (1.0 + g) * a3 + 2.0 - g) / interval,
            inertia * qo * qo * qd / (interval * interval))  # 1 + a₁ + a₂ + a₃ = Π(1 − p), without cancellation


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
    (N·m per rad of residual) when ``disturbance_bandwidth`` ``ω_d > 0`` (:func:`observer_gains`: exact pole
    placement, stable for any interval; the servo law's defaults :func:`disturbance_bandwidths`); the observer's
    ``bandwidth`` ``ω_o`` then defaults to ``ω_d`` (a triple pole). With ``motion_bandwidth`` ``ω_m > ω_d`` the
    poles rise with the speed ``v`` given to :meth:`correct` (the servo law gives the trajectory's ``|ω_d(t)|``,
    which noise does not touch: scheduling on ``|ω̂|`` feeds the noise back into the gains and rings),
    ``ω_o + r`` and ``ω_d + r`` with ``r = min(v/speed_scale, ω_m − ω_d)`` (gains recomputed at each
    measurement): a position-dependent torque error changes at a rate proportional to the speed, and at rest
    the lower poles keep the sensor's noise out of ``d̂``.

    With ``ω_d = 0`` the observer is the second-order one: gains for the interval ``Δ`` since the previous
    measurement (``sensor_period`` while measurements arrive on schedule, to 1 ppm): ``l₁ = min(2ω_oΔ, 1)``,
    ``l₂ = min(ω_o²Δ, 1/Δ)``. The caps keep the error dynamics stable for any ``Δ`` (a loop that misses
    deadlines): with ``l₂Δ ≤ 1`` and ``l₁ ≤ 1`` the error matrix ``[[1 − l₁, Δ(1 − l₁)], [−l₂, 1 − l₂Δ]]`` meets
    Jury's conditions (det ``1 − l₁``, ``1 − tr + det = l₂Δ > 0``, ``1 + tr + det = 4 − 2l₁ − l₂Δ ≥ 1``);
    ``ω_o = 1/Δ`` is the deadbeat observer. ``d_limit`` (N·m, default none) bounds ``|d̂|``."""

    def __init__(self, R0, w0=None, *, inertia: float, bandwidth: float | None = None,
                 sensor_period: float = 1.0 / CONTROL_RATE, history: float = 0.05,
                 disturbance_bandwidth: float = 0.0, motion_bandwidth: float = 0.0,
                 speed_scale: float = SPEED_SCALE, d_limit: float = math.inf):
        self.R = so3.as_rotations(R0, "R0").copy()
        self.w = np.zeros(3) if w0 is None else np.array(w0, dtype=float)
        self.d = np.zeros(3)
        self.inertia = checks.positive(inertia, "inertia")
        h = checks.positive(sensor_period, "sensor_period")
        self.disturbance_bandwidth = checks.non_negative(disturbance_bandwidth, "disturbance_bandwidth",
                                                         "a non-negative bandwidth in rad/s (0: no estimate)")
        if bandwidth is None:
            bandwidth = self.disturbance_bandwidth or OBSERVER_BANDWIDTH
        wo = checks.positive(bandwidth, "bandwidth")
        self.motion_bandwidth = checks.non_negative(motion_bandwidth, "motion_bandwidth",
                                                    "a non-negative bandwidth in rad/s (0: fixed poles)")
        self.speed_scale = checks.positive(speed_scale, "speed_scale", "a positive angle in radians")
        if not (isinstance(d_limit, (int, float)) and d_limit > 0):
            raise bad_value("d_limit", "a positive torque bound in N·m (inf: none)", d_limit)
        self.d_limit = float(d_limit)
        self.bandwidth, self.sensor_period = wo, h
        self.l1, self.l2, self.l3 = self.gains3(h)
        self.t = 0.0
        self._measured: float | None = None  # time of the last measurement
        self._predictions = 0  # prediction steps since the last measurement
        self._past = deque(maxlen=max(2, int(math.ceil(history / h)) * 4))
        self._past.append((0.0, self.R.copy()))

    def restart(self, R) -> None:
        """Start again from the orientation ``R (3, 3)`` now (the velocity and ``d̂`` kept), forgetting the
        history."""
        self.R = np.array(R, dtype=float)
        self._past.clear()
        self._past.append((self.t, self.R.copy()))
        self._measured = None
        self._predictions = 0

    def gains(self, interval: float) -> tuple[float, float]:
        """``(l₁, l₂)`` of the second-order observer for measurements ``interval`` s apart (see the class)."""
        wo = self.bandwidth
        return min(2.0 * wo * interval, 1.0), min(wo * wo * interval, 1.0 / interval)

    def gains3(self, interval: float, predictions: int = 1) -> tuple[float, float, float]:
        """``(l₁, l₂, l₃)`` for measurements ``interval`` s apart with ``predictions`` steps between them: the
        second-order gains and ``l₃ = 0`` without a disturbance estimate, else :func:`observer_gains`."""
        if self.disturbance_bandwidth == 0:
            return self.gains(interval) + (0.0,)
        return observer_gains(interval, self.bandwidth, self.disturbance_bandwidth, self.inertia, predictions)

    def predict(self, torque, h: float) -> None:
        """Advance by ``h`` s under ``torque`` (N·m, what the drive is believed to apply) and ``d̂``."""
        self.w = self.w + (h / self.inertia) * (np.asarray(torque, dtype=float) + self.d)
        self.R = so3.exp(h * self.w) @ self.R
        self.t += h
        self._predictions += 1
        self._past.append((self.t, self.R.copy()))

    def correct(self, R_meas, t_meas: float | None = None, speed: float = 0.0) -> None:
        """Blend in a measurement ``R_meas`` taken at ``t_meas`` (default now). A late measurement is compared with
        the estimate of its time ``t_k`` (the history), the correction made there and carried to every later
        estimate as the prediction would have: ``R̂(t) ← exp((l₁ + l₂ τ + l₃ τ²/(2I)) ε) R̂(t)``, ``τ = t − t_k``,
        for ``t ≥ t_k`` (the velocity correction ``l₂ε`` and the disturbance's ``l₃ε`` acting since ``t_k``), so a
        known latency costs no stability. ``speed`` (rad/s) raises the poles with ``motion_bandwidth`` (class)."""
        ref, k = self.R, None
        if t_meas is not None and t_meas < self.t - 1e-12:
            times = [p[0] for p in self._past]
            k = int(np.clip(np.searchsorted(times, t_meas), 0, len(times) - 1))
            ref = self._past[k][1]
        now = self.t if t_meas is None else t_meas
        interval = self.sensor_period if self._measured is None else now - self._measured
        self._measured = now
        n, self._predictions = max(self._predictions, 1), 0
        l1, l2, l3 = self.l1, self.l2, self.l3
        rise = 0.0
        if l3 and self.motion_bandwidth > self.disturbance_bandwidth:
            rise = min(speed / self.speed_scale, self.motion_bandwidth - self.disturbance_bandwidth)
        if rise > 1e-9 * self.disturbance_bandwidth and interval > 0:
            l1, l2, l3 = observer_gains(interval, self.bandwidth + rise, self.disturbance_bandwidth + rise,
                                        self.inertia, n)
        elif (not abs(interval - self.sensor_period) <= 1e-6 * self.sensor_period or (l3 and n != 1)) \
                and interval > 0:
            l1, l2, l3 = self.gains3(interval, n)
        eps = so3.log_single(R_meas @ ref.T)
        a = l3 / self.inertia
        if k is not None:  # re-propagate the history from t_k
            t_k = self._past[k][0]
            for j in range(k, len(self._past)):
                t_j, R_j = self._past[j]
                tau = t_j - t_k
                self._past[j] = (t_j, so3.exp((l1 + l2 * tau + 0.5 * a * tau * tau) * eps) @ R_j)
            tau = self.t - t_k
            self.R = so3.exp((l1 + l2 * tau + 0.5 * a * tau * tau) * eps) @ self.R
            self.w = self.w + (l2 + a * tau) * eps
        else:
            self.R = so3.exp(l1 * eps) @ self.R
            self.w = self.w + l2 * eps
        if l3:
            self.d = self.d + l3 * eps
            if self.d_limit < math.inf:
                size = math.sqrt(float(self.d @ self.d))
                if size > self.d_limit:
                    self.d = self.d * (self.d_limit / size)
