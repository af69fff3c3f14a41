"""The two callables of :func:`~spherestep.hardware.servo.run_servo`, built from the sensing and control rooms.

:class:`FieldTracker` (``estimate(state) -> R``): the sensing room's
:meth:`~spherestep.sensing.Estimator.track` (Gauss–Newton on SO(3) against the rotor's field table, the coils'
field at the *measured* currents subtracted), started from the last estimate carried on at the last rate of
turn over the device's clock, ``exp(ω̂ Δt) R̂`` (so a late reading starts close), with up to ``max_iterations``
steps while the residual is over the limit. A root-mean-square residual above ``residual_limit`` (default
10 × the part's noise) means that the readings fit no orientation — a magnetometer returning garbage —
and raises :class:`~spherestep.hardware.servo.ServoFault` ``SENSOR``.

:class:`ServoLaw` (``control(t, R, ω) -> currents``): the control room's :class:`~spherestep.control.GeometricPD`
torque for a reference ``t -> (R_r, ω_r, α_r)`` (a :class:`~spherestep.control.Trajectory`'s ``sample``, or
:func:`hold`), allocated to coil currents by :func:`~spherestep.control.allocation.allocate_matrix` (least copper
power within the drive's limits, warm-started), times the nominal current.
"""

from __future__ import annotations

import numpy as np

from .. import so3
from ..control.controller import rotation_error
from .servo import ServoFault

K_REUSE = 2e-3  # rad: the torque matrix is re-evaluated when the estimate has turned further than this


class FieldTracker:
    """``estimate(state) -> R`` (see the module) for a :class:`~spherestep.sensing.Estimator` whose known fields
    take currents per unit of ``nominal_current`` (A); ``R0`` the start. ``last`` is the last
    :class:`~spherestep.sensing.Estimate`."""

    def __init__(self, estimator, R0, nominal_current: float, *, iterations: int = 1, max_iterations: int = 4,
                 residual_limit: float | None = None):
        self.estimator = estimator
        self.R = so3.as_rotations(R0).reshape(3, 3).copy()
        self.nominal = float(nominal_current)
        self.iterations, self.max_iterations = int(iterations), max(int(iterations), int(max_iterations))
        self.residual_limit = 10 * estimator.noise_T if residual_limit is None else float(residual_limit)
        self.last = None
        self._time, self._rate = None, np.zeros(3)
        estimator.table.field_and_jacobian(self.R)  # first call here, not in the loop

    def __call__(self, state) -> np.ndarray:
        currents = state.currents / self.nominal
        R = self.R
        if self._time is not None:
            R = so3.exp(self._rate * (((state.time_us - self._time) & 0xFFFFFFFF) * 1e-6)) @ R
        done = 0
        while True:
            est = self.estimator.track(state.field, R, currents, iterations=self.iterations)
            R, done = est.R, done + self.iterations
            if est.residual_T <= self.residual_limit or done >= self.max_iterations:
                break
        self.last = est
        if est.residual_T > self.residual_limit:
            raise ServoFault(f"the magnetometers fit no orientation (RMS residual {est.residual_T * 1e3:.2f} mT, "
                             f"over {self.residual_limit * 1e3:.2f} mT)", "SENSOR")
        if self._time is not None and state.time_us != self._time:
            dt = ((state.time_us - self._time) & 0xFFFFFFFF) * 1e-6
            self._rate = rotation_error(R @ self.R.T) / dt
        self.R, self._time = R, state.time_us
        return R


def hold(R):
    """The reference of a fixed pose ``R``: ``t -> (R, 0, 0)``."""
    R = so3.as_rotations(R).reshape(3, 3).copy()
    zero = np.zeros(3)
    return lambda t: (R, zero, zero)


class ServoLaw:
    """``control(t, R, ω) -> currents (A)`` (see the module): ``law`` a :class:`~spherestep.control.GeometricPD`,
    ``model`` a torque model, ``reference(t) -> (R_r, ω_r, α_r)``, ``drive`` a
    :class:`~spherestep.control.DriveLimits`. The allocation keeps 1 % below the drive's current and 2 % below its
    power limit, room for the rounding to mA on the wire (the device refuses anything over).
    """

    def __init__(self, model, law, reference, drive):
        self.model, self.law, self.reference, self.drive = model, law, reference, drive
        self.allocation_limits = drive.replace(max_current=0.99 * drive.max_current,
                                               supply_power=0.98 * drive.supply_power)
        self._lam = None
        self._K = self._K_at = None
        self(0.0, np.asarray(reference(0.0)[0]), np.zeros(3))  # first calls (imports, caches) here
        self._lam = None

    def torque_matrix(self, R: np.ndarray) -> np.ndarray:
        """``K(R)``, re-evaluated only when ``R`` has turned more than ``K_REUSE`` rad from the last evaluation
        (a relative error of about ``K_REUSE`` over the pole spacing, 0.6 %, which the feedback absorbs)."""
        if self._K is None or np.linalg.norm(rotation_error(R @ self._K_at.T)) > K_REUSE:
            self._K, self._K_at = self.model.torque_matrix(R), R
        return self._K

    def __call__(self, t: float, R: np.ndarray, w: np.ndarray) -> np.ndarray:
        from ..control.allocation import allocate_matrix

        Rr, wr, ar = (np.asarray(x, dtype=float) for x in self.reference(t))
        tau = self.law.torque(R, w, Rr, wr, ar)
        a, self._lam = allocate_matrix(self.torque_matrix(R), tau, self.allocation_limits,
                                       failed=self.model.failed, lam0=self._lam)
        return a.currents * self.drive.nominal_current
