"""The whole loop over a real pseudo-terminal against the emulated motor (coils, rotor, magnetometers in a
separate process): holding a pose, turning 360° about the demo axis, and every injected fault ending with all
coils off within the device's watchdog period."""

from __future__ import annotations

import math
import os
import time

import numpy as np
import pytest

from spherestep import so3
from spherestep.control import Trajectory
from spherestep.errors import InputError
from spherestep.hardware.motor_emulator import MotorFaults
from spherestep.drive import servo_session, turn_reference

hold = Trajectory.hold

pytestmark = pytest.mark.slow

DEMO_AXIS = (1.0, 0.5, 2.0)
MIN_RATE = 150.0  # Hz: below this (a loaded test machine) the 360° turn is not judged
FAULT_AT = 0.4  # s of device time


@pytest.fixture(scope="module")
def rig():
    from spherestep.control import DriveLimits
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    design = prototype()
    return {"design": design, "model": torque_map(design), "sensors": default_array(design, 8),
            "drive": DriveLimits()}


def run(rig, reference, duration, **options):
    """An emulated session. The watchdog is 250 ms rather than the firmware's 100 ms, and a cycle may start up
    to 200 ms late, so that the load of a shared test machine does not end a run that is not under test."""
    options.setdefault("watchdog_ms", 250)
    options.setdefault("max_late", 0.2)
    return servo_session(rig["design"], reference, duration, emulate=True, sensors=rig["sensors"],
                         model=rig["model"], drive=rig["drive"], **options)


def test_holds_a_pose_within_a_tenth_of_a_degree(rig, tmp_path):
    target = so3.exp([0.002, -0.001, 0.003])
    s = run(rig, hold(target), 2.0, R0=np.eye(3), log=tmp_path / "hold.csv")
    assert s.report.outcome == "done", s.report.message
    errors = [math.degrees(so3.distance(truth.R, target)) for t, truth in s.truth if t > 0.5]  # device time
    assert len(errors) >= 3 and max(errors) < 0.1, errors
    assert s.report.rate > 20, s.report.to_dict()  # the 200 Hz target is measured by benchmarks/bench_hardware.py
    assert s.report.off_acknowledged and not s.final.enabled and np.abs(s.final.i).max() < 1e-3
    lines = (tmp_path / "hold.csv").read_text().splitlines()
    assert lines[0].startswith("t_s,late_s") and len(lines) == s.report.cycles + 1
    assert not (tmp_path / "hold.csv.part").exists()


def test_turns_360_degrees_about_the_demo_axis_within_3_s(rig):
    s = run(rig, turn_reference(np.eye(3), DEMO_AXIS, 2 * math.pi, 2.4, delay=0.2), 3.0)
    load = os.getloadavg()[0]
    if s.report.rate < MIN_RATE or (s.report.outcome == "LINK" and load >= os.cpu_count()):
        pytest.skip(f"the shared machine held the loop at {s.report.rate:.0f} Hz ({s.report.missed} deadlines "
                    f"missed, outcome {s.report.outcome}, load {load:.1f} on {os.cpu_count()} cores: the emulator "
                    f"starved of CPU); the turn is judged at {MIN_RATE:.0f} Hz or more on a machine with a free core "
                    "(benchmarks/bench_hardware.py measures it)")
    assert s.report.outcome == "done", s.report.message
    # on the way the rotor is half a turn from the start, about the demo axis; at 3 s it is back where it started
    t_half, half = max(s.truth, key=lambda sample: so3.distance(sample[1].R, np.eye(3)))
    assert math.degrees(so3.distance(half.R, np.eye(3))) > 170
    axis = np.asarray(DEMO_AXIS) / np.linalg.norm(DEMO_AXIS)
    turned = so3.log(half.R)
    assert abs(abs(turned @ axis) - np.linalg.norm(turned)) < 0.05
    assert s.truth[-1][0] > 2.9
    assert math.degrees(s.final_error()) < 0.1, s.report.to_dict()


def test_in_lockstep_the_loop_meets_the_targets_at_200_hz(rig):
    """The same loop, protocol frames, device and motor with the frames handed over in process on a simulated
    clock (LockstepLink): 200 Hz exactly, whatever the machine's load. Hold within 0.1° (measured 0.0042°), and
    the 360° turn about the demo axis back within 0.1° at 3 s (measured 0.019°, max tracking error 0.31°)."""
    target = so3.exp([0.002, -0.001, 0.003])
    s = run(rig, hold(target), 2.0, R0=np.eye(3), lockstep=True, watchdog_ms=100, max_late=0.05)
    assert s.report.outcome == "done" and s.report.rate == pytest.approx(200.0) and s.report.missed == 0
    assert max(math.degrees(so3.distance(truth.R, target)) for t, truth in s.truth if t > 1.0) < 0.1
    s = run(rig, turn_reference(np.eye(3), DEMO_AXIS, 2 * math.pi, 2.4, delay=0.2), 3.0, lockstep=True,
            watchdog_ms=100, max_late=0.05)
    assert s.report.outcome == "done" and s.report.rate == pytest.approx(200.0)
    assert max(math.degrees(so3.distance(truth.R, np.eye(3))) for _, truth in s.truth) > 170
    assert math.degrees(s.final_error()) < 0.1
    assert not s.final.enabled and np.abs(s.final.i).max() < 1e-3


def with_bias(reference_law_current: float = 0.3, coil: int = 0):
    """A status-free way to keep one coil at a sizeable current: the servo plus ``current`` A on ``coil``."""
    from dataclasses import replace

    from spherestep.control import ServoLaw

    class Biased(ServoLaw):
        def step(self, t, measurement=None, measured_at=None):
            cmd = super().step(t, measurement, measured_at)
            c = cmd.currents.copy()
            c[coil] += reference_law_current / self.limits.nominal_current
            return replace(cmd, currents=c)

    return Biased


@pytest.fixture
def biased(monkeypatch):
    """The session's control law with 0.3 A added on coil 0 (the servo holds against its torque), so that the
    coil faults meet a coil that carries current."""
    from spherestep.drive import session

    monkeypatch.setattr(session, "ServoLaw", with_bias())


@pytest.mark.parametrize("faults, codes", [
    (MotorFaults(open_coil=(0, FAULT_AT)), {"OPEN"}),
    (MotorFaults(stuck_coil=(0, FAULT_AT)), {"STUCK", "OVER"}),
    (MotorFaults(frozen_reading=(0, FAULT_AT)), {"STUCK"}),
    (MotorFaults(sensor_stops=(3, FAULT_AT)), {"SENSOR"}),
    (MotorFaults(sensor_garbage=(5, FAULT_AT)), {"SENSOR"}),
    (MotorFaults(vanish_at=FAULT_AT), {"LINK"}),
    (MotorFaults(deaf_at=FAULT_AT), {"LINK"}),
], ids=["open-coil", "stuck-coil", "frozen-sense", "sensor-stops", "sensor-garbage", "link-vanishes", "link-deaf"])
def test_every_fault_ends_with_all_coils_off_within_the_watchdog(rig, biased, faults, codes):
    s = run(rig, hold(np.eye(3)), 1.5, faults=faults)
    assert s.report.outcome in codes, s.report.to_dict()
    assert s.report.message
    # off at the fault (to the emulated clock's rounding: a stop detected on the fault's own tick) or within the watchdog
    assert FAULT_AT - 1e-9 <= s.final.off_at <= FAULT_AT + s.watchdog, (s.final.off_at, s.final.trips)
    assert not s.final.enabled
    assert np.abs(s.final.i).max() < 1e-3  # the coils' current has decayed


def test_a_slow_host_is_stopped_by_the_device_watchdog(rig, monkeypatch):
    from spherestep.drive import session

    stalled = []

    class Slow(session.ServoLaw):
        def step(self, t, measurement=None, measured_at=None):
            if t > 0.4 and not stalled:
                stalled.append(time.monotonic())
                time.sleep(0.4)  # the host misses 80 deadlines
            return super().step(t, measurement, measured_at)

    monkeypatch.setattr(session, "ServoLaw", Slow)
    s = run(rig, hold(np.eye(3)), 1.5, max_late=1.0)
    assert s.report.outcome == "WDOG", s.report.to_dict()
    stall = stalled[0] - s.started - s.final.slip  # in device time (any slip before the stall is subtracted)
    assert stall <= s.final.off_at <= stall + s.watchdog + 0.02, (stall, s.final.off_at, s.final.trips)
    assert not s.final.enabled and np.abs(s.final.i).max() < 1e-3


def test_the_hardware_loop_runs_the_control_rooms_law():
    from spherestep import control
    from spherestep.drive import session

    assert session.ServoLaw is control.ServoLaw  # one law: the simulation's (dynamics.simulate_servo) and this


def test_session_needs_a_port_or_the_emulator(rig):
    with pytest.raises(InputError, match="port"):
        servo_session(rig["design"], hold(np.eye(3)), 1.0, sensors=rig["sensors"], model=rig["model"])


def test_relay_plans_still_play_on_the_current_device(rig):
    """`spherestep run`'s path (Serial, protocol version 1, play) against the current-mode device: each step's
    coils carry ± the nominal current (1 A asked; 0.95 A reached, the 24 V / 24 Ω drive at its 0.95 duty limit),
    the others nothing, and the run ends all off."""
    from spherestep.commutation import Plan, Step, default_channel_map
    from spherestep.hardware import EmulatedMotor, MotorPty, Serial, play

    n = len(rig["design"].stator)
    I3 = np.eye(3)
    plan = Plan(steps=[Step(index=i, target=I3, achieved=I3, error=0.0, coils={i: 1, i + 5: -1}) for i in range(3)],
                coil_count=n, channel_map=default_channel_map(n))
    motor = EmulatedMotor(rig["design"], rig["model"], rig["sensors"], drive=rig["drive"])
    seen = []
    with MotorPty(motor, watchdog_ms=500) as dev:
        link = Serial(dev.port)
        original = link.hold

        def hold_and_look(seconds):
            original(seconds)
            seen.append(dev.truth().i.copy())

        link.hold = hold_and_look
        report = play(plan, link, rate=5.0)
        time.sleep(0.05)
        final = dev.truth()
    assert report.steps == 3 and report.device.protocol == 1 and report.device.channels == 2 * n
    for i, currents in enumerate(seen[:3]):
        assert currents[i] == pytest.approx(0.95, abs=0.02) and currents[i + 5] == pytest.approx(-0.95, abs=0.02)
        others = np.delete(currents, [i, i + 5])
        assert np.abs(others).max() < 0.05
    assert not final.enabled and np.abs(final.i).max() < 1e-3


def test_move_on_hardware_refuses_bad_input_with_exit_2(tmp_path):
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    exe = shutil.which("spherestep", path=str(Path(sys.executable).parent))
    for args in (["--emulate", "--port", "/dev/null"], ["--emulate", "--mode", "ramped"]):
        run_ = subprocess.run([exe, "move", "--axis", "1,0,0", "--angle", "10",
                               "--out", str(tmp_path), *args], capture_output=True, text=True, timeout=120)
        assert run_.returncode == 2, run_.stderr
        assert "Traceback" not in run_.stderr and run_.stderr.count("\n") == 1, run_.stderr
