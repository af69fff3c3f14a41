"""Refuse before working (issue 40 §2): an output path, port, file type or unit that cannot work is refused
before the first costly step — one line naming the option and the fix, exit 2, nothing written.

``calibrate``'s checks are shown to come first by making the first hold fail the test if it is ever reached (its
``--out c.json`` writing JSON is checked in tests/test_calibration.py's run on the emulator).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

import spherestep.drive as drive
from spherestep.cli import main
from spherestep.gallery import entry

DESIGN = entry("jhu-as-built").path


@pytest.fixture
def no_holds(monkeypatch):
    """``collect_holds`` (the first step that drives the coils) fails the test if calibrate reaches it."""
    def reached(*args, **kwargs):
        raise AssertionError("calibrate started holding before refusing its options")

    monkeypatch.setattr(drive, "collect_holds", reached)


def _refused(argv, capsys, folder: Path, *expected: str) -> str:
    before = sorted(os.listdir(folder))
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("spherestep: error: "), err
    for text in expected:
        assert text in err, err
    assert sorted(os.listdir(folder)) == before  # nothing written, not even a hidden temporary file
    return err


@pytest.mark.parametrize("name", ["c.txt", "c", "c.csv", "c.YAML.bak"])
def test_calibrate_out_suffix_is_refused_before_holding(tmp_path, capsys, no_holds, name):
    _refused(["calibrate", "--emulate", "--out", str(tmp_path / name)], capsys, tmp_path,
             "--out", ".yaml or .yml or .json")


def test_calibrate_unwritable_out_is_refused_before_holding(tmp_path, capsys, no_holds):
    (tmp_path / "afile").write_text("x")
    _refused(["calibrate", "--emulate", "--out", str(tmp_path / "afile" / "c.yaml")], capsys, tmp_path,
             "--out", "lies under")
    _refused(["calibrate", "--emulate", "--out", str(tmp_path)], capsys, tmp_path, "--out", "is a folder")


def test_calibrate_bad_port_is_refused_before_holding(tmp_path, capsys, no_holds):
    (tmp_path / "notaport").write_text("x")
    for port in ("/dev/spherestep-no-such-port", str(tmp_path / "notaport")):
        _refused(["calibrate", "--port", port, "--out", str(tmp_path / "c.yaml")], capsys, tmp_path,
                 "--port", "could not be opened", "/dev/ttyUSB0")


@pytest.mark.parametrize("radius", ["6", "0.15", "6.0e0"])
def test_packing_bare_radius_is_refused(tmp_path, capsys, radius):
    _refused(["packing", "cube", "--radius", radius, "--out", str(tmp_path / "p.csv")], capsys, tmp_path,
             "--radius", "with its unit", "'6 in'")


def test_packing_radius_with_unit_still_works(tmp_path):
    assert main(["packing", "cube", "--radius", "0.15 m", "--out", str(tmp_path / "p.csv")]) == 0
    lines = (tmp_path / "p.csv").read_text().splitlines()
    assert lines[0].split(",")[2:5] == ["x_m", "y_m", "z_m"] and len(lines) == 1 + 8  # caps at the cube's corners
    for line in lines[1:]:
        x, y, z = map(float, line.split(",")[2:5])
        assert abs((x * x + y * y + z * z) ** 0.5 - 0.15) < 1e-9


@pytest.mark.parametrize("mode", ["--dry-run", "--simulate"])
def test_run_port_with_dry_run_or_simulate_is_refused(tmp_path, capsys, mode):
    plan = tmp_path / "plan.json"
    plan.write_text("{}")  # never read: the conflict is refused first
    _refused(["run", str(plan), "--rate", "5", mode, "--port", "/dev/ttyUSB0"], capsys, tmp_path,
             "--port", f"left out with {mode}", f"drop --port or {mode}")


@pytest.mark.parametrize("argv", [["export", "{d}", "--out", "{base}/build"], ["design", "validate", "{d}"],
                                  ["design", "show", "{d}"], ["report", "{d}", "-o", "{base}/r.html"]])
@pytest.mark.parametrize("suffix", [".txt", "", ".json", ".yaml.bak"])
def test_design_file_with_another_suffix_is_refused(tmp_path, capsys, argv, suffix):
    design = tmp_path / f"motor{suffix}"
    design.write_text(DESIGN.read_text())  # a valid design: only its name is wrong
    argv = [a.replace("{d}", str(design)).replace("{base}", str(tmp_path)) for a in argv]
    _refused(argv, capsys, tmp_path, str(design), ".yaml, *.yml or *.toml", "rename it")


@pytest.mark.slow
@pytest.mark.parametrize("signum, code, name", [(2, 130, "SIGINT"), (15, 143, "SIGTERM")])
def test_calibrate_interrupted_says_whether_the_coils_are_off(tmp_path, signum, code, name):
    """Issue 40 §3: interrupted during its first hold on the emulated motor, calibrate says in one line that the
    coils are off (the loop switched them off and the emulated device acknowledged it), exit 130/143, nothing
    written."""
    import signal
    import subprocess
    import sys
    import threading

    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1] / "src"))
    p = subprocess.Popen([sys.executable, "-c", "from spherestep.cli import main; main()", "calibrate", "--emulate",
                          "--orientations", "2", "--out", str(tmp_path / "c.yaml")], env=env, cwd=tmp_path,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    lines, holding = [], threading.Event()

    def read():
        for line in p.stderr:
            lines.append(line)
            if "holding at orientation 1" in line:
                holding.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        assert holding.wait(timeout=1500), "".join(lines)
        os.killpg(p.pid, signal.Signals(signum))
        assert p.wait(timeout=120) == code, "".join(lines)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    reader.join(timeout=10)
    last = "".join(lines).strip().splitlines()[-1]
    assert last.startswith(f"spherestep: interrupted ({name}): all coils off"), "".join(lines)
    assert "nothing written" in last and "Traceback" not in "".join(lines)
    assert os.listdir(tmp_path) == []
