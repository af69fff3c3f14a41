"""The wire format shared by the host and the coil controller (``docs/protocol.md`` states it in full).

A frame is one ASCII line ``$SS,VERB[,ARG...]*CCCC\\n``: ``SS`` a two-digit hex sequence number (``--`` in a
NAK for a frame that could not be trusted), ``CCCC`` the CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no
reflection, no final XOR) of the bytes strictly between ``$`` and ``*``, four hex digits. At most
:data:`MAX_FRAME` bytes lie between ``$`` and the end of line; a ``$`` always starts a new frame and ``\\r`` is
ignored. Relay masks travel as 1–16 hex digits without prefix, bit ``b`` = channel ``b``.

Host verbs: ``HELLO,<version>``, ``SET,<enable>,<polarity>``, ``OFF``, ``PING``. Device replies:
``ACK,<verb>[,<data>...]`` or ``NAK,<code>`` with the same sequence number; the codes are :data:`NAK_CODES`.
This module is the single Python statement of that grammar; the reference firmware
(``firmware/spherestep/protocol.cpp``) implements the same, checked against the shared vectors in
``firmware/test/vectors.txt``.
"""

from __future__ import annotations

import binascii
import re
from dataclasses import dataclass

VERSION = 1
"""Protocol version spoken by this host and emulator (sent in ``HELLO``)."""

BAUDRATE = 115200
"""Line speed of the reference firmware (8 data bits, no parity, 1 stop bit)."""

MAX_FRAME = 80
"""Most bytes allowed between ``$`` and the end of line."""

MAX_MASK_DIGITS = 16
"""A relay mask has at most 16 hex digits (64 channels)."""

NAK_CODES = {
    "CRC": "checksum mismatch",
    "FRAME": "malformed frame (no '*CCCC' trailer, bad sequence field, non-printable byte or over-long line)",
    "VERB": "unknown command",
    "ARGS": "wrong number or format of arguments",
    "RANGE": "a mask sets a channel the device does not have",
    "SESSION": "no session: the host must send HELLO first",
    "VERSION": "protocol version not supported by the device",
    "WDOG": "the device's watchdog expired and switched every coil off; the host must send HELLO again",
}
"""NAK code → meaning. ``CRC`` and ``FRAME`` are answered with sequence ``--`` and are worth a retry."""

RETRYABLE = frozenset({"CRC", "FRAME"})
"""NAK codes after which the host retransmits the same frame."""

_HEX = frozenset("0123456789ABCDEFabcdef")
_DEC = frozenset("0123456789")


class FrameError(ValueError):
    """A received line is not a valid frame; ``code`` is the NAK code a device answers it with."""

    def __init__(self, code: str, detail: str):
        super().__init__(f"{code}: {detail}")
        self.code = code
        self.detail = detail


@dataclass(frozen=True)
class Frame:
    """A decoded frame: ``seq`` 0–255 (None for ``--``), the verb, and its arguments as text."""

    seq: int | None
    verb: str
    args: tuple[str, ...] = ()


def _shift8(crc: int) -> int:
    """Eight steps of the CRC register (polynomial 0x1021, most significant bit first)."""
    for _ in range(8):
        crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        crc &= 0xFFFF
    return crc


_CRC_TABLE = tuple(_shift8(b << 8) for b in range(256))


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (``crc16(b"123456789") == 0x29B1``), one table look-up per byte:
    ``crc = (crc << 8) ^ T[(crc >> 8) ^ b]`` with ``T[b]`` eight register steps from ``b << 8`` (the bit-by-bit
    form is in docs/protocol.md; the two agree because the register is linear)."""
    return binascii.crc_hqx(data, 0xFFFF)  # the same CRC (polynomial 0x1021, MSB first) in C: ~1 µs per frame


def crc16_table(data: bytes) -> int:
    """:func:`crc16` by the table in Python (the reference the tests hold :func:`binascii.crc_hqx` to)."""
    crc = 0xFFFF
    table = _CRC_TABLE
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ byte]
    return crc


_PRINTABLE = re.compile(rb"[\x20-\x7e]*")  # printable ASCII, checked in C


def format_mask(mask: int) -> str:
    """A relay mask as upper-case hex without prefix or leading zeros (``0`` for none)."""
    if mask < 0 or mask >= 1 << (4 * MAX_MASK_DIGITS):
        raise ValueError(f"mask must be in 0..2**64-1; instead received {mask}")
    return f"{mask:X}"


def parse_hex(text: str, min_digits: int, max_digits: int) -> int | None:
    """The value of ``text`` if it is min–max hex digits and nothing else, otherwise None."""
    if not min_digits <= len(text) <= max_digits or not set(text) <= _HEX:
        return None
    return int(text, 16)


def parse_decimal(text: str, max_digits: int) -> int | None:
    """The value of ``text`` if it is 1–max decimal digits and nothing else, otherwise None."""
    if not 1 <= len(text) <= max_digits or not set(text) <= _DEC:
        return None
    return int(text)


def encode(seq: int | None, verb: str, *args: object, max_frame: int = MAX_FRAME) -> bytes:
    """The complete frame ``$SS,VERB,ARGS*CCCC\\n`` as bytes (``seq`` None → ``--``)."""
    head = "--" if seq is None else f"{seq & 0xFF:02X}"
    body = ",".join([head, verb, *map(str, args)]).encode("ascii")
    if len(body) + 5 > max_frame:
        raise ValueError(f"frame body must fit in {max_frame} bytes; instead received {len(body) + 5}")
    return b"$" + body + b"*" + f"{crc16(body):04X}".encode("ascii") + b"\n"


def decode(line: bytes, max_frame: int = MAX_FRAME) -> Frame:
    """Decode the bytes between ``$`` and the end of line (neither included, ``\\r`` already removed);
    ``max_frame`` is the longest body accepted (protocol version 2 allows :data:`~.protocol2.MAX_FRAME2`).

    Raises :class:`FrameError` with code ``FRAME`` or ``CRC``, checked in the firmware's order: printable
    ASCII, a ``*`` followed by exactly four hex digits, the checksum, a sequence field of two hex digits (or
    ``--``) and a verb.
    """
    if len(line) > max_frame:
        raise FrameError("FRAME", f"longer than {max_frame} bytes")
    if _PRINTABLE.fullmatch(line) is None:
        raise FrameError("FRAME", "non-printable byte")
    star = line.rfind(b"*")
    if star < 0:
        raise FrameError("FRAME", "no '*' checksum separator")
    received = parse_hex(line[star + 1:].decode("ascii"), 4, 4)
    if received is None:
        raise FrameError("FRAME", "checksum is not four hex digits")
    body = line[:star]
    if crc16(body) != received:
        raise FrameError("CRC", f"checksum {received:04X} received, {crc16(body):04X} computed")
    fields = body.decode("ascii").split(",")
    if len(fields) < 2 or not fields[1]:
        raise FrameError("FRAME", "no verb")
    if fields[0] == "--":
        seq = None
    else:
        seq = parse_hex(fields[0], 2, 2)
        if seq is None:
            raise FrameError("FRAME", "sequence field is not two hex digits")
    return Frame(seq=seq, verb=fields[1], args=tuple(fields[2:]))


class LineReader:
    """Split a byte stream into frame bodies by the framing rules: ``$`` starts, ``\\n`` ends, ``\\r`` ignored.

    :meth:`feed` returns the completed bodies; an over-long body is returned truncated to ``MAX_FRAME + 1``
    bytes so that :func:`decode` rejects it with ``FRAME``. Bytes outside a frame are dropped. ``max_frame``
    is the longest body kept (``MAX_FRAME`` for version 1).
    """

    def __init__(self, max_frame: int = MAX_FRAME) -> None:
        self.max_frame = max_frame
        self._buf = bytearray()
        self._in_frame = False

    def feed(self, data: bytes) -> list[bytes]:
        """Consume ``data``; return the frame bodies completed by it, in order."""
        done = []
        i, n = 0, len(data)
        while i < n:  # by runs between the framing bytes (bytes.find in C, not a loop over bytes)
            if not self._in_frame:  # outside a frame: drop everything up to a '$'
                i = data.find(b"$", i)
                if i < 0:
                    break
                self._buf.clear()
                self._in_frame, i = True, i + 1
                continue
            ends = [j for j in (data.find(b"$", i), data.find(b"\n", i)) if j >= 0]
            stop = min(ends) if ends else n
            room = self.max_frame + 1 - len(self._buf)  # an over-long body is kept truncated to MAX_FRAME + 1
            if room > 0:
                self._buf += data[i:stop].replace(b"\r", b"")[:room]
            if stop == n:
                break
            if data[stop] == 0x0A:  # '\n' ends the frame; a '$' starts another
                done.append(bytes(self._buf))
                self._in_frame = False
            self._buf.clear()
            i = stop + 1
        return done
