"""One driven turn's result, whatever drove it: :class:`DriveResult` (arrays, numbers, per-mode details).

Angles are radians inside; :meth:`DriveResult.to_dict` gives degrees for people (``degrees=True``) and is
JSON-ready with no ``inf``/``NaN``: an arrival that never happened is ``null`` beside the reason
(``arrival_note``). :meth:`DriveResult.write` writes the files of ``spherestep move``: ``trajectory.csv`` (time,
rotor and target quaternions, error in degrees), ``currents.csv`` (A per coil), ``power.csv`` (W), ``move.png``
(:func:`figure_drive`) and ``move.json`` (the :meth:`~DriveResult.to_dict`).
"""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .. import so3


def _angle(degrees: bool):
    return ("deg", math.degrees) if degrees else ("rad", float)


ANGLE = "angle"
"""A key's conversion in a :data:`Keys` table: an angle, written ``<key>_deg`` (or ``_rad``), None kept."""

Keys = tuple[tuple[str, str] | tuple[str, str, Callable[[Any], Any] | str], ...]
"""``(json key, attribute[, conversion])`` rows: the value as is, :data:`ANGLE`, or a function of the value."""


def keyed_dict(obj, keys: Keys, degrees: bool = True) -> dict:
    """The JSON-ready dict of ``obj`` by a :data:`Keys` table, in its order; angles in degrees (or radians)."""
    unit, conv = _angle(degrees)
    out = {}
    for key, name, *how in keys:
        value = getattr(obj, name)
        if how and how[0] == ANGLE:
            out[f"{key}_{unit}"] = None if value is None else conv(value)
        else:
            out[key] = how[0](value) if how else value
    return out


class _Details:
    """A mode's details: :meth:`to_dict` from the class's :attr:`KEYS` table (one shape for every mode)."""

    KEYS: ClassVar[Keys] = ()

    def to_dict(self, degrees: bool = True) -> dict:
        return keyed_dict(self, self.KEYS, degrees)


def _ms(seconds: float) -> float:
    return 1e3 * seconds


@dataclass(frozen=True)
class SettledDetails(_Details):
    """The paper's relay steps, each settled: ``steps``, ``dwell`` (s), the rotor's tuned ``damping``
    (N·m·s/rad), whether every step settled within ``plan_tolerance`` (rad) of the plan (``executed``) and how many
    did (``steps_settled_on_plan``, of ``steps``)."""

    steps: int
    dwell: float
    damping: float
    executed: bool
    steps_settled_on_plan: int
    plan_tolerance: float

    KEYS: ClassVar[Keys] = (("steps", "steps"), ("dwell_s", "dwell"), ("damping_N_m_s_per_rad", "damping"),
                            ("executed", "executed"), ("steps_settled_on_plan", "steps_settled_on_plan"),
                            ("plan_tolerance", "plan_tolerance", ANGLE))


@dataclass(frozen=True)
class RampedDetails(_Details):
    """The relay steps ramped: the ``pull_out_rate`` (steps/s; 0 when every rate lost a step, the run shown is then
    the slowest rate's), when the ``last_step`` was energised (s), and every cruise rate ``tried`` with whether it
    lost a step."""

    pull_out_rate: float
    last_step: float
    tried: tuple[tuple[float, bool], ...]

    KEYS: ClassVar[Keys] = (
        ("pull_out_rate_steps_per_s", "pull_out_rate"), ("last_step_s", "last_step"),
        ("tried", "tried", lambda tried: [{"rate_steps_per_s": r, "lost_a_step": lost} for r, lost in tried]))


@dataclass(frozen=True)
class ServoDetails(_Details):
    """The simulated servo: ``trajectory`` how its time was chosen (``"fastest"``: :func:`~spherestep.control.
    plan_turn`; ``"given"``: the caller's ``duration``; ``"fixed"``: ``plan_turn`` refused this model, the turn
    takes the fixed time, ``note`` says why), ``motion_time`` (s), the ``sensor`` and its ``sensor_noise`` and
    largest ``sensor_error`` (rad), the rotor's ``damping`` (N·m·s/rad), ``mean_copper_power`` (W),
    ``peak_current`` (A) and the ``reachable_fraction`` of periods whose torque command was met."""

    trajectory: str
    note: str
    motion_time: float
    sensor: str
    sensor_noise: float
    sensor_error: float
    damping: float
    mean_copper_power: float
    peak_current: float
    reachable_fraction: float

    KEYS: ClassVar[Keys] = (
        ("trajectory", "trajectory"), ("trajectory_note", "note"), ("motion_time_s", "motion_time"),
        ("sensor", "sensor"), ("sensor_noise", "sensor_noise", ANGLE), ("sensor_error_max", "sensor_error", ANGLE),
        ("damping_N_m_s_per_rad", "damping"), ("mean_copper_power_W", "mean_copper_power"),
        ("peak_current_A", "peak_current"), ("reachable_fraction", "reachable_fraction"))


@dataclass(frozen=True)
class HardwareDetails(_Details):
    """The servo on a coil controller (``port``) or the emulated motor: the loop's ``outcome`` (``"done"`` or the
    fault code) and ``message``, ``cycles``, achieved ``rate`` and requested ``loop_rate`` (Hz), ``missed``
    deadlines, whether the device acknowledged all off (``off_acknowledged``), ``trajectory``/``note``/
    ``motion_time`` as for the simulated servo, the ``log`` file, and ``truth``: whether the errors are measured
    against the emulated rotor (``True``) or the loop's own estimate (``False``, a real port). Power on hardware
    is the copper power ``R Σ i²`` of the commanded currents (nothing measures the supply). The loop's health
    (:class:`~spherestep.hardware.ServoReport`): ``cpu_mean``/``cpu_max`` s of host CPU per cycle, ``realtime``
    (it ran with real-time scheduling), ``time_scale`` the pace it followed the trajectory at in the end and
    ``slowed`` how often it halved rate and pace for missed deadlines, ``late_wakeups`` the deadlines missed
    while the loop slept with its work done (the OS woke it late), ``late_readings`` the cycles run on the law's
    prediction because the device's answer came too late, ``end_error`` rad of its last estimate;
    The end (:func:`~spherestep.drive.hardware.drive_on_hardware`): ``end`` ``"hold"`` (the servo holds the turn's
    end ``hold`` s, and ``final_error`` is the rotor at the hold's last row) or ``"park"`` (it moves on into the
    detent well nearest the turn's end, holds it ``hold`` s, every coil goes off and the rotor is watched for up
    to a second, ``rest_after`` s from the loop's last cycle to the last look: the result's rows after the loop's
    ``cycles``; it rests at the bottom of the well it was last in, ``at_rest`` when it stayed within 1° of it over
    the last 0.3 s, ``swing`` rad the farthest it was, and ``final_error`` is that pose against the predicted
    well; ``None`` fields when it was not watched). ``rest_offset`` rad: the predicted unpowered rest (hold: the
    detent well the rotor falls into from the hold's last row, reported, not judged; park: the well parked in)
    from the requested turn's end. ``held_error`` rad is the rotor at the loop's last cycle against what the servo
    held (the turn's end, or the well), ``drift_after_off`` rad how far it moved from there after the coils went
    off (0.15 s after with hold, at the last look with park; ``None`` on a port with hold)"""

    outcome: str
    message: str
    cycles: int
    rate: float
    loop_rate: float
    missed: int
    off_acknowledged: bool
    trajectory: str
    note: str
    motion_time: float
    log: str
    truth: bool
    cpu_mean: float = 0.0
    cpu_max: float = 0.0
    realtime: bool = False
    time_scale: float = 1.0
    slowed: int = 0
    end_error: float | None = None
    drift_after_off: float | None = None
    late_wakeups: int = 0
    late_readings: int = 0
    end: str = "hold"
    hold: float = 0.5
    held_error: float | None = None
    rest_offset: float | None = None
    rest_after: float | None = None
    at_rest: bool | None = None
    swing: float | None = None

    KEYS: ClassVar[Keys] = (
        ("outcome", "outcome"), ("message", "message"), ("cycles", "cycles"), ("rate_Hz", "rate"),
        ("loop_rate_Hz", "loop_rate"), ("missed", "missed"), ("cpu_per_cycle_ms", "cpu_mean", _ms),
        ("cpu_max_ms", "cpu_max", _ms), ("realtime", "realtime"), ("time_scale", "time_scale"), ("slowed", "slowed"),
        ("late_wakeups", "late_wakeups"), ("late_readings", "late_readings"), ("loop_end_error", "end_error", ANGLE), ("drift_after_off", "drift_after_off", ANGLE),
        ("end", "end"), ("hold_s", "hold"), ("held_error", "held_error", ANGLE),
        ("predicted_rest_from_target", "rest_offset", ANGLE),
        ("rest_after_s", "rest_after"), ("at_rest", "at_rest"),
        ("swing", "swing", ANGLE),
        ("off_acknowledged", "off_acknowledged"), ("trajectory", "trajectory"), ("trajectory_note", "note"),
        ("motion_time_s", "motion_time"), ("log", "log"),
        ("errors_against", "truth", lambda truth: "emulated rotor" if truth else "the loop's estimate"))


Details = SettledDetails | RampedDetails | ServoDetails | HardwareDetails


@dataclass(frozen=True)
class DriveResult:
    """A turn of ``angle`` rad about ``axis`` (unit, fixed frame) driven in ``mode`` (servo, ramped, settled) on
    ``backend`` (simulated, emulated, port) with the torque model labelled ``model``.

    Per sample: ``times (T,)`` s, ``orientations`` and ``targets`` ``(T, 3, 3)`` (the target of the energised step
    for relays, the trajectory for the servo), ``sensor_error (T,)`` rad (the loop's estimate against the rotor;
    zero for the open-loop relays), coil ``currents (T, N)`` A and electrical ``power (T,)`` W. Numbers: ``time``
    (s) to arrive for good (``inf`` if it never did, ``arrival_note`` says why), ``final_error`` to the turn's end
    and ``max_tracking_error`` to the target (rad), ``peak_power``/``mean_power`` (W), the ``tolerance`` (rad) the
    run is judged by, and the mode's ``details``."""

    mode: str
    backend: str
    model: str
    axis: np.ndarray
    angle: float
    times: np.ndarray
    orientations: np.ndarray
    targets: np.ndarray
    sensor_error: np.ndarray
    currents: np.ndarray
    power: np.ndarray
    time: float
    arrival_note: str
    final_error: float
    max_tracking_error: float
    peak_power: float
    mean_power: float
    tolerance: float
    details: Details

    @property
    def tracking_error(self) -> np.ndarray:
        """Park distance (rad) from the rotor to its target, per sample."""
        return so3.distance(self.orientations, self.targets)

    @property
    def arrived(self) -> bool:
        """The rotor arrived at the turn's end for good (``time`` is finite)."""
        return math.isfinite(self.time)

    @property
    def ok(self) -> bool:
        """Arrived, and the final error is within the tolerance: the only result that may be reported as done
        (:func:`spherestep.drive.judgement.judge_drive`)."""
        return self.judgement().ok

    def judgement(self):
        """The :class:`~spherestep.drive.judgement.Judgement` of this run (:func:`~spherestep.drive.judgement.judge_drive`)."""
        from .judgement import judge_drive

        return judge_drive(self)

    def verdict(self) -> str:
        """One line: why the run is not :attr:`ok` (empty when it is)."""
        return self.judgement().reason

    KEYS: ClassVar[Keys] = (
        ("mode", "mode"), ("backend", "backend"), ("model", "model"), ("axis", "axis", np.ndarray.tolist),
        ("angle", "angle", ANGLE), ("time_s", "time", lambda t: t if math.isfinite(t) else None),
        ("arrival_note", "arrival_note"), ("final_error", "final_error", ANGLE),
        ("max_tracking_error", "max_tracking_error", ANGLE), ("peak_power_W", "peak_power"),
        ("mean_power_W", "mean_power"), ("tolerance", "tolerance", ANGLE), ("within_tolerance", "ok"))

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready (no ``inf``/``NaN``): angles in degrees, or radians with ``degrees=False``; ``judgement`` the
        one-line reason the run is not ok ("" when it is)."""
        return {**keyed_dict(self, self.KEYS, degrees), "judgement": self.judgement().reason,
                "details": self.details.to_dict(degrees)}

    def summary_line(self) -> str:
        """The console line: mode, backend, model, turn, time, errors, power."""
        time = f"in {self.time:.3g} s" if self.arrived else "never arrived"
        return (f"{self.mode} ({self.backend}, model {self.model}): {math.degrees(self.angle):g}° about "
                f"({', '.join(f'{a:.3f}' for a in self.axis)}) {time}; final error "
                f"{math.degrees(self.final_error):.3g}°, max tracking error {math.degrees(self.max_tracking_error):.3g}°;"
                f" power peak {self.peak_power:.3g} W, mean {self.mean_power:.3g} W")

    def trajectory_csv(self) -> str:
        """``t_s``, rotor quaternion ``qw…qz`` (scalar first), target quaternion, error (degrees)."""
        q = so3.quaternion_rows(self.orientations)
        qt = so3.quaternion_rows(self.targets)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["t_s", *so3.QUATERNION_COLUMNS, *(f"target_{c}" for c in so3.QUATERNION_COLUMNS), "error_deg"])
        for row in zip(self.times, q, qt, np.degrees(self.tracking_error)):
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
        """:func:`figure_drive` of this run."""
        time = f"{self.time:.3g} s" if self.arrived else "never arrived"
        return figure_drive(self.times, self.tracking_error, self.currents, self.power,
                            f"{self.mode} ({self.model}): {math.degrees(self.angle):g}° turn, time {time}, final "
                            f"error {math.degrees(self.final_error):.3g}°")

    FILES = ("trajectory.csv", "currents.csv", "power.csv", "move.png", "move.json")

    def write(self, out: str | Path) -> list[Path]:
        """:attr:`FILES` into ``out`` (created), each written atomically; returns the paths."""
        from ..atomic import atomic_path, write_text

        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        paths = [write_text(out / "trajectory.csv", self.trajectory_csv()),
                 write_text(out / "currents.csv", self.currents_csv()),
                 write_text(out / "power.csv", self.power_csv())]
        with atomic_path(out / "move.png") as tmp:
            self.figure().savefig(tmp, dpi=120, format="png")
        paths.append(out / "move.png")
        paths.append(write_text(out / "move.json", json.dumps(self.to_dict(), indent=1, allow_nan=False)))
        return paths


def figure_drive(times, errors, currents, power, title: str = ""):
    """Error to the target (degrees, log scale; ``errors`` in rad), coil currents (A) and electrical power (W)
    against time (s): the figure of a driven run (``spherestep move``, the demo's servo run)."""
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
