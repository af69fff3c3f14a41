"""The one orientation-sensor protocol of the servo loop, and the sensors that implement it.

:class:`OrientationSensor`: ``measure(t, R_true, currents) -> R | None`` is called once per control period at loop
time ``t`` (s) with the true orientation (simulation) and the per-unit coil currents flowing; it returns an
estimate ``(3, 3)`` when one is delivered at ``t``, else ``None``. A sensor samples every ``1/rate`` s and delivers
each sample ``latency`` s later, so a delivered estimate describes the rotor at ``t − latency`` (the servo law
corrects against its estimate of that time). :class:`SampledSensor` does this schedule and delay once; a sensor
writes only ``estimate(R_true, currents, R_prev)``, the estimate from one sample:

* :class:`NoisySensor`: the true orientation turned by Gaussian noise (a generic sensor);
* :class:`HallSensor`: the stator's magnetometer array and the SO(3) estimator (readings simulated from the true
  orientation and the currents that flow; it tracks from its previous estimate by Gauss–Newton, or starts
  globally);
* :class:`IdealSensor`: the true orientation;
* :class:`~spherestep.sensing.imu.ImuSensor` and :class:`~spherestep.sensing.imu.FusedSensor`: the IMU alone and
  gyro + array (MEKF).

On hardware the readings come from the device, not from a true orientation: there
:class:`~spherestep.sensing.estimate.Estimator.track` is the same Hall estimate (the hardware's ``FieldTracker``
wraps it), and the servo law takes its output as the measurement at the reading's device time.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import deque
from dataclasses import replace
from typing import Protocol, runtime_checkable

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .array import SensorArray
from .estimate import Estimate
from .field import rotor_field
from .model import field_model
from .placement import default_array
from .readings import actual_currents, sense
from .symmetry import symmetry_group

SENSOR_RATE = 1000.0  # Hz, the servo's control rate


@runtime_checkable
class OrientationSensor(Protocol):
    """Anything that measures the rotor's orientation for the servo loop (see the module): ``rate`` (Hz),
    ``latency`` (s, how old a delivered estimate is), ``measure(t, R_true, currents) -> (3, 3) | None``."""

    rate: float
    latency: float

    def measure(self, t: float, R_true: np.ndarray, currents: np.ndarray | None) -> np.ndarray | None: ...


class SampledSensor(ABC):
    """The :class:`OrientationSensor` schedule: a sample every ``1/rate`` s from ``t = 0``, each delivered
    ``latency`` s later (several due at once: the newest). A subclass writes ``estimate(R_true, currents,
    R_prev)``; ``R_prev`` is its own previous estimate (``start`` before the first; ``None``: none known)."""

    def __init__(self, rate: float = SENSOR_RATE, latency: float = 0.0, start=None):
        self.rate = checks.positive(rate, "rate", "a positive sampling rate in Hz")
        self.latency = checks.non_negative(latency, "latency", "a non-negative delay in seconds")
        self._last = None if start is None else so3.as_rotations(start, "start").reshape(3, 3).copy()
        self._next = 0.0
        self._queue: deque = deque()

    @abstractmethod
    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        """One sample's orientation estimate ``(3, 3)`` for the true ``R_true`` (what each sensor writes)."""

    def measure(self, t: float, R_true, currents=None) -> np.ndarray | None:
        if t >= self._next - 1e-12:
            self._last = self.estimate(R_true, currents, self._last)
            self._queue.append((t + self.latency, self._last))
            self._next += 1.0 / self.rate
        out = None
        while self._queue and self._queue[0][0] <= t + 1e-12:
            out = self._queue.popleft()[1]
        return out


class NoisySensor(SampledSensor):
    """The true orientation turned by a random rotation vector with independent N(0, ``noise``²) components
    (rad), sampled every ``1/rate`` s and delivered ``latency`` s later."""

    def __init__(self, noise: float = 0.0, *, rate: float = SENSOR_RATE, latency: float = 0.0,
                 rng: np.random.Generator | int | None = None):
        self.noise = checks.non_negative(noise, "noise", "a non-negative angle in radians")
        super().__init__(rate, latency)
        self.rng = np.random.default_rng(rng)

    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        return so3.exp(self.rng.normal(0.0, self.noise, 3)) @ R_true


class IdealSensor(SampledSensor):
    """The true orientation, as if measured perfectly (``rate`` Hz, ``latency`` s)."""

    def __init__(self, rate: float = SENSOR_RATE, latency: float = 0.0):
        super().__init__(rate, latency)

    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        return so3.as_rotations(R_true, "R_true").reshape(3, 3).copy()


class HallSensor(SampledSensor):
    """Magnetometer array + estimator for ``design`` (module doc), an :class:`OrientationSensor` of ``rate`` Hz
    and ``latency`` s that tracks from its previous estimate, from ``start`` at first (``None``: the global start).

    ``array``: a :class:`SensorArray` (default :func:`spherestep.sensing.default_array`); ``known``: extra known
    fields beside the coils (e.g. an iron model's); ``current_error``: RMS relative error of the currents the
    controller believes flow (the coil-field subtraction's residual); ``truth``: ``"table"`` simulates the
    rotor's field with the estimator's table (max error 1e-7 T, fast for loops) or ``"magpylib"``;
    ``iterations``: Gauss–Newton steps per update; ``noise_T``: RMS noise per axis in place of the part's;
    ``start_readings``: readings averaged for the global start
    (the rotor at rest at power-up); ``seed``: noise; ``cores``: whether the estimator models the iron cores'
    field (:mod:`.iron`: the cores magnetised by the rotor and the coils; default: when the design's coil is
    iron; ``False`` on an iron design estimates as if the stator were air while the readings still hold the
    cores' field — the cost of ignoring them). A rotor whose field has a symmetry group (the unmarked
    prototype's 60 rotations) is found only up to that group from no prior; a marked rotor is found exactly,
    the marker's near-symmetry resolved by :meth:`Estimator.initialise`."""

    def __init__(self, design, array: SensorArray | None = None, known=(), current_error: float = 0.0,
                 truth: str = "table", iterations: int = 1, start_readings: int = 32, noise_T: float | None = None,
                 seed=None, *, rate: float = SENSOR_RATE, latency: float = 0.0, start=None, cores: bool | None = None):
        super().__init__(rate, latency, start)
        if truth not in ("table", "magpylib"):
            raise bad_value("truth", "'table' or 'magpylib'", truth)
        self.design = design
        self.array = array if array is not None else default_array(design)
        if noise_T is not None:  # the same part with another noise (MagnetometerPart checks the value)
            self.array = replace(self.array, part=replace(self.array.part, noise_T=noise_T))
        self.array.check_fits(design)
        # what the readings hold (the cores' field on an iron design whatever the estimator models), and what the
        # estimator models: the same FieldModel, or with cores=False on iron the air-core model of the motor
        self.motor_field = field_model(design, self.array.positions)
        model = field_model(design, self.array.positions, cores, rotor=self.motor_field.rotor)  # checks cores
        self.field_model = self.motor_field if (model.cores is None) == (self.motor_field.cores is None) else model
        self.rotor_table, self.core_field, self.coils = (self.motor_field.rotor, self.motor_field.cores,
                                                         self.motor_field.coils)
        self.cores = self.field_model.cores is not None
        self.known = tuple(known)
        self.table = self.field_model.table
        self.estimator = self.field_model.estimator(self.array, self.known)
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
            B = self.rotor_table.field(R)
        else:
            B = rotor_field(self.design, self.array.positions, R)[0]
        if self.core_field is not None:
            B = B + self.core_field.field(R)
        if currents is not None:
            B = B + self.coils.field(actual_currents(currents, self.current_error, self.rng))
            for source in self.known:  # the extra known fields are really there too
                B = B + source.field(currents)
        return sense(self.array, B, self.rng)

    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        """The estimated orientation ``(3, 3)`` from one set of readings, tracked from ``R_prev`` (``None``: the
        global start from ``start_readings`` averaged readings)."""
        if R_prev is None:
            m = np.mean([self.readings(R_true, currents) for _ in range(max(self.start_readings, 1))], axis=0)
            self.last = self.estimator.initialise(m, currents, near_symmetry=self.near_symmetry)
        else:
            m = self.readings(R_true, currents)
            self.last = self.estimator.track_until(m, R_prev, currents, self.iterations)
        return self.last.R
