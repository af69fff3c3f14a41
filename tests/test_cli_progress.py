"""Progress on stderr for every command that can run longer than two seconds (issue 27 §4): plain periodic lines
when stderr is not a terminal (a pipe, a log, CI), nothing with ``--json`` or ``--quiet``."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

from spherestep.cli import main
from spherestep.cli import progress as cli_progress
from spherestep.progress import report

CLI = Path(__file__).resolve().parents[1] / "src" / "spherestep" / "cli"


def test_plain_lines_name_the_stage_count_and_time_and_are_throttled(capsys, monkeypatch):
    clock = iter([0.0, 0.0, 0.5, 1.0, 12.0, 13.0])  # the start, then one reading per line
    monkeypatch.setattr(cli_progress.time, "monotonic", lambda: next(clock))
    with cli_progress.progress("building") as say:
        say("mapping", 1, 400)  # a new stage: shown
        say("mapping", 2, 400)  # the same stage 0.5 s later: not shown
        say("mapping", 300, 400)  # 11 s after the stage was last shown: shown
        report("iron: a solve", 1, 3)  # the library's long work reaches the same lines
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["spherestep: building (0 s)", "spherestep: mapping 1/400 (0 s)",
                     "spherestep: mapping 300/400 (12 s)", "spherestep: iron: a solve 1/3 (13 s)"]


def test_disabled_progress_prints_nothing(capsys):
    with cli_progress.progress("building", enabled=False) as say:
        say("mapping", 1, 2)
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("module", ["move", "capability", "sense", "forces", "calibrate", "explore", "motor"])
def test_every_long_command_shows_progress(module):
    """The commands the issue names (``demo`` lives in cli/motor.py) each open the progress lines: ``progress(``
    from cli/progress.py (explore: as ``progress_lines`` beside its Rich bar)."""
    tree = ast.parse((CLI / f"{module}.py").read_text(encoding="utf-8"))
    imported = {a.asname or a.name for n in ast.walk(tree)
                if isinstance(n, ast.ImportFrom) and n.level == 1 and n.module == "progress" for a in n.names}
    calls = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
    assert imported & calls, f"cli/{module}.py opens no progress lines"


def test_explore_prints_plain_progress_when_not_a_terminal(tmp_path, capsys):
    """A real sweep (the quick grid on air cores, no torques: seconds) with stderr captured, not a terminal."""
    args = ["explore", "--quick", "--out", str(tmp_path / "o"), "--threads", "--workers", "1", "--samples", "200",
            "--core", "air", "--holding-torque-states", "0"]
    assert main(args) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "spherestep: reading stored results (0 s)"
    assert any(line.startswith("spherestep: evaluating designs 1/12 ") for line in err), err
    assert err[-1].startswith("spherestep: writing the table, the Pareto set and the design files"), err


def _console(*argv: str, every: float) -> subprocess.CompletedProcess:
    """The console script's path (``main()`` without argv) with the heartbeat's period set to ``every`` s."""
    code = f"import spherestep.cli.progress as p; p.PLAIN_EVERY = {every!r}; from spherestep.cli import main; main()"
    return subprocess.run([sys.executable, "-c", code, *argv], capture_output=True, text=True, timeout=300)


@pytest.mark.slow
def test_start_up_is_not_silent_but_a_quick_refusal_stays_one_line(tmp_path):
    """Issue 40 §4: the stretch before a command's first stage (libraries, the design's model: 25–53 s under a
    load of 16–20) has the heartbeat too; a refusal before it beats is still one line."""
    slow = _console("move", "--axis", "1,0.5,2", "--angle", "90", "--time", "0.001", "--out", str(tmp_path / "o"),
                    every=2.5)  # the heartbeat after 1 s; the model and the duration check take longer
    assert slow.returncode == 2, slow.stderr
    lines = slow.stderr.strip().splitlines()
    assert any(line.startswith("spherestep: starting: loading the libraries and the design … still working")
               for line in lines[:-1]), lines
    assert lines[-1].startswith("spherestep: error: --time") and not (tmp_path / "o").exists()
    quick = _console("move", "--axis", "0,0,0", "--angle", "90", every=10.0)
    assert quick.returncode == 2 and len(quick.stderr.strip().splitlines()) == 1, quick.stderr
