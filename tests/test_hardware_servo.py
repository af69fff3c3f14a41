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
    options.setdefault("rate", 200.0)  # the rate these numbers were measured at (the sessions' default is 500 Hz)
    return servo_session(rig["design"], reference, duration, emulate=True, sensors=rig["sensors"],
                         model=rig["model"], drive=rig["drive"], **options)


@pytest.mark.realtime  # over the pseudo-terminal on the wall clock: a starved machine moves the rotor off
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


def other_cpu(run):
    """``(result, share)``: ``run()``'s result and the share of the machine's cores (0 to 1) that processes other
    than this one and its children (the emulator) used meanwhile, from ``/proc/stat`` (None where there is none):
    what starved the machine."""
    def busy():
        with open("/proc/stat") as f:
            user, nice, system, idle, iowait, irq, softirq, steal = (float(x) for x in f.readline().split()[1:9])
        return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")  # guest is within user

    try:
        before, mine, wall = busy(), sum(os.times()[:4]), time.monotonic()
    except (OSError, ValueError):
        return run(), None
    result = run()
    others = busy() - before - (sum(os.times()[:4]) - mine)
    return result, others / ((time.monotonic() - wall) * os.cpu_count())


@pytest.mark.realtime
def test_turns_360_degrees_about_the_demo_axis_at_500_hz(rig):
    """Over the pseudo-terminal on the wall clock: 500 Hz, no deadline missed, never slowed, back within 0.05°.

    This VM stalls now and then whatever runs in it: ``bench_hardware.py --repeat 40`` (load 0.6–1.2) had 37 of
    40 such turns miss nothing and 3 ticks missed in all (1 while the loop slept with its work done:
    ``late_wakeups``, the OS woke it over a period late). So the turn is judged on the better of two runs (a loop that
    misses deadlines of its own misses them in both), and skipped, saying why, only when both fail while other
    processes kept more than a quarter of the machine busy (the loop runs with SCHED_FIFO where permitted, which
    holds it on a busy machine, but not on one whose two cores other processes fill: measured 4–5 deadlines
    missed of 1,500 at a load of 15)."""
    runs = []
    for _ in range(2):
        s, others = other_cpu(lambda: run(rig, turn_reference(np.eye(3), DEMO_AXIS, 2 * math.pi, 2.4, delay=0.2),
                                          3.0, rate=500.0))
        runs.append((s, others))
        if s.report.missed == 0 and s.report.outcome == "done" and s.report.cpu_mean < 0.5 / 500.0:
            break
    # the better run, by outcome, misses and the host's CPU: the VM's stalls reach the thread's CPU time too (a
    # quiet machine's mean is 0.68-0.76 ms per cycle, before and after the back-EMF; one fresh-clone CI run had
    # 1.16 ms): a loop whose own work is over budget is over in both runs
    s, others = min(runs, key=lambda run_: (run_[0].report.outcome != "done", run_[0].report.missed,
                                            run_[0].report.cpu_mean))
    r = s.report
    starved = all(o is not None and o > 0.25 for _, o in runs)
    if (r.missed or r.outcome != "done") and starved:
        pytest.skip(f"other processes kept {100 * others:.0f} % of the machine's {os.cpu_count()} cores busy during "
                    f"the sessions (load {os.getloadavg()[0]:.1f}; real-time scheduling "
                    f"{'on' if r.realtime else 'refused'}): {r.missed} deadlines missed, {r.rate:.0f} Hz, outcome "
                    f"{r.outcome} are theirs to explain")
    assert r.outcome == "done", r.to_dict()
    assert r.missed == 0 and r.slowed == 0 and r.rate == pytest.approx(500.0, rel=0.01), \
        ([run_[0].report.to_dict() for run_ in runs], others)
    assert r.late_readings < 0.01 * r.cycles, r.to_dict()  # a late reading costs one cycle on the prediction
    assert r.cpu_mean < 0.5 / 500.0, r.to_dict()  # the host's CPU: under half the period
    # on the way the rotor is half a turn from the start, about the demo axis; at 3 s it is back where it started
    t_half, half = max(s.truth, key=lambda sample: so3.distance(sample[1].R, np.eye(3)))
    assert math.degrees(so3.distance(half.R, np.eye(3))) > 170
    axis = np.asarray(DEMO_AXIS) / np.linalg.norm(DEMO_AXIS)
    turned = so3.log(half.R)
    assert abs(abs(turned @ axis) - np.linalg.norm(turned)) < 0.05
    assert s.truth[-1][0] > 2.9
    # the estimate at the loop's end, and the emulated rotor at its last sample (≤ 50 ms before; once the coils
    # are off it drifts on what speed it had left, measured 0.2° by 0.15 s later)
    at_end = math.degrees(so3.distance(s.truth[-1][1].R, np.eye(3)))
    assert math.degrees(r.end_error) < 0.05 and at_end < 0.1, (r.to_dict(), at_end)


def test_in_lockstep_the_360_degree_turn_holds_500_hz_within_its_cpu_budget(rig):
    """The emulated 360° turn judged always, whatever the machine's load: on the lockstep clock the loop keeps
    500 Hz exactly and misses nothing, the rotor ends within 0.05° (measured 0.0016° at the loop's end, 0.024°
    0.15 s after the coils went off, 0.031° max tracking error), and the host's CPU per cycle — this thread's
    time for the frames (with the in-process device's answer), the estimate and the law — stays under half the
    period on average and under the period in 99 % of the cycles (measured mean 0.36-0.70 ms): a slow loop fails
    here."""
    s = run(rig, turn_reference(np.eye(3), DEMO_AXIS, 2 * math.pi, 2.4, delay=0.2), 3.0, lockstep=True,
            watchdog_ms=100, max_late=0.05, rate=500.0)
    r = s.report
    assert r.outcome == "done" and r.rate == pytest.approx(500.0) and r.missed == 0 and r.slowed == 0, r.to_dict()
    assert max(math.degrees(so3.distance(truth.R, np.eye(3))) for _, truth in s.truth) > 170
    assert max(math.degrees(so3.distance(truth.R, s.trajectory.at(t)[0])) for t, truth in s.truth) < 0.3
    assert math.degrees(r.end_error) < 0.05 and math.degrees(s.final_error()) < 0.05, r.to_dict()
    # one cycle's thread CPU can jump when the other core is busy (the worst cycle measured 0.57-1.1 ms alone, 2.01
    # and 8.3 ms beside the full suite on two workers in a VM): the mean within half a period, 99 % of the cycles
    # within one, and the worst reported (cpu_max) but not judged
    assert r.cpu_mean < 0.5 / 500.0 and r.cpu_p99 < 1.0 / 500.0 and r.cpu_max >= r.cpu_p99, r.to_dict()
    assert not s.final.enabled and np.abs(s.final.i).max() < 1e-3


def starved(rig, faults, duration=3.0, rate=200.0, lockstep=True, **options):
    """The 360° turn with ``faults`` (a starved device: ``slow_answers``) and the loop's ``options`` (``on_missed``
    ...): ``(report, final truth)``, the session assembled as the drive room does, run_servo called directly."""
    from spherestep.control import GeometricPD, ServoLaw
    from spherestep.dynamics import Rotor
    from spherestep.drive.connect import emulated_motor
    from spherestep.hardware import DriveLink, FieldTracker, LockstepLink, MotorPty, run_servo, wire_limits
    from spherestep.sensing import field_model

    design, sensors, drive = rig["design"], rig["sensors"], rig["drive"]
    traj = turn_reference(np.eye(3), DEMO_AXIS, 2 * math.pi, 2.4, delay=0.2)
    rotor = Rotor.from_design(design, damping=0.01)
    estimator = field_model(design, sensors.positions).estimator(sensors)  # the session's (the cores on iron)
    law = ServoLaw(rig["model"], traj, GeometricPD(rotor.inertia, bandwidth=2 * math.pi * 3, rate=rate,
                                                   damping=rotor.damping),
                   limits=wire_limits(drive), sensor_rate=rate, delay=1, observer_bandwidth=rate)
    motor = emulated_motor(design, rig["model"], sensors, rotor=rotor, drive=drive, faults=faults)
    tracker = FieldTracker(estimator, np.eye(3), drive)
    if lockstep:
        link = LockstepLink(motor, watchdog_ms=100)
        report = run_servo(link, tracker, law, duration=duration, rate=rate, clock=link.clock, sleep=link.sleep,
                           max_late=0.05, **options)
        link.sleep(0.15)
        return report, link.truth(), traj
    with MotorPty(motor, watchdog_ms=250) as dev:
        with DriveLink(dev.port) as link:
            report = run_servo(link, tracker, law, duration=duration, rate=rate, max_late=0.2, **options)
        time.sleep(0.15)
        return report, dev.truth(), traj


STARVED = 0.012  # s: answers 2.4 periods late at 200 Hz


def test_a_starved_loop_told_to_stop_stops_with_every_coil_off_and_says_why(rig):
    report, final, _ = starved(rig, MotorFaults(slow_answers=(STARVED, 0.8, 9.0)), on_missed="stop")
    assert report.outcome == "SLOW" and report.missed >= 3, report.to_dict()
    assert f"missed {report.missed} deadlines" in report.message and "every coil off" in report.message
    assert "from the target" in report.message and report.end_error > math.radians(10)
    assert report.off_acknowledged and not final.enabled and np.abs(final.i).max() < 1e-3


def test_a_loop_starved_for_a_while_slows_the_motion_and_still_ends_on_target(rig):
    """Answers late for 0.4 s mid-turn: the loop halves its rate and the trajectory's pace (twice: 100 Hz is
    still too fast for 12 ms answers), follows the whole turn slower, recovers its rate once the device answers
    on time again, and ends on the target; the report says so."""
    report, final, traj = starved(rig, MotorFaults(slow_answers=(STARVED, 0.8, 1.2)))
    assert report.outcome == "done" and report.slowed == 2 and report.missed >= 3, report.to_dict()
    assert report.time_scale == 1.0  # back to the planned pace
    assert report.reference_times[-1] == pytest.approx(3.0, abs=0.01) and report.times[-1] > 4.0
    assert math.degrees(report.end_error) < 0.05, report.to_dict()
    slowed_at = np.flatnonzero(np.diff(report.reference_times) < 0.9 * np.diff(report.times))
    assert 0.8 <= report.times[slowed_at[0]] <= 1.0  # the pace fell where the answers came late
    assert not final.enabled


def test_a_loop_starved_beyond_the_slowest_pace_stops(rig):
    report, final, _ = starved(rig, MotorFaults(slow_answers=(0.045, 0.8, 9.0)))
    assert report.outcome == "SLOW" and report.time_scale == pytest.approx(0.125), report.to_dict()
    assert "at the slowest pace" in report.message and "every coil off" in report.message
    assert report.off_acknowledged and not final.enabled


def test_a_starved_emulator_over_the_line_stops_the_loop(rig):
    """The same on the wall clock, over the pseudo-terminal: the device process sleeps before every answer
    after 0.5 s, so the loop must miss its deadlines whatever the machine; told to stop, it stops."""
    report, final, _ = starved(rig, MotorFaults(slow_answers=(STARVED, 0.5, 9.0)), lockstep=False,
                               on_missed="stop")
    assert report.outcome == "SLOW" and report.missed >= 3, report.to_dict()
    assert report.off_acknowledged and not final.enabled


def test_in_lockstep_the_loop_meets_the_targets_at_200_hz(rig):
    """The same loop, protocol frames, device and motor with the frames handed over in process on a simulated
    clock (LockstepLink): 200 Hz exactly, whatever the machine's load. Hold within 0.1° (measured 0.0039°), and
    the 360° turn about the demo axis back within 0.1° at 3 s (measured 0.0020°, max tracking error 0.078°)."""
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


def with_bias(reference_law_current: float = 0.3, coil: int = 0, step_at: float = FAULT_AT + 0.05):
    """A status-free way to keep one coil at a sizeable current: the servo plus ``current`` A on ``coil``, 0.6 of
    it from ``step_at`` s of the loop's time on — the demand moves after the fault, so that a sense frozen at the
    coil's steady current is seen (the device cannot tell it from a quiet coil until the demand moves,
    docs/hardware.md; the servo's own corrections on a quiet hold may stay within the rule's 50 mA for longer than
    the watchdog)."""
    from dataclasses import replace

    from spherestep.control import ServoLaw

    class Biased(ServoLaw):
        def step(self, t, measurement=None, measured_at=None):
            cmd = super().step(t, measurement, measured_at)
            c = cmd.currents.copy()
            c[coil] += (reference_law_current if t < step_at else 0.6 * reference_law_current) / self.limits.nominal_current
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


@pytest.mark.realtime  # the device's watchdog measured against the host's stall on the wall clock (20 ms margin)
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
    coils carry ± the nominal current (1 A asked; ± 0.95 V/R less the coil's back-EMF e/R reached, the 24 V /
    24 Ω drive at its 0.95 duty limit, e = K(R)·ω/I_n of the rotor still turning), the others nothing, and the run
    ends all off (with the device told no back-EMF by SET, its held-reading rule must not trip)."""
    from spherestep.commutation import Plan, Step, default_channel_map
    from spherestep.drive.connect import emulated_motor
    from relays import play_relays
    from spherestep.hardware import MotorPty, Serial

    n = len(rig["design"].stator)
    I3 = np.eye(3)
    plan = Plan(steps=[Step(index=i, target=I3, achieved=I3, error=0.0, coils={i: 1, i + 5: -1}) for i in range(3)],
                coil_count=n, channel_map=default_channel_map(n))
    motor = emulated_motor(rig["design"], rig["model"], rig["sensors"], drive=rig["drive"])
    seen = []
    with MotorPty(motor, watchdog_ms=500) as dev:
        link = Serial(dev.port)
        original = link.hold

        def hold_and_look(seconds):
            original(seconds)
            seen.append(dev.truth())

        link.hold = hold_and_look
        report = play_relays(plan, link, rate=5.0)
        time.sleep(0.05)
        final = dev.truth()
    assert report.steps == 3 and report.device.protocol == 1 and report.device.channels == 2 * n
    drive = rig["drive"]
    for i, truth in enumerate(seen[:3]):
        currents = truth.i
        emf = drive.back_emf(truth.w @ rig["model"].torque_matrix(truth.R))
        reached = np.clip((np.array([0.95, -0.95]) * drive.supply_voltage - emf[[i, i + 5]]) / drive.resistance,
                          -1.0, 1.0)  # the 1 A asked, where the back-EMF leaves the drive enough
        assert currents[[i, i + 5]] == pytest.approx(reached, abs=0.01), (currents[[i, i + 5]], emf[[i, i + 5]])
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


def test_an_interrupt_inside_a_compiled_call_stops_the_loop_with_every_coil_off(rig, monkeypatch):
    """Ctrl-C or SIGTERM landing inside a numba call of the law surfaces as ``SystemError`` with the interrupt as
    its context (seen in the fresh-clone CI: ``move --emulate`` then said no word of the coils): the loop takes it
    as the interrupt, switches every coil off and reports ``INTERRUPT``; any other SystemError is not swallowed."""
    from spherestep.drive import session

    class Interrupted(session.ServoLaw):
        calls = 0
        error = KeyboardInterrupt

        def step(self, t, measurement=None, measured_at=None):
            type(self).calls += 1
            if type(self).calls == 50:
                try:
                    raise self.error()
                except BaseException as exc:
                    raise SystemError("CPUDispatcher(<function ...>) returned a result with an exception set") from exc
            return super().step(t, measurement, measured_at)

    monkeypatch.setattr(session, "ServoLaw", Interrupted)
    s = run(rig, hold(np.eye(3)), 1.0, lockstep=True, watchdog_ms=100, max_late=0.05)
    assert s.report.outcome == "INTERRUPT" and s.report.off_acknowledged and s.report.cycles == 48, s.report.to_dict()
    assert not s.final.enabled
    Interrupted.calls, Interrupted.error = 0, ValueError
    with pytest.raises(SystemError):
        run(rig, hold(np.eye(3)), 1.0, lockstep=True, watchdog_ms=100, max_late=0.05)
