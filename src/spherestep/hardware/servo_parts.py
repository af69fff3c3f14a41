"""The sensing half of :func:`~spherestep.hardware.servo.run_servo` on a device, and the wire's limits for the law.

The control half is the control room's :class:`~spherestep.control.ServoLaw`, the same object the simulation runs
(no copy of the law lives here).

:class:`FieldTracker` (``estimate(state, prior) -> R``) is the Hall sensor of the device. It and the simulation's
:class:`~spherestep.sensing.HallSensor` are one estimator, :meth:`spherestep.sensing.Estimator.track_until`
(Gauss–Newton on SO(3) against the rotor's field table, the coils' field at the currents subtracted), fed from two
sources: the simulated sensor synthesises readings from the true orientation and honours the whole
:class:`~spherestep.sensing.OrientationSensor` protocol (``measure(t, R_true, currents)``, ``rate``,
``latency``); on hardware there is no true orientation to sample — the device delivers readings, *measured*
currents and its clock in each :class:`~spherestep.hardware.protocol2.State` — so the tracker implements the part
of the protocol that applies: ``latency`` (0 s: an estimate describes the rotor at the state's device time, which
is the time the loop hands the law) and the estimate from readings. It searches from the law's prediction for the
reading's time (``prior``), with up to ``max_iterations`` steps while the residual is over the limit; a
root-mean-square residual above ``residual_limit`` (default 10 × the part's noise) means that the readings fit no
orientation — a magnetometer returning garbage — and raises :class:`~spherestep.hardware.servo.ServoFault`
``SENSOR``.

:func:`wire_limits`: the drive's limits less the room the wire's rounding to mA needs (the device refuses
anything over its limits), for the law's allocation.
"""

from __future__ import annotations

import numpy as np

from .. import so3
from .limits import CurrentLimits
from .servo import ServoFault

CURRENT_ROOM, POWER_ROOM = 0.99, 0.98  # the allocation keeps 1 % below the current limit, 2 % below the power
MAX_DUTY = CurrentLimits.max_duty  # the bridge's largest duty (the device's and the firmware's: 0.95)


def wire_limits(drive, max_duty: float = MAX_DUTY):
    """``drive`` (a :class:`~spherestep.control.DriveLimits`) with ``CURRENT_ROOM`` of its current,
    ``POWER_ROOM`` of its supply's power and ``max_duty`` of its supply's voltage (the most the bridge applies,
    :class:`~spherestep.hardware.limits.CurrentLimits`' ``max_duty``): what the law may allocate so that the mA
    on the wire stay within and the coil can follow. The law's voltage box is then ``|R I_n c + e| ≤ d_max V``
    (a coil holds at most ``d_max V / R``, 0.95 of the ``V / R`` its current limit allows on the prototype)."""
    return drive.replace(max_current=CURRENT_ROOM * drive.max_current, supply_power=POWER_ROOM * drive.supply_power,
                         supply_voltage=max_duty * drive.supply_voltage)


class FieldTracker:
    """``estimate(state, prior=None) -> R`` (see the module) for a :class:`~spherestep.sensing.Estimator` whose
    known fields take currents per unit of the nominal current of ``drive`` (a
    :class:`~spherestep.electrics.DriveLimits`: the state's amperes converted by its :meth:`per_unit`); ``R0`` the start (the search starts from the
    last estimate when no ``prior`` is given). ``last`` is the last :class:`~spherestep.sensing.Estimate`."""

    latency = 0.0  # s: the estimate is of the rotor at the state's device time

    def __init__(self, estimator, R0, drive, *, iterations: int = 1, max_iterations: int = 4,
                 residual_limit: float | None = None):
        self.estimator = estimator
        self.R = so3.as_rotations(R0).reshape(3, 3).copy()
        self.drive = drive
        self.iterations, self.max_iterations = int(iterations), max(int(iterations), int(max_iterations))
        self.residual_limit = 10 * estimator.noise_T if residual_limit is None else float(residual_limit)
        self.last = None
        estimator.table.field_and_jacobian(self.R)  # first call here, not in the loop

    def __call__(self, state, prior: np.ndarray | None = None) -> np.ndarray:
        est = self.estimator.track_until(state.field, self.R if prior is None else prior, self.drive.per_unit(state.currents),
                                         self.iterations, self.max_iterations, self.residual_limit)
        self.last = est
        if est.residual_T > self.residual_limit:
            raise ServoFault(f"the magnetometers fit no orientation (RMS residual {est.residual_T * 1e3:.2f} mT, "
                             f"over {self.residual_limit * 1e3:.2f} mT)", "SENSOR")
        self.R = est.R
        return est.R
