"""Every mistake gets a clear answer (issue 13): a table of bad command lines over every subcommand.

Each case runs the ``spherestep`` command in-process (``main(argv)``) and asserts: no traceback, exactly one
line on stderr (``spherestep: error: …`` for a user mistake, exit 2; ``spherestep: failed: …`` for a failure
of the machine, exit 1), and nothing new left under any name in the folders the command could write to (no
final file, no folder, no hidden temporary file). Read-only locations are real: a read-only tmpfs when the
tests run as root (else a chmod'ed folder, skipped for root), a full disk a tiny tmpfs. A few cases run as
real subprocesses (console script, exit status, stderr). ``python tests/test_cli_errors.py`` prints the
figures of docs/errors.md.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spherestep.cli import main
from spherestep.commutation import Plan, Step, default_channel_map

ROOT = os.geteuid() == 0
I3 = np.eye(3)


def _mount(path: Path, options: str) -> bool:
    path.mkdir(parents=True, exist_ok=True)
    if not ROOT or shutil.which("mount") is None:
        return False
    return subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                          capture_output=True).returncode == 0


def _plan_dict(n_steps: int = 3, coil_count: int = 4) -> dict:
    steps = [Step(index=i, target=I3, achieved=I3, error=0.0, coils={i % coil_count: 1, (i + 1) % coil_count: -1})
             for i in range(n_steps)]
    return Plan(steps=steps, coil_count=coil_count, channel_map=default_channel_map(coil_count)).to_dict()


def _write_plan(path: Path, change) -> str:
    data = _plan_dict()
    change(data)
    path.write_text(json.dumps(data))
    return str(path)


def _setitem(keys, value):
    def change(data):
        target = data
        for key in keys[:-1]:
            target = target[key]
        target[keys[-1]] = value
    return change


def _delitem(keys):
    def change(data):
        target = data
        for key in keys[:-1]:
            target = target[key]
        del target[keys[-1]]
    return change


PLAN_MISTAKES = {  # name -> change of a valid plan dict; each must be refused naming the field
    "no-channel-map": _delitem(["channel_map"]),
    "no-steps": _delitem(["steps"]),
    "no-coil-count": _delitem(["coil_count"]),
    "coil-count-text": _setitem(["coil_count"], "four"),
    "coil-count-zero": _setitem(["coil_count"], 0),
    "channel-map-short": lambda d: d["channel_map"].pop(),
    "channel-map-negative": _setitem(["channel_map", 0, "enable"], -1),
    "channel-map-clash": _setitem(["channel_map", 1, "enable"], 0),
    "channel-map-not-list": _setitem(["channel_map"], {"a": 1}),
    "steps-empty": _setitem(["steps"], []),
    "steps-not-list": _setitem(["steps"], "many"),
    "step-not-object": _setitem(["steps", 1], 7),
    "target-2x2": _setitem(["steps", 1, "target"], [[1, 0], [0, 1]]),
    "target-text": _setitem(["steps", 1, "target"], "identity"),
    "target-not-rotation": _setitem(["steps", 1, "target"], [[2, 0, 0], [0, 2, 0], [0, 0, 2]]),
    "achieved-nan": _setitem(["steps", 2, "achieved"], [[float("nan")] * 3] * 3),
    "coil-out-of-range": _setitem(["steps", 1, "coils"], {"9": 1}),
    "coil-negative": _setitem(["steps", 1, "coils"], {"-1": 1}),
    "polarity-2": _setitem(["steps", 1, "coils"], {"0": 2}),
    "coils-list": _setitem(["steps", 1, "coils"], [0, 1]),
    "mask-disagrees": _setitem(["steps", 1, "enable_mask"], "0x1"),
    "polarity-mask-disagrees": _setitem(["steps", 1, "polarity_mask"], "0xff"),
    "mask-not-hex": _setitem(["steps", 1, "enable_mask"], "lots"),
    "no-target": _delitem(["steps", 0, "target"]),
    "error-negative": _setitem(["steps", 0, "error_deg"], -1),
    "error-text": _setitem(["steps", 0, "error_deg"], "small"),
    "index-text": _setitem(["steps", 0, "index"], "first"),
    "held-bad": _setitem(["steps", 0, "held"], [[1]]),
    "next-pole-text": _setitem(["steps", 0, "next_pole"], "north"),
    "wrong-format": _setitem(["format"], "csv"),
    "wrong-version": _setitem(["version"], 99),
}


@pytest.fixture(scope="module")
def env(tmp_path_factory):
    """Inputs and output locations: a file, a FIFO, a read-only folder, a full disk, bad plans and designs."""
    yield from _make_env(tmp_path_factory.mktemp("errors"))


def _make_env(base: Path):
    """The generator behind :func:`env` (also used by :func:`measure`)."""
    e = {"base": base}
    (base / "afile.txt").write_text("not a folder\n")
    e["file"] = str(base / "afile.txt")
    e["dir"] = str(base / "adir")
    (base / "adir").mkdir()
    os.mkfifo(base / "fifo")
    e["fifo"] = str(base / "fifo")
    ro = base / "ro"
    e["ro_kind"] = "tmpfs" if _mount(ro, "size=1m,ro") else "chmod"
    if e["ro_kind"] == "chmod":
        ro.chmod(0o555)
    e["ro"] = str(ro)
    full = base / "full"
    e["full_kind"] = "tmpfs" if _mount(full, "size=128k") else None
    if e["full_kind"]:
        try:
            with open(full / "filler", "wb") as f:
                f.write(b"x" * (1 << 20))
        except OSError:
            pass
    e["full"] = str(full)
    plans = base / "plans"
    plans.mkdir()
    e["plan"] = _write_plan(plans / "good.json", lambda d: None)
    for name, change in PLAN_MISTAKES.items():
        e[f"plan:{name}"] = _write_plan(plans / f"{name}.json", change)
    (plans / "notjson.json").write_text("{not json")
    e["plan:not-json"] = str(plans / "notjson.json")
    (plans / "latin1.json").write_bytes(b"\xff\xfe\x00")
    e["plan:not-utf8"] = str(plans / "latin1.json")
    designs = base / "designs"
    designs.mkdir()
    proto = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", "design", "new",
                            str(designs / "proto.yaml")], capture_output=True, text=True)
    assert proto.returncode == 0, proto.stderr
    text = (designs / "proto.yaml").read_text()
    e["design"] = str(designs / "proto.yaml")
    bad = {
        "deep": "a: " + "[" * 3000 + "]" * 3000 + "\n",
        "notyaml": "rotor: [unclosed\n",
        "empty": "",
        "list": "- 1\n- 2\n",
        "binary": "\x00\x01\x02",
    }
    for name, body in bad.items():
        (designs / f"{name}.yaml").write_text(body)
        e[f"design:{name}"] = str(designs / f"{name}.yaml")
    (designs / "deep.toml").write_text("a = " + "[" * 3000 + "]" * 3000 + "\n")
    e["design:deep-toml"] = str(designs / "deep.toml")
    e["design:tol20"] = str(designs / "tol20.yaml")
    (designs / "tol20.yaml").write_text(_with_tolerance(text, "20 deg"))
    e["design:missing"] = str(designs / "missing.yaml")
    e["design:suffix"] = e["file"]
    e["design:fifo"] = e["fifo"]
    e["design:dir"] = e["dir"]
    yield e
    for mount in (ro, full):
        if ROOT:
            subprocess.run(["umount", str(mount)], capture_output=True)
    if e["ro_kind"] == "chmod":
        ro.chmod(0o755)


def _with_tolerance(text: str, value: str) -> str:
    lines = [line for line in text.splitlines() if not line.lstrip().startswith("tolerance")]
    return "\n".join(lines) + f"\ntolerance: {value}\n"


# -- the table ---------------------------------------------------------------------------------------------------
AX = ["--axis", "0,0,1"]
NUMBERS = ["nan", "inf", "-inf", "abc", "", "1e400"]
FOLDER_OUTS = ["{file}", "{file}/sub", "/dev/null", "{ro}", "{ro}/out", "{fifo}", "{file}/a/b"]
FILE_OUTS = ["{dir}", "{file}/x{suffix}", "/dev/null", "{ro}/x{suffix}", "{fifo}", "", "{base}/adir/"]

OUTPUT_COMMANDS = {  # command line with {out} for the output folder
    "demo": ["demo", "--out", "{out}", "--quiet"],
    "plan": ["plan", *AX, "--angle", "30", "--out", "{out}"],
    "simulate": ["simulate", *AX, "--angle", "30", "--out", "{out}"],
    "export": ["export", "{design}", "--out", "{out}"],
    "forces": ["forces", "--out", "{out}", "--json"],
    "explore": ["explore", "--quick", "--out", "{out}", "--threads", "--workers", "1"],
    "move": ["move", *AX, "--angle", "30", "--out", "{out}"],
    "capability": ["capability", "--samples", "10", "--out", "{out}"],
    "sense": ["sense", "--sensors", "4", "--samples", "5", "--out", "{out}"],
}
FILE_COMMANDS = {  # command line with {out} for an output file, and its suffix
    "report": (["report", "-o", "{out}"], ".html"),
    "packing": (["packing", "cube", "--out", "{out}"], ".csv"),
    "run-log": (["run", "{plan}", "--rate", "5", "--dry-run", "--log", "{out}"], ".log"),
}
NUMERIC_OPTIONS = {  # command line before the option, the option, values out of range besides NUMBERS
    ("demo", "--angle"): (["demo", "--out", "{base}/o"], ["0", "36001", "-1e9"]),
    ("plan", "--angle"): (["plan", *AX, "--out", "{base}/o"], ["0", "36001"]),
    ("plan", "--steps"): (["plan", *AX, "--angle", "30", "--out", "{base}/o"], ["0", "-3", "100001", "1.5"]),
    ("simulate", "--angle"): (["simulate", *AX, "--out", "{base}/o"], ["0", "99999"]),
    ("simulate", "--steps"): (["simulate", *AX, "--angle", "9", "--out", "{base}/o"], ["0", "10001"]),
    ("simulate", "--noise"): (["simulate", *AX, "--angle", "9", "--out", "{base}/o"], ["-1", "181"]),
    ("simulate", "--missed"): (["simulate", *AX, "--angle", "9", "--out", "{base}/o"], ["-0.1", "1", "2"]),
    ("simulate", "--seed"): (["simulate", *AX, "--angle", "9", "--out", "{base}/o"], ["-5", "1.5"]),
    ("report", "--angle"): (["report", "-o", "{base}/r.html"], ["0", "40000"]),
    ("forces", "--states"): (["forces", "--out", "{base}/o"], ["0", "-1", "10001"]),
    ("forces", "--seed"): (["forces", "--out", "{base}/o"], ["-5"]),
    ("run", "--rate"): (["run", "{plan}", "--dry-run"], ["0", "-5", "1001"]),
    ("run", "--max-on"): (["run", "{plan}", "--dry-run", "--rate", "5"], ["0", "-1"]),
    ("run", "--max-duty"): (["run", "{plan}", "--dry-run", "--rate", "5"], ["0", "1.5", "-0.5"]),
    ("run", "--duty-window"): (["run", "{plan}", "--dry-run", "--rate", "5"], ["0", "-2"]),
    ("run", "--channels"): (["run", "{plan}", "--dry-run", "--rate", "5"], ["0", "65", "-1"]),
    ("packing", "--refine"): (["packing", "cube", "--out", "{base}/p.csv"], ["-1", "5", "50"]),
    ("packing", "--target"): (["packing", "cube", "--out", "{base}/p.csv"], ["0", "5001", "10000000"]),
    ("explore", "--budget-coils"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0", "-1"]),
    ("explore", "--workers"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0", "-2", "100000"]),
    ("explore", "--samples"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0", "-10"]),
    ("explore", "--holding-torque-states"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["-1"]),
    ("explore", "--caps"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0", "200", "60,x"]),
    ("explore", "--tols"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0", "-1", "90"]),
    ("explore", "--rotor-levels"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["-1", "9", "a"]),
    ("explore", "--primary-ratio"): (["explore", "--quick", "--out", "{base}/o", "--threads"], ["0.5", "x"]),
    ("move", "--time"): (["move", *AX, "--angle", "30", "--out", "{base}/o"], ["0", "-1"]),
    ("move", "--sensor-noise"): (["move", *AX, "--angle", "30", "--out", "{base}/o"], ["-1"]),
    ("move", "--rate"): (["move", *AX, "--angle", "30", "--emulate", "--out", "{base}/o"], ["0", "-1"]),
    ("move", "--tolerance"): (["move", *AX, "--angle", "30", "--out", "{base}/o"], ["0", "-1", "181"]),
    ("capability", "--samples"): (["capability", "--out", "{base}/o"], ["0", "-1"]),
    ("capability", "--seed"): (["capability", "--out", "{base}/o"], ["-1"]),
    ("capability", "--threshold"): (["capability", "--out", "{base}/o"], ["-1"]),
    ("sense", "--sensors"): (["sense", "--out", "{base}/o"], ["0", "-1"]),
    ("sense", "--samples"): (["sense", "--out", "{base}/o"], ["0", "-1"]),
    ("sense", "--seed"): (["sense", "--out", "{base}/o"], ["-1"]),
}
KNOWN: dict[str, str] = {}  # cases expected to fail until their owner fixes them (none left)
AXIS_COMMANDS = {
    "demo": ["demo", "--out", "{base}/o"],
    "plan": ["plan", "--angle", "30", "--out", "{base}/o"],
    "simulate": ["simulate", "--angle", "30", "--out", "{base}/o"],
    "report": ["report", "-o", "{base}/r.html"],
    "move": ["move", "--angle", "30", "--out", "{base}/o"],
}
BAD_AXES = ["0,0,0", "1,2", "1,2,3,4", "a,b,c", "nan,0,1", "inf,0,0", ""]
DESIGN_COMMANDS = {  # command line with {d} for a design file
    "plan": ["plan", *AX, "--angle", "30", "--out", "{base}/o", "--design", "{d}"],
    "simulate": ["simulate", *AX, "--angle", "30", "--out", "{base}/o", "--design", "{d}"],
    "report": ["report", "{d}", "-o", "{base}/r.html"],
    "forces": ["forces", "--design", "{d}", "--out", "{base}/o"],
    "export": ["export", "{d}", "--out", "{base}/o"],
    "design-validate": ["design", "validate", "{d}"],
    "design-show": ["design", "show", "{d}"],
    "design-new-from": ["design", "new", "{base}/copy.yaml", "--from", "{d}"],
    "run-simulate": ["run", "{plan}", "--rate", "5", "--simulate", "--design", "{d}"],
}
BAD_DESIGNS = ["deep", "deep-toml", "notyaml", "empty", "list", "binary", "tol20", "missing", "suffix", "fifo", "dir"]
MISC = [  # (id, argv): other mistakes, all exit 2
    ("unknown-command", ["nonsense"]),
    ("unknown-option-demo", ["demo", "--bogus"]),
    ("unknown-option-plan", ["plan", "--bogus"]),
    ("unknown-option-run", ["run", "{plan}", "--bogus"]),
    ("unknown-option-packings", ["packings", "--bogus"]),
    ("unknown-option-design-show", ["design", "show", "--bogus"]),
    ("unknown-design-subcommand", ["design", "frobnicate"]),
    ("plan-missing-axis", ["plan", "--angle", "30"]),
    ("plan-missing-angle", ["plan", *AX]),
    ("simulate-missing-angle", ["simulate", *AX]),
    ("simulate-planner", ["simulate", *AX, "--angle", "9", "--planner", "magic", "--out", "{base}/o"]),
    ("simulate-closed-loop-potential", ["simulate", *AX, "--angle", "9", "--planner", "potential", "--noise", "0.1",
                                        "--out", "{base}/o"]),
    ("simulate-failed-coil-99", ["simulate", *AX, "--angle", "9", "--failed-coils", "99", "--out", "{base}/o"]),
    ("simulate-failed-coil-text", ["simulate", *AX, "--angle", "9", "--failed-coils", "a,b", "--out", "{base}/o"]),
    ("simulate-failed-coil-negative", ["simulate", *AX, "--angle", "9", "--failed-coils", "-1", "--out",
                                       "{base}/o"]),
    ("simulate-every-coil-failed", ["simulate", *AX, "--angle", "9", "--failed-coils",
                                    ",".join(str(k) for k in range(29)), "--out", "{base}/o"]),
    ("simulate-all-but-one-coil-failed", ["simulate", *AX, "--angle", "9", "--failed-coils",
                                          ",".join(str(k) for k in range(1, 29)), "--out", "{base}/o"]),
    ("export-unit", ["export", "{design}", "--out", "{base}/o", "--unit", "furlong"]),
    ("export-missing-file", ["export", "--out", "{base}/o"]),
    ("packing-unknown", ["packing", "no-such-packing", "--out", "{base}/p.csv"]),
    ("packing-both", ["packing", "cube", "--refine", "1", "--target", "10", "--out", "{base}/p.csv"]),
    ("packing-suffix", ["packing", "cube", "--out", "{base}/p.txt"]),
    ("packing-radius-text", ["packing", "cube", "--radius", "big", "--out", "{base}/p.csv"]),
    ("packing-radius-unit", ["packing", "cube", "--radius", "3 parsecs", "--out", "{base}/p.csv"]),
    ("packing-radius-negative", ["packing", "cube", "--radius", "-3 in", "--out", "{base}/p.csv"]),
    ("packing-radius-nan", ["packing", "cube", "--radius", "nan", "--out", "{base}/p.csv"]),
    ("packing-radius-zero", ["packing", "cube", "--radius", "0 m", "--out", "{base}/p.csv"]),
    ("packing-missing-out", ["packing", "cube"]),
    ("report-suffix", ["report", "-o", "{base}/r.pdf"]),
    ("report-missing-design", ["report", "{base}/nope.yaml", "-o", "{base}/r.html"]),
    ("run-no-port", ["run", "{plan}", "--rate", "5"]),
    ("run-missing-rate", ["run", "{plan}", "--dry-run"]),
    ("run-both-modes", ["run", "{plan}", "--rate", "5", "--dry-run", "--simulate"]),
    ("run-design-without-simulate", ["run", "{plan}", "--rate", "5", "--dry-run", "--design", "{design}"]),
    ("run-channels-without-dry-run", ["run", "{plan}", "--rate", "5", "--port", "/dev/ttyUSB0", "--channels", "8"]),
    ("run-bad-port", ["run", "{plan}", "--rate", "5", "--port", "/dev/spherestep-no-such-port"]),
    ("run-port-is-file", ["run", "{plan}", "--rate", "5", "--port", "{file}"]),
    ("run-missing-plan", ["run", "{base}/nope.json", "--rate", "5", "--dry-run"]),
    ("run-plan-is-folder", ["run", "{dir}", "--rate", "5", "--dry-run"]),
    ("run-plan-fifo", ["run", "{fifo}", "--rate", "5", "--dry-run"]),
    ("run-too-few-channels", ["run", "{plan}", "--rate", "5", "--dry-run", "--channels", "4"]),
    ("run-thermal", ["run", "{plan}", "--rate", "0.1", "--dry-run", "--max-on", "1"]),
    ("run-log-not-a-log", ["run", "{plan}", "--rate", "5", "--dry-run", "--log", "{design}"]),
    ("run-simulate-wrong-design", ["run", "{plan}", "--rate", "5", "--simulate"]),
    ("design-new-toml", ["design", "new", "{base}/new.toml"]),
    ("design-new-exists", ["design", "new", "{design}"]),
    ("design-new-folder", ["design", "new", "{dir}"]),
    ("design-new-from-missing", ["design", "new", "{base}/new.yaml", "--from", "{base}/nope.yaml"]),
    ("design-new-core", ["design", "new", "{base}/new.yaml", "--core", "copper"]),
    ("design-validate-missing-arg", ["design", "validate"]),
    ("explore-rotors", ["explore", "--quick", "--out", "{base}/o", "--threads", "--rotors", "no-such"]),
    ("explore-stators-empty", ["explore", "--quick", "--out", "{base}/o", "--threads", "--stators", ","]),
    ("explore-empty-grid", ["explore", "--quick", "--out", "{base}/o", "--threads", "--primary-ratio", "1",
                            "--rotors", "cube", "--stators", "truncated-icosahedron"]),
    ("explore-max-rotor-poles", ["explore", "--quick", "--out", "{base}/o", "--threads", "--max-rotor-poles", "0"]),
    ("explore-max-candidates", ["explore", "--quick", "--out", "{base}/o", "--threads", "--max-candidates", "-1"]),
    ("explore-max-lookup-voxels", ["explore", "--quick", "--out", "{base}/o", "--threads", "--max-lookup-voxels",
                                   "0"]),
    ("explore-scheduler", ["explore", "--quick", "--out", "{base}/o", "--scheduler", "not-an-address"]),
    # move (issue 27 §3): what cannot be done is refused before the work, naming the option and the fix
    ("move-time-below-bound", ["move", "--axis", "1,0.5,2", "--angle", "90", "--time", "0.01", "--out", "{base}/o"]),
    ("move-whole-turn-too-fast", ["move", "--axis", "1,0.5,2", "--angle", "360", "--time", "0.001", "--out",
                                  "{base}/o"]),
    ("move-rate-simulated", ["move", *AX, "--angle", "30", "--rate", "100", "--out", "{base}/o"]),
    ("move-sensor-imu-emulate", ["move", *AX, "--angle", "30", "--sensor", "imu", "--emulate", "--out", "{base}/o"]),
    ("move-sensor-hall-port", ["move", *AX, "--angle", "30", "--sensor", "hall", "--port", "/dev/null", "--out",
                               "{base}/o"]),
    ("move-sensor-noise-emulate", ["move", *AX, "--angle", "30", "--sensor-noise", "0.1", "--emulate", "--out",
                                   "{base}/o"]),
    ("move-sensor-noise-hall", ["move", *AX, "--angle", "30", "--sensor", "hall", "--sensor-noise", "0.1", "--out",
                                "{base}/o"]),
    ("move-sensor-noise-imu", ["move", *AX, "--angle", "30", "--sensor", "imu", "--sensor-noise", "0.1", "--out",
                               "{base}/o"]),
    ("move-sensor-noise-ramped", ["move", *AX, "--angle", "30", "--mode", "ramped", "--sensor-noise", "0.1", "--out",
                                  "{base}/o"]),
    ("move-time-settled", ["move", *AX, "--angle", "30", "--mode", "settled", "--time", "1", "--out", "{base}/o"]),
    ("move-time-ramped", ["move", *AX, "--angle", "30", "--mode", "ramped", "--time", "1", "--out", "{base}/o"]),
    ("move-relay-emulate", ["move", *AX, "--angle", "30", "--mode", "settled", "--emulate", "--out", "{base}/o"]),
    ("move-port-and-emulate", ["move", *AX, "--angle", "30", "--port", "/dev/null", "--emulate", "--out",
                               "{base}/o"]),
    ("move-core", ["move", *AX, "--angle", "30", "--core", "copper", "--out", "{base}/o"]),
    ("move-axis-underflow", ["move", "--axis", "1e-320,0,0", "--angle", "30", "--out", "{base}/o"]),
    ("move-bad-port", ["move", *AX, "--angle", "30", "--port", "/dev/spherestep-no-such-port", "--out", "{base}/o"]),
    ("move-port-is-file", ["move", *AX, "--angle", "30", "--port", "{file}", "--out", "{base}/o"]),
]


def _cases() -> list[tuple[str, list[str]]]:
    cases = []
    for name, argv in OUTPUT_COMMANDS.items():
        for out in FOLDER_OUTS:
            cases.append((f"{name}-out[{out}]", [a.replace("{out}", out) for a in argv]))
    for name, (argv, suffix) in FILE_COMMANDS.items():
        for out in FILE_OUTS:
            out = out.replace("{suffix}", suffix)
            cases.append((f"{name}-out[{out}]", [a.replace("{out}", out) for a in argv]))
    for (command, option), (argv, extra) in NUMERIC_OPTIONS.items():
        for value in dict.fromkeys(NUMBERS + extra):
            cases.append((f"{command}{option}[{value}]", [*argv, option, value]))
    for name, argv in AXIS_COMMANDS.items():
        for axis in BAD_AXES:
            cases.append((f"{name}--axis[{axis}]", [*argv, "--axis", axis]))
    for name, argv in DESIGN_COMMANDS.items():
        for design in BAD_DESIGNS:
            if design.startswith("deep") and name != "design-validate":
                continue  # ~10 s each for PyYAML to give up; every command shares the loader
            if design == "tol20" and name in ("export", "design-show", "design-new-from"):
                continue  # commands that do not step accept such a design (validate and the others refuse it)
            cases.append((f"{name}-design[{design}]", [a.replace("{d}", f"{{design:{design}}}") for a in argv]))
    for plan in [*PLAN_MISTAKES, "not-json", "not-utf8"]:
        cases.append((f"run-plan[{plan}]", ["run", f"{{plan:{plan}}}", "--rate", "5", "--dry-run"]))
    cases += MISC
    return cases


CASES = _cases()


def _fill(argv: list[str], env: dict) -> list[str]:
    out = []
    for arg in argv:
        for key, value in env.items():
            if isinstance(value, str):
                arg = arg.replace("{" + key + "}", value)
        out.append(arg.replace("{base}", str(env["base"])))
    return out


def _snapshot(*folders: Path) -> set[str]:
    seen = set()
    for folder in folders:
        for root, dirs, files in os.walk(folder):
            for name in dirs + files:
                path = os.path.join(root, name)
                if os.path.islink(path) or os.path.isdir(path) or os.path.isfile(path):
                    seen.add(f"{path}:{os.path.getsize(path) if os.path.isfile(path) else 'd'}")
    return seen


def test_the_table_is_long_and_covers_every_subcommand():
    assert len(CASES) >= 300
    firsts = {argv[0] + (" " + argv[1] if argv[0] == "design" else "") for _, argv in CASES}
    assert {"demo", "plan", "simulate", "report", "export", "forces", "packing", "explore", "run", "design new",
            "design validate", "design show", "move", "capability", "sense"} <= firsts


@pytest.mark.parametrize("argv", [pytest.param(argv, marks=pytest.mark.xfail(reason=KNOWN[name])) if name in KNOWN
                                  else argv for name, argv in CASES], ids=[name for name, _ in CASES])
def test_a_mistake_is_one_line_and_exit_2(argv, env, capsys, tmp_path, monkeypatch):
    if "{ro}" in " ".join(argv) and env["ro_kind"] == "chmod" and ROOT:
        pytest.skip("root ignores permission bits and tmpfs could not be mounted")
    monkeypatch.chdir(tmp_path)  # default output folders land here
    watched = (env["base"], tmp_path)
    before = _snapshot(*watched)
    code = main(_fill(argv, env))
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert "Traceback" not in captured.err
    assert len(lines) == 1, captured.err
    assert code == 2 and lines[0].startswith("spherestep: error: "), (code, lines)
    assert _snapshot(*watched) == before, "the command left something on disk"


def test_a_full_disk_is_exit_1_and_says_how_many_files_were_written(env, capsys):
    if not env["full_kind"]:
        pytest.skip("no tmpfs to fill (needs root)")
    out = Path(env["full"]) / "exports"
    code = main(["export", env["design"], "--out", str(out)])
    line = capsys.readouterr().err.strip()
    assert code == 1 and line.count("\n") == 0 and line.startswith("spherestep: failed: the disk is full")
    written = sorted(p.name for p in out.iterdir()) if out.exists() else []
    assert f"{len(written)} of 5 files written" in line
    assert not [n for n in written if n.startswith(".")]  # no temporary file left behind
    for name in written:  # whatever was written is whole
        assert (out / name).stat().st_size > 0


def test_stale_temporary_files_of_a_killed_run_are_removed(tmp_path, capsys):
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    stale = tmp_path / f".plan.csv.{int(dead.stdout)}.abcd.tmp"
    stale.write_text("half")
    alive = tmp_path / f".plan.csv.{os.getpid()}.efgh.tmp"  # a writer still running keeps its file
    alive.write_text("busy")
    assert main(["packing", "cube", "--out", str(tmp_path / "cube.csv")]) == 0
    assert not stale.exists() and alive.exists() and (tmp_path / "cube.csv").exists()


def test_no_arguments_prints_usage_and_version_works():
    for argv, code in ((["spherestep"], 0), (["spherestep", "--version"], 0),
                       (["spherestep", "packing", "cube", "--out", "/dev/null"], 2)):
        done = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", *argv[1:]],
                              capture_output=True, text=True, timeout=120)
        assert done.returncode == code, (argv, done.stderr)
        assert "Traceback" not in done.stderr and "error:" not in done.stdout
        if code == 0:
            assert done.stderr == "" and ("Usage" in done.stdout or done.stdout.startswith("spherestep "))
        else:
            assert len(done.stderr.strip().splitlines()) == 1


def measure(timeout: float = 60.0) -> dict:
    """Run the whole table outside pytest and count the outcomes (the figures of docs/errors.md): each case in
    a fresh subprocess-free call of ``main`` with a SIGALRM deadline; ``hangs`` are cases past ``timeout`` s."""
    import contextlib
    import io
    import signal
    import tempfile
    import time

    counts = {"inputs": len(CASES), "tracebacks": 0, "wrong_exits": 0, "accepted": 0, "more_than_one_line": 0,
              "left_files": 0, "hangs": 0}
    slow = []
    gen = _make_env(Path(tempfile.mkdtemp(prefix="errors-")))
    e = next(gen)

    def alarm(signum, frame):
        raise TimeoutError

    signal.signal(signal.SIGALRM, alarm)
    try:
        for name, argv in CASES:
            with tempfile.TemporaryDirectory() as cwd:
                os.chdir(cwd)
                before = _snapshot(e["base"], Path(cwd))
                err = io.StringIO()
                t0 = time.perf_counter()
                signal.setitimer(signal.ITIMER_REAL, timeout)
                try:
                    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                        code = main(_fill(argv, e))
                except TimeoutError:
                    counts["hangs"] += 1
                    print(f"hang: {name}", file=sys.stderr)
                    continue
                except BaseException as exc:  # noqa: BLE001 (a traceback would reach the user)
                    counts["tracebacks"] += 1
                    print(f"traceback: {name}: {type(exc).__name__}: {exc}", file=sys.stderr)
                    continue
                finally:
                    signal.setitimer(signal.ITIMER_REAL, 0)
                seconds = time.perf_counter() - t0
                slow.append((seconds, name))
                lines = err.getvalue().strip().splitlines()
                if code == 0:
                    counts["accepted"] += 1
                    print(f"accepted: {name}", file=sys.stderr)
                elif code != 2:
                    counts["wrong_exits"] += 1
                    print(f"exit {code}: {name}: {lines}", file=sys.stderr)
                if len(lines) != 1:
                    counts["more_than_one_line"] += 1
                if _snapshot(e["base"], Path(cwd)) != before:
                    counts["left_files"] += 1
                    print(f"left files: {name}", file=sys.stderr)
                os.chdir("/")
    finally:
        with contextlib.suppress(StopIteration):
            next(gen)  # unmounts
        shutil.rmtree(e["base"], ignore_errors=True)
    slow.sort(reverse=True)
    counts["slowest_s"] = [(round(t, 2), n) for t, n in slow[:5]]
    counts["median_s"] = round(sorted(t for t, _ in slow)[len(slow) // 2], 3) if slow else None
    return counts


if __name__ == "__main__":  # the figures of docs/errors.md: python tests/test_cli_errors.py
    print(json.dumps(measure(), indent=1))
