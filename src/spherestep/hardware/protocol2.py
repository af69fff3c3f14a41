"""Protocol version 2: signed coil currents and sensor readings over the same frames (``docs/protocol.md``).

The framing, checksum, sequence numbers, retries and the watchdog are those of version 1
(:mod:`~spherestep.hardware.protocol`); a session speaks version 2 when the host opens it with ``HELLO,2``.
Frames may then be up to :data:`MAX_FRAME2` bytes long. New verbs:

* ``DRIVE,<block>[,<emf>]``: one current setpoint per coil, each a signed 16-bit integer in mA written as four
  hex digits (two's complement), coil 0 first; optionally each coil's back-EMF estimate ``e_k`` (V, signed, in
  units of 10 mV, the same block format) from the host's ω (a device that reports :data:`CAP_EMF` in the
  handshake; without it ``e = 0``). The answer is ``ACK,DRIVE,<state>``.
* ``READ``: the state without changing anything: ``ACK,READ,<state>``.

``<state>`` is ``<time>,<stale>,<currents>,<field>``: the device's clock in µs (8 hex digits, wrapping),
a hex mask of magnetometers whose last sample is stale, the measured coil currents (a block of signed mA)
and the magnetometer block (three signed 16-bit counts per sensor, x y z in the sensor's own axes; the
handshake states the tesla per count).

Trips (every coil off, session over, the trip code answered to every command but ``HELLO`` and ``OFF``):
:data:`TRIP_CODES`. A setpoint over the device's current or power limit is refused with ``NAK,LIMIT``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..electrics import from_milliamperes
from .protocol import FrameError, parse_hex

_HEX = frozenset("0123456789ABCDEFabcdef")

VERSION2 = 2
"""Protocol version of the current-mode session."""

MAX_FRAME2 = 400
"""Most bytes between ``$`` and the end of line in a device that speaks version 2 (32 coils, 16 sensors)."""

CAP_EMF = 1
"""Capability bit in ``HELLO,2``'s answer: ``DRIVE`` takes a second block, each coil's back-EMF (10 mV units)."""

MAX_COILS = 32
MAX_SENSORS = 16

FULL_SCALE = 32767
"""A count of this magnitude means the channel saturated."""

TRIP_CODES = {
    "WDOG": "no accepted command for a watchdog period",
    "CRCS": "a storm of damaged frames (8 in a row during a session)",
    "OVER": "a measured coil current above the trip level (a shorted bridge or a coil stuck at full current)",
    "OPEN": "a coil's current does not follow its setpoint and stays near zero at full duty (an open coil)",
    "STUCK": "a coil's current does not follow at full duty, or its reading stays frozen while driven",
    "HEAT": "a coil's I²t thermal model exceeded its rating",
}
"""Trip code → cause. Each ends the session with every coil off until the next ``HELLO``."""

NAK_CODES2 = {"LIMIT": "a setpoint above the current limit, or setpoints above the power limit", **TRIP_CODES}
"""NAK codes added by version 2."""


def encode_block(values) -> str:
    """Signed 16-bit integers as concatenated four-digit upper-case hex (two's complement), clipped."""
    v = np.clip(np.rint(np.asarray(values, dtype=float)).astype(np.int64), -FULL_SCALE, FULL_SCALE)
    return v.reshape(-1).astype(">i2").tobytes().hex().upper()  # big-endian int16: the digits of x & 0xFFFF


def decode_block(text: str, count: int) -> np.ndarray | None:
    """``count`` signed 16-bit integers from a block of exactly ``4 count`` hex digits, otherwise None."""
    if len(text) != 4 * count or not set(text) <= _HEX:
        return None
    return np.frombuffer(bytes.fromhex(text), dtype=">i2").astype(np.int64)


@dataclass(frozen=True)
class State:
    """A decoded ``<state>``: device time (µs, wrapping at 2³²), stale sensor mask, measured currents (A)
    ``(N,)``, field (T, sensor axes) ``(S, 3)`` and the sensors with a channel at full scale ``(S,)``."""

    time_us: int
    stale: int
    currents: np.ndarray
    field: np.ndarray
    saturated: np.ndarray


def format_state(time_us: int, stale: int, currents_ma, field_counts) -> tuple[str, str, str, str]:
    """The four fields of ``<state>`` from integer mA and counts."""
    return f"{time_us & 0xFFFFFFFF:08X}", f"{stale:X}", encode_block(currents_ma), encode_block(field_counts)


def parse_state(args: tuple[str, ...], coils: int, sensors: int, field_lsb: float) -> State:
    """The state in the fields ``args`` (after ``ACK,VERB``), counts scaled by ``field_lsb`` T; raises
    :class:`FrameError` ``ARGS`` if malformed."""
    if len(args) != 4:
        raise FrameError("ARGS", f"a state has 4 fields; received {len(args)}")
    time_us = parse_hex(args[0], 8, 8)
    stale = parse_hex(args[1], 1, 4)
    currents = decode_block(args[2], coils)
    field = decode_block(args[3], 3 * sensors)
    if time_us is None or stale is None or currents is None or field is None:
        raise FrameError("ARGS", f"malformed state for {coils} coils and {sensors} sensors")
    counts = field.reshape(sensors, 3)
    return State(time_us, stale, from_milliamperes(currents), counts * field_lsb, np.any(np.abs(counts) >= FULL_SCALE, axis=1))


def frame_bytes(coils: int, sensors: int) -> dict[str, int]:
    """Bytes on the wire (``$`` to ``\\n``) of a ``DRIVE`` frame and of its answer, for the rate tables."""
    drive = len("$00,DRIVE,") + 4 * coils + len(",") + 4 * coils + len("*CCCC\n")  # currents and back-EMF
    answer = len("$00,ACK,DRIVE,") + 8 + len(",0,") + 4 * coils + len(",") + 12 * sensors + len("*CCCC\n")
    return {"drive": drive, "answer": answer, "round_trip": drive + answer}
