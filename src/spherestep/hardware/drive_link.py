"""The host side of protocol version 2 over a serial port: coil currents out, sensor state back.

Same discipline as the relay link (:class:`~spherestep.hardware.Serial`): stop-and-wait, a timeout or ``NAK
CRC``/``FRAME`` retransmits the same frame up to ``retries`` times, anything else ends the link. A device
that tripped answers with its trip code (:data:`~spherestep.hardware.protocol2.TRIP_CODES`), raised as
:class:`DeviceTrip`. Timeouts default to 20 ms so that ``timeout × (retries + 1)`` stays under the device's
watchdog period (100 ms) and a lost frame costs one loop period, not the session. See ``docs/protocol.md``.
"""

from __future__ import annotations

import math
import os
import select
import time
from collections import Counter, deque
from dataclasses import dataclass

import numpy as np
import serial as pyserial

from ..electrics import centivolts, from_milliamperes, milliamperes
from ..errors import InputError, bad_value
from .backend import LinkError
from .protocol import BAUDRATE, NAK_CODES, RETRYABLE, Frame, FrameError, LineReader, decode, encode, \
    parse_decimal, parse_hex
from .protocol2 import CAP_EMF, MAX_FRAME2, NAK_CODES2, TRIP_CODES, VERSION2, State, encode_block, parse_state
from .serialport import NakError, check_link, close_quietly, open_port
from .transcript import Transcript

_POLL = 0.002  # seconds one read waits before the deadline is checked again


class DeviceTrip(NakError):
    """The device switched every coil off by itself (watchdog, CRC storm, over-current, open or stuck coil,
    heat) and says so; ``code`` is the trip code."""


FIRMWARE = ("firmware/spherestep_drive (drive.cpp) of spherestep 0.1.0 from 2026-11-28 on, whose HELLO,2 "
            "answer reports the supply and the coils")
"""What to flash on a device whose handshake predates the supply and coil fields (named in the refusal)."""
AGREE = 0.02
"""How far (relative) a device's supply, coil resistance, inductance and current limit may lie from the design's
:class:`~spherestep.electrics.DriveLimits` (firmware constants are typed to three or four digits: the sketch's
18.7 mH against Wheeler's 18.714 mH is 0.08 %), besides the wire's rounding (half a mV, mΩ, µH or mA)."""


class DeviceMismatch(InputError):
    """The device's handshake disagrees with the design (an older firmware, another supply or other coils)."""


@dataclass(frozen=True)
class DriveInfo:
    """What a current-mode device reports in the handshake (SI units): ``supply_voltage`` (V), the coils'
    ``resistance`` (Ω) and ``inductance`` (H) that its current loop is tuned for, its ``max_current`` (A) and
    ``max_power`` (W) limits, and its ``capabilities`` (bits; :data:`~spherestep.hardware.protocol2.CAP_EMF`:
    ``DRIVE`` takes each coil's back-EMF)."""

    name: str
    coils: int
    sensors: int
    watchdog: float
    period: float
    max_current: float
    max_power: float
    field_lsb: float
    supply_voltage: float
    resistance: float
    inductance: float
    capabilities: int = 0

    @property
    def takes_emf(self) -> bool:
        """The device's ``DRIVE`` takes each coil's back-EMF (a second block); else only currents (``e = 0``)."""
        return bool(self.capabilities & CAP_EMF)

    def check_drive(self, drive, where: str = "the device") -> None:
        """Raise :class:`DeviceMismatch` (one line, naming the quantity) unless the supply, the coils' ``R`` and
        ``L`` and the current limit agree with ``drive`` (a :class:`~spherestep.electrics.DriveLimits`) within
        :data:`AGREE` plus the wire's rounding: the law's volts, time constants and amperes would be wrong."""
        for name, label, unit, device, design, step in (
                ("supply_voltage", "supply", "V", self.supply_voltage, drive.supply_voltage, 5e-4),
                ("resistance", "coil resistance", "Ω", self.resistance, drive.resistance, 5e-4),
                ("inductance", "coil inductance", "H", self.inductance, drive.inductance, 5e-7),
                ("max_current", "current limit", "A", self.max_current, drive.max_current, 5e-4)):
            if abs(device - design) > AGREE * abs(design) + step:
                error = DeviceMismatch(
                    f"{where} ({self.name}) reports a {label} of {device:.4g} {unit}, but the design's drive has "
                    f"{name} = {design:.4g} {unit}; flash the firmware with the design's coils and supply, or drive "
                    "it with the design of the motor it is wired to (a design file's coil:, docs/design-files.md); "
                    "every coil is off")
                error.field = name
                raise error


def device_info(ack: Frame, port: str) -> DriveInfo:
    """The :class:`DriveInfo` in an ``ACK,HELLO,2,...`` frame; :class:`DeviceMismatch` for the older 9-field
    answer (no supply or coils: :data:`FIRMWARE` to flash), :class:`LinkError` if it is not one."""
    d = ack.args[1:]
    if len(d) == 9 and parse_decimal(d[0], 9) == VERSION2:
        error = DeviceMismatch(f"device on {port} ({d[8]}) answered HELLO,2 without its supply voltage and coils "
                               f"(a firmware older than this host); flash {FIRMWARE}")
        error.field = "firmware"
        raise error
    nums = [parse_decimal(x, 9) for x in d[:11]] if len(d) in (12, 13) else [None]
    caps = parse_hex(d[11], 1, 8) if len(d) == 13 else 0  # a 12-field answer: a device without capabilities
    if None in nums or caps is None or nums[0] != VERSION2 or not all(nums[i] for i in (1, 3, 4, 8, 9, 10)):
        raise LinkError(f"device on {port} answered HELLO,2 with {','.join(d)!r}; expected version 2, coils, "
                        "sensors, watchdog_ms, period_us, max_mA, max_W, field_nT, supply_mV, coil_mOhm, coil_uH, "
                        "[capabilities,] name")
    _, coils, sensors, wd, period, ma, watts, lsb, mv, mohm, uh = nums
    return DriveInfo(d[-1], coils, sensors, wd / 1000, period * 1e-6, float(from_milliamperes(ma)), float(watts),
                     lsb * 1e-9, mv / 1000, mohm / 1000, uh * 1e-6, caps)


def drive_blocks(info: DriveInfo, currents, emf=None) -> tuple[str, ...]:
    """The arguments of ``DRIVE`` for ``info``'s device: the setpoints' block (mA) and, if the device takes it and
    ``emf`` is given, the back-EMF block (10 mV); a clear error naming the field for a wrong shape or a NaN."""
    c = np.asarray(currents, dtype=float)
    if c.shape != (info.coils,) or not np.all(np.isfinite(c)):
        raise bad_value("currents", f"{info.coils} finite coil currents in A", f"shape {c.shape}")
    if emf is None or not info.takes_emf:
        return (encode_block(milliamperes(c)),)
    e = np.asarray(emf, dtype=float)
    if e.shape != (info.coils,) or not np.all(np.isfinite(e)):
        raise bad_value("emf", f"{info.coils} finite back-EMF estimates in V", f"shape {e.shape}")
    return encode_block(milliamperes(c)), encode_block(centivolts(e))


class DriveLink:
    """The current-mode controller on serial port ``port`` (a USB CDC device, a pty's slave name).

    :meth:`open` shakes hands with ``HELLO,2``; :meth:`drive` sends every coil's current (A) and returns the
    :class:`~spherestep.hardware.protocol2.State` (measured currents, magnetometers); :meth:`read` the state
    alone; :meth:`off` switches every coil off. ``stats`` counts frames, retransmissions, timeouts, NAKs.
    """

    def __init__(self, port: str, *, baudrate: int = BAUDRATE, timeout: float = 0.02, retries: int = 2,
                 open_timeout: float = 3.0, transcript: Transcript | None = None):
        check_link(port, baudrate, timeout, retries, open_timeout)
        self.port, self.baudrate, self.timeout, self.retries = port, baudrate, float(timeout), retries
        self.open_timeout = float(open_timeout)
        self.transcript = transcript
        self.stats: Counter[str] = Counter()
        self.info: DriveInfo | None = None
        self._link: pyserial.Serial | None = None
        self._reader = LineReader(MAX_FRAME2)
        self._bodies: deque[bytes] = deque()
        self._seq = 0

    def __enter__(self) -> DriveLink:
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        """``OFF`` if the link still answers (if not, the device's watchdog switches off), then close."""
        try:
            if self._link is not None:
                self.off()
        except LinkError:
            pass
        finally:
            self.close()

    def open(self) -> DriveInfo:
        """Open the port and shake hands; the device reports coils, sensors, watchdog, period and limits."""
        self._link = open_port(self.port, self.baudrate, self.timeout, _POLL)
        try:
            self._link.reset_input_buffer()
            ack = self._transact("HELLO", VERSION2, attempts=max(1, math.ceil(self.open_timeout / 0.25)),
                                 timeout=0.25)
            self.info = device_info(ack, self.port)
        except BaseException:
            self.close()
            raise
        return self.info

    def close(self) -> None:
        link, self._link = self._link, None
        close_quietly(link)

    def drive(self, currents, *, emf=None, within: float | None = None) -> State | None:
        """Set every coil's current (A, ``(N,)``) and return the device's state; ``emf`` (V, ``(N,)``) each coil's
        back-EMF estimate, sent when the device takes it (:attr:`DriveInfo.takes_emf`; otherwise the
        currents-only ``DRIVE``, ``e = 0`` on the device). With ``within`` (s): one attempt, and ``None`` when no
        answer has come by then (a late reading: the frame was sent, and its answer, when it comes, is skipped by
        its sequence number)."""
        if self.info is None:
            raise LinkError(f"serial link to {self.port} is not open")
        blocks = drive_blocks(self.info, currents, emf)
        if within is None:
            return self._state(self._transact("DRIVE", *blocks))
        ack = self._transact("DRIVE", *blocks, attempts=1, timeout=within, late_ok=True)
        return None if ack is None else self._state(ack)

    def read(self) -> State:
        """The device's state (measured currents, magnetometers) without changing the setpoints."""
        return self._state(self._transact("READ"))

    def off(self) -> None:
        """Every coil off (obeyed in any state, even after a trip)."""
        self._transact("OFF")

    def _state(self, ack: Frame) -> State:
        try:
            return parse_state(ack.args[1:], self.info.coils, self.info.sensors, self.info.field_lsb)
        except FrameError as exc:
            raise LinkError(f"device on {self.port} sent a malformed state ({exc.detail})") from None

    # -- frames -------------------------------------------------------------------------------------------------
    def _log(self, kind: str, text: str) -> None:
        if self.transcript is not None:
            self.transcript.add(time.monotonic(), kind, text)

    def _lost(self, verb: str, exc: Exception) -> LinkError:
        reason = os.strerror(exc.errno) if getattr(exc, "errno", None) else str(exc)
        self._log("NOTE", f"link lost during {verb}: {reason}")
        return LinkError(f"serial link to {self.port} lost during {verb} ({reason})")

    def _answer(self, seq: int, verb: str, timeout: float) -> Frame | None:
        deadline = time.monotonic() + timeout
        while True:
            try:
                while not self._bodies:
                    wait = deadline - time.monotonic()
                    if wait <= 0:
                        self.stats["timeouts"] += 1
                        return None
                    if wait < _POLL and os.name == "posix" and not self._link.in_waiting:  # a read waits _POLL
                        select.select([self._link.fileno()], [], [], wait)  # s: a nearer deadline is kept exactly
                        if not self._link.in_waiting:
                            continue
                    self._bodies.extend(self._reader.feed(self._link.read(max(1, self._link.in_waiting))))
            except (pyserial.SerialException, OSError) as exc:
                raise self._lost(verb, exc) from None
            body = self._bodies.popleft()
            self._log("RX", "$" + body.decode("latin-1"))
            try:
                frame = decode(body, MAX_FRAME2)
            except FrameError:
                self.stats["ignored"] += 1
                continue
            code = frame.args[0] if frame.args else ""
            if frame.verb == "NAK" and (frame.seq == seq or (frame.seq is None and code in RETRYABLE)):
                self.stats["naks"] += 1
                if code in RETRYABLE:
                    return None
                meaning = {**NAK_CODES, **NAK_CODES2}.get(code, "unknown code")
                error = DeviceTrip if code in TRIP_CODES else NakError
                raise error(f"device refused {verb}: NAK {code} ({meaning})", code)
            if frame.verb == "ACK" and frame.seq == seq and frame.args[:1] == (verb,):
                return frame
            self.stats["ignored"] += 1

    def _transact(self, verb: str, *args: object, attempts: int | None = None, timeout: float | None = None,
                  late_ok: bool = False) -> Frame | None:
        if self._link is None:
            raise LinkError(f"serial link to {self.port} is not open")
        seq, self._seq = self._seq, (self._seq + 1) & 0xFF
        frame = encode(seq, verb, *args, max_frame=MAX_FRAME2)
        attempts = self.retries + 1 if attempts is None else attempts
        for attempt in range(attempts):
            if attempt:
                self.stats["retransmissions"] += 1
            self._log("TX", frame.decode("ascii"))
            self.stats["frames"] += 1
            try:
                self._link.write(frame)
            except pyserial.SerialTimeoutException:
                pass
            except (pyserial.SerialException, OSError) as exc:
                raise self._lost(verb, exc) from None
            ack = self._answer(seq, verb, self.timeout if timeout is None else timeout)
            if ack is not None:
                return ack
        if late_ok:
            return None
        raise LinkError(f"no valid answer from the device on {self.port} to {verb} after {attempts} attempts "
                        f"({self.stats['timeouts']} timeouts, {self.stats['naks']} NAKs so far)")
