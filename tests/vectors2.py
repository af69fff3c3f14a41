"""The one reader of firmware/test/vectors2.txt for Python: every line run against a rig, as
firmware/test/test_drive.cpp runs it against drive.cpp. A rig is the device under test with a table plant: the
Python CurrentDevice (tests/test_hardware_drive.py) or the firmware in QEMU (tests/test_firmware_qemu.py)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Protocol

from spherestep.hardware.protocol import crc16

VECTORS2 = Path(__file__).resolve().parents[1] / "firmware" / "test" / "vectors2.txt"
DEFAULT_LIMITS = dict(max_current=1.0, max_duty=0.95, max_power=100.0, continuous_current=1.0,
                      thermal_time=60.0, resistance=24.0)


class Rig(Protocol):
    """A device of ``coils``, ``sensors``, ``watchdog`` ms, ``period`` µs, ``name`` and ``limits`` (a dict for
    CurrentLimits; the loop: 24 V, 18.7 mH, 125 rad/s, 1000 mA, 8118 nT) whose sense reads the table."""

    def meas(self, ma: list[int]) -> None: ...
    def field(self, stale: int, counts: list[int]) -> None: ...
    def tick(self, now: int) -> None: ...
    def step(self, now: int) -> None: ...
    def send(self, data: bytes, now: int) -> list[bytes]: ...
    def duty(self) -> list[float]: ...
    def enabled(self) -> bool: ...
    def trip(self) -> tuple[str | None, int]: ...


def frame(body: str) -> bytes:
    return b"$" + body.encode() + f"*{crc16(body.encode()):04X}\n".encode()


def unescape(text: str) -> bytes:
    return text.encode().decode("unicode_escape").encode("latin-1")


def permille(x: float) -> int:
    return int(math.copysign(math.floor(abs(x) * 1000 + 0.5), x))


def run_vectors(new_rig, close_rig=lambda rig: None) -> int:
    """Run every line against rigs from ``new_rig(coils, sensors, watchdog, period, name, limits)`` (one per
    ``device2`` line; ``close_rig`` ends each); returns the lines checked. An AssertionError names the line."""
    limits = dict(DEFAULT_LIMITS)
    rig = None
    now, period = 0, 0
    replies: list[bytes] = []
    checked = 0
    try:
        for number, raw in enumerate(VECTORS2.read_text().splitlines(), 1):
            line = raw.strip()
            if not line or line.startswith("#"):
                continue
            where = f"vectors2.txt:{number}: {line}"
            op, _, rest = line.partition(" ")
            words = rest.split()
            if op == "crc":
                assert f"{crc16(words[0].encode()):04X}" == words[1], where
            elif op == "limits":
                ma, duty, watts, cont, thermal, res = map(float, words)
                limits = dict(max_current=ma / 1000, max_duty=duty / 1000, max_power=watts,
                              continuous_current=cont / 1000, thermal_time=thermal / 1000, resistance=res / 1000)
            elif op == "device2":
                if rig is not None:
                    close_rig(rig)
                coils, sensors, watchdog, period = map(int, words[:4])
                rig = new_rig(coils, sensors, watchdog, period, words[4], limits)
                limits, now, replies = dict(DEFAULT_LIMITS), 0, []
            elif op == "meas":
                rig.meas([int(x) for x in rest.split(",")])
            elif op == "field":
                rig.field(int(words[0], 16), [int(x) for x in words[1].split(",")])
            elif op == "@":
                now = int(rest)
                rig.tick(now)
            elif op == "step":
                at, count = map(int, words)
                for i in range(count):
                    now = at + i * period
                    rig.step(now)
            elif op in (">", ">raw"):
                assert not replies, f"{where} (previous send left {replies[0]!r} unchecked)"
                out = rig.send(frame(rest) if op == ">" else unescape(rest), now)
                replies = [b"$" + r for r in b"".join(out).split(b"$") if r]
            elif op == "<":
                assert replies and replies.pop(0) == frame(rest), f"{where} (got {replies})"
            elif op == "-":
                assert not replies, where
            elif op == "=":
                what = words[0]
                if what == "duty":
                    got = [permille(d) for d in rig.duty()]
                    assert got == [int(x) for x in words[1].split(",")], f"{where} (got {got})"
                elif what == "enabled":
                    assert rig.enabled() == (words[1] == "1"), where
                elif what == "trip":
                    code, coil = rig.trip()
                    if words[1] == "-":
                        assert code is None, f"{where} (got {code})"
                    else:
                        assert (code, coil) == (words[1], int(words[2])), f"{where} (got {code} {coil})"
                else:
                    raise AssertionError(f"{where}: unknown check")
            else:
                raise AssertionError(f"{where}: unknown operation")
            checked += 1
    finally:
        if rig is not None:
            close_rig(rig)
    return checked
