"""The servo loop in simulation: sensor → the servo law → coil electrics → rigid rotor.

Every control period ``h = 1/rate`` (1 kHz by default) at ``t = n h``:

1. the sensor (:class:`~spherestep.sensing.OrientationSensor`) may deliver a measurement, ``latency`` s old;
2. the servo law (:class:`~spherestep.control.ServoLaw`: observer, geometric PD, the model's cached ``K(R̂)`` and
   bias, warm-started least-power allocation) turns it and the trajectory into per-unit current references;
3. the coils (:class:`~spherestep.dynamics.electrics.CoilDrive`) follow the references ``I_n c`` (A) through their
   current loops for the period, against the back-EMF ``K(R)·ω/I_n`` of the true motion;
4. the rotor (:class:`~spherestep.dynamics.Rotor`, fourth-order Lie-group integrator, one step per period)
   moves under the plant model's torque at the period's mean coil currents.

The torque model is any :class:`~spherestep.statics.TorqueModel` (the magnets' torque map, the iron model);
the controller uses the same model as the plant (no model error) unless ``controller_model`` is given.
A hold is this loop along :meth:`Trajectory.hold <spherestep.control.Trajectory.hold>`; :func:`hold` is that
call, kept as the simulation's name for it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..control import GeometricPD, ModelCache, ServoLaw, Trajectory
from ..electrics import DriveLimits
from ..control.controller import CONTROL_RATE
from ..errors import bad_value
from ..statics import TorqueModel, is_torque_model
from .._fast.threads import single_blas_thread
from .electrics import CoilDrive
from .rotor import Rotor

__all__ = ["CONTROL_RATE", "HOLD_TOLERANCE", "ServoRun", "ServoSummary", "hold", "simulate_servo"]

HOLD_TOLERANCE = math.radians(0.05)


@dataclass(frozen=True)
class ServoSummary:
    """What a :class:`ServoRun` achieved (radians and SI inside): ``arrival_time`` s, the first time after which
    the rotor stays within ``tolerance`` rad of the trajectory's end, or ``None`` with ``arrival_reason`` when
    it is not there at the end; ``motion_time`` (the trajectory's duration) and ``simulated`` s; ``final_error``
    and ``max_tracking_error`` rad; ``peak_power``, ``mean_power`` (supply) and ``mean_copper_power`` W;
    ``peak_current`` A; ``reachable_fraction`` the share of periods whose torque command was within reach."""

    arrival_time: float | None
    arrival_reason: str | None
    tolerance: float
    motion_time: float
    simulated: float
    final_error: float
    max_tracking_error: float
    peak_power: float
    mean_power: float
    mean_copper_power: float
    peak_current: float
    reachable_fraction: float

    def to_dict(self, degrees: bool = True) -> dict:
        """The summary with the keys of the JSON outputs (angles in degrees, ``degrees=False`` radians); an
        arrival that never happened is ``None`` with its ``arrival_reason``; no infinities or NaNs."""
        unit, f = ("deg", math.degrees) if degrees else ("rad", float)
        return {"arrival_time_s": self.arrival_time, "arrival_reason": self.arrival_reason,
                "motion_time_s": self.motion_time, "simulated_s": self.simulated,
                f"final_error_{unit}": f(self.final_error), f"max_tracking_error_{unit}": f(self.max_tracking_error),
                "peak_power_W": self.peak_power, "mean_power_W": self.mean_power,
                "mean_copper_power_W": self.mean_copper_power, "peak_current_A": self.peak_current,
                "reachable_fraction": self.reachable_fraction}


@dataclass(frozen=True)
class ServoRun:
    """A closed-loop run, sampled once per control period: ``times (T,)`` s; ``orientations``, ``estimates`` and
    ``targets`` ``(T, 3, 3)``; ``angular_velocity (T, 3)`` rad/s; ``currents`` and ``references`` ``(T, N)`` (A,
    mean over each period and commanded); ``voltages (T, N)`` V (mean); ``power (T,)`` W drawn from the supply
    ``Σ v i`` (mean over each period); ``copper_power (T,)`` W ``Σ R i²``; ``torque_command (T, 3)`` N·m;
    ``reachable (T,)`` whether the allocation met the command; ``motion_time`` the trajectory's duration (s);
    ``disturbance (T, 3)`` N·m the servo law's estimate ``d̂`` of the torque its model gets wrong."""

    times: np.ndarray
    orientations: np.ndarray
    estimates: np.ndarray
    targets: np.ndarray
    angular_velocity: np.ndarray
    currents: np.ndarray
    references: np.ndarray
    voltages: np.ndarray
    power: np.ndarray
    copper_power: np.ndarray
    torque_command: np.ndarray
    reachable: np.ndarray
    motion_time: float
    disturbance: np.ndarray | None = None

    @property
    def tracking_error(self) -> np.ndarray:
        """Park distance (rad) between the rotor and the trajectory, per period."""
        return so3.distance(self.orientations, self.targets)

    @property
    def final_error(self) -> float:
        """Tracking error (rad) at the end of the run."""
        return float(self.tracking_error[-1])

    def arrival_time(self, tolerance: float = HOLD_TOLERANCE) -> float | None:
        """First time (s) after which the rotor stays within ``tolerance`` (rad) of the trajectory's end
        (``None`` if it is not there at the end)."""
        err = so3.distance(self.orientations, self.targets[-1])
        outside = np.flatnonzero(err > tolerance)
        if len(outside) == 0:
            return float(self.times[0])
        if outside[-1] == len(err) - 1:
            return None
        return float(self.times[outside[-1] + 1])

    def summary(self, tolerance: float = HOLD_TOLERANCE) -> ServoSummary:
        """The :class:`ServoSummary` of the run, arrival judged within ``tolerance`` (rad)."""
        tolerance = checks.positive(tolerance, "tolerance")
        err = self.tracking_error
        arrival = self.arrival_time(tolerance)
        reason = None if arrival is not None else (
            f"not within {math.degrees(tolerance):g}° of the end at {float(self.times[-1]):.3g} s "
            f"(final error {math.degrees(float(err[-1])):.3g}°)")
        return ServoSummary(arrival, reason, tolerance, self.motion_time, float(self.times[-1]), float(err[-1]),
                            float(err.max()), float(self.power.max()), float(self.power.mean()),
                            float(self.copper_power.mean()), float(np.abs(self.currents).max()),
                            float(self.reachable.mean()))

    def to_dict(self, degrees: bool = True) -> dict:
        """The :meth:`summary` as a dict (angles in degrees; ``degrees=False`` gives radians)."""
        return self.summary().to_dict(degrees)


@single_blas_thread
def simulate_servo(design, trajectory: Trajectory, model: TorqueModel | None = None, *,
                   limits: DriveLimits | None = None, rotor: Rotor | None = None,
                   controller: GeometricPD | None = None, sensor=None,
                   drive: CoilDrive | None = None, observer_bandwidth: float | None = None,
                   rate: float = CONTROL_RATE, settle: float = 0.5, start=None,
                   controller_model: TorqueModel | None = None,
                   disturbance_bandwidth: float | None = None, motion_bandwidth: float | None = None
                   ) -> ServoRun:
    """Run the servo loop of the module along ``trajectory`` and ``settle`` s beyond its end.

    ``model`` (default: the design's magnets' torque map) is the plant; ``limits`` the drive (default 24 V /
    100 W); ``rotor`` default :meth:`Rotor.from_design` (no damping); ``controller`` default
    :class:`GeometricPD` at ``rate``; ``sensor`` a :class:`~spherestep.sensing.OrientationSensor` (default a
    noiseless :class:`~spherestep.sensing.NoisySensor` at ``rate``); ``drive`` default
    :class:`CoilDrive` on ``limits``; ``start`` the true initial orientation (default the trajectory's start),
    the rotor at rest; the observer starts from the sensor's first measurement (the trajectory's start until
    one arrives). ``controller_model`` the servo law's belief (default ``model``: no model error);
    ``disturbance_bandwidth`` and ``motion_bandwidth`` rad/s its disturbance estimate at rest and in motion
    (default on, ``disturbance_bandwidth=0`` off; :class:`ServoLaw`).
    """
    if model is None:
        from ..magnetics import torque_map

        model = torque_map(design)
    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    if not isinstance(trajectory, Trajectory):
        raise bad_value("trajectory", "a spherestep.control.Trajectory", type(trajectory).__name__)
    rate = checks.positive(rate, "rate", "a positive control rate in Hz")
    settle = checks.non_negative(settle, "settle", "a non-negative time in seconds")
    limits = DriveLimits() if limits is None else limits
    drive = CoilDrive(limits) if drive is None else drive
    if drive.limits != limits:
        raise bad_value("drive", "a CoilDrive on the same limits as `limits`", drive.limits)
    rotor = Rotor.from_design(design) if rotor is None else rotor
    controller = GeometricPD(rotor.inertia, rate=rate, damping=rotor.damping) if controller is None else controller
    from ..sensing.sensor import NoisySensor, OrientationSensor  # here: the sensing room's import is heavy

    sensor = NoisySensor(rate=rate) if sensor is None else sensor
    if not isinstance(sensor, OrientationSensor):
        raise bad_value("sensor", "a spherestep.sensing.OrientationSensor (measure(t, R_true, currents), rate, "
                        "latency)", type(sensor).__name__)
    law = ServoLaw(model if controller_model is None else controller_model, trajectory, controller, limits=limits,
                   sensor_rate=sensor.rate, observer_bandwidth=observer_bandwidth,
                   disturbance_bandwidth=disturbance_bandwidth, motion_bandwidth=motion_bandwidth)
    h = 1.0 / rate
    N = model.coil_count
    plant = ModelCache(model, reuse=0.0)  # the true K(R) and bias, exact; compiled for a packed affine model
    R = trajectory.start.copy() if start is None else so3.as_rotations(start, "start").copy()
    w = np.zeros(3)
    i = np.zeros(N)
    integral = np.zeros(N)
    steps = int(math.ceil((trajectory.duration + settle) * rate - 1e-9)) + 1
    times = np.arange(steps) * h
    Rd_all = trajectory.sample(times)[0]
    rec = {k: [] for k in ("R", "Rh", "w", "i", "iref", "v", "p", "pc", "tau", "ok", "d")}
    latency = sensor.latency
    for n in range(steps):
        t = n * h
        meas = sensor.measure(t, R, limits.per_unit(i))
        cmd = law.step(t, meas, t - latency)
        i_ref = law.amperes(cmd.currents)
        K_true, b_true = plant.at(R) if plant.compiled else (np.asarray(model.torque_matrix(R), dtype=float), None)
        emf = limits.back_emf(w @ K_true)
        i, integral, i_mean, v_mean, energy = drive.run(i, integral, i_ref, emf, h)
        c_mean = limits.per_unit(i_mean)
        rec["Rh"].append(cmd.estimate)
        rec["R"].append(R)
        rec["w"].append(w)
        if plant.compiled:  # τ = b(R) + K(R) c at each stage, the start's from the K and b above
            R, w, _ = rotor.step(R, w, lambda Rb, c=c_mean: _affine_torque(plant, Rb, c), h, b_true + K_true @ c_mean)
        else:
            R, w, _ = rotor.step(R[None], w[None], lambda Rb, c=c_mean[None]: model.torque(Rb, c), h)
            R, w = R[0], w[0]
        rec["i"].append(i_mean)
        rec["iref"].append(i_ref)
        rec["v"].append(v_mean)
        rec["p"].append(energy / h)
        rec["pc"].append(limits.resistance * float(i_mean @ i_mean))
        rec["tau"].append(cmd.requested)
        rec["ok"].append(cmd.reachable)
        rec["d"].append(cmd.disturbance)
    return ServoRun(times, np.array(rec["R"]), np.array(rec["Rh"]), Rd_all, np.array(rec["w"]), np.array(rec["i"]),
                    np.array(rec["iref"]), np.array(rec["v"]), np.array(rec["p"]), np.array(rec["pc"]),
                    np.array(rec["tau"]), np.array(rec["ok"]), float(trajectory.duration), np.array(rec["d"]))


def _affine_torque(plant: ModelCache, R: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``b(R) + K(R) c`` (N·m) of an affine model through its exact (``reuse = 0``) :class:`ModelCache`."""
    K, b = plant.at(R)
    return b + K @ c


def hold(design, R_target, model: TorqueModel | None = None, *, duration: float = 1.0, start=None,
         **kwargs) -> ServoRun:
    """Hold the rotor at ``R_target`` for ``duration`` s (from ``start``, default the target itself):
    :func:`simulate_servo` along :meth:`Trajectory.hold <spherestep.control.Trajectory.hold>`."""
    return simulate_servo(design, Trajectory.hold(R_target), model, settle=duration, start=start, **kwargs)
