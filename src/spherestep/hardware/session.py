"""One servo session on a coil controller — a real board on a serial port, or the emulated motor on a
pseudo-terminal — with the estimator and control law of :mod:`.servo_parts` assembled for a design.

:func:`servo_session` is what ``spherestep move ... --port DEV`` (or ``--emulate``) calls: it builds the
sensing room's :class:`~spherestep.sensing.Estimator` for the design's magnetometer array, the control room's
:class:`~spherestep.control.GeometricPD` and allocation, opens the link with protocol version 2, runs
:func:`~spherestep.hardware.servo.run_servo` and always ends with every coil off. With ``emulate`` it also
serves :class:`~spherestep.hardware.motor_emulator.MotorPty` and returns the emulated motor's
:class:`~spherestep.hardware.motor_emulator.Truth` at the end, so the result can be judged against the truth.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..errors import bad_value
from .drive_link import DriveLink
from .servo import ServoReport, run_servo
from .servo_parts import FieldTracker, ServoLaw, hold

BANDWIDTH = 2 * math.pi * 3  # rad/s: the servo's closed-loop natural frequency on hardware (a 5 ms loop, ~1 cycle late)


@dataclass
class Session:
    """A finished session: the loop's :class:`~spherestep.hardware.servo.ServoReport`, the reference it
    followed (``t -> (R, ω, α)``), and for an emulated motor the ``truth`` samples ``[(loop time, Truth)]`` taken
    every ``truth_every`` s, the ``final`` :class:`~spherestep.hardware.motor_emulator.Truth` (0.15 s after the
    end, the coils off), the device's ``watchdog`` (s) and when it ``started`` (``time.monotonic()``)."""

    report: ServoReport
    reference: object
    truth: list
    final: object | None
    watchdog: float | None = None
    started: float | None = None

    def final_error(self) -> float | None:
        """Park distance (rad) between the emulated rotor at the end and the reference's end (None on hardware)."""
        if self.final is None:
            return None
        return float(so3.distance(self.final.R, np.asarray(self.reference(1e9)[0])))


def turn_reference(start, axis, angle: float, duration: float, delay: float = 0.0):
    """The control room's fastest-profile (triangular) turn by ``angle`` rad about ``axis`` taking ``duration`` s
    after ``delay`` s: ``t -> (R, ω, α)``."""
    from ..control.trajectory import Trajectory, segment

    if not (isinstance(duration, (int, float)) and math.isfinite(duration) and duration > 0):
        raise bad_value("duration", "a positive time in seconds", duration)
    if angle == 0:
        return hold(start)
    acceleration = 4 * abs(angle) / duration ** 2
    return Trajectory((segment(start, axis, angle, acceleration, None, t0=delay),)).sample


def servo_session(design, reference, duration: float, *, port: str | None = None, emulate: bool = False,
                  lockstep: bool = False, rate: float = 200.0, log=None, status=None, faults=None, sensors=None, model=None, drive=None,
                  R0=None, watchdog_ms: int | None = None, max_late: float | None = None,
                  truth_every: float = 0.05) -> Session:
    """Run the servo for ``duration`` s following ``reference`` (``t -> (R, ω, α)``) on the controller at
    ``port``, or with ``emulate`` on the emulated motor (``faults`` a
    :class:`~spherestep.hardware.motor_emulator.MotorFaults`, ``watchdog_ms`` its watchdog). ``sensors``
    defaults to the sensing room's :func:`~spherestep.sensing.default_array` of 8, ``model`` to the design's
    torque map, ``drive`` to :class:`~spherestep.control.DriveLimits`, ``R0`` (the start, for the estimate and
    the emulated rotor) to the reference's start. ``log``, ``status``, ``rate``, ``max_late``: see
    :func:`~spherestep.hardware.servo.run_servo`. With ``lockstep`` (and ``emulate``) the frames go straight to
    the device in this process on a simulated clock (:class:`~spherestep.hardware.motor_emulator.LockstepLink`):
    the same loop, protocol and motor with the rate kept exactly, whatever the machine's load."""
    from ..control import DriveLimits, GeometricPD
    from ..dynamics import Rotor
    from ..magnetics import torque_map
    from ..sensing import CoilField, Estimator, FieldTable, default_array

    if (port is None) == (not emulate):
        raise bad_value("port", "a serial device, or emulate=True (one of the two)", port)
    if lockstep and not emulate:
        raise bad_value("lockstep", "used only with emulate=True", lockstep)
    sensors = default_array(design, 8) if sensors is None else sensors
    model = torque_map(design) if model is None else model
    drive = DriveLimits() if drive is None else drive
    R0 = np.asarray(reference(0.0)[0]) if R0 is None else so3.as_rotations(R0).reshape(3, 3)
    rotor = Rotor.from_design(design, damping=0.01)
    table = FieldTable.build(design, sensors.positions)
    estimator = Estimator(table, sensors.axes, sensors.part, (CoilField.build(design, sensors.positions),))
    estimate = FieldTracker(estimator, R0, drive.nominal_current)
    law = GeometricPD(rotor.inertia, bandwidth=BANDWIDTH, rate=rate, damping=rotor.damping)
    control = ServoLaw(model, law, reference, drive)
    options = {} if max_late is None else {"max_late": max_late}
    if not emulate:
        with DriveLink(port) as link:
            report = run_servo(link, estimate, control, duration=duration, rate=rate, log=log, status=status,
                               **options)
        return Session(report, reference, [], None)

    from .motor_emulator import EmulatedMotor, LockstepLink, MotorPty

    motor = EmulatedMotor(design, model, sensors, rotor=rotor, drive=drive, R0=R0, faults=faults)
    truth: list = []
    device = {} if watchdog_ms is None else {"watchdog_ms": watchdog_ms}
    if lockstep:
        link = LockstepLink(motor, **device)

        def observe_here(t, R, w, currents):
            if len(truth) <= int(t / truth_every):
                truth.append((t, link.truth()))
            if status is not None:
                status(t, R, w, currents)

        report = run_servo(link, estimate, control, duration=duration, rate=rate, log=log, status=observe_here,
                           clock=link.clock, sleep=link.sleep, **options)
        link.sleep(0.15)
        return Session(report, reference, truth, link.truth(), link.device.watchdog_ms / 1000, 0.0)
    with MotorPty(motor, **device) as dev:
        def observe(t, R, w, currents):
            if len(truth) <= int(t / truth_every):
                truth.append((t, dev.truth()))
            if status is not None:
                status(t, R, w, currents)

        with DriveLink(dev.port) as link:
            report = run_servo(link, estimate, control, duration=duration, rate=rate, log=log, status=observe,
                               **options)
        time.sleep(0.15)  # the device runs on: a watchdog trip after a lost link lands in the truth
        final = dev.truth()
    return Session(report, reference, truth, final, dev.device.watchdog_ms / 1000, dev.started)


def move_on_hardware(design, axis, angle: float, *, duration: float | None = None, port: str | None = None,
                     emulate: bool = False, rate: float = 200.0, log=None, status=None, settle: float = 0.5,
                     **options) -> Session:
    """Turn the rotor by ``angle`` rad about ``axis`` from where it is taken to be (the identity) on a controller
    (``port``) or the emulated motor (``emulate``): in ``duration`` s (:func:`turn_reference`), or by default
    the fastest trapezoidal turn the drive guarantees along the path
    (:func:`spherestep.control.trajectory.plan_turn`); the loop runs ``settle`` s longer. What
    ``spherestep move ... --port DEV`` / ``--emulate`` calls; ``options`` go to :func:`servo_session`."""
    from ..control import DriveLimits
    from ..control.trajectory import plan_turn
    from ..dynamics import Rotor
    from ..magnetics import torque_map

    a = np.asarray(axis, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.linalg.norm(a) > 0:
        raise bad_value("axis", "a non-zero 3-vector", axis)
    model = options.pop("model", None) or torque_map(design)
    drive = options.pop("drive", None) or DriveLimits()
    if duration is None:
        plan = plan_turn(model, np.eye(3), a, angle, Rotor.from_design(design).inertia, drive)
        reference, turn_time = plan.sample, plan.duration
    else:
        reference, turn_time = turn_reference(np.eye(3), a, angle, duration), duration
    return servo_session(design, reference, turn_time + settle, port=port, emulate=emulate, rate=rate, log=log,
                         status=status, model=model, drive=drive, **options)
