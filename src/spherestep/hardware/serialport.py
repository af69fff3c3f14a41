"""The serial back end: the host side of the line protocol over a serial port (pyserial).

Stop-and-wait: each command frame waits for its ACK with the same sequence number; a timeout, a ``NAK CRC``
or a ``NAK FRAME`` retransmits the same frame (all commands set absolute states, so a repeat is harmless) up
to ``retries`` times, then the link is given up with :class:`~spherestep.hardware.LinkError`. Other NAK codes
raise :class:`NakError` at once. While holding, ``PING`` keep-alives go out every quarter of the device's
watchdog period. Every frame sent and received goes into ``transcript``. See ``docs/protocol.md``.
"""

from __future__ import annotations

import math
import os
import time
from collections import Counter, deque
from collections.abc import Mapping

import serial as pyserial

from .. import checks
from ..errors import InputError, bad_value
from .backend import Backend, DeviceInfo, LinkError
from .protocol import BAUDRATE, NAK_CODES, RETRYABLE, VERSION, Frame, FrameError, LineReader, decode, encode, \
    format_mask, parse_decimal, parse_hex
from .transcript import Transcript

_POLL = 0.005  # seconds one read waits before the deadline is checked again


def check_link(port, baudrate, timeout, retries, open_timeout) -> None:
    """The one check of a serial link's settings (both protocol versions): a device name, a positive baud
    rate, positive timeouts in seconds, a non-negative retry count."""
    if not isinstance(port, str) or not port.strip():
        raise bad_value("port", "a serial device name such as /dev/ttyUSB0, /dev/ttyACM0 or COM3", port)
    for name, value in (("timeout", timeout), ("open_timeout", open_timeout)):
        checks.positive(value, name, "a positive number of seconds")
    checks.count(retries, "retries", 0, expected="a non-negative integer")
    checks.count(baudrate, "baudrate", expected="a positive integer such as 115200")


def open_port(port: str, baudrate: int, write_timeout: float, poll: float = _POLL) -> pyserial.Serial:
    """The serial device ``port`` opened exclusively, reads waiting at most ``poll`` s (both protocol versions);
    an :class:`InputError` naming the port and how to find the right one when it cannot be opened."""
    try:
        return pyserial.Serial(port, baudrate, timeout=poll, write_timeout=write_timeout, exclusive=True)
    except (pyserial.SerialException, OSError, ValueError) as exc:
        reason = os.strerror(exc.errno) if getattr(exc, "errno", None) else str(exc)
        raise InputError(f"port {port!r} could not be opened ({reason}); give the serial device of the coil "
                         "controller, such as /dev/ttyUSB0, /dev/ttyACM0 or COM3 (python -m serial.tools.list_ports "
                         "lists them)") from None


def close_quietly(link: pyserial.Serial | None) -> None:
    """Close ``link`` if there is one, ignoring the errors of a device that has already vanished."""
    if link is not None:
        try:
            link.close()
        except (pyserial.SerialException, OSError):
            pass


class NakError(LinkError):
    """The device refused a command with a NAK that a retry cannot cure; ``code`` is the NAK code."""

    def __init__(self, message: str, code: str):
        super().__init__(message)
        self.code = code


class Serial(Backend):
    """The coil controller on serial port ``port`` (``/dev/ttyUSB0``, ``COM3``, a pty's slave name).

    ``timeout``: seconds to wait for each answer; ``retries``: retransmissions of one frame before giving
    up; ``open_timeout``: seconds the handshake keeps retrying (boards that reset when the port opens need
    about 2 s). ``stats`` counts frames, acknowledgements, retransmissions, timeouts, NAKs and ignored lines.
    """

    def __init__(self, port: str, *, baudrate: int = BAUDRATE, timeout: float = 0.25, retries: int = 3,
                 open_timeout: float = 3.0, transcript: Transcript | None = None):
        check_link(port, baudrate, timeout, retries, open_timeout)
        self.port = port
        self.baudrate = baudrate
        self.timeout = float(timeout)
        self.retries = retries
        self.open_timeout = float(open_timeout)
        self.transcript = transcript if transcript is not None else Transcript()
        self.stats: Counter[str] = Counter()
        self.info: DeviceInfo | None = None
        self._link: pyserial.Serial | None = None
        self._reader = LineReader()
        self._bodies: deque[bytes] = deque()
        self._seq = 0
        self._last_ack = 0.0
        self._state = (0, 0)

    # -- connection -------------------------------------------------------------------------------------------
    def open(self) -> DeviceInfo:
        """Open the port and shake hands: the device reports protocol version, channels and watchdog."""
        self._link = open_port(self.port, self.baudrate, self.timeout)
        try:
            self._link.reset_input_buffer()
            attempts = max(1, math.ceil(self.open_timeout / self.timeout))
            ack = self._transact("HELLO", VERSION, attempts=attempts)
            self.info = self._device_info(ack)
        except BaseException:
            self.close()
            raise
        self._note(f"device {self.info.name!r}: protocol {self.info.protocol}, {self.info.channels} channels, "
                   f"watchdog {self.info.watchdog * 1000:.0f} ms")
        return self.info

    def _device_info(self, ack: Frame) -> DeviceInfo:
        data = ack.args[1:]
        version = parse_decimal(data[0], 3) if data else None
        if version != VERSION:
            raise LinkError(f"device on {self.port} speaks protocol version {data[0] if data else '?'}; "
                            f"this host speaks version {VERSION}")
        channels = parse_decimal(data[1], 2) if len(data) == 4 else None
        watchdog = parse_decimal(data[2], 5) if len(data) == 4 else None
        if channels is None or not 1 <= channels <= 64 or not watchdog:
            raise LinkError(f"device on {self.port} answered HELLO with {','.join(data)!r}; expected "
                            "version,channels,watchdog_ms,name")
        return DeviceInfo(name=data[3], protocol=version, channels=channels, watchdog=watchdog / 1000)

    def close(self) -> None:
        """Close the port (safe to call twice, and after the device vanished)."""
        link, self._link = self._link, None
        close_quietly(link)

    # -- outputs ----------------------------------------------------------------------------------------------
    def write(self, enable: int, polarity: int, coils: Mapping[int, int]) -> None:
        """``SET`` the masks; the device echoes the masks it now drives, which must be the ones sent."""
        ack = self._transact("SET", format_mask(enable), format_mask(polarity))
        self._expect_state(ack, enable, polarity)

    def off(self) -> None:
        """``OFF``: every enable relay, then every polarity relay, opened."""
        self._expect_state(self._transact("OFF"), 0, 0)

    def hold(self, seconds: float) -> None:
        """Wait ``seconds``, sending ``PING`` each quarter watchdog period; each ping must report the same
        masks as the last command (otherwise the device lost its state)."""
        if self._link is None or self.info is None:
            raise LinkError(f"serial link to {self.port} is not open")
        end = time.monotonic() + seconds
        interval = self.info.watchdog / 4
        while (now := time.monotonic()) < end:
            due = self._last_ack + interval
            if now >= due:
                ack = self._transact("PING")
                self._expect_state(ack, *self._state)
            else:
                time.sleep(min(end, due) - now)

    def _expect_state(self, ack: Frame, enable: int, polarity: int) -> None:
        data = ack.args[1:]
        got = tuple(parse_hex(a, 1, 16) for a in data) if len(data) == 2 else ()
        if got != (enable, polarity):
            raise LinkError(f"device on {self.port} reports masks {','.join(data)!r} after {ack.args[0]}; the "
                            f"host expected {format_mask(enable)},{format_mask(polarity)}")
        self._state = (enable, polarity)

    # -- frames -----------------------------------------------------------------------------------------------
    def _note(self, text: str) -> None:
        self.transcript.add(time.monotonic(), "NOTE", text)

    def _lost(self, verb: str, exc: Exception) -> LinkError:
        reason = os.strerror(exc.errno) if getattr(exc, "errno", None) else str(exc)
        self._note(f"link lost during {verb}: {reason}")
        return LinkError(f"serial link to {self.port} lost during {verb} ({reason})")

    def _send(self, frame: bytes, verb: str) -> None:
        self.transcript.add(time.monotonic(), "TX", frame.decode("ascii"))
        self.stats["frames"] += 1
        try:
            self._link.write(frame)
        except pyserial.SerialTimeoutException:
            self._note(f"write of {verb} timed out")
        except (pyserial.SerialException, OSError) as exc:
            raise self._lost(verb, exc) from None

    def _next_body(self, deadline: float, verb: str) -> bytes | None:
        try:
            while not self._bodies:
                if time.monotonic() >= deadline:
                    return None
                self._bodies.extend(self._reader.feed(self._link.read(max(1, self._link.in_waiting))))
        except (pyserial.SerialException, OSError) as exc:
            raise self._lost(verb, exc) from None
        return self._bodies.popleft()

    def _answer(self, seq: int, verb: str) -> Frame | None:
        """The ACK to frame ``seq``, or None when it should be retransmitted (timeout, NAK CRC/FRAME)."""
        deadline = time.monotonic() + self.timeout
        while (body := self._next_body(deadline, verb)) is not None:
            self.transcript.add(time.monotonic(), "RX", "$" + body.decode("latin-1"))
            try:
                frame = decode(body)
            except FrameError as exc:
                self.stats["ignored"] += 1
                self._note(f"ignored a damaged answer ({exc})")
                continue
            code = frame.args[0] if frame.args else ""
            if frame.verb == "NAK" and (frame.seq == seq or (frame.seq is None and code in RETRYABLE)):
                self.stats["naks"] += 1
                if code in RETRYABLE:
                    return None
                raise NakError(f"device refused {verb}: NAK {code} ({NAK_CODES.get(code, 'unknown code')})", code)
            if frame.verb == "ACK" and frame.seq == seq and frame.args[:1] == (verb,):
                return frame
            self.stats["ignored"] += 1
            self._note(f"ignored an answer to another frame (sequence {frame.seq}, {frame.verb})")
        self.stats["timeouts"] += 1
        self._note(f"no answer to {verb} within {self.timeout * 1000:.0f} ms")
        return None

    def _transact(self, verb: str, *args: object, attempts: int | None = None) -> Frame:
        """Send one command and return its ACK, retransmitting as the protocol allows."""
        if self._link is None:
            raise LinkError(f"serial link to {self.port} is not open")
        seq, self._seq = self._seq, (self._seq + 1) & 0xFF
        frame = encode(seq, verb, *args)
        attempts = self.retries + 1 if attempts is None else attempts
        for attempt in range(attempts):
            if attempt:
                self.stats["retransmissions"] += 1
                self._note(f"retransmitting {verb} (attempt {attempt + 1} of {attempts})")
            self._send(frame, verb)
            ack = self._answer(seq, verb)
            if ack is not None:
                self.stats["acked"] += 1
                self._last_ack = time.monotonic()
                return ack
        self._note(f"giving up {verb} after {attempts} attempts")
        raise LinkError(f"no valid answer from the device on {self.port} to {verb} after {attempts} attempts "
                        f"({self.stats['timeouts']} timeouts, {self.stats['naks']} NAKs so far); check the cable, "
                        f"the baud rate ({self.baudrate}) and that the firmware is running")
