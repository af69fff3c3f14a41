"""``spherestep run``: dry run, a real pseudo-terminal device, bad input, a vanishing device and Ctrl-C."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from spherestep.cli import main
from spherestep.commutation import Plan, Step, default_channel_map
from spherestep.hardware import Faults, PtyDevice

I3 = np.eye(3)


def write_plan(path, n_steps, coil_count=4):
    steps = [Step(index=i, target=I3, achieved=I3, error=0.0, coils={i % coil_count: 1, (i + 1) % coil_count: -1})
             for i in range(n_steps)]
    Plan(steps=steps, coil_count=coil_count, channel_map=default_channel_map(coil_count)).to_json(path)
    return path


def one_error_line(err):
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    return lines[0]


def test_dry_run_prints_and_logs_what_would_be_sent(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 5)
    log = tmp_path / "logs" / "dry.log"
    assert main(["run", str(plan), "--rate", "4", "--dry-run", "--log", str(log)]) == 0
    out = capsys.readouterr().out
    assert ("dry run: 5 frames (the start and 4 steps) at 4 Hz would take 1.250 s on a 8-channel controller (the "
            "channels the plan uses); nothing was sent; final state all coils off") in out
    assert "0x9" in out and "0- 3+" in out and "all off" in out
    lines = log.read_text().splitlines()
    assert lines[-1].split(None, 2)[1:] == ["NOTE", "end: 5 frames streamed; all coils off"]
    lines = lines[:-1]
    assert [line.split()[2].split(",")[1].split("*")[0] for line in lines] == ["HELLO"] + ["SET"] * 5 + ["OFF"]
    assert [float(line.split()[0]) for line in lines] == pytest.approx([0, 0, 0.25, 0.5, 0.75, 1.0, 1.25])
    assert not list(log.parent.glob(".*.tmp"))


def test_run_streams_to_a_device_and_logs_acknowledgements(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 6)
    log = tmp_path / "run.log"
    with PtyDevice(channels=32, watchdog_ms=300) as dev:
        code = main(["run", str(plan), "--port", dev.port, "--rate", "30", "--log", str(log)])
        state, frames = dev.state(), dev.frames
    assert code == 0
    out = capsys.readouterr().out
    assert (f"streamed 6 frames (the start and 5 steps) at 30 Hz to {dev.port} (device 'spherestep-emu', protocol 1, "
            "32 channels)") in out
    assert "8 frames acknowledged, 0 retransmissions" in out and "final state all coils off, acknowledged" in out
    assert state == (0, 0) and frames == 8
    text = log.read_text()
    assert text.count(" TX ") == 8 and text.count(",ACK,") == 8 and "ACK,OFF,0,0" in text


def test_bad_port_is_one_line_and_exit_2(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 2)
    assert main(["run", str(plan), "--port", "/dev/spherestep-no-such-port", "--rate", "5"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith("spherestep: error: port '/dev/spherestep-no-such-port' could not be opened")


@pytest.mark.parametrize("content, message", [
    ("{not json", "plan must be a JSON plan file"),
    (json.dumps({"format": "spherestep-plan", "version": 2, "coil_count": 4}), "plan.channel_map must be present"),
    (json.dumps({"format": "spherestep-plan", "version": 1, "coil_count": 4}), "plan.version must be 2"),
    (json.dumps({"format": "something-else"}), "plan.format must be"),
])
def test_malformed_plan_is_one_line_and_exit_2(tmp_path, capsys, content, message):
    plan = tmp_path / "plan.json"
    plan.write_text(content)
    assert main(["run", str(plan), "--rate", "5", "--dry-run"]) == 2
    assert message in one_error_line(capsys.readouterr().err)


def test_dry_run_stands_in_for_the_given_channel_count(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 2, coil_count=20)  # 40 channels
    assert main(["run", str(plan), "--rate", "5", "--dry-run", "--channels", "32"]) == 2
    assert "uses relay channel 39, but device 'dry-run' has 32 channels" in one_error_line(capsys.readouterr().err)
    assert main(["run", str(plan), "--rate", "5", "--dry-run"]) == 0  # default: the channels the plan uses
    assert "on a 40-channel controller (the channels the plan uses)" in capsys.readouterr().out


@pytest.mark.parametrize("args, message", [
    (["--rate", "5"], "--port must be the controller's serial device"),
    (["--rate", "5", "--port", "/dev/ttyUSB0", "--channels", "64"], "--channels must be given only with --dry-run"),
    (["--rate", "5", "--dry-run", "--channels", "65"], "--channels must be a channel count 1..64"),
    (["--rate", "0", "--dry-run"], "--rate must be a positive number of steps per second"),
    (["--rate", "5", "--dry-run", "--max-duty", "1.5"], "--max-duty must be a fraction in (0, 1]"),
    (["--rate", "5", "--dry-run", "--max-on", "-1"], "--max-on must be a positive number of seconds"),
    (["--rate", "0.5", "--dry-run", "--max-on", "1.5"],
     "coil 0 would stay on for 2.000 s without a break (to the end of step 0), over max_on = 1.5 s"),
])
def test_bad_options_are_one_line_and_exit_2(tmp_path, capsys, args, message):
    plan = write_plan(tmp_path / "plan.json", 3)
    assert main(["run", str(plan), *args]) == 2
    assert message in one_error_line(capsys.readouterr().err)


def test_thermal_violation_is_refused_before_the_device_is_touched(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 3)
    with PtyDevice(channels=32) as dev:
        assert main(["run", str(plan), "--port", dev.port, "--rate", "1", "--max-on", "1.5"]) == 2
        assert dev.frames == 0
    assert "over max_on = 1.5 s" in one_error_line(capsys.readouterr().err)


def test_device_vanishing_is_one_line_exit_1_and_the_log_is_kept(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 10)
    log = tmp_path / "run.log"
    with PtyDevice(faults=Faults(vanish_after=4), channels=32, watchdog_ms=200) as dev:
        code = main(["run", str(plan), "--port", dev.port, "--rate", "20", "--log", str(log)])
        deadline = time.monotonic() + 2
        while dev.state() != (0, 0) and time.monotonic() < deadline:
            time.sleep(0.01)
        state = dev.state()
    assert code == 1 and state == (0, 0)
    line = one_error_line(capsys.readouterr().err)
    assert line.startswith(f"spherestep: failed: serial link to {dev.port} lost during SET")
    assert "link lost during SET" in log.read_text()


def test_ctrl_c_switches_every_coil_off(tmp_path):
    plan = write_plan(tmp_path / "plan.json", 200)
    log = tmp_path / "run.log"
    with PtyDevice(channels=32, watchdog_ms=5000) as dev:  # a watchdog too slow to be what switches off
        proc = subprocess.Popen(
            [sys.executable, "-c", "from spherestep.cli import main; main()", "run", str(plan), "--port", dev.port,
             "--rate", "20", "--log", str(log)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 20
            while dev.frames < 5 and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.02)
            assert dev.frames >= 5 and dev.state() != (0, 0)
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=10)
        finally:
            proc.kill()
        state, trips, trace = dev.state(), dev.device.trips, list(dev.device.trace)
    assert proc.returncode == 130
    assert one_error_line(err) == "spherestep: interrupted (SIGINT): all coils off, acknowledged by the device"
    assert state == (0, 0) and trips == [] and trace[-2:] == [("enable", 0), ("polarity", 0)]
    lines = log.read_text().splitlines()
    last_tx = max(i for i, line in enumerate(lines) if " TX " in line)
    assert ",OFF*" in lines[last_tx] and any(",ACK,OFF,0,0*" in line for line in lines[last_tx:])
