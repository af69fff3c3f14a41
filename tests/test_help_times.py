"""Every time a help text states is measured (issue 40 §4(d)): each is held to the stored benchmark
(benchmarks/bench_help_times.py → data/bench_help_times.json), not timed on the test machine.

"about X" must be within a factor :data:`ABOUT` of the CPU seconds measured (the load-independent part of a
one-core command's time; the record keeps the wall time and the load beside it); a range ("seconds to a minute")
must hold the measurement. A help text that states a time not listed here fails :func:`test_no_unlisted_time`.
"""

import json
import re
from pathlib import Path

import pytest
import typer.main

from spherestep._fast.compiling import FIRST_COMPILE_SECONDS
from spherestep.cli import app

STORE = Path(__file__).resolve().parents[1] / "data" / "bench_help_times.json"
ABOUT = 1.5
WORDS = {"a": 1, "one": 1, "two": 2, "three": 3}
UNITS = {"s": 1, "second": 1, "seconds": 1, "minute": 60, "minutes": 60}
ABOUT_RE = re.compile(r"about (\d+(?:\.\d+)?|a|one|two|three) (s|seconds?|minutes?)\b")
# (command, option or None for the command's own help, the benchmark case); "about X" unless a range is given
STATED = {
    ("forces", "--core"): "forces-core-both",
    ("gallery", "--measure"): "gallery-measure",
    ("demo", "--quick"): "demo-quick",
}
RANGES = {  # (command, option): (text, case, low s, high s, CPU divided by the workers it ran on)
    ("synthesize", "--budget"): ("quick (seconds to a minute)", "synthesize-quick", 1.0, 60.0, 2),
    ("explore", "--quick"): ("12 designs, seconds)", "explore-quick", 1.0, 60.0, 1),
}


def _help(command: str, option: str | None) -> str:
    cmd = typer.main.get_command(app).commands[command]
    if option is None:
        return cmd.help or ""
    return " ".join(next(p for p in cmd.params if option in p.opts).help.split())


def _stated(text: str) -> float:
    found = ABOUT_RE.findall(text)
    assert len(found) == 1, text
    number, unit = found[0]
    return float(WORDS.get(number, number) if number in WORDS else number) * UNITS[unit]


@pytest.fixture(scope="module")
def measured() -> dict:
    data = json.loads(STORE.read_text(encoding="utf-8"))
    assert data["benchmark"] == "help_times"
    return data["values"]


@pytest.mark.parametrize("where", list(STATED))
def test_about_times_match_the_benchmark(where, measured):
    case = measured[STATED[where]]
    assert case["exit"] == 0, case
    stated = _stated(_help(*where))
    assert case["cpu_s"] / ABOUT <= stated <= case["cpu_s"] * ABOUT, (where, stated, case)


@pytest.mark.parametrize("where", list(RANGES))
def test_ranges_hold_the_benchmark(where, measured):
    text, name, low, high, workers = RANGES[where]
    assert text in _help(*where)
    case = measured[name]
    assert case["exit"] == 0 and low <= case["cpu_s"] / workers <= high, (where, case)


def test_the_compile_line_states_the_measured_time(measured):
    case = measured["first-compile"]
    assert case["exit"] == 0
    assert case["cpu_s"] / ABOUT <= FIRST_COMPILE_SECONDS <= case["cpu_s"] * ABOUT, case


def test_no_unlisted_time():
    """Every "about N s/minutes" in any command's or option's help is one of :data:`STATED`."""
    group = typer.main.get_command(app)
    found = set()
    for name, cmd in group.commands.items():
        for param in [None, *cmd.params]:
            text = " ".join(((cmd.help or "") if param is None else (getattr(param, "help", "") or "")).split())
            if ABOUT_RE.search(text):
                found.add((name, None if param is None else param.opts[0]))
    assert found <= set(STATED), found - set(STATED)
