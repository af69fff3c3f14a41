"""One servo session on a coil controller — a real board on a serial port, or the emulated motor on a
pseudo-terminal — the application assembled for a design from the rooms above: the hardware room's field tracker,
link, loop and emulator, the sensing room's estimator and the control room's servo law.

:func:`servo_session` is what ``spherestep move ... --port DEV`` (or ``--emulate``) runs, through
:func:`move_on_hardware` and :func:`spherestep.drive.drive_turn`: it builds the sensing room's
:class:`~spherestep.sensing.Estimator` for the design's magnetometer array and the control room's
:class:`~spherestep.control.ServoLaw` (the simulation's law, allocating within
:func:`spherestep.hardware.wire_limits`), opens the link with protocol version 2, runs
:func:`spherestep.hardware.run_servo` and always ends with every coil off. With ``emulate`` it also
serves :class:`~spherestep.hardware.motor_emulator.MotorPty` and returns the emulated motor's
:class:`~spherestep.hardware.motor_emulator.Truth` at the end, so the result can be judged against the truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..control import GeometricPD, ServoLaw, Trajectory
from ..errors import ComputationError, bad_value
from ..hardware import LOOP_RATE, FieldTracker, ServoReport, run_servo, wire_limits
from .connect import EMULATED_DAMPING, connect, session_kind

DELAY = 1  # control periods: the currents computed in a cycle are driven at the next cycle's start
# The observer's bandwidth on hardware is the loop's rate in rad/s, ω_o = 1/h: its gains are then l₁ = 1, l₂ h = 1
# (deadbeat: the magnetometer array's estimate is nearly noise-free, so the estimate follows each measurement and
# ω̂ is the model's prediction corrected by the whole residual). Measured on the emulated 360° turn in lockstep at
# 200 Hz: max tracking error 0.31° and final 0.019° (120 rad/s: 0.44° and 0.016°; the former difference filter:
# 0.34° and 0.043°). The iron prototype at 500 Hz (the emulator's 4 kHz current loop, 2026-11-25): the 360° turn
# about (1, 0.5, 2) from a detent well in lockstep tracks within 0.47° and parks 0.006° off; a hold within 0.004°.
# The law's lead (ServoLaw(lead=...)): a command computed from the reading at t takes effect one period later (the
# device stamps a reading when it applies the frame's currents, so the link's latency separates the next frame the
# same) and acts over the period after: its middle, 1.5 periods. Measured in lockstep at 500 Hz on the iron
# prototype's fastest 360° turn about (1, 0.5, 2) (1.475 s; 2026-11-28): max tracking 0.866° without a lead, 0.397°
# at 1 period, 0.314° at 1.5, 0.337° at 2; held-out turns, 270° about (-1, 2, 0.5) and 180° about (0.3, -1, 1):
# 0.441° and 0.490° at 1 period, 0.323° and 0.299° at 1.5 (benchmarks/bench_emulated_tracking.py).
LEAD = 1.5
QEMU_RATE = 100.0  # Hz: the servo's default rate on the firmware in QEMU (the DRIVE round trip in drive.connect)
SETTLE = 0.5  # s the loop runs on after the trajectory's end
# After the coils go off the rotor is watched until it rests: sampled OFF_FIRST s after and then every REST_EVERY s,
# at rest once it moved at most REST_MOTION in each of two intervals in a row (0.2°/s: an air rotor coasting on the
# speed the hold left it, ~0.16°/s, counts as at rest), for at most REST_LIMIT s (an unpowered iron rotor released
# off a detent well tumbles for seconds: the emulated rotor's damping decays its swing over 2J/c ≈ 14 s).
OFF_FIRST, REST_EVERY, REST_MOTION, REST_LIMIT = 0.15, 0.05, math.radians(0.01), 1.0
# A rotor still swinging at the limit rests at the bottom of the well it swings in (drive.hardware: the model's
# unpowered minimum from the last look) if it stayed within REST_BAND of it over the last REST_SPAN s — a swing in
# one well (the wells of the iron prototype lie 9-14° apart), not a tumble from well to well.
REST_SPAN, REST_BAND = 0.3, math.radians(1.0)
BANDWIDTH = 2 * math.pi * 3  # rad/s: the servo's closed-loop natural frequency on hardware (a 5 ms loop, ~1 cycle late)


@dataclass
class Session:
    """A finished session: the loop's :class:`~spherestep.hardware.servo.ServoReport`, the
    :class:`~spherestep.control.Trajectory` it followed, and for an emulated motor the ``truth`` samples
    ``[(loop time, Truth)]`` taken every ``truth_every`` s (0: every cycle; the loop time is the cycle's, the
    truth's own time ``Truth.t`` is on the device's clock: :attr:`ServoReport.device_start`), ``held`` the
    :class:`~spherestep.hardware.motor_emulator.Truth` at the loop's last cycle (the servo still holding) and
    ``final`` 0.15 s after the end (the coils off: an iron motor's detent moves the rotor into its nearest well),
    the device's ``watchdog`` (s) and when it ``started`` (``time.monotonic()``); with the firmware in QEMU its
    ``step_cost`` ``(steps, mean, max)`` in instructions per control step that drove the coils; ``rest`` the
    :class:`Rest` watched after the coils went off (the emulated rotor's truth, or on a port the loop's estimate
    from the device's readings; ``None`` when the watch could not be made); ``after`` what the session's
    ``after`` returned; ``kind`` the :func:`~spherestep.drive.connect.connect` kind it ran on."""

    report: ServoReport
    trajectory: Trajectory
    truth: list
    final: object | None
    watchdog: float | None = None
    started: float | None = None
    held: object | None = None
    step_cost: tuple | None = None
    rest: Rest | None = None
    after: object | None = None
    kind: str = "port"

    @property
    def reference(self):
        """``t -> (R, ω, α)``: the trajectory's :meth:`~spherestep.control.Trajectory.at`."""
        return self.trajectory.at

    def final_error(self) -> float | None:
        """Park distance (rad) between the emulated rotor at the loop's last cycle, held by the servo, and the
        trajectory's end (None on hardware)."""
        end = self.held if self.held is not None else self.final
        if end is None:
            return None
        return float(so3.distance(end.R, self.trajectory.end))

    def drift_after_off(self) -> float | None:
        """How far (rad) the rotor moved from the loop's last cycle to where it was last watched after the coils
        went off (:attr:`rest`; without a watch, the emulated rotor ``OFF_FIRST`` s after: :attr:`final`; None
        when neither was seen)."""
        if not self.report.orientations or (self.rest is None and self.final is None):
            return None
        last = self.held.R if self.held is not None else self.report.orientations[-1]
        seen = self.rest.samples[-1][1] if self.rest is not None else self.final.R
        return float(so3.distance(seen, last))


@dataclass(frozen=True)
class Rest:
    """The rotor watched after the coils went off (module constants ``OFF_FIRST`` … ``REST_LIMIT``): ``samples``
    ``[(device time s, R)]``, ``at_rest`` whether it came to rest (else it was still moving at the limit) and the
    ``speed`` (rad/s) over the last interval."""

    samples: list
    at_rest: bool
    speed: float


def watch_rest(sample, wait) -> Rest:
    """Watch the rotor after the coils went off: ``wait(s)`` lets time pass, ``sample()`` gives ``(device time s,
    R)``; stops at rest or after ``REST_LIMIT`` s (module constants)."""
    wait(OFF_FIRST)
    samples, calm, waited = [sample()], 0, OFF_FIRST
    while waited < REST_LIMIT - 1e-9:
        wait(REST_EVERY)
        waited += REST_EVERY
        samples.append(sample())
        moved = float(so3.distance(samples[-1][1], samples[-2][1]))
        calm = calm + 1 if moved <= REST_MOTION else 0
        if calm >= 2:
            break
    span = samples[-1][0] - samples[-2][0] if len(samples) > 1 else 0.0
    speed = float(so3.distance(samples[-1][1], samples[-2][1])) / span if span > 0 else math.nan
    return Rest(samples, calm >= 2, speed)


def turn_reference(start, axis, angle: float, duration: float, delay: float = 0.0) -> Trajectory:
    """The control room's fastest-profile (triangular) turn by ``angle`` rad about ``axis`` taking ``duration`` s
    after ``delay`` s (:meth:`Trajectory.hold` for no angle)."""
    from ..control.trajectory import segment

    duration = checks.positive(duration, "duration", "a positive time in seconds")
    if angle == 0:
        return Trajectory.hold(start)
    acceleration = 4 * abs(angle) / duration ** 2
    return Trajectory((segment(start, axis, angle, acceleration, None, t0=delay),))


def servo_session(design, trajectory: Trajectory, duration: float, *, port: str | None = None, emulate: bool = False,
                  lockstep: bool = False, rate: float = LOOP_RATE, log=None, status=None, faults=None, sensors=None, model=None, drive=None,
                  R0=None, watchdog_ms: int | None = None, max_late: float | None = None,
                  truth_every: float = 0.05, plant=None, cores: bool | None = None, firmware: str = "python",
                  watch: bool = False, plant_rotor=None, sensor_errors=None, sensor_calibration=None,
                  after=None) -> Session:
    """Run the servo for ``duration`` s following ``trajectory`` (a :class:`~spherestep.control.Trajectory`;
    :meth:`~spherestep.control.Trajectory.hold` for a pose) on the controller at
    ``port``, or with ``emulate`` on the emulated motor (``faults`` a
    :class:`~spherestep.hardware.motor_emulator.MotorFaults`, ``watchdog_ms`` its watchdog). ``sensors``
    defaults to the sensing room's :func:`~spherestep.sensing.default_array` of 8, ``model`` and ``drive`` to the
    design's own (:func:`spherestep.magnetics.design_model`: the iron model and the iron coil's limits for the
    prototype), ``R0`` (the start, for the estimate and
    the emulated rotor) to the trajectory's start. ``log``, ``status``, ``rate``, ``max_late``: see
    :func:`~spherestep.hardware.servo.run_servo`. With ``lockstep`` (and ``emulate``) the frames go straight to
    the device in this process on a simulated clock (:class:`~spherestep.hardware.motor_emulator.LockstepLink`):
    the same loop, protocol and motor with the rate kept exactly, whatever the machine's load. ``plant`` (with
    ``emulate``) the torque model the emulated rotor obeys, default ``model`` (a mismatched motor: calibration).
    The estimator fits the sensing room's :func:`~spherestep.sensing.field_model` of the design, the one the
    emulated motor's magnetometers read and the simulated Hall sensor uses: on an iron design the rotor's field
    plus the cores it magnetises, and the iron coils' (``cores=False``: the rotor and the bare windings, the
    iron ignored, for comparison). ``firmware`` (with ``emulate``, not ``lockstep``): ``"python"`` the Python
    device on a pseudo-terminal (:class:`~spherestep.hardware.motor_emulator.MotorPty`), ``"qemu"`` the firmware
    itself in QEMU (:class:`~spherestep.hardware.qemu.QemuMotor`; its control step's instructions in
    :attr:`Session.step_cost`). With ``watch`` the rotor is watched after the coils go off until it rests
    (:func:`watch_rest`, :attr:`Session.rest`; what a move's end is judged by: ``drive.hardware``). ``plant_rotor``
    (with ``emulate``) the emulated rotor as built (a
    :class:`~spherestep.dynamics.Rotor`; default the design's with damping :data:`EMULATED_DAMPING`, which the
    controller assumes either way) and ``sensor_errors`` its magnetometers as built
    (:class:`~spherestep.sensing.SensorErrors`; the estimator keeps the nominal ``sensors``). ``sensor_calibration``
    (:class:`~spherestep.sensing.ArrayCalibration`): the estimator reads through it. ``after(conn)`` is called on the
    open :class:`~spherestep.drive.Connection` once the loop has ended well (every coil off), before it is let go;
    its result is :attr:`Session.after`."""
    from ..dynamics import Rotor
    from ..magnetics import design_model
    from ..sensing import ArrayCalibration, default_array, field_model

    if not isinstance(trajectory, Trajectory):
        raise bad_value("trajectory", "a spherestep.control.Trajectory (Trajectory.hold(R) for a pose)",
                        type(trajectory).__name__)
    kind = session_kind(port, emulate, lockstep, firmware)
    for name, value in (("plant_rotor", plant_rotor), ("sensor_errors", sensor_errors)):
        if value is not None and not emulate:
            raise bad_value(name, "used only with emulate=True (the motor as built is the emulated one)", value)
    if plant_rotor is not None and not isinstance(plant_rotor, Rotor):
        raise bad_value("plant_rotor", "a spherestep.dynamics.Rotor (or None)", type(plant_rotor).__name__)
    sensors = default_array(design, 8) if sensors is None else sensors
    if model is None or drive is None:
        own = design_model(design)
        model = own.model if model is None else model
        drive = own.limits if drive is None else drive
    R0 = trajectory.start if R0 is None else so3.as_rotations(R0).reshape(3, 3)
    rotor = Rotor.from_design(design, damping=EMULATED_DAMPING)
    if sensor_calibration is None:
        estimator = field_model(design, sensors.positions, cores).estimator(sensors)
    elif isinstance(sensor_calibration, ArrayCalibration):
        estimator = sensor_calibration.estimator(design, sensors, cores)
    else:
        raise bad_value("sensor_calibration", "a spherestep.sensing.ArrayCalibration (or None)",
                        type(sensor_calibration).__name__)
    estimate = FieldTracker(estimator, R0, drive)
    controller = GeometricPD(rotor.inertia, bandwidth=BANDWIDTH, rate=rate, damping=rotor.damping)
    options = {} if max_late is None else {"max_late": max_late}
    law = ServoLaw(model, trajectory, controller, limits=wire_limits(drive), sensor_rate=rate, delay=DELAY,
                   observer_bandwidth=rate, lead=LEAD / rate, current_lag=current_lag(kind))
    truth: list = []
    held: list = [None]  # the truth at the latest cycle
    with connect(design, kind, port=port, plant=model if plant is None else plant, limits=drive, sensors=sensors,
                 R0=R0, faults=faults, watchdog_ms=watchdog_ms, rotor=rotor if plant_rotor is None else plant_rotor,
                 sensor_errors=sensor_errors) as conn:
        observe = status
        if conn.truth is not None:
            def observe(t, R, w, currents):
                held[0] = conn.truth()
                if truth_every <= 0 or len(truth) <= int(t / truth_every):
                    truth.append((t, held[0]))
                if status is not None:
                    status(t, R, w, currents)

        report = run_servo(conn.link, estimate, law, duration=duration, rate=rate, log=log, status=observe,
                           **conn.timing, **options)
        extra = after(conn) if after is not None and report.outcome == "done" else None
        if conn.truth is None:  # a board: the rest from its own readings, estimated, while the link still answers
            return Session(report, trajectory, [], None,
                           rest=_rest_on_port(conn.link, estimate, report) if watch else None, after=extra, kind=kind)
        seen: list = []  # the truth at each look; the first, OFF_FIRST s after the end, is the session's final

        def sample():
            seen.append(conn.truth())
            return seen[-1].t, seen[-1].R

        # the first release sends OFF; the device runs on (a watchdog trip after a lost link lands in the truth)
        if watch:
            rest = watch_rest(sample, conn.release)
        else:
            conn.release(OFF_FIRST)
            sample()
            rest = None
        cost = conn.step_cost() if conn.step_cost is not None else None
    return Session(report, trajectory, truth, seen[0], conn.watchdog, conn.started, held[0], cost, rest, extra, kind)


def session_series(session: Session, limits, field: str, expected: str, lag: float = 0.0):
    """``(t, R, c)`` of a finished session for a fit: the loop's times (s), estimated orientations and the
    currents per unit of ``limits`` over each period — commanded in a cycle, driven from the next cycle's start (the
    session's one-period delay) and, with the device's current ``lag`` (s, :func:`current_lag`), the mean a
    first-order current carries over each period (:func:`~spherestep.electrics.period_means`: the law
    pre-emphasises its setpoints so that this mean is the current it allocated). An interrupted loop (every coil
    off) re-raises its interrupt; one that did not run to the end is an InputError naming ``field``."""
    from ..electrics import period_means
    from ..interrupts import interrupt_for, last_signal

    rep = session.report
    if rep.outcome == "INTERRUPT":  # the loop caught Ctrl-C or SIGTERM and switched every coil off: unwind on,
        stop = interrupt_for(last_signal())  # saying whether the device acknowledged it (the CLI tells the user)
        stop.off_acknowledged = bool(rep.off_acknowledged)
        raise stop
    if rep.outcome != "done" or len(rep.times) < 4:
        raise bad_value(field, expected, f"outcome {rep.outcome} ({rep.message})")
    t = np.asarray(rep.times, dtype=float)
    R = so3.as_rotations(rep.orientations).reshape(-1, 3, 3)
    c = limits.per_unit(np.asarray(rep.currents, dtype=float))
    c = np.vstack([np.zeros((1, c.shape[1])), c[:-1]])
    return t, R, period_means(c, lag, float(np.median(np.diff(t))))


def current_lag(kind: str) -> float:
    """The time constant (s) the coil currents of a ``kind`` of device (:func:`~spherestep.drive.connect.connect`'s)
    follow their setpoints with: the emulated motor's device's current loop, ``1/ω_c`` =
    ``period / CURRENT_BANDWIDTH`` (0.5 ms at its 4 kHz, 2 ms for the firmware in QEMU at 1 kHz); 0 (no
    pre-emphasis) on a board, whose HELLO does not report its loop's bandwidth."""
    from ..hardware.motor_emulator import CURRENT_BANDWIDTH, DEVICE_PERIOD
    from .connect import QEMU_PERIOD

    if kind == "port":
        return 0.0
    period = QEMU_PERIOD if kind == "qemu" else DEVICE_PERIOD
    return period / CURRENT_BANDWIDTH


def _rest_on_port(link, estimate, report) -> Rest | None:
    """:func:`watch_rest` on a board's readings (``READ``, coils off), estimated from the loop's last estimate;
    None when the loop never ran or the link no longer answers."""
    import time as clock

    from ..hardware import LinkError

    if not report.orientations or report.device_start is None:
        return None
    try:
        return watch_rest(lambda: (lambda state: (state.time_us * 1e-6, estimate(state)))(link.read()), clock.sleep)
    except (LinkError, ComputationError):
        return None


def move_on_hardware(design, axis, angle: float, *, duration: float | None = None, port: str | None = None,
                     emulate: bool = False, rate: float = LOOP_RATE, log=None, status=None, settle: float = SETTLE,
                     **options) -> Session:
    """Turn the rotor by ``angle`` rad about ``axis`` from where it is taken to be (the stepper state nearest the
    identity along the turn, as in simulation: :func:`spherestep.commutation.turn_targets`) on a controller
    (``port``) or the emulated motor (``emulate``): in ``duration`` s (:func:`turn_reference`), or by default
    the fastest trapezoidal turn the drive guarantees along the path
    (:func:`spherestep.control.plan_turn`); the loop runs ``settle`` s longer. ``model`` and ``drive`` (in
    ``options``) default to the design's own; the other ``options`` go to :func:`servo_session`. What
    :func:`spherestep.drive.drive_turn` runs for ``backend="emulated"``/``"port"``."""
    from ..commutation import turn_targets
    from ..control import plan_turn
    from ..dynamics import Rotor
    from ..magnetics import design_model

    a = checks.axis(axis)
    start = turn_targets(design, a, angle, steps=1)[0]
    model, drive = options.pop("model", None), options.pop("drive", None)
    if model is None or drive is None:
        own = design_model(design)
        model = own.model if model is None else model
        drive = own.limits if drive is None else drive
    if duration is None:
        trajectory = plan_turn(model, start, a, angle, Rotor.from_design(design).inertia, drive)
    else:
        trajectory = turn_reference(start, a, angle, duration)
    return servo_session(design, trajectory, trajectory.duration + settle, port=port, emulate=emulate, rate=rate, log=log,
                         status=status, model=model, drive=drive, **options)
