"""A property-based fuzz of the command line (issue 40 §5): Hypothesis builds bad command lines for every
``spherestep`` subcommand — a valid skeleton with one fault injected — and each runs in-process
(``spherestep.cli.main``) in a fresh, empty working folder. Every one must: exit 2 (a user mistake), print
exactly one line on stderr, ``spherestep: error: …``, and no traceback, and leave the working folder empty and
the input files untouched.

The faults: an unknown option or subcommand, a stray argument, an option without its value, a number option given text (or a
fraction where a whole number is due, or a non-finite value), a bad ``--axis``, a bad ``--core``, a missing input
file, an input file of random text, a design file with a wrong suffix, a wrong output suffix, a bare
``--radius``. ``EXAMPLES`` per subcommand, ≥ 1,000 in all (the test below says how many).
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import string
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spherestep.cli import _command, main
from spherestep.commutation import Plan, Step, default_channel_map

pytestmark = pytest.mark.slow  # ~1,100 command lines: about a minute on the loaded 2-core machine

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = 60
PLAN = "{inputs}/plan.json"
DESIGN = "{inputs}/motor.yaml"
SPEC = "{inputs}/spec.yaml"

# Each skeleton is a valid command line as groups of tokens (a fault is inserted between groups, never between an
# option and its value); inputs live in a separate folder, every output in the working folder.
SKELETONS: dict[str, list[tuple[str, ...]]] = {
    "explore": [("explore",), ("--quick",), ("--threads",), ("--out", "o")],
    "export": [("export",), (DESIGN,), ("--out", "o")],
    "forces": [("forces",), ("--out", "o")],
    "demo": [("demo",), ("--quick",), ("--out", "o")],
    "plan": [("plan",), ("--axis", "1,0,0"), ("--angle", "30"), ("--out", "o")],
    "packings": [("packings",)],
    "packing": [("packing",), ("cube",), ("--radius", "1 in"), ("--out", "p.csv")],
    "report": [("report",), ("-o", "r.html")],
    "run": [("run",), (PLAN,), ("--rate", "5"), ("--dry-run",)],
    "simulate": [("simulate",), ("--axis", "1,0,0"), ("--angle", "30"), ("--out", "o")],
    "capability": [("capability",), ("--out", "o")],
    "move": [("move",), ("--axis", "1,0,0"), ("--angle", "30"), ("--out", "o")],
    "sense": [("sense",), ("--out", "o")],
    "gallery": [("gallery",), ("--out", "o")],
    "synthesize": [("synthesize",), (SPEC,), ("--out", "o"), ("--threads",)],
    "calibrate": [("calibrate",), ("--emulate",), ("--out", "c.yaml")],
    "design new": [("design", "new"), ("n.yaml",)],
    "design validate": [("design", "validate"), (DESIGN,)],
    "design show": [("design", "show"), (DESIGN,)],
}
INPUT_FILES = {  # skeleton token -> the options/arguments that take an input file
    "export": ["FILE"], "design validate": ["FILE"], "design show": ["FILE"], "run": ["PLAN", "--design"],
    "synthesize": ["SPEC"], "report": ["FILE"], "plan": ["--design"], "simulate": ["--design"],
    "forces": ["--design"], "capability": ["--design"], "move": ["--design"], "sense": ["--design"],
    "calibrate": ["--design"], "design new": ["--from"],
}
DESIGN_INPUTS = {"FILE", "--design", "--from"}
OUT_FILES = {"packing": ("--out", (".csv", ".json")), "report": ("-o", (".html",)),
             "calibrate": ("--out", (".yaml", ".yml", ".json"))}


def _commands():
    """``{"design show": click command, …}``: every subcommand of the app (the fuzz must cover each)."""
    out = {}
    for name, command in _command().commands.items():
        for sub, leaf in getattr(command, "commands", {}).items():
            out[f"{name} {sub}"] = leaf
        if not hasattr(command, "commands"):
            out[name] = command
    return out


COMMANDS = _commands()


def _options(command: str, kind) -> list[str]:
    """The command's options whose Python type is ``kind`` (flags excluded)."""
    return [p.opts[0] for p in COMMANDS[command].params if p.param_type_name == "option"
            and not getattr(p, "is_flag", False) and p.type_descriptor.annotation is kind]


def _parses(text: str, kind) -> bool:
    try:
        kind(text)
    except (ValueError, OverflowError):
        return False
    return True


WORD = st.text(string.ascii_lowercase + "-_", min_size=1, max_size=12)
NOT_A_NUMBER = st.text(min_size=0, max_size=12).filter(lambda s: not _parses(s, float) and "\x00" not in s)
NON_FINITE = st.sampled_from(["nan", "inf", "-inf", "NaN", "1e999"])
FRACTION = st.floats(min_value=-1e6, max_value=1e6, allow_nan=False).filter(lambda x: x != int(x)).map(repr)


def _bad_axis(text: str) -> bool:
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        return True
    return len(values) != 3 or not all(math.isfinite(v) for v in values) or not any(values)


AXIS = st.one_of(
    st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr), st.just("0")), max_size=5)
    .map(",".join), st.text(max_size=15)).filter(lambda s: _bad_axis(s) and "\x00" not in s)


@st.composite
def fault(draw, command: str):
    """``(tokens, what)``: the command's skeleton with one fault injected, and a description of the fault."""
    groups = [list(g) for g in SKELETONS[command]]
    head = 2 if command.startswith("design ") else 1
    valued = [p.opts[0] for p in COMMANDS[command].params if p.param_type_name == "option"
              and not getattr(p, "is_flag", False)]
    kinds = ["unknown-option", "extra-argument"] + (["missing-value"] if valued else []) + ["not-a-number"]
    numbers = _options(command, int) + _options(command, float)
    floats = _options(command, float)
    if not numbers:
        kinds.remove("not-a-number")
    if _options(command, int):
        kinds.append("fraction")
    if floats:
        kinds.append("non-finite")
    if any(p.opts[0] == "--axis" for p in COMMANDS[command].params):
        kinds.append("axis")
    if any(p.opts[0] == "--core" for p in COMMANDS[command].params):
        kinds.append("core")
    if command in INPUT_FILES:
        kinds += ["missing-input", "random-input"]
    if DESIGN_INPUTS & set(INPUT_FILES.get(command, ())):
        kinds.append("design-suffix")
    if command in OUT_FILES:
        kinds.append("out-suffix")
    if command == "packing":
        kinds.append("bare-radius")
    if command.startswith("design "):
        kinds.append("unknown-subcommand")
    kind = draw(st.sampled_from(kinds))
    at = draw(st.integers(head, len(groups)))
    inputs = {}  # name -> text of an input file the fault writes

    def set_option(option: str, value: str) -> None:
        for g in groups:
            if g[0] == option:
                g[1:] = [value]
                return
        groups.insert(at, [option, value])

    if kind == "unknown-option":
        known = {o for p in COMMANDS[command].params for o in p.opts + getattr(p, "secondary_opts", [])}
        option = draw(WORD.map(lambda w: "--" + w).filter(lambda o: o not in known and o != "--debug"
                                                          and o != "--help"))
        groups.insert(at, [option])
    elif kind == "extra-argument":  # a stray word (for report's optional FILE: a design file that is not there)
        groups.append([draw(st.text(string.ascii_letters + string.digits + "._", min_size=1, max_size=12))])
    elif kind == "missing-value":
        groups.append([draw(st.sampled_from(valued))])
    elif kind == "not-a-number":
        set_option(draw(st.sampled_from(numbers)), draw(NOT_A_NUMBER))
    elif kind == "fraction":
        set_option(draw(st.sampled_from(_options(command, int))), draw(FRACTION))
    elif kind == "non-finite":
        set_option(draw(st.sampled_from(floats)), draw(NON_FINITE))
    elif kind == "axis":
        set_option("--axis", draw(AXIS))
    elif kind == "core":
        set_option("--core", draw(WORD.filter(lambda w: w not in ("air", "iron"))))
    elif kind in ("missing-input", "random-input", "design-suffix"):
        slots = INPUT_FILES[command] if kind != "design-suffix" else \
            [s for s in INPUT_FILES[command] if s in DESIGN_INPUTS]
        slot = draw(st.sampled_from(slots))
        if kind == "missing-input":
            name = "{inputs}/" + draw(WORD) + ".missing.yaml"
        elif kind == "random-input":
            name = "{inputs}/random" + (".json" if slot == "PLAN" else ".yaml")
            inputs[name] = draw(st.text(max_size=200))
        else:
            suffix = draw(st.sampled_from([".txt", ".json", "", ".yaml.bak", ".cfg"]))
            name = "{inputs}/motor-copy" + suffix
            inputs[name] = (ROOT / "src/spherestep/data/gallery/jhu-as-built.yaml").read_text()
        if slot in ("FILE", "PLAN", "SPEC"):
            skeleton_value = {"FILE": DESIGN, "PLAN": PLAN, "SPEC": SPEC}[slot]
            for g in groups:
                if g == [skeleton_value]:
                    g[0] = name
                    break
            else:  # report's FILE is optional: give it
                groups.insert(head, [name])
        else:
            set_option(slot, name)
    elif kind == "out-suffix":
        option, allowed = OUT_FILES[command]
        suffix = draw(st.text(string.ascii_lowercase, max_size=5).map(lambda s: "." + s if s else "")
                      .filter(lambda s: s not in allowed))
        set_option(option, "out" + suffix)
    elif kind == "bare-radius":
        set_option("--radius", draw(st.floats(min_value=1e-3, max_value=1e3).map(repr)))
    elif kind == "unknown-subcommand":
        groups[0] = ["design", draw(WORD.filter(lambda w: w not in ("new", "validate", "show")))]
    return [t for g in groups for t in g], kind, inputs


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """The skeletons' input files: a valid design, plan and spec."""
    folder = tmp_path_factory.mktemp("fuzz-inputs")
    (folder / "motor.yaml").write_text((ROOT / "src/spherestep/data/gallery/jhu-as-built.yaml").read_text())
    (folder / "spec.yaml").write_text((ROOT / "examples/specs/camera-gimbal.yaml").read_text())
    steps = [Step(index=i, target=np.eye(3), achieved=np.eye(3), error=0.0, coils={i % 4: 1, (i + 1) % 4: -1})
             for i in range(3)]
    plan = Plan(steps=steps, coil_count=4, channel_map=default_channel_map(4))
    (folder / "plan.json").write_text(json.dumps(plan.to_dict()))
    return folder


def _snapshot(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_size for p in folder.rglob("*")}


def test_the_fuzz_covers_every_subcommand():
    assert set(SKELETONS) == set(COMMANDS)  # a new subcommand must be given a skeleton here
    assert EXAMPLES * len(SKELETONS) >= 1000


@pytest.mark.parametrize("command", sorted(SKELETONS))
def test_bad_command_line_is_one_line_exit_2_nothing_written(command, inputs):
    before = _snapshot(inputs)
    seen: Counter = Counter()  # the faults tried

    @settings(max_examples=EXAMPLES, deadline=None, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture,
                                     HealthCheck.filter_too_much])
    @given(case=fault(command))
    def run(case):
        argv, kind, files = case
        seen[kind] += 1
        written = []
        for name, text in files.items():
            path = Path(name.replace("{inputs}", str(inputs)))
            path.write_text(text)
            written.append(path)
        argv = [a.replace("{inputs}", str(inputs)) for a in argv]
        here = os.getcwd()
        try:
            with tempfile.TemporaryDirectory(prefix="fuzz-cwd-") as cwd:
                os.chdir(cwd)
                err, out = io.StringIO(), io.StringIO()
                with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
                    code = main(argv)
                left = os.listdir(cwd)
        finally:
            os.chdir(here)
            for path in written:
                path.unlink()
        text = err.getvalue()
        assert code == 2, (kind, argv, code, text, out.getvalue()[-500:])
        assert "Traceback" not in text + out.getvalue(), (kind, argv, text)
        lines = text.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("spherestep: error: "), (kind, argv, text)
        assert left == [], (kind, argv, left)

    run()
    assert _snapshot(inputs) == before  # the inputs untouched
    # every example ran (Hypothesis' final replay of a passing run adds none), and more than one kind of fault
    assert sum(seen.values()) >= EXAMPLES and len(seen) >= 2, seen
    print(command, dict(seen))
