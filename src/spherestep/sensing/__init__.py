"""Orientation from the rotor's own field: magnetometer arrays, estimation on SO(3), symmetry, IMU fusion.

* :mod:`.parts`: datasheet figures (TMAG5273A2 magnetometer, BMI270 + BMM150 IMU).
* :mod:`.array`: :class:`SensorArray` (positions, axes, part), candidate positions clear of the coils.
* :mod:`.field`: :class:`FieldTable`, the rotor's field at the sensors from one 1-D table per radius, with
  its Jacobian on SO(3); :class:`CoilField` and the :class:`KnownField` protocol for subtracted fields.
* :mod:`.iron`: the iron stator's cores magnetised by the rotor (:class:`CoreField`, a table per sensor over the
  magnet's direction; :class:`IronFieldTable` = rotor + cores) and by the coils (:class:`IronCoilField`);
  :func:`iron_fields` (stored for the prototype's default array, else built on first use).
* :mod:`.model`: :func:`field_model` -> :class:`FieldModel`, what the sensors see of a design (rotor, the cores on
  iron, coils), built one way for the simulated sensor, the emulated motor, the hardware session's estimator,
  :func:`accuracy` and :func:`calibrate`.
* :mod:`.readings`: simulated readings (magpylib, noise, saturation, LSB, current-sense error).
* :mod:`.estimate`: :class:`Estimator` (Gauss–Newton / Levenberg–Marquardt on SO(3), global start).
* :mod:`.calibration`: :func:`calibrate` (positions, gains, offsets from readings at unknown poses).
* :mod:`.absolute`: :func:`detent_wells`, :func:`refined_wells`, :func:`calibrate_array_absolute` → :class:`ArrayCalibration` (offsets,
  gains and the array's turn against the detent wells, orientations known absolutely; its ``estimator``).
* :mod:`.sensor_errors`: :class:`SensorErrors` (an array as built: per-sensor offsets and gains, the array turned).
* :mod:`.symmetry`: :func:`symmetry_group`, :func:`marked_design`.
* :mod:`.placement`: :func:`greedy_placement` (worst-case Fisher information), :func:`accuracy`.
* :mod:`.imu`: :class:`Imu`, :class:`Mekf`, :class:`ImuSensor`, :class:`FusedSensor`.
* :mod:`.figures`: :func:`figure_layout`.
* :mod:`.sensor`: the one :class:`OrientationSensor` protocol of the servo loop (``measure(t, R_true, currents)``,
  ``rate``, ``latency`` — honoured), :class:`SampledSensor`; :class:`NoisySensor`, :class:`HallSensor`,
  :class:`IdealSensor` (and the IMU sensors above) implement it.
"""

from .absolute import ArrayCalibration, CalibratedEstimator, Wells, calibrate_array_absolute, detent_wells, refined_wells
from .array import SensorArray, candidate_positions, coil_collisions, fibonacci_directions, radial_frames
from .calibration import Calibration, calibrate, field_gradient
from .estimate import Estimate, Estimator, super_fibonacci
from .figures import figure_layout
from .field import CoilField, FieldTable, KnownField, axial_field_table, rotor_field
from .iron import CoreField, IronCoilField, IronFieldTable, core_response, iron_fields
from .model import FieldModel, field_model
from .imu import FusedSensor, Imu, ImuSensor, Mekf, triad
from .parts import BMI270_BMM150, TMAG5273A2, ImuPart, MagnetometerPart
from .placement import Accuracy, Placement, accuracy, default_array, greedy_placement, smallest_eigenvalue
from .readings import actual_currents, sense, true_field
from .sensor_errors import SensorErrors
from .sensor import HallSensor, IdealSensor, NoisySensor, OrientationSensor, SampledSensor
from .symmetry import MarkerEffect, marked_design, marker_effect, symmetry_group

__all__ = [
    "ArrayCalibration", "CalibratedEstimator", "Wells", "calibrate_array_absolute", "detent_wells", "refined_wells", "Accuracy", "BMI270_BMM150", "Calibration", "CoilField", "CoreField", "IronCoilField", "IronFieldTable",
    "core_response", "iron_fields", "Estimate", "Estimator", "FieldModel", "FieldTable", "FusedSensor", "HallSensor",
    "IdealSensor", "Imu", "ImuPart", "ImuSensor", "KnownField", "MagnetometerPart", "MarkerEffect", "Mekf", "NoisySensor",
    "OrientationSensor", "Placement", "SampledSensor", "SensorErrors",
    "SensorArray", "TMAG5273A2", "accuracy", "actual_currents", "axial_field_table", "calibrate", "field_gradient", "candidate_positions",
    "coil_collisions", "default_array", "fibonacci_directions", "field_model", "figure_layout", "greedy_placement", "marked_design", "marker_effect",
    "radial_frames", "rotor_field", "sense", "smallest_eigenvalue", "super_fibonacci", "symmetry_group",
    "triad", "true_field",
]
