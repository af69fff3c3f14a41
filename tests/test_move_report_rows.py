"""The hardware move's report is its files (issue 38 §2): every figure of ``move.json`` (and so the console,
which prints the same result) is recomputed here from the rows ``trajectory.csv`` holds, on a run the loop slowed.

The slowed run is forced deterministically: the emulated iron prototype in lockstep (the simulated clock) with a
starved device (its answers 6 ms late between 0.5 and 0.9 s at 200 Hz), so the loop halves its rate and pace
once, then recovers. Before the fix the report took the target on the emulator's clock without the slow-down
(170–180° on the wall clock's slowed runs, while the CSV peaked at ~2°)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from spherestep.drive.hardware import drive_on_hardware
from spherestep.drive.turn import Turn, choose_model
from spherestep.hardware.motor_emulator import MotorFaults

pytestmark = pytest.mark.slow

AXIS, ANGLE, TIME = (1.0, 0.5, 2.0), math.radians(90), 1.5


@pytest.fixture(scope="module")
def slowed(tmp_path_factory):
    from spherestep.motor import prototype

    design = prototype()
    job = Turn(design, AXIS, ANGLE, choose_model(design), math.radians(0.05))
    result = drive_on_hardware(job, duration=TIME, port=None, emulate=True, rate=200.0, lockstep=True,
                               watchdog_ms=100, max_late=0.05, faults=MotorFaults(slow_answers=(0.006, 0.5, 0.9)))
    out = tmp_path_factory.mktemp("slowed")
    result.write(out)
    return result, out


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def park_distance_deg(q1, q2):
    """Park's metric from unit quaternions (independent of so3.distance): ``2 acos |q1 · q2|``, degrees."""
    dot = np.abs(np.sum(q1 * q2, axis=-1))
    return np.degrees(2 * np.arccos(np.clip(dot, 0.0, 1.0)))


def test_a_slowed_runs_report_is_computed_from_its_csv(slowed):
    result, out = slowed
    d = json.loads((out / "move.json").read_text())
    assert d["details"]["slowed"] >= 1 and d["details"]["outcome"] == "done", d["details"]
    table = rows(out / "trajectory.csv")
    rotor = np.array([[float(r[c]) for c in ("qw", "qx", "qy", "qz")] for r in table])
    target = np.array([[float(r[f"target_{c}"]) for c in ("qw", "qx", "qy", "qz")] for r in table])
    column = np.array([float(r["error_deg"]) for r in table])
    # the error column is the rotor against the target in the same row, and the report's maximum is its maximum
    np.testing.assert_allclose(park_distance_deg(rotor, target), column, atol=1e-5)
    assert d["max_tracking_error_deg"] == pytest.approx(column.max(), abs=2e-6)
    assert column.max() < 10, column.max()  # a slowed run tracks its paced target (the false report was 170-180°)
    # the end is the default hold (issue 38 §3): the rows are the loop's alone, and the final error is the last
    # row's rotor against the turn's end (the last target: the loop ended after it), where the servo held it
    assert d["details"]["end"] == "hold" and d["details"]["cycles"] == len(table)
    assert d["final_error_deg"] == pytest.approx(park_distance_deg(rotor[-1], target[-1]), abs=1e-5)
    assert d["details"]["held_error_deg"] == pytest.approx(d["final_error_deg"], abs=1e-9)
    # the arrival: the first row after which the rotor stays within the tolerance of the end
    to_end = park_distance_deg(rotor, target[-1])
    outside = np.flatnonzero(to_end > d["tolerance_deg"])
    if d["time_s"] is None:
        assert len(outside) and outside[-1] == len(table) - 1
    else:
        assert d["time_s"] == pytest.approx(float(table[outside[-1] + 1 if len(outside) else 0]["t_s"]), abs=1e-6)
    # the power and currents files hold the same rows, on the same clock
    power = rows(out / "power.csv")
    currents = rows(out / "currents.csv")
    assert [r["t_s"] for r in power] == [r["t_s"] for r in currents] == [r["t_s"] for r in table]
    assert d["peak_power_W"] == pytest.approx(max(float(r["power_W"]) for r in power), abs=1e-5)


def test_the_target_rows_follow_the_loops_pace_not_the_emulators_clock(slowed):
    """Each row's target is the trajectory at the time the loop followed it: the row's own time before the
    slow-down, behind it after (the triangle profile inverted from the angle the target has turned)."""
    from spherestep import so3

    result, _ = slowed
    turned = so3.distance(result.targets, result.targets[0])
    a = 4 * ANGLE / TIME ** 2  # the given time's triangle profile, θ(τ) = a τ²/2 to the middle
    tau = np.where(turned <= ANGLE / 2, np.sqrt(2 * turned / a), TIME - np.sqrt(np.maximum(2 * (ANGLE - turned) / a,
                                                                                          0.0)))
    t = result.times
    moving = (turned > 1e-3) & (turned < ANGLE - 1e-3)
    early = moving & (t < 0.45)
    assert early.sum() > 20 and np.abs(tau[early] - t[early]).max() < 1e-4
    late = moving & (t > 1.0)
    assert late.sum() > 20 and np.all(tau[late] < t[late] - 0.1), (t[late][:3], tau[late][:3])
    assert t[-1] > TIME + 0.5 + 0.1  # the run lengthened by the time spent at half the pace
