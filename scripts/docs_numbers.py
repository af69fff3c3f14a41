"""Every generated number in README and docs/ from stored measurement files, so the docs cannot drift (issue 27 §4).

A generated block is the text between ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` in a markdown file; each
NAME is registered in :data:`BLOCKS` with its file, the stored measurement it is rendered from and the renderer.
Blocks on their own lines hold tables; inline blocks hold a sentence's numbers. The stored measurements
(``data/``) are written by the commands below, never by hand:

    make demo && python scripts/docs_numbers.py demo     # data/demo_summary.json from spherestep-out/summary.json
    python scripts/docs_numbers.py forces                # data/forces_states.json: `spherestep forces`, 20 states
    python scripts/docs_numbers.py robust [BENCH.json]   # data/servo_robust.json: benchmarks/bench_servo_robust.py
    python scripts/docs_numbers.py iron                  # data/iron_compare.json: scripts/iron_compare.py
    python scripts/docs_numbers.py calibration           # data/calibration_table.json: bench_calibration.py
                                                         # (~10 min quiet)
    python scripts/docs_numbers.py bench [NAME ...]      # data/bench_NAME.json: every benchmark of BENCHES (or
                                                         # those named) run one after another: ~15 min quiet,
                                                         # ~40 min at load 10 (bench_motor's 812-pole rotor)
    python scripts/docs_numbers.py potential             # data/potential_numbers.json: the prototype's energy
                                                         # model (measure_potential, ~1 min)
    python scripts/docs_numbers.py dynamics              # data/dynamics_tune.json: dynamics.tune (~30 s)
    python scripts/docs_numbers.py explore [FOLDER]      # data/explore_default.json: docs/explore.md's default
                                                         # sweep (spherestep explore --budget-coils 32 --workers 2,
                                                         # ~15-40 min), or the summary of a finished FOLDER
                                                         # (these three rewrite only their own page's blocks)
    python scripts/docs_numbers.py control-notes         # data/docs_control_notes.json: docs/control.md's numbers
                                                         # outside the demo and the benchmarks (~3 min)
    python scripts/docs_numbers.py sensing-notes         # data/docs_sensing_notes.json: docs/sensing.md's
                                                         # (~5 min; these two rewrite only their own store's blocks)
    python scripts/docs_numbers.py all                   # demo + forces (the end-of-session run; not bench)
    python scripts/docs_numbers.py                       # rewrite every block from the stored files
    python scripts/docs_numbers.py --check               # list the blocks that differ, exit 1 if any

``bench`` is a separate step (minutes of both cores): run it on a quiet machine, alone; each stored benchmark
records its date, command, machine and the load average at its start and end, and every table it feeds states
them. The gallery's blocks read ``src/spherestep/data/gallery/metrics.csv`` (``scripts/gallery_metrics.py``).
Each command that stores a measurement then rewrites every block. ``tests/test_docs_numbers.py`` renders every
block again from the stored files and compares it with the docs (and holds the cheap stored numbers against the
live code).
"""

from __future__ import annotations

import datetime
import json
import os
import re
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Callable

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the pages: scripts/docs_pages

from docs_pages.benches import BENCHES, control_loop_table, control_speed_table, hardware_cycle, iron_bench_table, iron_mom_table, loop_cost_table, loop_evaluations, loop_law, loop_simulate, performance_table, sensing_accuracy, sensing_magpylib, sensing_rate, sensing_rms, sensing_session_update, sensing_timing, sensing_update  # noqa: E402, F401
from docs_pages.common import FORCES_SEED, FORCES_STATES, ROOT, STORES, _num, stored  # noqa: E402, F401
from docs_pages.control_notes import calibration_coupling, calibration_fastest, calibration_shell, iron_capability_least, measure_control_notes, notes_capability, notes_coupled_cost, notes_coupling, notes_emf, notes_emulated_calibration, notes_fastest_summary, notes_fastest_table, notes_hold_stretch, notes_iron_coil, notes_move, notes_planning, notes_weakest_hold, relay_sweep, robust_summary, servo_drag  # noqa: E402, F401
from docs_pages.demo import demo_servo_power, drives_table, iron_drives, iron_meaning, iron_table, motor_metrics, motor_states, motor_violations, move_servo, readme_table, run_frames  # noqa: E402, F401
from docs_pages.explore import EXPLORE_OPTIONS, EXPLORE_SUBSET, explore_family, explore_measured, explore_pareto_table, explore_prototype, explore_run, run_explore  # noqa: E402, F401
from docs_pages.forces import forces_soft, forces_steps, forces_summary, forces_table, measure_forces  # noqa: E402, F401
from docs_pages.gallery import gallery_asbuilt, gallery_drive_table, gallery_escape, gallery_gimbal, gallery_relay, gallery_servo, gallery_table  # noqa: E402, F401
from docs_pages.iron import iron_compare_table  # noqa: E402, F401
from docs_pages.physics import POTENTIAL_OFFSET_STATES, dynamics_inertia, dynamics_speed, dynamics_tune, measure_dynamics, measure_potential, planners_potential, potential_bandlimit, potential_cutoff, potential_fit, potential_kernel, potential_offsets, potential_profiles, potential_stiffness, potential_targets, potential_timings  # noqa: E402, F401
from docs_pages.sensing_notes import SENSING_GLOBAL_TRIALS, measure_sensing_notes, sensing_notes_accuracy, sensing_notes_calibration, sensing_notes_common, sensing_notes_few, sensing_notes_field, sensing_notes_global, sensing_notes_global_short, sensing_notes_imu, sensing_notes_iron_accuracy, sensing_notes_iron_bias, sensing_notes_iron_calibration, sensing_notes_iron_cost, sensing_notes_iron_margin, sensing_notes_loop_cost, sensing_notes_marker, sensing_notes_marker_cost, sensing_notes_model_error, sensing_notes_onestep, sensing_notes_placement, sensing_notes_pub, sensing_notes_run, sensing_notes_scatter, sensing_notes_servo, sensing_notes_symmetry, sensing_notes_table  # noqa: E402, F401
from docs_pages.servo_runs import calibration_summary, calibration_table, robust_table  # noqa: E402, F401

# the demo summary's keys not stored: file lists and per-state lists (their counts are the numbers)
DROP = ("escape_violation_states", "escape_violation_states_note", "files")
MARKER = re.compile(r"<!-- ([a-z0-9-]+):(start|end) -->")


def _store(name: str, value) -> None:
    STORES[name].write_text(json.dumps(value, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"stored {STORES[name].relative_to(ROOT)}")


@dataclass(frozen=True)
class Block:
    """One generated block: ``name`` its marker, ``path`` the file, ``source`` the stored measurement (a tuple of
    them: the renderer gets ``{source: stored}``)."""

    name: str
    path: str
    source: str | tuple[str, ...]
    render: Callable[[dict], str]
    inline: bool = False

    @property
    def sources(self) -> tuple[str, ...]:
        return self.source if isinstance(self.source, tuple) else (self.source,)

    def data(self, cache: dict | None = None):
        """What ``render`` takes: the stored measurement, or ``{source: stored}`` for several."""
        cache = {} if cache is None else cache
        got = {s: cache.setdefault(s, stored(s)) for s in self.sources}
        return got if isinstance(self.source, tuple) else got[self.source]

    def missing(self) -> list[str]:
        """The stored files this block needs that do not exist."""
        return [str(STORES[s].relative_to(ROOT)) for s in self.sources if not STORES[s].exists()]

    def text(self, data) -> str:
        body = self.render(data)
        sep = "" if self.inline else "\n"
        return f"<!-- {self.name}:start -->{sep}{body}{sep}<!-- {self.name}:end -->"


BLOCKS = (
    Block("demo-numbers", "README.md", "demo", readme_table),
    Block("drives-table", "docs/control.md", "demo", drives_table),
    Block("move-servo", "docs/control.md", "demo", move_servo, inline=True),
    Block("demo-servo-power", "docs/control.md", "demo", demo_servo_power, inline=True),
    Block("robust-table", "docs/control.md", "robust", robust_table),
    Block("calibration-table", "docs/control.md", "calibration", calibration_table),
    Block("calibration-summary", "docs/control.md", "calibration", calibration_summary, inline=True),
    Block("run-frames", "docs/errors.md", "demo", run_frames, inline=True),
    Block("motor-metrics", "docs/motor.md", "demo", motor_metrics, inline=True),
    Block("motor-states", "docs/motor.md", "demo", motor_states, inline=True),
    Block("motor-violations", "docs/motor.md", "demo", motor_violations, inline=True),
    Block("iron-table", "docs/magnetics.md", "demo", iron_table),
    Block("iron-drives", "docs/magnetics.md", "demo", iron_drives, inline=True),
    Block("iron-meaning", "docs/magnetics.md", "demo", iron_meaning, inline=True),
    Block("forces-table", "docs/magnetics.md", "forces", forces_table),
    Block("forces-summary", "docs/magnetics.md", "forces", forces_summary, inline=True),
    Block("forces-soft", "docs/magnetics.md", "forces", forces_soft, inline=True),
    Block("forces-steps", "docs/magnetics.md", "forces", forces_steps, inline=True),
    Block("iron-compare", "docs/magnetics.md", "iron", iron_compare_table),
    Block("gallery-table", "docs/gallery.md", "gallery", gallery_table),
    Block("gallery-drive-table", "docs/gallery.md", "gallery", gallery_drive_table),
    Block("gallery-asbuilt", "docs/gallery.md", "gallery", gallery_asbuilt, inline=True),
    Block("gallery-escape", "docs/gallery.md", "gallery", gallery_escape, inline=True),
    Block("gallery-gimbal", "docs/gallery.md", "gallery", gallery_gimbal, inline=True),
    Block("gallery-servo", "docs/gallery.md", "gallery", gallery_servo, inline=True),
    Block("gallery-relay", "docs/gallery.md", "gallery", gallery_relay, inline=True),
    Block("bench-sensing-timing", "docs/sensing.md", "bench-sensing", sensing_timing),
    Block("bench-sensing-rate", "docs/sensing.md", "bench-sensing", sensing_rate, inline=True),
    Block("bench-sensing-magpylib", "docs/sensing.md", "bench-sensing", sensing_magpylib, inline=True),
    Block("bench-sensing-update", "docs/sensing.md", "bench-sensing", sensing_update, inline=True),
    Block("bench-sensing-rms", "docs/sensing.md", "bench-sensing", sensing_rms, inline=True),
    Block("bench-sensing-accuracy", "docs/sensing.md", "bench-sensing", sensing_accuracy, inline=True),
    Block("bench-sensing-session-update", "docs/sensing.md", "bench-servo_loop", sensing_session_update, inline=True),
    Block("bench-performance", "README.md", tuple(f"bench-{n}" for n in BENCHES if n != "iron"), performance_table),
    Block("bench-loop-cost", "docs/hardware.md", "bench-servo_loop", loop_cost_table),
    Block("bench-loop-simulate", "docs/hardware.md", "bench-servo_loop", loop_simulate, inline=True),
    Block("bench-hw-cycle", "docs/hardware.md", "bench-hardware", hardware_cycle, inline=True),
    Block("bench-control-speed", "docs/control.md", "bench-control", control_speed_table),
    Block("bench-loop-table", "docs/control.md", "bench-servo_loop", control_loop_table),
    Block("bench-loop-law", "docs/control.md", "bench-servo_loop", loop_law, inline=True),
    Block("bench-loop-evaluations", "docs/control.md", "bench-servo_loop", loop_evaluations, inline=True),
    Block("bench-iron-models", "docs/magnetics.md", "bench-iron", iron_bench_table),
    Block("bench-iron-mom", "docs/magnetics.md", "bench-iron", iron_mom_table),
    Block("potential-profiles", "docs/potential.md", "potential", potential_profiles, inline=True),
    Block("potential-bandlimit", "docs/potential.md", "potential", potential_bandlimit, inline=True),
    Block("potential-kernel", "docs/potential.md", "potential", potential_kernel, inline=True),
    Block("potential-cutoff", "docs/potential.md", "potential", potential_cutoff, inline=True),
    Block("potential-offsets", "docs/potential.md", "potential", potential_offsets),
    Block("potential-stiffness", "docs/potential.md", "potential", potential_stiffness, inline=True),
    Block("potential-fit", "docs/potential.md", "potential", potential_fit, inline=True),
    Block("bench-potential-planner", "docs/potential.md", "bench-planners", planners_potential, inline=True),
    Block("bench-potential-timings", "docs/potential.md", "bench-potential", potential_timings),
    Block("bench-potential-targets", "docs/potential.md", ("bench-potential", "bench-planners", "bench-dynamics"),
          potential_targets),
    Block("dynamics-inertia", "docs/dynamics.md", "dynamics", dynamics_inertia, inline=True),
    Block("dynamics-tune", "docs/dynamics.md", "dynamics", dynamics_tune, inline=True),
    Block("bench-dynamics-speed", "docs/dynamics.md", "bench-dynamics", dynamics_speed, inline=True),
    Block("explore-run", "docs/explore.md", "explore", explore_run),
    Block("explore-pareto", "docs/explore.md", "explore", explore_pareto_table),
    Block("explore-prototype", "docs/explore.md", "explore", explore_prototype, inline=True),
    Block("explore-measured", "docs/explore.md", "explore", explore_measured, inline=True),
    Block("explore-family", "docs/explore.md", "explore", explore_family, inline=True),
    Block("control-notes-iron-coil", "docs/control.md", "control-notes", notes_iron_coil, inline=True),
    Block("control-notes-capability", "docs/control.md", "control-notes", notes_capability, inline=True),
    Block("control-notes-fastest", "docs/control.md", "control-notes", notes_fastest_table),
    Block("control-notes-fastest-summary", "docs/control.md", "control-notes", notes_fastest_summary, inline=True),
    Block("control-notes-move", "docs/control.md", "control-notes", notes_move, inline=True),
    Block("control-notes-planning", "docs/control.md", "control-notes", notes_planning, inline=True),
    Block("control-notes-coupled-cost", "docs/control.md", "control-notes", notes_coupled_cost, inline=True),
    Block("control-notes-emf", "docs/control.md", "control-notes", notes_emf, inline=True),
    Block("control-notes-hold-stretch", "docs/control.md", "control-notes", notes_hold_stretch, inline=True),
    Block("control-notes-coupling", "docs/control.md", "control-notes", notes_coupling, inline=True),
    Block("control-notes-weakest-hold", "docs/control.md", "control-notes", notes_weakest_hold, inline=True),
    Block("control-notes-emulated-calibration", "docs/control.md", "control-notes", notes_emulated_calibration,
          inline=True),
    Block("robust-summary", "docs/control.md", "robust", robust_summary, inline=True),
    Block("calibration-fastest", "docs/control.md", "calibration", calibration_fastest, inline=True),
    Block("servo-drag", "docs/control.md", "demo", servo_drag, inline=True),
    Block("relay-sweep", "docs/control.md", "demo", relay_sweep, inline=True),
    Block("calibration-coupling", "docs/control.md", "calibration", calibration_coupling, inline=True),
    Block("calibration-shell", "docs/control.md", "calibration", calibration_shell, inline=True),
    Block("iron-capability-least", "docs/control.md", "demo", iron_capability_least, inline=True),
    Block("sensing-notes-run", "docs/sensing.md", "sensing-notes", sensing_notes_run, inline=True),
    Block("sensing-notes-table", "docs/sensing.md", "sensing-notes", sensing_notes_table),
    Block("sensing-notes-onestep", "docs/sensing.md", "sensing-notes", sensing_notes_onestep, inline=True),
    Block("sensing-notes-loop-cost", "docs/sensing.md", "sensing-notes", sensing_notes_loop_cost, inline=True),
    Block("sensing-notes-global", "docs/sensing.md", "sensing-notes", sensing_notes_global),
    Block("sensing-notes-global-short", "docs/sensing.md", "sensing-notes", sensing_notes_global_short, inline=True),
    Block("sensing-notes-placement", "docs/sensing.md", "sensing-notes", sensing_notes_placement, inline=True),
    Block("sensing-notes-accuracy", "docs/sensing.md", "sensing-notes", sensing_notes_accuracy),
    Block("sensing-notes-few", "docs/sensing.md", "sensing-notes", sensing_notes_few, inline=True),
    Block("sensing-notes-model-error", "docs/sensing.md", "sensing-notes", sensing_notes_model_error),
    Block("sensing-notes-calibration", "docs/sensing.md", "sensing-notes", sensing_notes_calibration),
    Block("sensing-notes-common", "docs/sensing.md", "sensing-notes", sensing_notes_common, inline=True),
    Block("sensing-notes-scatter", "docs/sensing.md", "sensing-notes", sensing_notes_scatter, inline=True),
    Block("sensing-notes-imu", "docs/sensing.md", "sensing-notes", sensing_notes_imu),
    Block("sensing-notes-servo", "docs/sensing.md", "sensing-notes", sensing_notes_servo),
    Block("sensing-notes-iron-cost", "docs/sensing.md", "sensing-notes", sensing_notes_iron_cost),
    Block("sensing-notes-iron-calibration", "docs/sensing.md", "sensing-notes", sensing_notes_iron_calibration,
          inline=True),
    Block("sensing-notes-field", "docs/sensing.md", "sensing-notes", sensing_notes_field, inline=True),
    Block("sensing-notes-symmetry", "docs/sensing.md", "sensing-notes", sensing_notes_symmetry, inline=True),
    Block("sensing-notes-marker", "docs/sensing.md", "sensing-notes", sensing_notes_marker, inline=True),
    Block("sensing-notes-marker-cost", "docs/sensing.md", "sensing-notes", sensing_notes_marker_cost),
    Block("sensing-notes-iron-bias", "docs/sensing.md", "sensing-notes", sensing_notes_iron_bias, inline=True),
    Block("sensing-notes-iron-margin", "docs/sensing.md", "sensing-notes", sensing_notes_iron_margin, inline=True),
    Block("sensing-notes-iron-accuracy", "docs/sensing.md", "sensing-notes", sensing_notes_iron_accuracy, inline=True),
    *(Block(f"sensing-notes-pub-{k}", "docs/sensing.md", "sensing-notes", sensing_notes_pub(k), inline=True)
      for k in ("3", "positions", "calibrated", "fused", "imu")),
)


def current(text: str, name: str) -> str | None:
    """The block ``name`` in ``text``, markers included (None when the file has no such markers)."""
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    if start not in text:
        return None
    i, j = text.index(start), text.index(end) + len(end)
    return text[i:j]


def marked_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def differing() -> list[str]:
    """The blocks whose text in the docs is not what the stored measurements render (or whose markers are gone)."""
    cache: dict = {}
    bad = []
    for b in BLOCKS:
        if b.missing():
            bad.append(f"{b.name}: {', '.join(b.missing())} missing")
            continue
        have = current((ROOT / b.path).read_text(encoding="utf-8"), b.name)
        if have != b.text(b.data(cache)):
            bad.append(f"{b.path}: {b.name}" + (" (markers missing)" if have is None else ""))
    return bad


def write(paths: set[str] | None = None, sources: set[str] | None = None) -> int:
    """Rewrite every block from the stored measurements (only those in the files ``paths``, or rendered from the
    stores ``sources``, when given); the number of blocks changed."""
    cache: dict = {}
    changed = 0
    for b in BLOCKS:
        if paths is not None and b.path not in paths:
            continue
        if sources is not None and not set(b.sources) & sources:
            continue
        if b.missing():
            print(f"skipped {b.name}: {', '.join(b.missing())} missing")
            continue
        path = ROOT / b.path
        text = path.read_text(encoding="utf-8")
        have = current(text, b.name)
        if have is None:
            print(f"skipped {b.name}: no markers in {b.path}")
            continue
        new = b.text(b.data(cache))
        if new != have:
            path.write_text(text.replace(have, new), encoding="utf-8")
            changed += 1
            print(f"rewrote {b.path}: {b.name}")
    return changed


def store_demo(source: Path) -> None:
    summary = {k: v for k, v in json.loads(source.read_text(encoding="utf-8")).items() if k not in DROP}
    if isinstance(summary.get("escape_violations"), list):  # the states themselves: their count is the number
        summary["escape_violations"] = len(summary["escape_violations"])
    _store("demo", summary)


def store_robust(source: Path | None) -> None:
    if source is None:
        source = Path(tempfile.mkstemp(suffix=".json")[1])
        subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_servo_robust.py"), "--json", str(source)],
                       check=True, cwd=ROOT)
    when = datetime.datetime.fromtimestamp(source.stat().st_mtime, datetime.UTC)
    _store("robust", {"measured": when.strftime("%Y-%m-%d %H:%M UTC"), "note": "",
                      "source": "benchmarks/bench_servo_robust.py", "rows": json.loads(source.read_text(encoding="utf-8"))})


def run_bench(name: str) -> None:
    """Run one benchmark of :data:`BENCHES` (alone: one at a time) storing ``data/bench_NAME.json``."""
    script, *options = BENCHES[name]
    print(f"running benchmarks/{script} {' '.join(options)} (load {os.getloadavg()[0]:.1f})", flush=True)
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / script), *options, "--json",
                    str(STORES[f"bench-{name}"])], check=True, cwd=ROOT,
                   env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})


def main(argv: list[str]) -> int:
    args = list(argv)
    if args[:1] == ["--check"]:
        bad = differing()
        for line in bad:
            print(f"differs: {line}")
        return 1 if bad else 0
    cmd = args.pop(0) if args else "write"
    arg = Path(args[0]) if args else None
    if cmd in ("demo", "all"):
        store_demo(arg or ROOT / "spherestep-out" / "summary.json")
    if cmd in ("forces", "all"):
        _store("forces", measure_forces())
    if cmd == "robust":
        store_robust(arg)
    if cmd == "iron":
        subprocess.run([sys.executable, str(ROOT / "scripts" / "iron_compare.py"), "--json", str(STORES["iron"])],
                       check=True, cwd=ROOT)
    if cmd == "calibration":
        subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_calibration.py"), "--json",
                        str(STORES["calibration"])], check=True, cwd=ROOT)
    if cmd == "bench":
        names = args or list(BENCHES)
        unknown = [n for n in names if n not in BENCHES]
        if unknown:
            print(f"unknown benchmark {', '.join(unknown)}: one of {', '.join(BENCHES)}", file=sys.stderr)
            return 2
        for name in names:
            run_bench(name)
    own = {"potential": {"docs/potential.md"}, "dynamics": {"docs/dynamics.md"}, "explore": {"docs/explore.md"}}
    if cmd in own:  # these store their own measurement and rewrite only their page's blocks
        if cmd == "potential":
            _store("potential", measure_potential())
        elif cmd == "dynamics":
            _store("dynamics", measure_dynamics())
        else:
            _store("explore", run_explore(arg))
        print(f"{write(own[cmd])} blocks rewritten")
        return 0
    if cmd in ("control-notes", "sensing-notes"):  # pages shared with other stores: only this store's blocks
        _store(cmd, measure_control_notes() if cmd == "control-notes" else measure_sensing_notes())
        print(f"{write(sources={cmd})} blocks rewritten")
        return 0
    if cmd not in ("demo", "forces", "robust", "iron", "calibration", "bench", "all", "write"):
        print(f"unknown command {cmd!r}: demo [SUMMARY], forces, robust [BENCH.json], iron, calibration, bench [NAME ...], "
              "potential, dynamics, explore [FOLDER], control-notes, sensing-notes, all [SUMMARY], --check", file=sys.stderr)
        return 2
    print(f"{write()} blocks rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
