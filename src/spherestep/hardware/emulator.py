"""A coil controller in Python: the reference firmware's state machine, served on a pseudo-terminal.

:class:`Emulator` is a line-for-line counterpart of ``firmware/spherestep/protocol.cpp`` (both pass
``firmware/test/vectors.txt``): times are integer milliseconds like the firmware's ``millis()``, outputs are
the enable and polarity relay masks. :class:`PtyDevice` runs one on the master end of ``os.openpty()`` so that
a host opens the slave's tty name like a USB serial adapter, with optional :class:`Faults` injected on the
line. Use it to try a plan without hardware::

    with PtyDevice(channels=32) as dev, CoilDriver(Serial(dev.port), plan.channel_map) as driver:
        driver.apply(plan.steps[0], duration=0.2)
        driver.hold(0.2)

See also ``docs/protocol.md``.
"""

from __future__ import annotations

import os
import select
import threading
import time
from collections import deque
from dataclasses import dataclass

from .. import checks
from ..errors import bad_value
from .protocol import MAX_MASK_DIGITS, VERSION, FrameError, LineReader, decode, encode, format_mask, parse_decimal, \
    parse_hex

_NAME_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789._-")


class Emulator:
    """The device state machine: parse frames, answer ACK/NAK, drive outputs, run the watchdog.

    ``channels`` relay channels (1–64), watchdog period ``watchdog_ms`` (> 0), ``name`` reported in the
    handshake. ``enable``/``polarity`` are the relay masks now driven; ``trace`` the last 4096 output writes as
    ``("enable" | "polarity", mask)`` in the order the relays were switched (polarity relays only move while
    every enable relay is open).
    """

    def __init__(self, channels: int = 32, watchdog_ms: int = 500, name: str = "spherestep-emu"):
        channels = checks.count(channels, "channels", 1, 4 * MAX_MASK_DIGITS, expected="an integer 1..64")
        watchdog_ms = checks.count(watchdog_ms, "watchdog_ms", 1, 65535, expected="an integer 1..65535 (milliseconds)")
        if not 1 <= len(name) <= 16 or not set(name) <= _NAME_CHARS:
            raise bad_value("name", "1-16 characters from A-Z a-z 0-9 . _ -", name)
        self.channels = channels
        self.watchdog_ms = watchdog_ms
        self.name = name
        self.enable = 0
        self.polarity = 0
        self.session = False
        self.tripped = False
        self.trips = 0
        self.last_valid_ms = 0
        self.trace: deque[tuple[str, int]] = deque(maxlen=4096)
        self._reader = LineReader()
        self._all_off()

    def receive(self, data: bytes, now_ms: int) -> bytes:
        """Consume received bytes at time ``now_ms``; return the replies (complete frames) to send back."""
        return b"".join(self._process(body, now_ms) for body in self._reader.feed(data))

    def tick(self, now_ms: int) -> None:
        """Watchdog: no accepted command for ``watchdog_ms`` during a session → all off, session over."""
        if self.session and now_ms - self.last_valid_ms >= self.watchdog_ms:
            self._all_off()
            self.session = False
            self.tripped = True
            self.trips += 1

    def _set_enable(self, mask: int) -> None:
        self.enable = mask
        self.trace.append(("enable", mask))

    def _set_polarity(self, mask: int) -> None:
        self.polarity = mask
        self.trace.append(("polarity", mask))

    def _all_off(self) -> None:
        self._set_enable(0)
        self._set_polarity(0)

    def _apply(self, enable: int, polarity: int) -> None:
        if polarity != self.polarity:
            if self.enable:
                self._set_enable(0)
            self._set_polarity(polarity)
        if enable != self.enable:
            self._set_enable(enable)

    def _process(self, body: bytes, now_ms: int) -> bytes:
        self.tick(now_ms)
        try:
            frame = decode(body)
        except FrameError as exc:
            return encode(None, "NAK", exc.code)
        if frame.seq is None:
            return encode(None, "NAK", "FRAME")
        seq, verb, args = frame.seq, frame.verb, frame.args

        def nak(code: str) -> bytes:
            return encode(seq, "NAK", code)

        def accepted(*data: object) -> bytes:
            if self.session:
                self.last_valid_ms = now_ms
            return encode(seq, "ACK", verb, *data)

        def no_session() -> bytes:
            return nak("WDOG" if self.tripped else "SESSION")

        if verb == "HELLO":
            version = parse_decimal(args[0], 3) if len(args) == 1 else None
            if version is None:
                return nak("ARGS")
            if version != VERSION:
                return nak("VERSION")
            self._all_off()
            self.session, self.tripped = True, False
            return accepted(VERSION, self.channels, self.watchdog_ms, self.name)
        if verb == "SET":
            masks = [parse_hex(a, 1, MAX_MASK_DIGITS) for a in args] if len(args) == 2 else [None]
            if None in masks:
                return nak("ARGS")
            if not self.session:
                return no_session()
            enable, polarity = masks
            if (enable | polarity) >> self.channels:
                return nak("RANGE")
            self._apply(enable, polarity)
            return accepted(format_mask(self.enable), format_mask(self.polarity))
        if verb == "OFF":
            if args:
                return nak("ARGS")
            self._all_off()
            return accepted(0, 0)
        if verb == "PING":
            if args:
                return nak("ARGS")
            if not self.session:
                return no_session()
            return accepted(format_mask(self.enable), format_mask(self.polarity))
        return nak("VERB")


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


class PtyDevice:
    """An :class:`Emulator` on the master end of a pseudo-terminal; the host opens :attr:`port`.

    Runs a daemon thread from :meth:`start` (or ``with``) to :meth:`stop`. The watchdog keeps running after a
    ``vanish_after`` or ``silent_after`` fault, as it would on a powered board whose link is gone.
    ``frames`` counts the frames received.
    """

    def __init__(self, emulator: Emulator | None = None, faults: Faults | None = None, *, channels: int = 32,
                 watchdog_ms: int = 500, name: str = "spherestep-emu"):
        self.emulator = emulator if emulator is not None else Emulator(channels, watchdog_ms, name)
        self.faults = faults or Faults()
        self.frames = 0
        import tty  # POSIX only, like pseudo-terminals themselves

        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)
        self.port = os.ttyname(self._slave)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._serve, name=f"PtyDevice {self.port}", daemon=True)
        self._t0 = time.monotonic()
        self._lock = threading.Lock()
        self._lines = bytearray()
        self._pending: list[tuple[float, bytes]] = []

    def now_ms(self) -> int:
        """Milliseconds since this device was created (its ``millis()``)."""
        return int((time.monotonic() - self._t0) * 1000)

    def state(self) -> tuple[int, int]:
        """``(enable, polarity)`` masks now driven, read consistently with the device thread."""
        with self._lock:
            return self.emulator.enable, self.emulator.polarity

    def start(self) -> PtyDevice:
        """Start serving; returns self."""
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close both ends of the pseudo-terminal."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)
        for fd in (self._master, self._slave):
            if fd is not None:
                os.close(fd)
        self._master = self._slave = None

    def __enter__(self) -> PtyDevice:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def _close_master(self) -> None:
        os.close(self._master)
        self._master = None

    def _frames_in(self, data: bytes) -> list[bytes]:
        """Split received bytes at each end of line, keeping the line ending."""
        self._lines.extend(data)
        out = []
        while (i := self._lines.find(b"\n")) >= 0:
            out.append(bytes(self._lines[:i + 1]))
            del self._lines[:i + 1]
        return out

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
            reply = self.emulator.receive(raw, self.now_ms())
        if not reply or n in f.mute:
            return
        if n in f.garble_reply:
            reply = _flip_middle(reply)
        self._pending.append((time.monotonic() + dict(f.delay).get(n, 0.0), reply))

    def _serve(self) -> None:
        silent_after = self.faults.silent_after
        while not self._stop.is_set():
            with self._lock:
                self.emulator.tick(self.now_ms())
            now = time.monotonic()
            while self._master is not None and self._pending and self._pending[0][0] <= now:
                os.write(self._master, self._pending.pop(0)[1])
            listening = self._master is not None and (silent_after is None or self.frames < silent_after)
            if not listening:
                self._stop.wait(0.002)
                continue
            wait = 0.002 if self._pending else 0.01
            ready, _, _ = select.select([self._master], [], [], wait)
            if not ready:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:  # no host has the slave open: nothing to read yet
                self._stop.wait(0.002)
                continue
            for raw in self._frames_in(data):
                if self._master is None or (silent_after is not None and self.frames >= silent_after):
                    break
                self._handle(raw)
