"""The estimator and the control law the hardware loop runs until the sensing and control rooms publish theirs.

:class:`FieldTracker` (orientation from the magnetometers): the sensing room's rotor field
(:class:`~spherestep.sensing.field.FieldTable`, with its Jacobian) and coil field
(:class:`~spherestep.sensing.field.CoilField`, at the measured currents); Gauss–Newton on SO(3) from the last
estimate carried on at the last rate of turn over the device's clock (``exp(ω̂ Δt) R``), ``θ = argmin ‖B_meas − B_coils(i) − B(R) − J θ‖²``, ``R ← exp(θ̂) R``, ``iterations`` times per
reading (one suffices at 200 Hz: the rotor turns at most a few hundredths of a radian between readings), up to
``max_iterations`` while the residual is over the limit (after a late reading). A root-mean-square residual above ``residual_limit`` (default 10 × the part's noise) means the
readings do not fit any orientation (a sensor returning garbage): :class:`~spherestep.hardware.servo.ServoFault`
``SENSOR``.

:class:`PoseServo` (the control law): computed torque on SO(3) with a reference ``R_r(t)``, ``ω_r(t)``, ``α_r(t)``,
``τ = I α_r + k_p log(R_r Rᵀ) + k_d (ω_r − ω)``, ``k_p = I ω_n²``, ``k_d = 2 ζ ω_n I``, allocated to currents by
:func:`spherestep.control.allocation.allocate_matrix` (least copper power within the drive's limits, warm
started). :func:`turn` gives a minimum-jerk turn about an axis, :func:`hold` a fixed pose.
"""

from __future__ import annotations

import math

import numpy as np

from .. import so3
from ..errors import bad_value
from .motor_emulator import K_REUSE
from .servo import ServoFault, log_near_identity


class FieldTracker:
    """``estimate(state) -> R`` for :func:`~spherestep.hardware.servo.run_servo` (see the module).

    ``design``, ``sensors`` (a :class:`~spherestep.sensing.SensorArray`), the start orientation ``R0``, the
    nominal current (A per unit, for the coil field). ``residual`` is the last RMS residual (T).
    """

    def __init__(self, design, sensors, R0, nominal_current: float, *, iterations: int = 1,
                 max_iterations: int = 4, residual_limit: float | None = None):
        from ..sensing.field import CoilField, FieldTable

        self.table = FieldTable.build(design, sensors.positions)
        self.coils = CoilField.build(design, sensors.positions)
        self.axes = sensors.axes
        self.R = so3.as_rotations(R0).reshape(3, 3).copy()
        self.nominal = float(nominal_current)
        self.iterations, self.max_iterations = int(iterations), max(int(iterations), int(max_iterations))
        self.residual_limit = 10 * sensors.part.effective_noise_T if residual_limit is None else residual_limit
        self.residual = 0.0
        self._last, self._rate = None, np.zeros(3)
        self.table.field_and_jacobian(self.R)  # first call here, not in the loop

    def __call__(self, state) -> np.ndarray:
        B = np.einsum("sab,sb->sa", self.axes, state.field) - self.coils.field(state.currents / self.nominal)
        if self._last is not None:  # start from the last estimate carried on at the last rate of turn
            dt = ((state.time_us - self._last[0]) & 0xFFFFFFFF) * 1e-6
            self.R = so3.exp(self._rate * dt) @ self.R
        previous = self._last
        for k in range(self.max_iterations):
            model, J = self.table.field_and_jacobian(self.R)
            J = J.reshape(-1, 3)
            theta = np.linalg.lstsq(J, (B - model).reshape(-1), rcond=None)[0]
            self.R = so3.exp(theta) @ self.R
            r = (B - model).reshape(-1) - J @ theta  # the residual after this step, to first order
            self.residual = float(np.sqrt(np.mean(r * r)))
            if k + 1 >= self.iterations and self.residual <= self.residual_limit:
                break
        if previous is not None and state.time_us != previous[0]:
            dt = ((state.time_us - previous[0]) & 0xFFFFFFFF) * 1e-6
            self._rate = log_near_identity(self.R @ previous[1].T) / dt
        self._last = (state.time_us, self.R.copy())
        if self.residual > self.residual_limit:
            worst = int(np.argmax(np.sum(r.reshape(-1, 3) ** 2, axis=1)))
            raise ServoFault(f"the magnetometers fit no orientation (RMS residual {self.residual * 1e3:.2f} mT, "
                             f"over {self.residual_limit * 1e3:.2f} mT; worst sensor {worst})", "SENSOR")
        return self.R


def hold(R):
    """The reference of a fixed pose ``R``: ``t -> (R, 0, 0)``."""
    R = so3.as_rotations(R).reshape(3, 3).copy()
    zero = np.zeros(3)
    return lambda t: (R, zero, zero)


def turn(R0, axis, angle: float, duration: float, start: float = 0.0):
    """A minimum-jerk turn by ``angle`` (rad) about the fixed ``axis`` from ``R0`` between ``start`` and
    ``start + duration`` s: ``θ(t) = angle · (10 s³ − 15 s⁴ + 6 s⁵)``, ``s = (t − start) / duration``;
    returns ``t -> (R_r, ω_r, α_r)``."""
    a = np.asarray(axis, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise bad_value("axis", "a non-zero 3-vector", axis)
    if not (isinstance(duration, (int, float)) and duration > 0):
        raise bad_value("duration", "a positive time in seconds", duration)
    a = a / np.linalg.norm(a)
    R0 = so3.as_rotations(R0).reshape(3, 3).copy()

    def reference(t: float):
        s = min(max((t - start) / duration, 0.0), 1.0)
        th = angle * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5)
        dth = angle * (30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration
        ddth = angle * (60 * s - 180 * s ** 2 + 120 * s ** 3) / duration ** 2
        return so3.exp(th * a) @ R0, dth * a, ddth * a

    return reference


class PoseServo:
    """``control(t, R, ω) -> currents (A)`` for :func:`~spherestep.hardware.servo.run_servo` (see the module).

    ``model`` a torque model, ``inertia`` kg·m², ``reference(t) -> (R_r, ω_r, α_r)``, ``drive`` a
    :class:`spherestep.control.DriveLimits`; natural frequency ``bandwidth`` rad/s and ``damping`` ζ.
    """

    def __init__(self, model, inertia: float, reference, drive, *, bandwidth: float = 2 * math.pi * 3,
                 damping: float = 1.0):
        self.model, self.inertia, self.reference, self.drive = model, float(inertia), reference, drive
        # 1 % below the device's current and 2 % below its power limit: room for the mA rounding on the wire
        self.allocation_limits = drive.replace(max_current=0.99 * drive.max_current,
                                               supply_power=0.98 * drive.supply_power)
        self.kp = self.inertia * bandwidth ** 2
        self.kd = 2.0 * damping * bandwidth * self.inertia
        self._lam = None
        self._K = self._K_at = None
        self(0.0, reference(0.0)[0], np.zeros(3))  # first calls (imports, caches) here, not in the loop
        self._lam = None

    def torque_matrix(self, R: np.ndarray) -> np.ndarray:
        """``K(R)``, re-evaluated only when ``R`` has turned more than ``K_REUSE`` rad from the last evaluation
        (a relative error of about ``K_REUSE`` over the pole spacing, 0.6 %, which the feedback absorbs)."""
        if self._K is None or np.linalg.norm(log_near_identity(R @ self._K_at.T)) > K_REUSE:
            self._K, self._K_at = self.model.torque_matrix(R), R
        return self._K

    def __call__(self, t: float, R: np.ndarray, w: np.ndarray) -> np.ndarray:
        from ..control.allocation import allocate_matrix

        Rr, wr, ar = self.reference(t)
        tau = self.inertia * ar + self.kp * log_near_identity(Rr @ R.T) + self.kd * (wr - w)
        a, self._lam = allocate_matrix(self.torque_matrix(R), tau, self.allocation_limits,
                                       failed=self.model.failed, lam0=self._lam)
        return a.currents * self.drive.nominal_current
