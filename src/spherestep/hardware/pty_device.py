"""The one pseudo-terminal server: a :class:`~spherestep.hardware.current_device.CurrentDevice` on the master end
of ``os.openpty()``, so that a host opens :attr:`PtyDevice.port` like a USB serial adapter. POSIX only.

One server, two clocks:

* the device alone (by default the relay board of ``protocol.cpp``, :meth:`CurrentDevice.relay_board`) runs on
  the wall clock in a daemon thread of this process; its watchdog ticks at least every 10 ms and its state is
  read directly (:meth:`PtyDevice.state`, :attr:`PtyDevice.device`);
* a device whose bridges are an emulated motor (``motor``, an
  :class:`~spherestep.hardware.motor_emulator.EmulatedMotor`) runs in a forked process, as a board does not
  share the host's interpreter and its lock: the device's control step every ``motor.period`` of emulated time,
  kept up with the wall clock, catching up at most ``MAX_CATCH_UP`` when the process was held up (beyond that
  emulated time slips, so that the host never meets a motor that ran 10 ms unattended in a burst); it publishes
  the :class:`Truth` (:meth:`PtyDevice.truth`). :class:`~spherestep.hardware.motor_emulator.MotorPty` builds
  this server for a motor with the matching device.

Frames are answered as they complete, at the device's time. Line faults by frame number (:class:`Faults`) apply
to either; a motor's faults by time (``vanish_at``, ``deaf_at``, ``slow_answers`` of
:class:`~spherestep.hardware.motor_emulator.MotorFaults`) to a motor's. Try a plan without hardware
(``connect`` is :func:`spherestep.drive.connect`)::

    with PtyDevice(channels=32) as dev, connect(None, "relay port", port=dev.port,
                                                channel_map=plan.channel_map) as conn, CoilDriver(conn.link) as driver:
        driver.apply(plan.steps[0], duration=0.2)
        driver.hold(0.2)

See also ``docs/protocol.md``.
"""

from __future__ import annotations

import gc
import os
import select
import signal
import threading
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import bad_value
from .current_device import CurrentDevice

if TYPE_CHECKING:
    from .motor_emulator import EmulatedMotor

_TRIP_ORDER = ("WDOG", "CRCS", "OVER", "OPEN", "STUCK", "HEAT")
_MAX_TRIPS = 8
STARTUP = 0.2  # s of emulated time a motor's device process runs idle before start() returns
DEVICE_RT_PRIORITY = 30  # above the host loop's (spherestep.hardware.servo.RT_PRIORITY): the device answers first
PUBLISH_EVERY = 2e-3  # s of emulated time between two publications of the truth
WAKE_EVERY = 1e-3  # s: a motor's device process sleeps at most this long between steps when no frame arrives
IDLE_WAIT = 0.01  # s: the device alone sleeps at most this long between two ticks of its watchdog
MAX_CATCH_UP = 0.01  # s: when the process falls further behind the wall clock, emulated time slips instead


@dataclass(frozen=True)
class Faults:
    """Line faults a :class:`PtyDevice` injects, by the 0-based number of the frame it receives.

    ``corrupt``: one bit of the frame's middle byte flipped (→ NAK). ``drop``: the second half of the frame,
    end of line included, lost (→ no answer until the host retransmits). ``mute``: the frame is obeyed but
    the answer lost. ``garble_reply``: the answer has one byte flipped. ``delay``: frame number → seconds the
    answer is held back. ``silent_after``: from this frame on nothing is read or answered (the device hangs;
    its watchdog still runs). ``vanish_after``: on this frame the device closes its end of the line.
    """

    corrupt: frozenset[int] = frozenset()
    drop: frozenset[int] = frozenset()
    mute: frozenset[int] = frozenset()
    garble_reply: frozenset[int] = frozenset()
    delay: tuple[tuple[int, float], ...] = ()
    silent_after: int | None = None
    vanish_after: int | None = None


def _flip_middle(data: bytes) -> bytes:
    """``data`` with bit 1 of its middle byte flipped (never touching ``$`` or the end of line)."""
    i = len(data) // 2
    return data[:i] + bytes([data[i] ^ 0x02]) + data[i + 1:]


@dataclass(frozen=True)
class Truth:
    """The emulated motor as the device process last published it: orientation ``R``, angular velocity ``w``
    (rad/s), coil currents ``i`` (A), emulated time ``t`` (s, from :attr:`PtyDevice.started`), bridges
    ``enabled``, ``off_at`` (s) the last time the coils went from driven to off, ``slip`` (s) how far emulated
    time has fallen behind the wall clock (the process was starved), and the device's ``trips``
    ``(code, coil, time s)``: emulated time ``t`` is wall time ``− started − slip``."""

    R: np.ndarray
    w: np.ndarray
    i: np.ndarray
    t: float
    enabled: bool
    off_at: float
    slip: float
    trips: tuple[tuple[str, int, float], ...]


class PtyDevice:
    """``device`` (default: :meth:`CurrentDevice.relay_board` of ``channels``, ``watchdog_ms``, ``name``) on a
    pseudo-terminal, with line ``faults``; the host opens :attr:`port`. A device with bridges needs them to be the
    emulated ``motor`` (nothing else would move its currents). With ``motor`` it
    runs in a forked process, asking with ``realtime`` for ``SCHED_FIFO`` scheduling (``DEVICE_RT_PRIORITY``,
    where the OS permits it) with its garbage collector paused, as the firmware runs on its own core; see the
    module. The device's time runs from :meth:`start` (:attr:`started`, ``time.monotonic()`` at device time 0).

    Serves from :meth:`start` (or ``with``) to :meth:`stop`. The watchdog keeps running after a line fault, as
    it would on a powered board whose link is gone. ``frames`` counts the frames received (by the thread: a
    motor's device process counts its own).
    """

    def __init__(self, device: CurrentDevice | None = None, faults: Faults | None = None, *,
                 motor: EmulatedMotor | None = None, realtime: bool = True, channels: int = 32,
                 watchdog_ms: int = 500, name: str = "spherestep-emu"):
        import multiprocessing as mp
        import tty  # POSIX only, like pseudo-terminals themselves

        if device is None:
            if motor is not None:
                raise bad_value("device", "the CurrentDevice whose bridges are the motor", device)
            device = CurrentDevice.relay_board(channels, watchdog_ms, name)
        if device.bridges is not motor:  # what would advance bridges that are not an emulated motor's?
            raise bad_value("motor", "the device's bridges (an EmulatedMotor), or None with a relay board",
                            type(motor).__name__)
        self.device, self.motor = device, motor
        self.faults = faults if faults is not None else Faults()
        self.realtime = bool(realtime)
        self.frames = 0
        self.started: float | None = None
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._lock = threading.Lock()
        self._lines = bytearray()
        self._pending: list[tuple[float, bytes]] = []
        self._slip = 0.0
        if motor is None:
            self._stop = threading.Event()
            self._runner = threading.Thread(target=self._serve, name=f"PtyDevice {self.port}", daemon=True)
        else:
            ctx = mp.get_context("fork")
            self._shared = ctx.Array("d", 9 + 3 + len(motor.i) + 5 + 3 * _MAX_TRIPS, lock=True)
            self._stop = ctx.Event()
            self._runner = ctx.Process(target=self._serve, name=f"PtyDevice {self.port}", daemon=True)

    # -- the host's side ----------------------------------------------------------------------------------------
    def now_us(self) -> int:
        """The device's clock, µs: the emulated motor's time, or the wall clock since :meth:`start`."""
        if self.motor is not None:
            return round(self.motor.t * 1e6)
        return round((time.monotonic() - self.started) * 1e6)

    def state(self) -> tuple[int, int]:
        """``(enable, polarity)`` masks now set, read consistently with the device thread (the device alone; a
        motor's device lives in its own process: see :meth:`truth`)."""
        with self._lock:
            return self.device.enable, self.device.polarity

    def truth(self) -> Truth:
        """The emulated motor now, as its device process last published it (see :class:`Truth`)."""
        if self.motor is None:
            raise bad_value("motor", "an emulated motor (only a motor's device process publishes its truth)", None)
        n = len(self.motor.i)
        with self._shared.get_lock():
            v = np.array(self._shared[:])
        count = int(v[14 + n])
        rows = v[17 + n:].reshape(_MAX_TRIPS, 3)[:min(count, _MAX_TRIPS)]
        trips = tuple((_TRIP_ORDER[int(c)], int(k), float(t)) for c, k, t in rows)
        return Truth(v[:9].reshape(3, 3), v[9:12], v[12:12 + n], float(v[12 + n]), bool(v[13 + n]),
                     float(v[15 + n]), float(v[16 + n]), trips)

    def start(self) -> PtyDevice:
        """Start serving; returns self (with a motor, once its process has run ``STARTUP`` s idle)."""
        m = self.motor
        if m is None:
            self.started = time.monotonic()
            self._runner.start()
            return self
        m.warm_up()  # first calls (caches, compiled code) here, inherited by the device process
        self._publish()
        self.started = time.monotonic() - m.t
        self._runner.start()
        # the forked process's first steps touch (and copy) its pages: milliseconds to tens of them on a busy
        # machine. Let that happen before a host talks to it — the device idles, coils off, for STARTUP s.
        deadline = time.monotonic() + 10 * STARTUP
        while self.truth().t < STARTUP and time.monotonic() < deadline and self._runner.is_alive():
            time.sleep(0.005)
        return self

    def stop(self) -> None:
        """Stop serving and close both ends of the pseudo-terminal."""
        self._stop.set()
        if self._runner.is_alive():
            self._runner.join(timeout=5)
            if self._runner.is_alive() and self.motor is not None:
                self._runner.kill()
                self._runner.join()
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None

    def __enter__(self) -> PtyDevice:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # -- the device's side (the thread, or the forked process) --------------------------------------------------
    def _close_master(self) -> None:
        os.close(self._master)
        self._master = None

    def _listening(self, t: float) -> bool:
        """Whether the device reads the line at time ``t`` (s): not gone, hung (``silent_after``) or deaf."""
        f = self.faults
        if self._master is None or (f.silent_after is not None and self.frames >= f.silent_after):
            return False
        deaf_at = None if self.motor is None else self.motor.faults.deaf_at
        return deaf_at is None or t < deaf_at

    def _frames_in(self, data: bytes) -> list[bytes]:
        """Split received bytes at each end of line, keeping the line ending."""
        self._lines.extend(data)
        out = []
        while (i := self._lines.find(b"\n")) >= 0:
            out.append(bytes(self._lines[:i + 1]))
            del self._lines[:i + 1]
        return out

    def _answer(self, listening: bool) -> None:
        """Take the frames waiting on the line at the device's time now."""
        if not listening or not select.select([self._master], [], [], 0)[0]:
            return
        try:
            data = os.read(self._master, 4096)
        except OSError:  # no host has the slave open: nothing to read yet
            self._stop.wait(0.002)
            return
        silent_after = self.faults.silent_after
        for raw in self._frames_in(data):
            if self._master is None or (silent_after is not None and self.frames >= silent_after):
                break
            self._handle(raw)

    def _handle(self, raw: bytes) -> None:
        n = self.frames
        self.frames += 1
        f = self.faults
        if f.vanish_after is not None and n >= f.vanish_after:
            self._close_master()
            return
        if n in f.corrupt:
            raw = _flip_middle(raw)
        if n in f.drop:
            raw = raw[:len(raw) // 2]
        with self._lock:
            reply = self.device.receive(raw, self.now_us())
        if not reply or n in f.mute:
            return
        if n in f.garble_reply:
            reply = _flip_middle(reply)
        if self.motor is not None and (stall := self.motor.faults.answer_delay(self.motor.t)) > 0:
            time.sleep(stall)  # a starved device: the process stalls before it answers
        self._pending.append((time.monotonic() + dict(f.delay).get(n, 0.0), reply))
        self._flush()

    def _flush(self) -> None:
        """Write the answers whose time has come."""
        now = time.monotonic()
        while self._master is not None and self._pending and self._pending[0][0] <= now:
            try:
                os.write(self._master, self._pending.pop(0)[1])
            except OSError:  # the host has gone
                pass

    def _steps_to(self, t: float, listening: bool) -> None:
        """A motor's control steps up to emulated time ``t``, answering frames between steps as they come."""
        m, dev = self.motor, self.device
        while m.t + m.period <= t + 1e-12:
            self._answer(listening)
            m.advance_to(m.t + m.period)
            dev.step(round(m.t * 1e6))

    def _publish(self) -> None:
        m = self.motor
        m.sync()  # the rotor brought up to the coils' time, as truth_of does in lockstep
        trips = self.device.trips[:_MAX_TRIPS]
        rows = [(_TRIP_ORDER.index(c), k, us * 1e-6) for c, k, us in trips]
        rows += [(0.0, 0.0, 0.0)] * (_MAX_TRIPS - len(rows))
        values = np.concatenate([m.R.ravel(), m.w, m.i, [m.t, float(m.enabled), len(self.device.trips),
                                                         self.device.off_us * 1e-6, self._slip], np.ravel(rows)])
        with self._shared.get_lock():
            self._shared[:] = values.tolist()

    def _serve(self) -> None:
        """Bring the device up to the clock (the watchdog alone; with a motor its control steps, answering frames
        between steps), answer what has come, then wait for bytes. Frames are taken at the earliest time they
        can have arrived, so that a stall of a motor's process (not of the host) does not trip the watchdog.
        The host's Ctrl-C reaches that process too (one process group): it is ignored there, and the host stops
        the device after switching the coils off."""
        m = self.motor
        if m is not None:
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            if self.realtime:  # a microcontroller's loop: real-time scheduling where the OS permits it
                try:
                    os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(DEVICE_RT_PRIORITY))
                except (AttributeError, OSError):
                    pass
                gc.disable()
        vanish_at = None if m is None else m.faults.vanish_at
        t0 = self.started
        published = 0.0 if m is None else m.t
        while not self._stop.is_set():
            t = time.monotonic() - t0
            if m is not None and t > m.t + MAX_CATCH_UP:  # starved by the machine: emulated time slips, no burst
                self._slip += t - (m.t + MAX_CATCH_UP)
                t0 += t - (m.t + MAX_CATCH_UP)
                t = m.t + MAX_CATCH_UP
            if self._master is not None and vanish_at is not None and t >= vanish_at:
                self._close_master()
            self._flush()
            listening = self._listening(t)
            self._answer(listening)
            if m is None:
                with self._lock:
                    self.device.tick(self.now_us())
                wait = IDLE_WAIT
            else:
                self._steps_to(t, listening)
                if m.t - published >= PUBLISH_EVERY:
                    self._publish()
                    published = m.t
                # wake for a frame at once, else every WAKE_EVERY s at most (the steps due are caught up on
                # waking): a 4 kHz current loop need not wake the process 4000 times a second on a shared machine
                wait = max(m.period, WAKE_EVERY)
            if self._pending:
                wait = min(wait, max(0.0, self._pending[0][0] - time.monotonic()))
            if listening and self._master is not None:
                select.select([self._master], [], [], wait)
            else:
                self._stop.wait(wait)
