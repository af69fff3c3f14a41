"""Frames per second through a pseudo-terminal: host Serial back end ↔ Python emulator, side by side; then the
current mode (protocol version 2) against the emulated motor.

Relay mode, each row: median over REPEATS rounds of FRAMES acknowledged commands (stop-and-wait, so one frame
in flight), and its ratio to the SET round trip; then how late ``play`` starts its steps when it keeps a RATE Hz
schedule. Current mode (:func:`servo`): the per-frame costs side by side (CRC table vs bit by bit, encode and
parse, one device control step), ``DRIVE`` round trips per second against the emulated motor (29 coils, 8
magnetometers, the device in its own process), and whole sessions at 200 Hz: holding a pose, the 360° turn
about (1, 0.5, 2) in 2.4 s, and the fault drill (time from each injected fault to all coils off). The machine's
load average is printed with them: on a shared 2-core machine the loop rate is the machine's, not the code's.
Run: ``.venv/bin/python benchmarks/bench_hardware.py`` (``--servo`` for the current mode only; ``--repeat N`` for
the 500 Hz turn N times, how often the machine stalls the loop; ``--json PATH`` also stores the numbers for
``scripts/docs_numbers.py``).
"""

from __future__ import annotations

import math
import os
import platform
import statistics
import sys
import time

import numpy as np

from _record import Record
from spherestep.commutation import Plan, Step, default_channel_map
from spherestep.hardware import DryRun, PtyDevice, RelayLink, Serial, play
from spherestep.hardware.protocol import crc16, crc16_table, decode, encode

FRAMES = 500
SERVO_RATES = (200.0, 500.0)  # Hz: the loop's former default and today's
REPEATS = 5
RATE, RATE_STEPS = 200.0, 200  # a schedule to keep: steps at RATE Hz
RECORD = Record("hardware", argv=[])  # the run's record; from sys.argv (``--json PATH``) when run as a script


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
            play(plan, RelayLink(Serial(dev.port), plan.channel_map), rate=1e6)
            link.open()

        cases = {
            "SET round trip over pty": lambda: [link.write(1 << (i % 16), 1 << (16 + i % 16), {})
                                                for i in range(FRAMES)],
            "PING round trip over pty": lambda: [link._transact("PING") for _ in range(FRAMES)],
            "play() over pty, rate unbounded": play_pty,
            "play() on DryRun": lambda: play(plan, RelayLink(DryRun(), plan.channel_map), rate=1e6),
            "encode + decode only": lambda: [decode(encode(0x12, "SET", "3", "20")[1:-1]) for _ in range(FRAMES)],
            "crc16 of a SET frame": lambda: [crc16(frame) for _ in range(FRAMES)],
        }
        # play() sends HELLO and OFF around the plan's steps
        counts = {name: FRAMES + 2 if name.startswith("play") else FRAMES for name in cases}
        rates = frames_per_second(cases, counts)
        link.off()
        link.close()
        short = Plan(steps=plan.steps[:RATE_STEPS], coil_count=16, channel_map=plan.channel_map)
        lags = [play(short, RelayLink(Serial(dev.port), short.channel_map), rate=RATE).max_lag for _ in range(REPEATS)]
    base = rates["SET round trip over pty"]
    print(f"# bench_hardware  {time.strftime('%Y-%m-%d')}  {platform.machine()}  {os.cpu_count()} cores  "
          f"Python {platform.python_version()}  (medians of {REPEATS} interleaved rounds of {FRAMES} frames)")
    print(f"{'what':<34} {'frames/s':>12} {'ratio to SET':>13}")
    for name, rate in rates.items():
        print(f"{name:<34} {rate:>12,.0f} {rate / base:>13.2f}")
    print(f"play() of {RATE_STEPS} steps at {RATE:g} Hz over pty: worst step lateness "
          f"{statistics.median(lags) * 1000:.2f} ms (median of {REPEATS} runs; max {max(lags) * 1000:.2f} ms)")
    RECORD.put("relay frames per second", rates)
    RECORD.put("play lateness ms", {"rate Hz": RATE, "median": statistics.median(lags) * 1e3, "max": max(lags) * 1e3})


def servo() -> None:
    from _timing import median_seconds

    from spherestep import so3
    from spherestep.control import DriveLimits, Trajectory
    from spherestep.drive import servo_session, turn_reference
    from spherestep.drive.connect import emulated_motor
    from spherestep.hardware import CurrentDevice, DriveLink, MotorFaults, MotorPty
    from spherestep.hardware.protocol import _shift8
    from spherestep.hardware.protocol2 import MAX_FRAME2, encode_block, frame_bytes, parse_state
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    hold = Trajectory.hold

    def crc_bitwise(data: bytes) -> int:
        crc = 0xFFFF
        for byte in data:
            crc = _shift8(crc ^ (byte << 8))
        return crc

    design = prototype()
    model, sensors, drive = torque_map(design), default_array(design, 8), DriveLimits()
    n, S = len(design.stator), len(sensors)
    answer = encode(0, "ACK", "DRIVE", "00000000", "0", encode_block(np.arange(n)), encode_block(np.arange(3 * S)),
                    max_frame=MAX_FRAME2)
    body = answer[1:-1]
    motor = emulated_motor(design, model, sensors, drive=drive)
    device = CurrentDevice(motor, n, S)
    device.receive(encode(0, "HELLO", 2), 0)
    device.receive(encode(1, "DRIVE", encode_block(np.full(n, 100)), max_frame=MAX_FRAME2), 0)
    costs = {
        "crc16, binascii (244-byte answer)": median_seconds(200, crc16, answer[1:-7]),
        "crc16, table in Python (same)": median_seconds(200, crc16_table, answer[1:-7]),
        "crc16, bit by bit (same)": median_seconds(50, crc_bitwise, answer[1:-7]),
        "encode DRIVE (29 coils)": median_seconds(200, lambda: encode(1, "DRIVE", encode_block(np.zeros(n)),
                                                                      max_frame=MAX_FRAME2)),
        "decode + parse the answer": median_seconds(200, lambda: parse_state(decode(body, MAX_FRAME2).args[1:], n, S,
                                                                               8e-6)),
        "device control step (Python)": median_seconds(200, device.step, 1000),
        "motor: coils over one period": median_seconds(200, motor._advance_coils, motor.period),
        "motor: magnetometers (sense)": median_seconds(200, motor.sense),
    }
    load = os.getloadavg()
    print(f"\n# bench_hardware --servo  {time.strftime('%Y-%m-%d')}  {platform.machine()}  {os.cpu_count()} cores  "
          f"Python {platform.python_version()}  load average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f}")
    sizes = frame_bytes(n, S)
    print(f"frame bytes ({n} coils, {S} sensors): DRIVE {sizes['drive']}, answer {sizes['answer']}, round trip "
          f"{sizes['round_trip']}; at 115200 baud (10 bits a byte) at most "
          f"{115200 / 10 / sizes['round_trip']:.1f} round trips/s")
    base = costs["crc16, binascii (244-byte answer)"]
    print(f"{'per frame':<34} {'median µs':>10} {'ratio to CRC':>13}")
    for name, sec in costs.items():
        print(f"{name:<34} {sec * 1e6:>10.1f} {sec / base:>13.2f}")
    RECORD.put("per frame us", {name: sec * 1e6 for name, sec in costs.items()})

    with MotorPty(emulated_motor(design, model, sensors, drive=drive), watchdog_ms=1000) as dev, \
            DriveLink(dev.port, timeout=0.5) as link:
        block = np.zeros(n)
        rounds = []
        for _ in range(REPEATS + 1):
            t = time.perf_counter()
            for _ in range(200):
                link.drive(block)
            rounds.append(200 / (time.perf_counter() - t))
        RECORD.put("DRIVE round trips per second", statistics.median(rounds[1:]))
        print(f"DRIVE round trips over pty against the emulated motor: {statistics.median(rounds[1:]):,.0f}/s "
              f"(median of {REPEATS} rounds of 200; min {min(rounds[1:]):,.0f}, max {max(rounds[1:]):,.0f})")

    def session(reference, duration, **options):
        return servo_session(design, reference, duration, emulate=True, sensors=sensors, model=model, drive=drive,
                             **options)

    target = so3.exp([0.002, -0.001, 0.003])
    turning = turn_reference(np.eye(3), (1.0, 0.5, 2.0), 2 * math.pi, 2.4, delay=0.2)
    print(f"{'session (SERVO_RATE asked; emulated time reached)':<52} {'rate Hz':>8} {'missed':>7} {'RT':>3} "
          f"{'CPU ms mean/max':>16} {'outcome':>8} {'error °':>9}")
    for how, extra in (("pty", dict(max_late=0.2, watchdog_ms=250)), ("lockstep", dict(lockstep=True))):
        for rate in SERVO_RATES:
            s = session(hold(target), 3.0, R0=np.eye(3), rate=rate, **extra)
            held = [math.degrees(so3.distance(tr.R, target)) for t, tr in s.truth if t > 0.5]
            _row(f"hold 3 s at {rate:g} Hz, max error after 0.5 s, {how}", s.report, max(held, default=math.nan),
                 ("hold", how, rate))
            s = session(turning, 3.0, rate=rate, **extra)
            _row(f"360° (1,0.5,2) 2.4 s at {rate:g} Hz, end error, {how}", s.report, math.degrees(s.report.end_error),
                 ("turn", how, rate))
    print(f"load average now {os.getloadavg()[0]:.1f}")
    at = 1.0  # mid-turn, on the coil carrying the most current (index −1); the line faults at 0.4 s of a hold
    drill = {"open coil": (MotorFaults(open_coil=(-1, at)), True), "coil stuck at full current":
             (MotorFaults(stuck_coil=(-1, at)), True), "frozen current sense": (MotorFaults(frozen_reading=(-1, at)), True),
             "magnetometer stops": (MotorFaults(sensor_stops=(3, at)), True),
             "magnetometer garbage": (MotorFaults(sensor_garbage=(5, at)), True),
             "link vanishes": (MotorFaults(vanish_at=0.4), False), "link deaf": (MotorFaults(deaf_at=0.4), False)}
    print(f"{'fault (watchdog 100 ms)':<28} {'where':>9} {'outcome':>8} {'to all off, ms':>15}")
    off = 0
    for name, (faults, in_lockstep) in drill.items():
        if in_lockstep:  # mid-turn, on the simulated clock (the machine's load cannot delay it)
            s, start = session(turning, 1.5, faults=faults, lockstep=True), at
        else:  # over the pty: a line fault needs the line
            s, start = session(hold(np.eye(3)), 2.0, faults=faults, max_late=0.09), 0.4
        latency = (s.final.off_at - start) * 1000
        off += (0 <= latency <= 100) and not s.final.enabled and s.report.outcome != "done"
        print(f"{name:<28} {'lockstep' if in_lockstep else 'pty':>9} {s.report.outcome:>8} {latency:>15.1f}")
        RECORD.values.setdefault("faults", []).append({"fault": name, "where": "lockstep" if in_lockstep else "pty",
                                                       "outcome": s.report.outcome, "to all off ms": latency})
    print(f"all coils off within the watchdog period: {off} of {len(drill)}")
    RECORD.put("faults all off", [off, len(drill)])


def repeat(runs: int) -> None:
    """The 360° turn about (1, 0.5, 2) in 2.4 s at 500 Hz over the pty, ``runs`` times (``--repeat N``): per run
    the deadlines missed (and how many of them were late wake-ups), the late readings and the halvings; then the
    totals — how often this machine stalls the loop, apart from the loop's own cost."""
    from spherestep.control import DriveLimits
    from spherestep.drive import servo_session, turn_reference
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    design = prototype()
    model, sensors = torque_map(design), default_array(design, 8)
    turning = turn_reference(np.eye(3), (1.0, 0.5, 2.0), 2 * math.pi, 2.4, delay=0.2)
    print(f"# the 360° turn at 500 Hz over the pty, {runs} runs; load average {os.getloadavg()[0]:.1f}")
    rows = []
    for k in range(runs):
        r = servo_session(design, turning, 3.0, emulate=True, sensors=sensors, model=model, drive=DriveLimits(),
                          rate=500.0, max_late=0.2, watchdog_ms=250).report
        rows.append({"missed": r.missed, "late wakeups": r.late_wakeups, "late readings": r.late_readings,
                     "slowed": r.slowed, "cycles": r.cycles, "cpu max ms": r.cpu_max * 1e3,
                     "end error deg": math.degrees(r.end_error)})
        print(f"run {k + 1:>3}: {r.missed} missed ({r.late_wakeups} late wake-ups), {r.late_readings} late readings, "
              f"slowed {r.slowed}, worst cycle CPU {r.cpu_max * 1e3:.2f} ms, end {math.degrees(r.end_error):.4f}°")
    clean = sum(row["missed"] == 0 for row in rows)
    totals = {key: sum(row[key] for row in rows) for key in ("missed", "late wakeups", "late readings", "slowed",
                                                              "cycles")}
    print(f"{clean} of {runs} runs missed nothing; in all {totals}; load average now {os.getloadavg()[0]:.1f}")
    RECORD.put("repeat", {"runs": rows, "clean runs": clean, "totals": totals})


def _row(label: str, report, error: float, key: tuple) -> None:
    RECORD.values.setdefault("sessions", []).append(
        {"case": key[0], "how": key[1], "rate asked Hz": key[2], "rate Hz": report.rate, "missed": report.missed,
         "realtime": report.realtime, "cpu mean ms": report.cpu_mean * 1e3, "cpu max ms": report.cpu_max * 1e3,
         "outcome": report.outcome, "error deg": error})
    print(f"{label:<52} {report.rate:>8.0f} {report.missed:>7} {'yes' if report.realtime else 'no':>3} "
          f"{report.cpu_mean * 1e3:>7.2f}/{report.cpu_max * 1e3:<8.2f} {report.outcome:>8} {error:>9.4f}")


if __name__ == "__main__":
    RECORD = Record("hardware")  # --json PATH: what this run measured, for scripts/docs_numbers.py
    if "--repeat" in sys.argv:
        repeat(int(sys.argv[sys.argv.index("--repeat") + 1]))
    else:
        if "--servo" not in sys.argv:
            main()
        servo()
    RECORD.write()
