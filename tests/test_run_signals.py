"""``spherestep run`` on the operator's path (issue 13 §5): SIGTERM and SIGINT during a run against the
pseudo-terminal emulator switch every coil off (OFF acknowledged) and leave the log on disk; the log is
streamed as the run goes; --log refuses to overwrite a file that is not a log; --json; a failed start leaves
a log saying why; the final line states the final coil state."""

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
from spherestep.hardware import PtyDevice

I3 = np.eye(3)


def write_plan(path, n_steps, coil_count=4):
    steps = [Step(index=i, target=I3, achieved=I3, error=0.0, coils={i % coil_count: 1, (i + 1) % coil_count: -1})
             for i in range(n_steps)]
    Plan(steps=steps, coil_count=coil_count, channel_map=default_channel_map(coil_count)).to_json(path)
    return path


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # as a background job of a non-interactive shell starts it


@pytest.mark.parametrize("sig, code, name, ignored", [(signal.SIGTERM, 143, "SIGTERM", False),
                                                      (signal.SIGINT, 130, "SIGINT", False),
                                                      (signal.SIGINT, 130, "SIGINT", True)])
def test_a_signal_mid_run_switches_every_coil_off_and_keeps_the_log(tmp_path, sig, code, name, ignored):
    plan = write_plan(tmp_path / "plan.json", 400)
    log = tmp_path / "run.log"
    with PtyDevice(channels=32, watchdog_ms=5000) as dev:  # a watchdog too slow to be what switches off
        proc = subprocess.Popen(
            [sys.executable, "-c", "from spherestep.cli import main; main()", "run", str(plan), "--port", dev.port,
             "--rate", "20", "--log", str(log)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            preexec_fn=_ignore_sigint if ignored else None)
        try:
            deadline = time.monotonic() + 30
            while dev.frames < 6 and time.monotonic() < deadline and proc.poll() is None:
                time.sleep(0.02)
            assert dev.frames >= 6 and dev.state() != (0, 0)
            streamed = log.read_text()  # the log grows while the run goes
            assert streamed.count(" TX ") >= 5
            proc.send_signal(sig)
            out, err = proc.communicate(timeout=15)
        finally:
            proc.kill()
        state, trips, trace = dev.state(), dev.device.trips, list(dev.device.trace)
    assert proc.returncode == code, err
    assert err.strip() == f"spherestep: interrupted ({name}): all coils off, acknowledged by the device"
    assert state == (0, 0) and trips == [] and trace[-2:] == [("enable", 0), ("polarity", 0)]
    lines = log.read_text().splitlines()
    last_tx = max(i for i, line in enumerate(lines) if " TX " in line)
    assert ",OFF*" in lines[last_tx] and any(",ACK,OFF,0,0*" in line for line in lines[last_tx:])
    reason = "stopped by SIGTERM" if sig == signal.SIGTERM else "interrupted by Ctrl-C"
    assert lines[-1].split(None, 2)[1:] == ["NOTE", f"{reason}: {'Terminated' if sig == signal.SIGTERM else 'KeyboardInterrupt'}"]


def test_log_never_overwrites_a_file_that_is_not_a_log(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 3)
    precious = tmp_path / "motor.yaml"
    precious.write_text("name: precious\n")
    assert main(["run", str(plan), "--rate", "5", "--dry-run", "--log", str(precious)]) == 2
    err = capsys.readouterr().err
    assert "is not a spherestep log; give --force" in err and precious.read_text() == "name: precious\n"
    log = tmp_path / "dry.log"
    assert main(["run", str(plan), "--rate", "5", "--dry-run", "--log", str(log)]) == 0
    assert main(["run", str(plan), "--rate", "5", "--dry-run", "--log", str(log)]) == 0  # a log may be replaced
    capsys.readouterr()
    assert main(["run", str(plan), "--rate", "5", "--dry-run", "--log", str(precious), "--force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["log"] == str(precious)
    assert " TX " in precious.read_text()


def test_json_result_and_final_state(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 4)
    assert main(["run", str(plan), "--rate", "10", "--dry-run", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["frames"] == 4 and result["steps"] == 3 and result["mode"] == "dry-run"
    assert result["final_state"] == "all coils off" and result["channels"] == 8
    assert [s["enable"] for s in result["sent"]][-1] == "0x0"


def test_a_failed_start_leaves_a_log_that_says_why(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 3)
    log = tmp_path / "run.log"
    assert main(["run", str(plan), "--rate", "5", "--port", "/dev/spherestep-no-such-port", "--log", str(log)]) == 2
    assert capsys.readouterr().err.count("\n") == 1
    text = log.read_text()
    assert " NOTE failed: port '/dev/spherestep-no-such-port' could not be opened" in text


def test_relay_masks_that_disagree_with_the_coils_are_refused(tmp_path, capsys):
    plan = write_plan(tmp_path / "plan.json", 3)
    data = json.loads(plan.read_text())
    data["steps"][1]["enable_mask"] = "0x1"
    plan.write_text(json.dumps(data))
    assert main(["run", str(plan), "--rate", "5", "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert "plan.steps[1].enable_mask must be 0x" in err and "disagrees" in err


def test_an_interrupt_inside_a_compiled_call_is_reported_as_the_interrupt(tmp_path, monkeypatch, capsys):
    """A Ctrl-C landing in a numba call (``run --simulate`` steps a compiled plant) surfaces as ``SystemError``
    with the interrupt as its context: ``run`` says it was interrupted and notes it in the log, exit 130."""
    import spherestep.hardware as hardware

    def interrupted(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(<function ...>) returned a result with an exception set") from exc

    monkeypatch.setattr(hardware, "play", interrupted)
    plan = write_plan(tmp_path / "plan.json", 4)
    log = tmp_path / "run.log"
    code = main(["run", str(plan), "--dry-run", "--rate", "10", "--log", str(log)])
    err = capsys.readouterr().err
    assert code == 130 and err.strip().splitlines()[-1] == "spherestep: interrupted (SIGINT): all coils off", err
    assert log.read_text().splitlines()[-1].split(None, 2)[1:] == ["NOTE", "interrupted by Ctrl-C: KeyboardInterrupt"]
