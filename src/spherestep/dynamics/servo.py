"""The servo loop in simulation: sensor → observer → controller → allocation → coil electrics → rigid rotor.

Every control period ``h = 1/rate`` (1 kHz by default):

1. the sensor (:class:`OrientationSensor`) may deliver a measurement; the observer
   (:class:`~spherestep.control.Observer`) corrects its estimate with it;
2. the controller (:class:`~spherestep.control.GeometricPD`) turns the estimate and the trajectory's
   ``(R_d, ω_d, α_d)`` into a torque command;
3. the allocation (:func:`~spherestep.control.allocate_matrix`) turns it into coil current references at the
   *estimated* orientation, using the model's ``K(R̂)`` and bias (out of reach: the closest reachable torque);
4. the coils (:class:`~spherestep.dynamics.electrics.CoilDrive`) follow the references through their current
   loops for the period, against the back-EMF ``K(R)·ω/I_n`` of the true motion;
5. the rotor (:class:`~spherestep.dynamics.Rotor`, fourth-order Lie-group integrator, one step per period)
   moves under the model's torque at the period's mean coil currents;
6. the observer predicts the next period with the torque the allocation promised.

The torque model is any :class:`~spherestep.statics.TorqueModel` (the magnets' torque map, the iron model);
the controller uses the same model as the plant (no model error) unless ``controller_model`` is given.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .. import so3
from ..control import DriveLimits, GeometricPD, Observer, Trajectory, allocate_matrix
from ..control.controller import CONTROL_RATE
from ..errors import bad_value
from ..statics import TorqueModel
from .._threads import single_blas_thread
from ..units import in_radians
from .electrics import CoilDrive
from .rotor import Rotor

HOLD_TOLERANCE = math.radians(0.05)


@runtime_checkable
class OrientationSensor(Protocol):
    """Anything that measures the rotor's orientation: ``measure(t, R_true, currents)`` returns a new estimate
    ``(3, 3)`` when one is due at time ``t`` (s), else ``None``; ``latency`` (s) is how old a delivered
    estimate is. ``currents`` (per unit) is what a magnetometer-based estimator needs to remove the coils'
    own field."""

    latency: float

    def measure(self, t: float, R_true: np.ndarray, currents: np.ndarray) -> np.ndarray | None: ...


class NoisySensor:
    """An orientation sensor: samples the true orientation every ``1/rate`` s, turns it by a random rotation
    vector with independent N(0, ``noise``²) components (rad), and delivers it ``latency`` s later."""

    def __init__(self, noise: float = 0.0, *, rate: float = CONTROL_RATE, latency: float = 0.0,
                 rng: np.random.Generator | int | None = None):
        if not (isinstance(noise, (int, float)) and math.isfinite(noise) and noise >= 0):
            raise bad_value("noise", "a non-negative angle in radians", noise)
        if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
            raise bad_value("rate", "a positive sampling rate in Hz", rate)
        if not (isinstance(latency, (int, float)) and math.isfinite(latency) and latency >= 0):
            raise bad_value("latency", "a non-negative delay in seconds", latency)
        self.noise, self.rate, self.latency = float(noise), float(rate), float(latency)
        self.rng = np.random.default_rng(rng)
        self._next = 0.0
        self._queue: deque = deque()

    def measure(self, t: float, R_true: np.ndarray, currents: np.ndarray) -> np.ndarray | None:
        if t >= self._next - 1e-12:
            self._queue.append((t + self.latency, so3.exp(self.rng.normal(0.0, self.noise, 3)) @ R_true))
            self._next += 1.0 / self.rate
        out = None
        while self._queue and self._queue[0][0] <= t + 1e-12:
            out = self._queue.popleft()[1]
        return out


@dataclass(frozen=True)
class ServoRun:
    """A closed-loop run, sampled once per control period: ``times (T,)`` s; ``orientations``, ``estimates`` and
    ``targets`` ``(T, 3, 3)``; ``angular_velocity (T, 3)`` rad/s; ``currents`` and ``references`` ``(T, N)`` (A,
    mean over each period and commanded); ``voltages (T, N)`` V (mean); ``power (T,)`` W drawn from the supply
    ``Σ v i`` (mean over each period); ``copper_power (T,)`` W ``Σ R i²``; ``torque_command (T, 3)`` N·m;
    ``reachable (T,)`` whether the allocation met the command; ``motion_time`` the trajectory's duration (s)."""

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

    @property
    def tracking_error(self) -> np.ndarray:
        """Park distance (rad) between the rotor and the trajectory, per period."""
        return so3.distance(self.orientations, self.targets)

    @property
    def final_error(self) -> float:
        """Tracking error (rad) at the end of the run."""
        return float(self.tracking_error[-1])

    def arrival_time(self, tolerance: float = HOLD_TOLERANCE) -> float:
        """First time (s) after which the rotor stays within ``tolerance`` (rad) of the trajectory's end
        (``inf`` if it is not there at the end)."""
        err = so3.distance(self.orientations, self.targets[-1])
        outside = np.flatnonzero(err > tolerance)
        if len(outside) == 0:
            return float(self.times[0])
        if outside[-1] == len(err) - 1:
            return math.inf
        return float(self.times[outside[-1] + 1])

    def summary(self, tolerance: float = HOLD_TOLERANCE) -> dict:
        """Time to arrive within ``tolerance``, the motion's duration, final and maximum tracking errors
        (degrees), peak and mean supply power and mean copper power (W), the share of periods whose torque
        command was within reach."""
        err = np.degrees(self.tracking_error)
        return {"arrival_time_s": self.arrival_time(tolerance), "motion_time_s": self.motion_time,
                "simulated_s": float(self.times[-1]), "final_error_deg": float(err[-1]),
                "max_tracking_error_deg": float(err.max()), "peak_power_W": float(self.power.max()),
                "mean_power_W": float(self.power.mean()), "mean_copper_power_W": float(self.copper_power.mean()),
                "peak_current_A": float(np.abs(self.currents).max()),
                "reachable_fraction": float(self.reachable.mean())}

    def to_dict(self, degrees: bool = True) -> dict:
        """The :meth:`summary` (angles in degrees; ``degrees=False`` gives radians)."""
        return self.summary() if degrees else in_radians(self.summary())


@single_blas_thread
def simulate_servo(design, trajectory: Trajectory, model: TorqueModel | None = None, *,
                   limits: DriveLimits | None = None, rotor: Rotor | None = None,
                   controller: GeometricPD | None = None, sensor: OrientationSensor | None = None,
                   drive: CoilDrive | None = None, observer_bandwidth: float | None = None,
                   rate: float = CONTROL_RATE, settle: float = 0.5, start=None,
                   controller_model: TorqueModel | None = None) -> ServoRun:
    """Run the servo loop of the module along ``trajectory`` and ``settle`` s beyond its end.

    ``model`` (default: the design's magnets' torque map) is the plant; ``limits`` the drive (default 24 V /
    100 W); ``rotor`` default :meth:`Rotor.from_design` (no damping); ``controller`` default
    :class:`GeometricPD` at ``rate``; ``sensor`` default a noiseless sensor at ``rate``; ``drive`` default
    :class:`CoilDrive` on ``limits``; ``start`` the true initial orientation (default the trajectory's start),
    the rotor at rest; the observer starts from the sensor's first measurement (the trajectory's start until
    one arrives).
    """
    if model is None:
        from ..magnetics import torque_map

        model = torque_map(design)
    if not isinstance(model, TorqueModel):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    if not isinstance(trajectory, Trajectory):
        raise bad_value("trajectory", "a spherestep.control.Trajectory", type(trajectory).__name__)
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
        raise bad_value("rate", "a positive control rate in Hz", rate)
    if not (isinstance(settle, (int, float)) and math.isfinite(settle) and settle >= 0):
        raise bad_value("settle", "a non-negative time in seconds", settle)
    limits = DriveLimits() if limits is None else limits
    drive = CoilDrive(limits) if drive is None else drive
    if drive.limits != limits:
        raise bad_value("drive", "a CoilDrive on the same limits as `limits`", drive.limits)
    rotor = Rotor.from_design(design) if rotor is None else rotor
    controller = GeometricPD(rotor.inertia, rate=rate, damping=rotor.damping) if controller is None else controller
    sensor = NoisySensor(rate=rate) if sensor is None else sensor
    if not isinstance(sensor, OrientationSensor):
        raise bad_value("sensor", "an object with measure(t, R_true, currents) and latency", type(sensor).__name__)
    ctrl_model = model if controller_model is None else controller_model
    h = 1.0 / rate
    sensor_rate = getattr(sensor, "rate", rate)
    observer = Observer(trajectory.start, inertia=rotor.inertia, sensor_period=1.0 / sensor_rate,
                        **({} if observer_bandwidth is None else {"bandwidth": observer_bandwidth}))
    N, In = model.coil_count, limits.nominal_current
    R = trajectory.start.copy() if start is None else so3.as_rotations(start, "start").copy()
    w = np.zeros(3)
    i = np.zeros(N)
    integral = np.zeros(N)
    lam = None
    zeros = np.zeros(N)
    steps = int(math.ceil((trajectory.duration + settle) * rate - 1e-9)) + 1
    Rd_all, wd_all, ad_all = trajectory.sample(np.arange(steps) * h)
    rec = {k: [] for k in ("R", "Rh", "w", "i", "iref", "v", "p", "pc", "tau", "ok")}
    measured = False
    probe = so3.random(8, 0)  # a model with no torque at zero current anywhere needs no bias per period
    biased = bool(np.any(np.asarray(ctrl_model.torque(probe, np.zeros((8, N)))) != 0))
    for n in range(steps):
        t = n * h
        c_now = i / In
        meas = sensor.measure(t, R, c_now)
        if meas is not None and not measured:  # the observer starts from the first measurement
            observer.R, measured = so3.as_rotations(meas).copy(), True
        elif meas is not None:
            observer.correct(meas, t - sensor.latency)
        rec["Rh"].append(observer.R)
        tau_cmd = controller.torque(observer.R, observer.w, Rd_all[n], wd_all[n], ad_all[n])
        K_hat = np.asarray(ctrl_model.torque_matrix(observer.R), dtype=float)
        bias = np.asarray(ctrl_model.torque(observer.R, zeros), dtype=float) if biased else None
        alloc, lam = allocate_matrix(K_hat, tau_cmd, limits, bias=bias, failed=ctrl_model.failed, lam0=lam)
        i_ref = alloc.currents * In
        K_true = np.asarray(model.torque_matrix(R), dtype=float)
        emf = (w @ K_true) / In
        i, integral, i_mean, v_mean, energy = drive.run(i, integral, i_ref, emf, h)
        c_mean = i_mean / In
        rec["R"].append(R)
        rec["w"].append(w)
        R, w, _ = rotor.step(R[None], w[None], lambda Rb, c=c_mean[None]: model.torque(Rb, c), h)
        R, w = R[0], w[0]
        observer.predict(alloc.torque - rotor.damping * observer.w, h)
        rec["i"].append(i_mean)
        rec["iref"].append(i_ref)
        rec["v"].append(v_mean)
        rec["p"].append(energy / h)
        rec["pc"].append(limits.resistance * float(i_mean @ i_mean))
        rec["tau"].append(tau_cmd)
        rec["ok"].append(alloc.reachable)
    times = np.arange(steps) * h
    return ServoRun(times, np.array(rec["R"]), np.array(rec["Rh"]), Rd_all, np.array(rec["w"]), np.array(rec["i"]),
                    np.array(rec["iref"]), np.array(rec["v"]), np.array(rec["p"]), np.array(rec["pc"]),
                    np.array(rec["tau"]), np.array(rec["ok"]), float(trajectory.duration))


def hold(design, R_target, model: TorqueModel | None = None, *, duration: float = 1.0, start=None,
         **kwargs) -> ServoRun:
    """Hold the rotor at ``R_target`` for ``duration`` s (from ``start``, default the target itself):
    :func:`simulate_servo` along a zero-length trajectory."""
    R_target = so3.as_rotations(R_target, "R_target")
    trajectory = Trajectory.turn(R_target, [0.0, 0.0, 1.0], 0.0, 1.0)
    return simulate_servo(design, trajectory, model, settle=duration, start=start, **kwargs)
