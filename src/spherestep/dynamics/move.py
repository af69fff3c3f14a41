"""One turn driven one way, with its files: what ``spherestep move`` runs.

:func:`drive_turn` turns the rotor by ``angle`` about ``axis`` from the stepper state nearest the identity with
``mode`` ``"servo"`` (:func:`~spherestep.control.plan_turn` and :func:`~.servo.simulate_servo`; ``duration``
sets the turn's time as a triangle profile of acceleration ``4θ/T²``, else the fastest turn within the
guaranteed torque), ``"ramped"`` (relay steps at the pull-out rate, :mod:`.ramped`) or ``"settled"`` (today's
relay stepping, :func:`~.simulate.simulate` with :func:`~.tuning.tune`). :meth:`Move.write` writes the
trajectory (CSV), the coil currents (CSV, A), the electrical power (CSV, W), a plot and a JSON summary.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import so3
from ..atomic import write_text
from ..control import DriveLimits, Trajectory, plan_turn
from ..errors import bad_value
from .rotor import Rotor

MODES = ("servo", "ramped", "settled")


@dataclass(frozen=True)
class Move:
    """A driven turn: ``mode``; per sample ``times (T,)`` s, ``orientations`` and ``targets`` ``(T, 3, 3)``,
    coil ``currents (T, N)`` (A), electrical ``power (T,)`` (W); ``summary`` (JSON-ready, degrees)."""

    mode: str
    times: np.ndarray
    orientations: np.ndarray
    targets: np.ndarray
    currents: np.ndarray
    power: np.ndarray
    summary: dict

    @property
    def errors(self) -> np.ndarray:
        """Park distance (rad) from the rotor to its target, per sample."""
        return so3.distance(self.orientations, self.targets)

    def trajectory_csv(self) -> str:
        """``t_s``, rotor quaternion ``qw…qz`` (scalar first), target quaternion, error (degrees)."""
        from scipy.spatial.transform import Rotation

        q = Rotation.from_matrix(self.orientations).as_quat(scalar_first=True)
        qt = Rotation.from_matrix(self.targets).as_quat(scalar_first=True)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["t_s", "qw", "qx", "qy", "qz", "target_qw", "target_qx", "target_qy", "target_qz", "error_deg"])
        for row in zip(self.times, q, qt, np.degrees(self.errors)):
            w.writerow([f"{row[0]:.6f}", *(f"{x:.12f}" for x in row[1]), *(f"{x:.12f}" for x in row[2]),
                        f"{row[3]:.6f}"])
        return buf.getvalue()

    def currents_csv(self) -> str:
        """``t_s`` and one column per coil, ``coil_k_A``."""
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["t_s"] + [f"coil_{k}_A" for k in range(self.currents.shape[1])])
        for t, c in zip(self.times, self.currents):
            w.writerow([f"{t:.6f}", *(f"{x:.6f}" for x in c)])
        return buf.getvalue()

    def power_csv(self) -> str:
        """``t_s, power_W``."""
        return "t_s,power_W\n" + "".join(f"{t:.6f},{p:.6f}\n" for t, p in zip(self.times, self.power))

    def figure(self):
        """:func:`figure_drive` of this move."""
        return figure_drive(self.times, self.errors, self.currents, self.power,
                            f"{self.mode}: {self.summary['angle_deg']:g}° turn, time {self.summary['time_s']:.3g} s, "
                            f"final error {self.summary['final_error_deg']:.3g}°")

    def write(self, out: str | Path) -> list[Path]:
        """``trajectory.csv``, ``currents.csv``, ``power.csv``, ``move.png`` and ``move.json`` into ``out``
        (created), each written atomically; returns the paths."""
        from ..atomic import atomic_path

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        paths = [write_text(out / "trajectory.csv", self.trajectory_csv()),
                 write_text(out / "currents.csv", self.currents_csv()),
                 write_text(out / "power.csv", self.power_csv())]
        with atomic_path(out / "move.png") as tmp:
            self.figure().savefig(tmp, dpi=120, format="png")
        paths.append(out / "move.png")
        paths.append(write_text(out / "move.json", json.dumps(self.summary, indent=1)))
        return paths


def figure_drive(times, errors, currents, power, title: str = ""):
    """Error to the target (degrees, log scale; ``errors`` in rad), coil currents (A) and electrical power (W)
    against time (s): the figure of a driven run (``spherestep move``, the report's servo run)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(9, 7.5), layout="constrained")
    ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
    ax1.semilogy(times, np.maximum(np.degrees(errors), 1e-5), color="C0")
    ax1.set_ylabel("error to target (°)")
    ax1.set_title(title)
    ax1.grid(alpha=0.3, which="both")
    ax2.plot(times, currents, lw=0.7)
    ax2.set_ylabel("coil currents (A)")
    ax2.grid(alpha=0.3)
    ax3.plot(times, power, color="C3", lw=0.8)
    ax3.set_ylabel("electrical power (W)")
    ax3.set_xlabel("time (s)")
    ax3.grid(alpha=0.3)
    return fig


SENSORS = ("ideal", "hall", "imu")


def drive_turn(design, axis, angle: float, *, mode: str = "servo", duration: float | None = None,
               sensor_noise: float = 0.0, sensor: str = "ideal", model=None, limits: DriveLimits | None = None,
               seed: int = 0) -> Move:
    """Drive a turn of ``angle`` rad about ``axis`` (fixed frame) with ``mode`` (see the module); ``duration``
    (s) only for the servo (default: the fastest turn within the guaranteed torque). The servo's orientation
    comes from ``sensor``: ``"ideal"`` (the true orientation turned by noise of σ ``sensor_noise`` rad),
    ``"hall"`` (the stator's magnetometer array and its estimator, :class:`spherestep.sensing.HallSensor`, with
    the coils' field subtracted at a 1 % current error) or ``"imu"`` (a gyro, accelerometer and magnetometer
    in the rotor, :class:`spherestep.sensing.ImuSensor`), both tracking from the known start."""
    from ..commutation import turn

    if mode not in MODES:
        raise bad_value("mode", f"one of {', '.join(MODES)}", mode)
    if duration is not None and mode != "servo":
        raise bad_value("duration", "given only for the servo (relay modes run at their own pace)", duration)
    if duration is not None and not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise bad_value("duration", "a positive time in seconds", duration)
    if not (isinstance(sensor_noise, (int, float)) and math.isfinite(sensor_noise) and sensor_noise >= 0):
        raise bad_value("sensor_noise", "a non-negative angle in radians", sensor_noise)
    if sensor not in SENSORS:
        raise bad_value("sensor", f"one of {', '.join(SENSORS)}", sensor)
    if sensor != "ideal" and sensor_noise:
        raise bad_value("sensor_noise", "0 with the hall and imu sensors (their noise is the part's own)",
                        sensor_noise)
    if model is None:
        from ..magnetics import torque_map

        model = torque_map(design)
    limits = DriveLimits() if limits is None else limits
    plan = turn(design, axis, math.degrees(angle))
    n = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    start, end = plan.targets[0], plan.targets[-1]
    base = {"mode": mode, "axis": n.tolist(), "angle_deg": math.degrees(angle)}
    In = limits.nominal_current
    if mode == "servo":
        from .servo import simulate_servo

        rotor = Rotor.from_design(design)
        if duration is None:
            traj = plan_turn(model, start, n, angle, rotor.inertia, limits)
        else:
            traj = Trajectory.turn(start, n, angle, 4.0 * abs(angle) / duration ** 2)
        run = simulate_servo(design, traj, model, limits=limits, rotor=rotor,
                             sensor=_sensor(design, sensor, sensor_noise, traj.start, seed), settle=0.3)
        s = run.summary()
        summary = base | {"time_s": s["arrival_time_s"], "final_error_deg": math.degrees(
            float(so3.distance(run.orientations[-1], end)))} | s | {
            "sensor": sensor, "sensor_noise_deg": math.degrees(sensor_noise),
            "sensor_error_max_deg": math.degrees(float(so3.distance(run.estimates, run.orientations).max()))}
        return Move(mode, run.times, run.orientations, run.targets, run.currents, run.power, summary)
    from .tuning import tune

    tuning = tune(design, model)
    if mode == "ramped":
        from .ramped import pull_out_rate

        pull = pull_out_rate(design, plan, model, rotor=tuning.rotor, dt=tuning.dt)
        if pull.run is None:
            raise bad_value("axis", "a turn that ramped relay stepping can drive without losing steps",
                            f"steps lost at every rate tried ({[r for r, _ in pull.tried]} steps/s)")
        run = pull.run
        idx = np.clip(np.searchsorted(run.step_times, run.times, side="right"), 0, len(plan.targets) - 1)
        summary = base | run.summary() | {"time_s": run.arrival_time(),
                                          "pull_out_rate_steps_per_s": pull.rate}
        return Move(mode, run.times, run.orientations, plan.targets[idx], run.currents * In, run.power, summary)
    from .simulate import simulate

    sim = simulate(design, plan, model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    idx = np.clip(np.floor(sim.times / tuning.dwell + 1e-9).astype(int) + 1, 0, len(plan.targets) - 1)
    power = limits.supply_voltage * In * np.count_nonzero(sim.active_coils, axis=1)
    summary = base | sim.summary() | {"time_s": float(sim.times[-1]), "final_error_deg": math.degrees(
        float(so3.distance(sim.settled[-1], end))), "peak_power_W": float(power.max()),
        "mean_power_W": float(power.mean()), "dwell_s": tuning.dwell}
    return Move(mode, sim.times, sim.orientations, plan.targets[idx], sim.active_coils * In, power, summary)


def _sensor(design, kind: str, noise: float, start, seed: int):
    """The servo's orientation sensor of kind ``kind`` (see :func:`drive_turn`), at the control rate."""
    from .servo import CONTROL_RATE, NoisySensor

    if kind == "ideal":
        return NoisySensor(noise, rng=seed)
    from ..sensing import HallSensor, ImuSensor, LoopSensor

    inner = HallSensor(design, current_error=0.01, seed=seed) if kind == "hall" else \
        ImuSensor(design, 1.0 / CONTROL_RATE, seed=seed)
    return LoopSensor(inner, rate=CONTROL_RATE, start=start)
