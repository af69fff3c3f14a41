"""Sensors for the servo loop: ``measure(R_true, currents, R_prev) -> R_estimate``.

* :class:`HallSensor`: the stator's magnetometer array and the SO(3) estimator (readings simulated from the
  true orientation and the currents that flow; the estimate tracks from ``R_prev`` by one Gauss–Newton step,
  or starts globally when there is no ``R_prev``).
* :class:`IdealSensor`: returns the true orientation (the reference).

The IMU alternatives (:class:`~spherestep.sensing.imu.ImuSensor`, :class:`~spherestep.sensing.imu.FusedSensor`)
have the same ``measure`` plus the time step they need for their gyro. :class:`LoopSensor` wraps any of them in
the servo's ``measure(t, R_true, currents)`` form (:func:`spherestep.dynamics.simulate_servo`).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from .. import so3
from ..errors import bad_value
from .array import SensorArray
from .estimate import Estimate, Estimator
from .field import CoilField, FieldTable, rotor_field
from .placement import default_array
from .readings import actual_currents, sense
from .symmetry import symmetry_group


class IdealSensor:
    """The true orientation, as if measured perfectly."""

    def measure(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        return so3.as_rotations(R_true, "R_true").reshape(3, 3).copy()


class HallSensor:
    """Magnetometer array + estimator for ``design`` (module doc).

    ``array``: a :class:`SensorArray` (default :func:`spherestep.sensing.default_array`); ``known``: extra known
    fields beside the coils (e.g. an iron model's); ``current_error``: RMS relative error of the currents the
    controller believes flow (the coil-field subtraction's residual); ``truth``: ``"table"`` simulates the
    rotor's field with the estimator's table (max error 1e-7 T, fast for loops) or ``"magpylib"``;
    ``iterations``: Gauss–Newton steps per update; ``noise_T``: RMS noise per axis in place of the part's;
    ``start_readings``: readings averaged for the global start
    (the rotor at rest at power-up); ``seed``: noise. A rotor whose field has a symmetry group (the unmarked
    prototype's 60 rotations) is found only up to that group from no prior; a marked rotor is found exactly,
    the marker's near-symmetry resolved by :meth:`Estimator.initialise`."""

    def __init__(self, design, array: SensorArray | None = None, known=(), current_error: float = 0.0,
                 truth: str = "table", iterations: int = 1, start_readings: int = 32, noise_T: float | None = None,
                 seed=None):
        if truth not in ("table", "magpylib"):
            raise bad_value("truth", "'table' or 'magpylib'", truth)
        self.design = design
        self.array = array if array is not None else default_array(design)
        if noise_T is not None:  # the same part with another noise (MagnetometerPart checks the value)
            self.array = replace(self.array, part=replace(self.array.part, noise_T=noise_T))
        self.array.check_fits(design)
        self.coils = CoilField.build(design, self.array.positions)
        self.table = FieldTable.build(design, self.array.positions)
        self.known = tuple(known)
        self.estimator = Estimator(self.table, self.array.axes, self.array.part, (self.coils, *self.known))
        self.current_error = current_error
        self.truth = truth
        self.iterations = int(iterations)
        self.rng = np.random.default_rng(seed)
        self.start_readings = int(start_readings)
        places = symmetry_group(design, polarity=False)
        self.near_symmetry = places if len(places) > len(symmetry_group(design)) else None
        self.last: Estimate | None = None

    def readings(self, R_true, currents=None) -> np.ndarray:
        """One set of readings ``(S, 3)`` for the true orientation and the commanded currents."""
        R = so3.as_rotations(R_true, "R_true")
        if R.shape != (3, 3):
            raise bad_value("R_true", "one rotation matrix (3, 3)", f"shape {R.shape}")
        if self.truth == "table":
            B = self.table.field(R)
        else:
            B = rotor_field(self.design, self.array.positions, R)[0]
        if currents is not None:
            B = B + self.coils.field(actual_currents(currents, self.current_error, self.rng))
            for source in self.known:  # the extra known fields are really there too
                B = B + source.field(currents)
        return sense(self.array, B, self.rng)

    def measure(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        """The estimated orientation ``(3, 3)`` from one set of readings."""
        if R_prev is None:
            m = np.mean([self.readings(R_true, currents) for _ in range(max(self.start_readings, 1))], axis=0)
            self.last = self.estimator.initialise(m, currents, near_symmetry=self.near_symmetry)
        else:
            m = self.readings(R_true, currents)
            self.last = self.estimator.track(m, R_prev, currents, self.iterations)
        return self.last.R


class LoopSensor:
    """A sensing sensor in the servo's :class:`~spherestep.dynamics.servo.OrientationSensor` form:
    ``measure(t, R_true, currents)`` returns an estimate every ``1/rate`` s (else ``None``), ``latency`` s old.
    The inner ``sensor`` (:class:`HallSensor`, :class:`IdealSensor`, an IMU sensor with ``dt = 1/rate``) tracks
    from its own previous estimate, starting from ``start`` (``None``: the global start, up to the rotor's
    symmetry)."""

    def __init__(self, sensor, rate: float = 1000.0, latency: float = 0.0, start=None):
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise bad_value("rate", "a positive sampling rate in Hz", rate)
        if not (isinstance(latency, (int, float)) and math.isfinite(latency) and latency >= 0):
            raise bad_value("latency", "a non-negative delay in seconds", latency)
        self.sensor, self.rate, self.latency = sensor, float(rate), float(latency)
        self._last = None if start is None else so3.as_rotations(start, "start").reshape(3, 3).copy()
        self._next = 0.0

    def measure(self, t: float, R_true, currents=None):
        if t < self._next - 1e-12:
            return None
        self._next += 1.0 / self.rate
        self._last = self.sensor.measure(R_true, currents, self._last)
        return self._last
