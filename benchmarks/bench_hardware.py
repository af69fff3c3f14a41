"""Frames per second through a pseudo-terminal: host Serial back end ↔ Python emulator, side by side.

Each row: median over REPEATS rounds of FRAMES acknowledged commands (stop-and-wait, so one frame in flight),
and its ratio to the SET round trip; then how late ``play`` starts its steps when it keeps a RATE Hz
schedule. Run: ``.venv/bin/python benchmarks/bench_hardware.py``.
"""

from __future__ import annotations

import os
import platform
import statistics
import time

import numpy as np

from spherestep.commutation import Plan, Step, default_channel_map
from spherestep.hardware import DryRun, PtyDevice, Serial, play
from spherestep.hardware.protocol import crc16, decode, encode

FRAMES = 500
REPEATS = 5
RATE, RATE_STEPS = 200.0, 200  # a schedule to keep: steps at RATE Hz


def frames_per_second(cases: dict, frames: dict) -> dict:
    """Median frames per second of each ``cases[name]()`` over REPEATS rounds, the cases interleaved within a
    round so that drift of the machine's speed affects them alike; one unmeasured warm-up round first."""
    times = {name: [] for name in cases}
    for round_ in range(REPEATS + 1):
        for name, run in cases.items():
            t = time.perf_counter()
            run()
            if round_:
                times[name].append(time.perf_counter() - t)
    return {name: frames[name] / statistics.median(ts) for name, ts in times.items()}


def main() -> None:
    I3 = np.eye(3)
    plan = Plan(steps=[Step(index=i, target=I3, achieved=I3, error=0.0, coils={i % 16: 1, (i + 3) % 16: -1})
                       for i in range(FRAMES)], coil_count=16, channel_map=default_channel_map(16))
    frame = encode(0x12, "SET", "FFFFFFFF", "FFFF0000")
    with PtyDevice(channels=32, watchdog_ms=1000) as dev:
        link = Serial(dev.port)
        link.open()

        def play_pty():
            link.close()
            play(plan, Serial(dev.port), rate=1e6)
            link.open()

        cases = {
            "SET round trip over pty": lambda: [link.write(1 << (i % 16), 1 << (16 + i % 16), {})
                                                for i in range(FRAMES)],
            "PING round trip over pty": lambda: [link._transact("PING") for _ in range(FRAMES)],
            "play() over pty, rate unbounded": play_pty,
            "play() on DryRun": lambda: play(plan, DryRun(), rate=1e6),
            "encode + decode only": lambda: [decode(encode(0x12, "SET", "3", "20")[1:-1]) for _ in range(FRAMES)],
            "crc16 of a SET frame": lambda: [crc16(frame) for _ in range(FRAMES)],
        }
        # play() sends HELLO and OFF around the plan's steps
        counts = {name: FRAMES + 2 if name.startswith("play") else FRAMES for name in cases}
        rates = frames_per_second(cases, counts)
        link.off()
        link.close()
        short = Plan(steps=plan.steps[:RATE_STEPS], coil_count=16, channel_map=plan.channel_map)
        lags = [play(short, Serial(dev.port), rate=RATE).max_lag for _ in range(REPEATS)]
    base = rates["SET round trip over pty"]
    print(f"# bench_hardware  {time.strftime('%Y-%m-%d')}  {platform.machine()}  {os.cpu_count()} cores  "
          f"Python {platform.python_version()}  (medians of {REPEATS} interleaved rounds of {FRAMES} frames)")
    print(f"{'what':<34} {'frames/s':>12} {'ratio to SET':>13}")
    for name, rate in rates.items():
        print(f"{name:<34} {rate:>12,.0f} {rate / base:>13.2f}")
    print(f"play() of {RATE_STEPS} steps at {RATE:g} Hz over pty: worst step lateness "
          f"{statistics.median(lags) * 1000:.2f} ms (median of {REPEATS} runs; max {max(lags) * 1000:.2f} ms)")


if __name__ == "__main__":
    main()
