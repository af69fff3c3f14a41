"""The one place a backend is chosen and built: :func:`connect` ``(design, kind, ...)``.

Kinds (:data:`KINDS`):

* ``"port"``: a current-mode coil controller on a serial device (:class:`~spherestep.hardware.DriveLink`,
  protocol 2);
* ``"lockstep"``: the emulated motor and its device in this process on a simulated clock
  (:class:`~spherestep.hardware.LockstepLink`): the servo keeps its rate exactly, whatever the machine's load;
* ``"pty"``: the emulated motor behind its device in a forked process on a real pseudo-terminal
  (:class:`~spherestep.hardware.MotorPty`), reached by a :class:`~spherestep.hardware.DriveLink` on its port;
* ``"qemu"``: as ``"pty"`` with the firmware itself (``drive.cpp``/``protocol.cpp`` built for QEMU's
  ``mps2-an500``, :class:`~spherestep.hardware.qemu.QemuMotor`) as the device, its current loop at
  :data:`QEMU_PERIOD` and its link's timeout :data:`QEMU_TIMEOUT`;
* ``"relay port"``: a relay board on a serial device (:class:`~spherestep.hardware.Serial`, protocol 1);
* ``"dry run"``: nothing is sent, every frame recorded (:class:`~spherestep.hardware.DryRun`, protocol 1);
* ``"simulated"``: a relay plan on the design's simulated rotor (:class:`~spherestep.hardware.Simulated`,
  protocol 1, the dynamics room's integrator).

Every kind yields a :class:`~spherestep.hardware.Link` (``drive(currents A)``, ``read()``, ``off()``, ``info``, a
context manager): protocol 2's serial or lockstep link, or for the protocol-1 kinds a
:class:`~spherestep.hardware.RelayLink` over the relay back end (coils at 0 or ± the nominal current, the relay
wire format unchanged) for :func:`~spherestep.hardware.play`. The emulated motor is
assembled here from the rooms that know its parts (:func:`emulated_motor`: the dynamics room's rotor, the sensing
room's field model, the control room's torque cache), so the hardware room imports none of them.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass

from .. import so3
from ..errors import bad_value

KINDS = ("port", "lockstep", "pty", "qemu", "relay port", "dry run", "simulated")
FIRMWARES = ("python", "qemu")  # the emulated motor's device: the Python CurrentDevice, or drive.cpp in QEMU
# The firmware in QEMU: its current loop at 1 kHz (the model steps the board once per period through QEMU, 0.1-0.3
# ms a step on a loaded 2-core machine: 4 kHz slipped), and 0.1 s for an answer on its UART0 (QEMU hands each
# received byte over between its threads: a 29-coil DRIVE took 3-10 ms at load 9-12, measured)
QEMU_PERIOD = 1e-3
QEMU_TIMEOUT = 0.1
EMULATED_DAMPING = 0.01  # N·m·s/rad: the emulated rotor's viscous damping (the drive room's emulated motor)


@dataclass
class Connection:
    """What :func:`connect` yields: the ``kind``, the ``link`` (protocol 2: ``drive``/``read``/``off``/``info``;
    protocol 1: a :class:`~spherestep.hardware.Backend`), for an emulated motor ``motor`` and its device's
    ``truth()`` (the :class:`~spherestep.hardware.Truth` now), ``timing`` (``clock``/``sleep`` for
    :func:`~spherestep.hardware.run_servo`: the simulated clock of ``"lockstep"``, else empty: the wall clock),
    the device's ``watchdog`` (s) and when it ``started`` (``time.monotonic()``; 0 on the simulated clock)."""

    kind: str
    link: object
    motor: object | None = None
    truth: Callable | None = None
    timing: dict | None = None
    watchdog: float | None = None
    started: float | None = None
    _release: Callable | None = None
    step_cost: Callable | None = None

    def release(self, seconds: float = 0.0):
        """Let go of the link (``OFF`` if it still answers, then close) and let ``seconds`` pass — emulated time
        in lockstep, the wall clock otherwise — so a watchdog trip after a lost link lands in the truth; returns
        the emulated motor's truth then (None on a real device)."""
        if self._release is not None:
            self._release()
            self._release = None
        if self.kind == "lockstep":
            self.link.sleep(seconds)
        elif seconds > 0:
            time.sleep(seconds)
        return None if self.truth is None else self.truth()


def session_kind(port: str | None = None, emulate: bool = False, lockstep: bool = False,
                 firmware: str = "python") -> str:
    """The kind (:data:`KINDS`) a servo session runs on: ``"port"`` for a serial device ``port``; with ``emulate``
    the emulated motor, ``"lockstep"`` on the simulated clock, ``"qemu"`` with the firmware in QEMU, else
    ``"pty"``. One of ``port`` and ``emulate``; ``lockstep`` and ``firmware`` other than ``"python"`` only with
    ``emulate`` and not together (InputError naming the field)."""
    if (port is None) == (not emulate):
        raise bad_value("port", "a serial device, or emulate=True (one of the two)", port)
    if lockstep and not emulate:
        raise bad_value("lockstep", "used only with emulate=True", lockstep)
    if firmware not in FIRMWARES or (firmware != "python" and (not emulate or lockstep)):
        raise bad_value("firmware", "python, or qemu with emulate=True and no lockstep", firmware)
    return "port" if not emulate else "lockstep" if lockstep else "qemu" if firmware == "qemu" else "pty"


def emulated_motor(design, plant, sensors, *, drive, R0=None, faults=None, rotor=None, period: float | None = None,
                   sensor_errors=None):
    """The :class:`~spherestep.hardware.EmulatedMotor` of ``design`` obeying the torque model ``plant``, its
    magnetometers ``sensors`` (:class:`~spherestep.sensing.SensorArray`), with the drive's limits ``drive``:
    ``rotor`` (default the design's, damping :data:`EMULATED_DAMPING`), the sensing room's
    :func:`~spherestep.sensing.field_model` at the sensors and the servo law's :class:`~spherestep.control.ModelCache`
    of ``plant``, exact (re-evaluated at every rotor step); ``R0`` the start, ``faults`` a :class:`~spherestep.hardware.MotorFaults`, ``period`` its device's
    current loop (s; default the emulator's). ``sensor_errors`` (:class:`~spherestep.sensing.SensorErrors`): the
    magnetometers as built — the true field at the turned array, read through each chip's offset and gain — while
    the host's estimator keeps the nominal ``sensors``."""
    from ..control import ModelCache
    from ..dynamics import Rotor
    from ..hardware import EmulatedMotor
    from ..sensing import FieldModel, FieldTable, SensorErrors, field_model

    rotor = Rotor.from_design(design, damping=EMULATED_DAMPING) if rotor is None else rotor
    field, chips = field_model(design, sensors.positions), None
    if sensor_errors is not None:
        if not isinstance(sensor_errors, SensorErrors):
            raise bad_value("sensor_errors", "a spherestep.sensing.SensorErrors (or None)", type(sensor_errors).__name__)
        sensors, chips = sensor_errors.placed(sensors), sensor_errors.read
        # the rotor's field at the turned positions exactly; on iron the cores' and the coils' field at the nominal
        # ones (their tables at other positions take minutes to build; a 0.1° turn moves a sensor 0.3 mm)
        field = (field_model(design, sensors.positions) if field.cores is None else
                 FieldModel(FieldTable.build(design, sensors.positions), field.cores, field.coils))
    return EmulatedMotor(design, plant, sensors, rotor=rotor, field=field,
                         torque_cache=ModelCache(plant, reuse=0.0), drive=drive, R0=R0, faults=faults, chips=chips,
                         **({} if period is None else {"period": period}))


def simulated_relays(design, model, start, *, rotor=None, dt: float = 5e-3, channels: int | None = None):
    """The :class:`~spherestep.hardware.Simulated` relay back end: the dynamics room's
    :class:`~spherestep.dynamics.Integrator` of ``design``'s rotor (``rotor``, default the design's) under
    ``model`` at step ``dt`` (s), at rest at ``start``, standing in for ``channels`` relays."""
    from ..dynamics import Integrator, Rotor
    from ..hardware import Simulated

    rotor = Rotor.from_design(design) if rotor is None else rotor
    return Simulated(Integrator(model, rotor, dt), len(design.stator), start, channels=channels)


@contextmanager
def connect(design, kind: str, *, port: str | None = None, plant=None, limits=None, sensors=None, R0=None,
            faults=None, watchdog_ms: int | None = None, rotor=None, channels: int | None = None, transcript=None,
            dt: float = 5e-3, channel_map=None, sensor_errors=None) -> Iterator[Connection]:
    """A :class:`Connection` of ``kind`` (module docstring) for ``design``, closed on leaving (every coil off).

    ``port``: the serial device (``"port"``, ``"relay port"``). The emulated motor (``"lockstep"``, ``"pty"``):
    ``plant`` the torque model it obeys, ``limits`` its :class:`~spherestep.electrics.DriveLimits`, ``sensors``
    its magnetometers, ``R0`` its start, ``faults`` (:class:`~spherestep.hardware.MotorFaults`), ``watchdog_ms``
    its device's watchdog, ``rotor`` (default the design's, damping :data:`EMULATED_DAMPING`), ``sensor_errors``
    its magnetometers as built (:func:`emulated_motor`). ``"simulated"``:
    ``plant`` the rotor's torque model, ``R0`` its start, ``rotor``, ``dt``, ``channels``. ``"dry run"``:
    ``channels``, ``transcript``; ``"relay port"``: ``transcript``. The relay kinds need the plan's
    ``channel_map`` (and take ``limits``' nominal current as the relays' current, default the default coils'):
    their link is a :class:`~spherestep.hardware.RelayLink`, opened and closed by
    :class:`~spherestep.hardware.CoilDriver`."""
    from .. import hardware

    if kind not in KINDS:
        raise bad_value("kind", f"one of {', '.join(KINDS)}", kind)
    if kind in ("port", "relay port") and not port:
        raise bad_value("port", f"a serial device for kind {kind!r}, such as /dev/ttyUSB0", port)
    device = {} if watchdog_ms is None else {"watchdog_ms": watchdog_ms}

    def relays(backend) -> Connection:  # protocol 1 behind the one Link; CoilDriver opens and closes it
        link = hardware.RelayLink(backend, channel_map, limits)
        return Connection(kind, link, timing={"clock": link.clock, "sleep": link.sleep})
    with ExitStack() as stack:
        inner = ExitStack()  # the host's link, let go before the device (Connection.release)
        if kind == "port":
            if limits is None:
                raise bad_value("limits", "the design's DriveLimits, which the device's handshake must agree with "
                                "(spherestep.magnetics.design_model(design).limits)", limits)
            stack.callback(inner.close)
            link = inner.enter_context(hardware.DriveLink(port))
            link.info.check_drive(limits, f"the device on {port}")
            yield Connection(kind, link, timing={}, watchdog=link.info.watchdog, _release=inner.close)
            return
        if kind in ("relay port", "dry run", "simulated") and channel_map is None:
            raise bad_value("channel_map", f"the plan's relay channel map for kind {kind!r} (Plan.channel_map)",
                            channel_map)
        if kind == "relay port":
            yield relays(hardware.Serial(port, transcript=transcript))
            return
        if kind == "dry run":
            yield relays(hardware.DryRun(**({} if channels is None else {"channels": channels}),
                                         transcript=transcript))
            return
        if plant is None:
            raise bad_value("plant", f"the torque model the rotor obeys (kind {kind!r})", plant)
        start = None if R0 is None else so3.as_rotations(R0, "R0").reshape(3, 3)
        if kind == "simulated":
            if start is None:
                raise bad_value("R0", "the simulated rotor's start (3×3, at rest)", R0)
            yield relays(simulated_relays(design, plant, start, rotor=rotor, dt=dt, channels=channels))
            return
        motor = emulated_motor(design, plant, sensors, drive=limits, R0=start, faults=faults, rotor=rotor,
                               period=QEMU_PERIOD if kind == "qemu" else None, sensor_errors=sensor_errors)
        if kind == "lockstep":
            link = stack.enter_context(hardware.LockstepLink(motor, **device))
            link.info.check_drive(motor.drive_limits, "the emulated device")
            yield Connection(kind, link, motor, link.truth, {"clock": link.clock, "sleep": link.sleep},
                             link.device.watchdog_ms / 1000, 0.0)
            return
        if kind == "qemu":
            from ..hardware.qemu import QemuMotor

            dev = stack.enter_context(QemuMotor(motor, **device))
            stack.callback(inner.close)  # after the device's exit is registered: the link closes first
            link = inner.enter_context(hardware.DriveLink(dev.port, timeout=QEMU_TIMEOUT))
            link.info.check_drive(motor.drive_limits, "the firmware in QEMU")
            yield Connection(kind, link, motor, dev.truth, {}, dev.watchdog_ms / 1000, dev.started, inner.close,
                             dev.step_cost)
            return
        dev = stack.enter_context(hardware.MotorPty(motor, **device))
        stack.callback(inner.close)  # after the device's exit is registered: the link closes first
        link = inner.enter_context(hardware.DriveLink(dev.port))
        link.info.check_drive(motor.drive_limits, "the emulated device")
        yield Connection(kind, link, motor, dev.truth, {}, dev.device.watchdog_ms / 1000, dev.started, inner.close)
