"""The dry-run back end: records what it would send, on a simulated clock, without any device."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from .. import checks
from .backend import Backend, DeviceInfo
from .protocol import MAX_MASK_DIGITS, VERSION, encode, format_mask
from .transcript import Transcript


@dataclass(frozen=True)
class Sent:
    """One recorded output state: time (s on the dry-run clock), masks, and the coils they encode."""

    t: float
    enable: int
    polarity: int
    coils: dict[int, int]


class DryRun(Backend):
    """A back end that only records. Its clock starts at 0 and advances by :meth:`hold`, so a dry run of a
    long plan takes no time; ``sent`` lists every output state and ``transcript`` the exact ``SET``/``OFF``
    frames a :class:`~spherestep.hardware.Serial` link would carry (keep-alives aside).
    ``channels`` is the device it stands in for (32: four 8-relay boards, Sec. IV-B).
    """

    def __init__(self, channels: int = 32, transcript: Transcript | None = None):
        self.channels = checks.count(channels, "channels", 1, 4 * MAX_MASK_DIGITS, expected="an integer 1..64")
        self.transcript = transcript if transcript is not None else Transcript()
        self.sent: list[Sent] = []
        self._now = 0.0
        self._seq = 0

    def _frame(self, verb: str, *args: object) -> None:
        self.transcript.add(self._now, "TX", encode(self._seq, verb, *args).decode("ascii"))
        self._seq = (self._seq + 1) & 0xFF

    def open(self) -> DeviceInfo:
        """Report the stand-in device (no watchdog) and record the handshake."""
        self._frame("HELLO", VERSION)
        return DeviceInfo(name="dry-run", protocol=VERSION, channels=self.channels, watchdog=None)

    def write(self, enable: int, polarity: int, coils: Mapping[int, int]) -> None:
        """Record the state and its ``SET`` frame."""
        self.sent.append(Sent(self._now, enable, polarity, dict(coils)))
        self._frame("SET", format_mask(enable), format_mask(polarity))

    def off(self) -> None:
        """Record all off and its ``OFF`` frame."""
        self.sent.append(Sent(self._now, 0, 0, {}))
        self._frame("OFF")

    def hold(self, seconds: float) -> None:
        """Advance the simulated clock."""
        self._now += max(0.0, seconds)

    def clock(self) -> float:
        """The simulated clock (seconds since the dry run began)."""
        return self._now
