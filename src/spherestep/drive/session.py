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

from .. import checks, so3
from ..control import GeometricPD, ServoLaw, Trajectory
from ..errors import bad_value
from ..hardware import LOOP_RATE, FieldTracker, ServoReport, run_servo, wire_limits
from .connect import EMULATED_DAMPING, connect

DELAY = 1  # control periods: the currents computed in a cycle are driven at the next cycle's start
# The observer's bandwidth on hardware is the loop's rate in rad/s, ω_o = 1/h: its gains are then l₁ = 1, l₂ h = 1
# (deadbeat: the magnetometer array's estimate is nearly noise-free, so the estimate follows each measurement and
# ω̂ is the model's prediction corrected by the whole residual). Measured on the emulated 360° turn in lockstep at
# 200 Hz: max tracking error 0.31° and final 0.019° (120 rad/s: 0.44° and 0.016°; the former difference filter:
# 0.34° and 0.043°). The iron prototype at 500 Hz (the emulator's 4 kHz current loop, 2026-11-25): the 360° turn
# about (1, 0.5, 2) from a detent well in lockstep tracks within 0.47° and parks 0.006° off; a hold within 0.004°.
FIRMWARES = ("python", "qemu")  # the emulated motor's device: the Python CurrentDevice, or drive.cpp in QEMU
QEMU_RATE = 100.0  # Hz: the servo's default rate on the firmware in QEMU (the DRIVE round trip in drive.connect)
SETTLE = 0.5  # s the loop runs on after the trajectory's end
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
    ``step_cost`` ``(steps, mean, max)`` in instructions per control step that drove the coils; ``after`` what the
    session's ``after`` returned."""

    report: ServoReport
    trajectory: Trajectory
    truth: list
    final: object | None
    watchdog: float | None = None
    started: float | None = None
    held: object | None = None
    step_cost: tuple | None = None
    after: object | None = None

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
        """How far (rad) the emulated rotor moved in the 0.15 s after the coils went off (None on hardware)."""
        if self.held is None or self.final is None:
            return None
        return float(so3.distance(self.final.R, self.held.R))


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
                  plant_rotor=None, sensor_errors=None, sensor_calibration=None, after=None) -> Session:
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
    :attr:`Session.step_cost`). ``plant_rotor`` (with ``emulate``) the emulated rotor as built (a
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
    if (port is None) == (not emulate):
        raise bad_value("port", "a serial device, or emulate=True (one of the two)", port)
    if lockstep and not emulate:
        raise bad_value("lockstep", "used only with emulate=True", lockstep)
    for name, value in (("plant_rotor", plant_rotor), ("sensor_errors", sensor_errors)):
        if value is not None and not emulate:
            raise bad_value(name, "used only with emulate=True (the motor as built is the emulated one)", value)
    if plant_rotor is not None and not isinstance(plant_rotor, Rotor):
        raise bad_value("plant_rotor", "a spherestep.dynamics.Rotor (or None)", type(plant_rotor).__name__)
    if firmware not in FIRMWARES or (firmware != "python" and (not emulate or lockstep)):
        raise bad_value("firmware", "python, or qemu with emulate=True and no lockstep", firmware)
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
    law = ServoLaw(model, trajectory, controller, limits=wire_limits(drive), sensor_rate=rate, delay=DELAY,
                   observer_bandwidth=rate)
    options = {} if max_late is None else {"max_late": max_late}
    kind = "port" if not emulate else "lockstep" if lockstep else "qemu" if firmware == "qemu" else "pty"
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
        if conn.truth is None:
            return Session(report, trajectory, [], None, after=extra)
        final = conn.release(0.15)  # the device runs on: a watchdog trip after a lost link lands in the truth
        cost = conn.step_cost() if conn.step_cost is not None else None
    return Session(report, trajectory, truth, final, conn.watchdog, conn.started, held[0], cost, extra)


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
