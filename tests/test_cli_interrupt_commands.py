"""Ctrl-C and SIGTERM in ``capability``, ``sense``, ``forces`` and ``calibrate`` (issue 27 §3, "in every
subcommand"; ``move``, ``run`` and the hardware commands are held in test_cli_interrupt.py, test_run_signals.py and
test_hardware_cli.py): exit 130/143, one line saying which signal, no traceback, the output complete or absent.

Each command runs with small options (a few seconds of work) and gets the signal once its plain progress line
(stderr is a pipe) says it is inside the long stage. SIGINT is sent to a child started with SIGINT ignored, as a
background job of a non-interactive shell starts it (``make test &``): the command must reset it to the default
and still stop (``spherestep.cli.main``)."""

import signal
import subprocess
import sys
import time

import pytest

SIGNALS = [(signal.SIGINT, 130, "SIGINT"), (signal.SIGTERM, 143, "SIGTERM")]

# command, its options (besides --out), the progress line's start that says it is in the long stage, the files a
# complete output holds (a folder's names; for calibrate the --out file itself: None)
COMMANDS = {
    "capability": (["--samples", "200000"], "spherestep: mapping the torque capability",
                   {"capability.json", "capability.png"}),
    "sense": (["--sensors", "8", "--samples", "10000"], "spherestep: estimating the orientation", {"sensors.json"}),
    "forces": (["--states", "400", "--core", "air"], "spherestep: holding and step torques",
               {"force_curve.csv", "force_curve.png", "forces.json"}),
    "calibrate": (["--emulate", "--orientations", "200"], "spherestep: calibrating", None),
}


def _ignore_sigint():
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # as a background job of a non-interactive shell starts it


def _interrupt(args, ready: str, sig, settle: float = 1.0):
    """Start ``spherestep ARGS``, wait for the progress line starting with ``ready``, wait ``settle`` s, send
    ``sig``; returns (exit code, stderr)."""
    proc = subprocess.Popen([sys.executable, "-c", "from spherestep.cli import main; main()", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_ignore_sigint if sig == signal.SIGINT else None)
    try:
        seen, deadline = [], time.monotonic() + 300
        while time.monotonic() < deadline:
            line = proc.stderr.readline()
            seen.append(line)
            if not line or line.startswith(ready):
                break
        assert seen[-1].startswith(ready), seen
        time.sleep(settle)
        assert proc.poll() is None, f"the command ended before the signal: raise its options ({seen})"
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    return proc.returncode, "".join(seen) + err


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, name", SIGNALS, ids=["SIGINT", "SIGTERM"])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_signal_mid_command_exits_with_one_line_and_complete_or_no_output(tmp_path, command, sig, code, name):
    options, ready, complete = COMMANDS[command]
    out = tmp_path / ("calibration.yaml" if complete is None else command)
    status, err = _interrupt([command, *options, "--out", str(out)], ready, sig)
    lines = err.strip().splitlines()
    assert status == code, err
    assert "Traceback" not in err and "Error" not in err, err
    assert all(line.startswith("spherestep: ") for line in lines), err  # progress lines, then the one line
    said = [line for line in lines if "interrupted" in line]
    assert len(said) == 1 and said[0].startswith(f"spherestep: interrupted ({name})") and said[0] == lines[-1], err
    if complete is None:
        assert not out.exists() or out.read_text(encoding="utf-8").strip(), "an empty calibration file"
    else:
        assert not out.exists() or {p.name for p in out.iterdir()} == complete, sorted(out.iterdir())


@pytest.mark.slow
@pytest.mark.parametrize("sig, code, name", SIGNALS, ids=["SIGINT", "SIGTERM"])
def test_move_emulate_interrupted_in_the_loop_says_all_off_was_acknowledged(tmp_path, sig, code, name):
    """A signal while the loop drives the emulated motor (its ``t … turned …`` status lines come every 0.25 s):
    the loop switches every coil off and the one line says the device acknowledged it, as ``run`` says; exit
    130/143, no traceback from the emulator's process, nothing left in --out (the loop's log included)."""
    out = tmp_path / "move"
    status, err = _interrupt(["move", "--axis", "1,0.5,2", "--angle", "360", "--emulate", "--out", str(out)],
                             "spherestep: t ", sig, settle=0.3)
    lines = err.strip().splitlines()
    assert status == code, err
    assert "Traceback" not in err and all(line.startswith("spherestep: ") for line in lines), err
    assert lines[-1] == f"spherestep: interrupted ({name}): all coils off, acknowledged by the device", err
    assert sum("interrupted" in line for line in lines) == 1, err
    assert not out.exists(), sorted(out.iterdir())


@pytest.mark.parametrize("failure, code, line", [
    ("SIGTERM", 143, "spherestep: interrupted (SIGTERM)"),
    (OSError(28, "No space left on device"), 1, "1 of 2 files written")])
def test_capability_interrupted_between_its_two_files_leaves_none(tmp_path, monkeypatch, capsys, failure, code, line):
    """SIGTERM arrives, or the disk fills, as the figure is written after capability.json: the folder is absent, or
    the one line counts what was written, never a lone capability.json without a word."""
    import os

    from spherestep import plots
    from spherestep.cli import main

    def fail(*args, **kwargs):
        if failure == "SIGTERM":
            os.kill(os.getpid(), signal.SIGTERM)  # the CLI's handler raises in this (the main) thread
            time.sleep(5)
        raise failure

    monkeypatch.setattr(plots, "save_figure", fail)
    out = tmp_path / "cap"
    assert main(["capability", "--samples", "20", "--out", str(out), "--json"]) == code
    err = capsys.readouterr().err
    assert line in err and len(err.strip().splitlines()) == 1, err
    assert not out.exists() or code != 143
