"""How a turn is driven: one registry, :data:`DRIVE_MODES` (mode → :class:`DriveMode`, the backends it runs on), and
:func:`drive_turn`, one lookup in it (issue 36).

Each mode's runner takes the prepared :class:`~.turn.Turn` (the model, the plan and the relay tuning made once) and
the :class:`Options`; none of them builds a backend. On the simulated motor the turn is the dynamics room's
integration (:meth:`~.turn.Turn.settled`, :meth:`~.turn.Turn.ramped`, :meth:`~.turn.Turn.servo`); on an emulated
motor or a port the servo runs on the :class:`~spherestep.hardware.Link` that :func:`~.connect.connect` builds for
the kind :func:`~.connect.session_kind` names (:func:`~.hardware.drive_on_hardware` through
:func:`~.session.servo_session`). Relay plans on hardware run with ``spherestep run``.

===========  =====================  =========================================================================
mode         backends               what runs
===========  =====================  =========================================================================
``servo``    simulated              a rest-to-rest trajectory tracked at 1 kHz (:func:`~spherestep.dynamics.simulate_servo`)
``servo``    emulated, port         the same law on the device behind a ``Link`` (the servo session)
``ramped``   simulated              the relay plan's steps at the pull-out rate
``settled``  simulated              the paper's relay steps, each settled
===========  =====================  =========================================================================
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from .. import checks
from ..errors import bad_value
from .result import DriveResult
from .turn import Turn, check_duration, choose_model

SENSORS = ("ideal", "hall", "imu")


@dataclass(frozen=True)
class Options:
    """What a runner may use beyond the prepared turn (see :func:`drive_turn` for each)."""

    duration: float | None = None
    sensor: str = "ideal"
    sensor_noise: float = 0.0
    seed: int = 0
    rates: object = None
    port: str | None = None
    rate: float | None = None
    log: object = None
    firmware: str = "python"
    end: str = "hold"
    hold: float | None = None
    plant_error: object = None


@dataclass(frozen=True)
class DriveMode:
    """One way to drive a turn: its ``name`` and ``runs``, backend → ``run(turn, options) -> DriveResult``."""

    name: str
    runs: Mapping[str, Callable[[Turn, Options], DriveResult]] = field(default_factory=dict)


def _settled(job: Turn, o: Options) -> DriveResult:
    return job.settled()


def _ramped(job: Turn, o: Options) -> DriveResult:
    return job.ramped(o.rates)


def _servo(job: Turn, o: Options) -> DriveResult:
    return job.servo(o.duration, sensor=o.sensor, sensor_noise=o.sensor_noise, seed=o.seed)


def _servo_on_link(backend: str) -> Callable[[Turn, Options], DriveResult]:
    """The servo session on ``backend`` (``"emulated"``: the emulated motor, its device in Python or the firmware
    in QEMU, ``plant_error`` its motor as built; ``"port"``: a board on ``port``)."""
    def run(job: Turn, o: Options) -> DriveResult:
        from ..hardware import LOOP_RATE
        from .hardware import drive_on_hardware
        from .session import QEMU_RATE

        options = {}
        if o.plant_error is not None:
            from ..magnetics import design_model
            from ..sensing import default_array

            options = {"plant": o.plant_error.plant(design_model(job.design).model),
                       "plant_rotor": o.plant_error.rotor(job.design),
                       "sensor_errors": o.plant_error.sensor_errors(default_array(job.design, 8))}
        default = QEMU_RATE if o.firmware == "qemu" else LOOP_RATE
        return drive_on_hardware(job, duration=o.duration, port=o.port, emulate=backend == "emulated",
                                 rate=default if o.rate is None else o.rate, log=o.log, firmware=o.firmware,
                                 end=o.end, hold=o.hold, **options)
    return run


DRIVE_MODES = {
    "servo": DriveMode("servo", {"simulated": _servo, "emulated": _servo_on_link("emulated"),
                                 "port": _servo_on_link("port")}),
    "ramped": DriveMode("ramped", {"simulated": _ramped}),
    "settled": DriveMode("settled", {"simulated": _settled}),
}
MODES = tuple(DRIVE_MODES)
BACKENDS = ("simulated", "emulated", "port")


def check_options(mode: str, backend: str, *, duration=None, sensor: str = "ideal", sensor_noise: float = 0.0,
                  port=None, rate=None, firmware: str = "python", end: str = "hold", hold=None,
                  plant_error=None) -> None:
    """Refuse options that do not apply to ``mode`` and ``backend`` (InputError naming the option)."""
    if mode not in DRIVE_MODES:
        raise bad_value("mode", f"one of {', '.join(MODES)}", mode)
    if backend not in BACKENDS:
        raise bad_value("backend", f"one of {', '.join(BACKENDS)}", backend)
    if duration is not None:
        if mode != "servo":
            raise bad_value("duration", "given only for the servo (relay modes run at their own pace)", duration)
        checks.positive(duration, "duration", "a positive time in seconds")
    checks.non_negative(sensor_noise, "sensor_noise", "a non-negative angle in radians")
    if sensor not in SENSORS:
        raise bad_value("sensor", f"one of {', '.join(SENSORS)}", sensor)
    if sensor != "ideal" and sensor_noise:
        raise bad_value("sensor_noise", "0 with the hall and imu sensors (their noise is the part's own)",
                        sensor_noise)
    if mode != "servo" and (sensor != "ideal" or sensor_noise):
        raise bad_value("sensor", "ideal and no sensor_noise unless mode='servo' (relay modes run open loop)",
                        sensor)
    if backend not in DRIVE_MODES[mode].runs:
        raise bad_value("mode", "servo on an emulated motor or a port (relay plans run with spherestep run)", mode)
    if backend != "simulated" and (sensor != "ideal" or sensor_noise):
        raise bad_value("sensor", "ideal and no sensor_noise on an emulated motor or a port (the loop reads the "
                        "stator's magnetometer array)", sensor)
    if backend == "port" and not port:
        raise bad_value("port", "the coil controller's serial device with backend='port'", port)
    if backend != "port" and port is not None:
        raise bad_value("port", "left out unless backend='port'", port)
    if rate is not None:
        if backend == "simulated":
            raise bad_value("rate", "left out on the simulated motor (its loop runs at 1 kHz); a loop rate for the "
                            "emulated motor or a port", rate)
        checks.positive(rate, "rate", "a positive loop rate in Hz")
    if firmware != "python" and backend != "emulated":
        raise bad_value("firmware", "python unless backend='emulated' (the firmware in QEMU drives the emulated "
                        "motor)", firmware)
    if hold is not None and backend == "simulated":
        raise bad_value("hold", "left out on the simulated motor (its coils never go off)", hold)
    if end != "hold" and backend == "simulated":
        raise bad_value("end", "hold on the simulated motor (park ends a move on an emulated motor or a port, "
                        "where the coils go off)", end)
    if plant_error is not None and backend != "emulated":
        raise bad_value("plant_error", "left out unless backend='emulated' (the emulated motor as built)", plant_error)


def drive_turn(design, axis, angle_rad: float, *, mode: str = "servo", backend: str = "simulated", model=None,
               limits=None, duration: float | None = None, sensor: str = "ideal", sensor_noise: float = 0.0,
               port: str | None = None, rate: float | None = None, tolerance: float | None = None, seed: int = 0,
               rates=None, log=None, progress: Callable[[str], None] | None = None,
               firmware: str = "python", end: str = "hold", hold: float | None = None,
               plant_error=None) -> DriveResult:
    """Drive a turn of ``angle_rad`` about ``axis`` (fixed frame) in ``mode`` on ``backend``: the options checked,
    the turn prepared (:class:`~.turn.Turn`), then ``DRIVE_MODES[mode].runs[backend]`` (module docstring).

    ``model``/``limits``: default the design's own (:func:`spherestep.magnetics.design_model`). ``duration`` (s):
    the servo's time (default the fastest turn; refused under the bang-bang bound, :func:`~.turn.check_duration`).
    ``sensor`` (simulated servo): ``"ideal"`` (the true orientation turned by noise of σ ``sensor_noise`` rad),
    ``"hall"`` (the stator's magnetometer array and its estimator, the coils' field subtracted at a 1 % current
    error) or ``"imu"`` (gyro, accelerometer and magnetometer in the rotor). ``port`` (backend ``"port"``) the
    serial device; ``rate`` the loop rate (Hz) on an emulated motor or a port (default
    :data:`spherestep.hardware.LOOP_RATE`, 500); ``log`` the loop's per-cycle CSV there. ``rates``: the ramped
    cruise rates tried. ``firmware`` (backend ``"emulated"``): the device behind the line, ``"python"`` or
    ``"qemu"`` (:func:`~spherestep.drive.session.servo_session`; its rate then defaults to
    :data:`~spherestep.drive.session.QEMU_RATE`). ``end`` (emulated motor or port): ``"hold"`` or ``"park"``, how
    the move ends before the coils go off and ``hold`` s it is held (default 0.5;
    :func:`~spherestep.drive.hardware.drive_on_hardware`: hold is judged where the servo holds the rotor, park
    where it rests in the predicted well with the coils off). ``tolerance`` (rad): a result is
    :attr:`~DriveResult.ok` only within it (default the mode's own,
    :data:`~spherestep.drive.judgement.MODE_TOLERANCE`). ``progress(text)`` hears each stage. ``plant_error``
    (backend ``"emulated"``): a :class:`~spherestep.drive.PlantError`, the emulated motor as built (its torque
    plant from the design's own model, its rotor and its sensors), whatever model the servo runs on.
    """
    check_options(mode, backend, duration=duration, sensor=sensor, sensor_noise=sensor_noise, port=port, rate=rate,
                  firmware=firmware, end=end, hold=hold, plant_error=plant_error)
    job = Turn(design, axis, angle_rad, choose_model(design, model, limits), tolerance, progress)
    if duration is not None:
        check_duration(design, job.axis, job.angle, job.chosen, duration, start=job.start)
    return DRIVE_MODES[mode].runs[backend](job, Options(duration, sensor, sensor_noise, seed, rates, port, rate, log,
                                                         firmware, end, hold, plant_error))
