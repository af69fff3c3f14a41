"""The firmware run as firmware: ``drive.cpp`` and ``protocol.cpp`` built with ``arm-none-eabi-g++`` for QEMU's
``mps2-an500`` (a Cortex-M7) with the board layer ``firmware/qemu/board.cpp``, run in ``qemu-system-arm``.

* The host link is the board's UART0, a pseudo-terminal (``-serial pty``): :attr:`QemuBoard.port` is a serial
  device like a USB port, for :class:`~spherestep.hardware.DriveLink` as it is.
* The board's pins are a host-side model: the coil currents its ADCs would read, the duties its PWM would drive
  and the magnetometer counts live in the board's PSRAM, which QEMU backs with a file this module maps too
  (:data:`EXCHANGE`, the layout of ``board.cpp``'s ``Exchange``); one-byte doorbells on UART1 say what is in
  (``C`` configure, ``T`` currents and time in: one control step, ``W`` time in: the watchdog, ``F`` counts in)
  and what is out (``R`` configured, ``D`` duties and state out, ``S`` counts wanted).
* ``-icount shift=4,sleep=off``: QEMU counts instructions (2⁴ ns of virtual time each) and the board's SysTick
  (25 MHz) counts each control step; the board times a 100002-instruction loop once, so
  :meth:`QemuBoard.step_cost` gives instructions per step without trusting either clock.

:class:`QemuMotor` puts an :class:`~spherestep.hardware.motor_emulator.EmulatedMotor` behind the board, kept up
with the wall clock in a forked process as :class:`~spherestep.hardware.motor_emulator.MotorPty` keeps the Python
device, publishing the same :class:`~spherestep.hardware.pty_device.Truth`. Missing tools are one line saying
what to install (:func:`require_tools`).
"""

from __future__ import annotations

import hashlib
import mmap
import os
import select
import shutil
import signal
import sys
import subprocess
import tempfile
import threading
import time
import tty
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ComputationError, InputError, bad_value
from .backend import LinkError
from .pty_device import _MAX_TRIPS, DEVICE_RT_PRIORITY, STARTUP, Truth

FIRMWARE = Path(__file__).resolve().parents[3] / "firmware"
SOURCES = ("qemu/board.cpp", "spherestep/drive.cpp", "spherestep/protocol.cpp")
HEADERS = ("spherestep/drive.h", "spherestep/wire.h", "spherestep/protocol.h", "qemu/mps2_an500.ld")
CFLAGS = ("-mcpu=cortex-m7", "-mthumb", "-mfpu=fpv5-d16", "-mfloat-abi=hard", "-O2", "-std=gnu++17",
          "-fno-exceptions", "-fno-rtti", "-fno-threadsafe-statics", "-ffunction-sections", "-Wall", "-Wextra",
          "-Werror", "-nostartfiles", "-specs=nano.specs", "-specs=nosys.specs", "-Wl,--gc-sections")
ICOUNT_SHIFT = 4  # -icount shift: an instruction is 2^4 ns of virtual time
ICOUNT = ("-icount", f"shift={ICOUNT_SHIFT},sleep=off")
CALIBRATION_INSTRUCTIONS = 100002  # board.cpp's timed loop
PSRAM = 16 << 20  # bytes of the board's PSRAM (at 0x60000000), the exchange at its start
TRIP_CODES = ("", "WDOG", "CRCS", "OVER", "OPEN", "STUCK", "HEAT")
INSTALL = "Debian: apt-get install qemu-system-arm gcc-arm-none-eabi libnewlib-arm-none-eabi (as root: make browser)"

EXCHANGE = np.dtype([
    ("coils", "<u4"), ("sensors", "<u4"), ("watchdog_ms", "<u4"), ("period_us", "<u4"), ("nominal_ma", "<i4"),
    ("field_lsb_nt", "<u4"), ("limits", "<f8", 7), ("loop", "<f8", 3), ("name", "S20"),
    ("now_us", "<u4"), ("stale", "<u4"), ("ma", "<i4", 32), ("counts", "<i4", 48),
    ("enabled", "<u4"), ("version", "<u4"), ("trip", "<u4"), ("trip_coil", "<i4"), ("trips", "<u4"),
    ("duty", "<f4", 32), ("steps", "<u4"), ("max_ticks", "<u4"), ("sum_ticks", "<u8"), ("calibration", "<u4"),
    ("build", "S108"), ("received", "<u4"), ("answered", "<u4"), ("trip_us", "<u4"), ("off_us", "<u4")],
    align=True)


def require_tools(*tools: str) -> dict[str, str]:
    """The paths of ``tools`` (default the compiler and QEMU); an :class:`InputError` naming what is missing and
    how to install it otherwise."""
    tools = tools or ("arm-none-eabi-g++", "qemu-system-arm")
    found = {t: shutil.which(t) for t in tools}
    missing = [t for t, p in found.items() if p is None]
    if missing:
        error = InputError(f"--firmware qemu needs {' and '.join(missing)}, which "
                           f"{'is' if len(missing) == 1 else 'are'} not installed ({INSTALL})")
        error.field = "firmware"
        raise error
    return found


def build_firmware(cache: Path | None = None) -> Path:
    """The board's ELF image, built from :data:`SOURCES` with :data:`CFLAGS` into ``cache`` (default
    ``$XDG_CACHE_HOME/spherestep`` or ``~/.cache/spherestep``) under the hash of the sources and flags, so that a
    build is reused until a source changes (older builds are then removed); written atomically."""
    gxx = require_tools("arm-none-eabi-g++")["arm-none-eabi-g++"]
    digest = hashlib.sha256(" ".join(CFLAGS).encode())
    for name in SOURCES + HEADERS:
        digest.update((FIRMWARE / name).read_bytes())
    if cache is None:
        cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "spherestep"
    cache.mkdir(parents=True, exist_ok=True)
    elf = cache / f"spherestep-mps2-an500-{digest.hexdigest()[:16]}.elf"
    if elf.exists():
        return elf
    fd, partial = tempfile.mkstemp(suffix=".elf", dir=cache)
    os.close(fd)
    try:
        build = subprocess.run([gxx, *CFLAGS, "-I", str(FIRMWARE / "spherestep"), "-T",
                                str(FIRMWARE / "qemu" / "mps2_an500.ld"), *(str(FIRMWARE / s) for s in SOURCES),
                                "-lm", "-o", partial], capture_output=True, text=True, timeout=300)
        if build.returncode != 0:
            raise ComputationError(f"the firmware did not build for mps2-an500: {build.stderr.strip()[:400]}")
        os.replace(partial, elf)
        for old in cache.glob("spherestep-mps2-an500-*.elf"):  # builds of sources that have changed since
            if old != elf:
                old.unlink(missing_ok=True)
    finally:
        if os.path.exists(partial):
            os.unlink(partial)
    return elf


@dataclass(frozen=True)
class BoardState:
    """What the board drives after a step or a tick: bridges ``enabled``, protocol ``version`` of the session (0
    none), the last ``trip`` code ('' none) and its ``coil`` (−1 none), ``trips`` so far, ``duty`` (N,)."""

    enabled: bool
    version: int
    trip: str
    coil: int
    trips: int
    duty: np.ndarray


def _orphan_dies() -> None:
    """In QEMU's process before exec: SIGTERM when the process that started it dies (Linux; elsewhere nothing),
    so that a host killed outright leaves no board running."""
    try:
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except (AttributeError, OSError):
        pass


def _realtime() -> None:
    """As :func:`_orphan_dies`, and QEMU's threads at the device's real-time priority where the OS permits it (set
    before exec: inherited by every thread it starts), as the Python device's process is: the board answers
    before the host's loop asks."""
    _orphan_dies()
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(DEVICE_RT_PRIORITY))
    except (AttributeError, OSError):
        pass


class QemuBoard:
    """One ``qemu-system-arm -M mps2-an500`` running the firmware (``elf``, default :func:`build_firmware`):
    :attr:`port` the host link (UART0's pseudo-terminal); :meth:`configure` once, then :meth:`step` and
    :meth:`tick` at the model's times, :meth:`serve` between them (the magnetometers a reply asks for:
    ``sense()`` → ``(counts (S, 3), stale mask)``). ``timeout`` s: how long a doorbell may go unanswered before
    the board is taken for dead (:class:`LinkError`); ``realtime``: QEMU at ``SCHED_FIFO`` where permitted."""

    def __init__(self, elf: Path | None = None, *, timeout: float = 5.0, realtime: bool = True):
        self.elf, self.timeout, self.realtime = elf, float(timeout), bool(realtime)
        self.port: str | None = None
        self.build = ""
        self.coils = self.sensors = 0
        self._qemu: subprocess.Popen | None = None
        self._doorbells: int | None = None
        self._hold: int | None = None
        self._memory: mmap.mmap | None = None
        self._path: str | None = None
        self._rung = bytearray()

    # -- life --------------------------------------------------------------------------------------------------------
    def start(self) -> QemuBoard:
        """Start QEMU (a session of its own: a Ctrl-C at the terminal is the host's to handle, not QEMU's), find
        its two pseudo-terminals and map the exchange."""
        qemu = require_tools("qemu-system-arm")["qemu-system-arm"]
        elf = self.elf if self.elf is not None else build_firmware()
        fd, self._path = tempfile.mkstemp(prefix="spherestep-qemu-", dir="/dev/shm" if os.path.isdir("/dev/shm")
                                          else None)
        os.ftruncate(fd, PSRAM)  # its size now: QEMU opens it only after it has named its ptys
        os.close(fd)
        self._owner = os.getpid()
        self._qemu = subprocess.Popen(
            [qemu, "-M", "mps2-an500,memory-backend=psram", "-object",
             f"memory-backend-file,id=psram,size={PSRAM},mem-path={self._path},share=on", "-nographic",
             "-monitor", "none", "-serial", "pty", "-serial", "pty", *ICOUNT,
             "-kernel", str(elf)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            bufsize=0, start_new_session=True, preexec_fn=_realtime if self.realtime else _orphan_dies)
        try:
            ptys = self._ptys()
            self.port = ptys[0]
            self._doorbells = os.open(ptys[1], os.O_RDWR | os.O_NOCTTY)
            tty.setraw(self._doorbells)
            with open(self._path, "r+b") as f:
                self._memory = mmap.mmap(f.fileno(), PSRAM)
        except BaseException:
            self.stop()
            raise
        threading.Thread(target=self._drain, daemon=True).start()
        return self

    def _ptys(self) -> list[str]:
        """The two pseudo-terminals QEMU names in its first lines (UART0's, UART1's)."""
        out, text = self._qemu.stdout.fileno(), b""
        deadline = time.monotonic() + 10.0
        while text.count(b"redirected to /dev/") < 2 or not text.endswith(b"\n"):
            left = deadline - time.monotonic()
            chunk = os.read(out, 4096) if left > 0 and select.select([out], [], [], left)[0] else b""
            if not chunk:
                raise LinkError("qemu-system-arm did not start: "
                                f"{text.decode(errors='replace').strip()[-300:] or 'no output within 10 s'}")
            text += chunk
        lines = text.decode(errors="replace").splitlines()
        return [line.split("redirected to ")[1].split()[0] for line in lines if "redirected to /dev/" in line]

    def _drain(self) -> None:
        """Keep reading QEMU's output (its warnings, dropped), so that it never blocks on a full pipe."""
        for _ in self._qemu.stdout:
            pass

    def stop(self) -> None:
        """Stop QEMU and release the exchange (safe to call twice)."""
        if self._qemu is not None and os.getpid() == self._owner and self._qemu.poll() is None:
            self._qemu.terminate()
            try:
                self._qemu.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._qemu.kill()
                self._qemu.wait()
        for fd in (self._doorbells, self._hold):
            if fd is not None:
                os.close(fd)
        self._doorbells = self._hold = None
        if self._memory is not None:
            self._memory.close()
            self._memory = None
        if self._path is not None and os.path.exists(self._path):
            os.unlink(self._path)
        self._path = None

    def __enter__(self) -> QemuBoard:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def alive(self) -> bool:
        """Whether QEMU runs (asked by pid in a forked process, whose Popen cannot wait for it)."""
        if self._qemu is None:
            return False
        if os.getpid() == self._owner:
            return self._qemu.poll() is None
        try:
            os.kill(self._qemu.pid, 0)
        except OSError:
            return False
        return True

    @property
    def exchange(self) -> np.ndarray:
        """The exchange record (a view of the board's PSRAM: writes reach the board)."""
        return np.frombuffer(self._memory, dtype=EXCHANGE, count=1)[0]

    # -- doorbells ---------------------------------------------------------------------------------------------------
    def configure(self, coils: int, sensors: int, *, watchdog_ms: int, period_us: int, limits, supply: float,
                  inductance: float, bandwidth: float, nominal_ma: int, field_lsb_nt: int, name: str) -> str:
        """Build the board's device (``CurrentDevice`` of drive.h with these settings, ``limits`` a
        :class:`~spherestep.hardware.limits.CurrentLimits`); returns the firmware's build line."""
        x = self.exchange
        x["coils"], x["sensors"], x["watchdog_ms"], x["period_us"] = coils, sensors, watchdog_ms, period_us
        x["nominal_ma"], x["field_lsb_nt"], x["name"] = nominal_ma, field_lsb_nt, name.encode()
        x["limits"] = (limits.max_current, limits.max_duty, limits.max_power, limits.continuous_current,
                       limits.thermal_time, limits.resistance, limits.trip_ratio)
        x["loop"] = (supply, inductance, bandwidth)
        self.coils, self.sensors = coils, sensors
        self._ring(b"C", b"R", None)
        os.unlink(self._path)  # both have it mapped now (the board answered from it): nothing left behind
        self._path = None
        self.build = x["build"].decode()
        self._connect()
        return self.build

    def _connect(self) -> None:
        """Hold the host link's pseudo-terminal open from here on and wait until QEMU reads it: QEMU looks for a
        reader of a pty it found closed only once a second, and until then what the host sends waits (the first
        HELLO took up to a second, while an iron rotor drifted off its start). Carriage returns outside a frame
        are ignored by the firmware's frame reader; it counts them as received."""
        self._hold = os.open(self.port, os.O_RDWR | os.O_NOCTTY)
        tty.setraw(self._hold)
        deadline, written = time.monotonic() + 3.0, 0
        while self.received() < max(written, 1):  # until it has read one, and then every one sent
            if time.monotonic() > deadline or not self.alive():
                raise LinkError("the firmware in QEMU does not read its host link (UART0) after 3 s")
            if self.received() == 0:
                os.write(self._hold, b"\r")
                written += 1
            time.sleep(0.01)

    def step(self, now_us: int, ma, sense=None) -> BoardState:
        """One control step at ``now_us`` with the coil currents ``ma`` (integer mA, (N,))."""
        x = self.exchange
        x["now_us"] = now_us & 0xFFFFFFFF
        x["ma"][:self.coils] = np.asarray(ma)
        self._ring(b"T", b"D", sense)
        return self.state()

    def tick(self, now_us: int, sense=None) -> BoardState:
        """The board's time set to ``now_us`` and its watchdog run (no control step)."""
        self.exchange["now_us"] = now_us & 0xFFFFFFFF
        self._ring(b"W", b"D", sense)
        return self.state()

    def state(self) -> BoardState:
        x = self.exchange
        return BoardState(bool(x["enabled"]), int(x["version"]), TRIP_CODES[int(x["trip"])], int(x["trip_coil"]),
                          int(x["trips"]), x["duty"][:self.coils].astype(float))

    def serve(self, sense, wait: float = 0.0) -> None:
        """Answer the board's requests for the magnetometers (``sense``) for up to ``wait`` s."""
        deadline = time.monotonic() + wait
        while True:
            left = deadline - time.monotonic()
            if self._rung:
                self._answer(self._rung.pop(0), sense)
            elif select.select([self._doorbells], [], [], max(0.0, left))[0]:
                self._rung += os.read(self._doorbells, 64)
            elif left <= 0:
                return

    def received(self) -> int:
        """Bytes the board has taken from the host link, each after its reply went out."""
        return int(self.exchange["received"])

    def answered(self) -> int:
        """Bytes the board has put on the host link."""
        return int(self.exchange["answered"])

    def step_cost(self) -> tuple[int, float, float]:
        """``(steps, mean, max)``: the control steps that drove the coils and their instructions (the SysTick
        counts scaled by the calibration loop's 100002 instructions)."""
        x = self.exchange
        per_tick = CALIBRATION_INSTRUCTIONS / max(int(x["calibration"]), 1)
        steps = int(x["steps"])
        return steps, int(x["sum_ticks"]) * per_tick / max(steps, 1), int(x["max_ticks"]) * per_tick

    def _answer(self, doorbell: int, sense) -> None:
        if doorbell != ord("S"):
            raise LinkError(f"the firmware in QEMU rang {bytes([doorbell])!r} unasked")
        if sense is None:
            raise LinkError("the firmware in QEMU asked for the magnetometers where none are served")
        counts, stale = sense()
        x = self.exchange
        x["counts"][:3 * self.sensors] = np.asarray(counts).reshape(-1)
        x["stale"] = stale
        os.write(self._doorbells, b"F")

    def _ring(self, doorbell: bytes, answer: bytes, sense) -> None:
        os.write(self._doorbells, doorbell)
        deadline = time.monotonic() + self.timeout
        while True:
            while self._rung:
                b = self._rung.pop(0)
                if b == answer[0]:
                    return
                self._answer(b, sense)
            left = deadline - time.monotonic()
            if left <= 0 or not self.alive():
                raise LinkError(f"the firmware in QEMU did not answer {doorbell.decode()!r} within "
                                f"{self.timeout:g} s{'' if self.alive() else ' (QEMU has exited)'}")
            if select.select([self._doorbells], [], [], left)[0]:
                self._rung += os.read(self._doorbells, 64)


PUBLISH_EVERY = 2e-3  # s of emulated time between two publications of the truth (as MotorPty)
MAX_CATCH_UP = 0.01  # s: a model further behind the wall clock lets emulated time slip instead (as MotorPty)


class QemuMotor:
    """The firmware in QEMU driving ``motor`` (an :class:`~spherestep.hardware.motor_emulator.EmulatedMotor`):
    a :class:`QemuBoard` configured with :func:`~spherestep.hardware.motor_emulator.matching_device_options`
    (overridden by ``device_options``: ``watchdog_ms``, ``limits``...), the motor as its pins in a forked process
    that runs one board step per ``motor.period`` of emulated time kept up with the wall clock (``MAX_CATCH_UP``,
    then emulated time slips), answering the board's requests for the magnetometers in between. :attr:`port` is
    the host link; :meth:`truth` the :class:`~spherestep.hardware.pty_device.Truth`, as from ``MotorPty``. The
    motor's coil and sensor faults apply; its line faults (``vanish_at``, ``deaf_at``, ``slow_answers``) belong
    to the Python device's pseudo-terminal and are refused here."""

    def __init__(self, motor, *, elf: Path | None = None, realtime: bool = True, **device_options):
        import multiprocessing as mp

        from .current_device import CurrentDevice
        from .motor_emulator import matching_device_options

        f = motor.faults
        for name in ("vanish_at", "deaf_at", "slow_answers"):
            if getattr(f, name) is not None:
                raise bad_value(f"faults.{name}", "None with the firmware in QEMU (a line fault of the Python "
                                "device's pseudo-terminal; stop the host instead)", getattr(f, name))
        options = {**matching_device_options(motor), "watchdog_ms": 100, "name": "spherestep-qemu",
                   **device_options}
        CurrentDevice(motor, len(motor.design.stator), len(motor.sensors), **options)  # the same checks
        self.motor, self.options, self.realtime = motor, options, bool(realtime)
        self.watchdog_ms = int(options["watchdog_ms"])
        self.board = QemuBoard(elf, realtime=realtime)
        self.started: float | None = None
        self.port: str | None = None
        n = len(motor.i)
        ctx = mp.get_context("fork")
        self._shared = ctx.Array("d", 9 + 3 + n + 5 + 3 * _MAX_TRIPS, lock=True)
        self._stop = ctx.Event()
        self._runner = ctx.Process(target=self._serve, name="QemuMotor", daemon=True)

    def start(self) -> QemuMotor:
        """Start QEMU, configure the board, fork the model's process; returns self once it has run ``STARTUP`` s
        of emulated time idle (as ``MotorPty``)."""
        m, o = self.motor, self.options
        self.board.start()
        try:
            self.port = self.board.port
            self.board.configure(len(m.design.stator), len(m.sensors), watchdog_ms=o["watchdog_ms"],
                                 period_us=o["period_us"], limits=o["limits"], supply=o["supply"],
                                 inductance=o["inductance"], bandwidth=o["bandwidth"], nominal_ma=o["nominal_ma"],
                                 field_lsb_nt=o["field_lsb_nt"], name=o["name"])
            m.warm_up()
            self._trips: list[tuple[str, int, float]] = []
            self._slip = 0.0
            self._publish()
            self.started = time.monotonic() - m.t
            self._runner.start()
            deadline = time.monotonic() + 2.0  # the forked process's first steps copy its pages: let it settle
            while self.truth().t < STARTUP and time.monotonic() < deadline and self._runner.is_alive():
                time.sleep(0.005)
            if not self._runner.is_alive():
                raise LinkError("the motor model of the firmware in QEMU stopped at its start")
        except BaseException:
            self.stop()
            raise
        return self

    def stop(self) -> None:
        """Stop the model's process and QEMU."""
        self._stop.set()
        if self._runner.is_alive():
            self._runner.join(timeout=5)
            if self._runner.is_alive():
                self._runner.kill()
                self._runner.join()
        self.board.stop()

    def __enter__(self) -> QemuMotor:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def step_cost(self) -> tuple[int, float, float]:
        """:meth:`QemuBoard.step_cost` (read while QEMU runs)."""
        return self.board.step_cost()

    def truth(self) -> Truth:
        """The emulated motor now, as the model's process last published it."""
        n = len(self.motor.i)
        with self._shared.get_lock():
            v = np.array(self._shared[:])
        count = int(v[14 + n])
        rows = v[17 + n:].reshape(_MAX_TRIPS, 3)[:min(count, _MAX_TRIPS)]
        trips = tuple((TRIP_CODES[int(c)], int(k), float(t)) for c, k, t in rows)
        return Truth(v[:9].reshape(3, 3), v[9:12], v[12:12 + n], float(v[12 + n]), bool(v[13 + n]),
                     float(v[15 + n]), float(v[16 + n]), trips)

    def _publish(self) -> None:
        m = self.motor
        m.sync()
        rows = [(TRIP_CODES.index(c), k, t) for c, k, t in self._trips[:_MAX_TRIPS]]
        rows += [(0.0, 0.0, 0.0)] * (_MAX_TRIPS - len(rows))
        off_at = int(self.board.exchange["off_us"]) * 1e-6
        values = np.concatenate([m.R.ravel(), m.w, m.i, [m.t, float(m.enabled), len(self._trips), off_at,
                                                         self._slip], np.ravel(rows)])
        with self._shared.get_lock():
            self._shared[:] = values.tolist()

    def _step(self) -> None:
        """One period of the coils, then one board step at the new time with the currents they carry."""
        m = self.motor
        m.advance_to(m.t + m.period)
        s = self.board.step(round(m.t * 1e6), m.measure(), m.sense)
        m.drive(s.duty, s.enabled)
        if s.trips > len(self._trips):  # at a step or on a frame since: the board's time of the trip
            self._trips.append((s.trip, s.coil, int(self.board.exchange["trip_us"]) * 1e-6))

    def _serve(self) -> None:
        """The model's process: board steps up to the wall clock, the magnetometers between them."""
        import gc

        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the host switches the coils off, then stops this process
        signal.signal(signal.SIGTERM, signal.SIG_DFL)
        if self.realtime:
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(DEVICE_RT_PRIORITY))
            except (AttributeError, OSError):
                pass
            gc.disable()
        m, t0, published = self.motor, self.started, self.motor.t
        try:
            while not self._stop.is_set():
                t = time.monotonic() - t0
                if t > m.t + MAX_CATCH_UP:  # starved: emulated time slips, no burst
                    self._slip += t - (m.t + MAX_CATCH_UP)
                    t0 += t - (m.t + MAX_CATCH_UP)
                    t = m.t + MAX_CATCH_UP
                while m.t + m.period <= t + 1e-12:
                    self._step()
                if m.t - published >= PUBLISH_EVERY:
                    self._publish()
                    published = m.t
                self.board.serve(m.sense, max(0.0, m.t + m.period - (time.monotonic() - t0)))
        except LinkError as exc:
            self._publish()  # the board is gone (QEMU stopped): the host sees the link fail
            if not self._stop.is_set():
                print(f"spherestep: the motor model stopped: {exc}", file=sys.stderr)
