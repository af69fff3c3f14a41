"""The iron-aware relay planner (issue 39) on the prototype's own iron model: planning speed, against a baseline.

Run: ``.venv/bin/python benchmarks/bench_iron_planner.py [--trials N] [--design FILE] [--baseline REF] [--json PATH]``.

For each trial: a 360° turn about a random axis (seeded) from the stepper state nearest the identity, the default
steps (0.35 of a max step), planned by :func:`spherestep.commutation.plan_iron` with the design's iron model, its
limits and the iron relay tuning (each chosen landing is integrated on the tuned rotor). Reported: median plan
time for the 360° turn (s), median planning steps per second (wall, and per CPU second: on a loaded machine the
wall clock counts others' work), steps per plan, blocked steps. Targets (issue 39): ≥ 200 steps/s, a 360° turn
≤ 5 s. The first call (numba compiles, the iron tables load) is left out.

``--baseline REF[,REF…]`` (default ``29370bb,75d235a``: the planner before issue 39's first speed-up and before
its fused table evaluation; ``none`` to skip): the same trials, in the same run, planned by the source tree at
each git commit (``git archive`` into a temporary folder, run in a child process after a first child has
compiled and cached its numba kernels — a freshly compiled kernel and one loaded from the cache can differ in
rounding, which changes a borderline choice on some turns, so both sides load theirs from a cache), with the
ratio of the medians and whether every plan is the same (statuses, coils and landings to 1e-6 rad, as
``tests/test_iron_planner.py`` holds three turns).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

import numpy as np

from _record import Record

ROOT = Path(__file__).resolve().parents[1]
BASELINE = "29370bb,75d235a"


def measure(design_file: str | None, trials: int) -> tuple[list, list]:
    """``(rows, plans)``: per trial ``(wall s, steps/s, CPU s, steps/CPU s, steps, blocked)`` and the plan's steps
    as ``(status, coils, achieved)``."""
    from spherestep.commutation import plan_iron, turn_targets
    try:  # where the tuning lives since issue 36's untying; the baselines' trees had it in commutation
        from spherestep.dynamics import iron_tuning
    except ImportError:
        from spherestep.commutation import iron_tuning
    from spherestep.magnetics import design_model
    from spherestep.motor import MotorDesign, prototype

    design = prototype() if design_file is None else MotorDesign.load(design_file)
    own = design_model(design)
    tuning = iron_tuning(design, own.model)
    plan_iron(design, turn_targets(design, (0, 0, 1), math.radians(10)), own.model, limits=own.limits, tuning=tuning)
    rng = np.random.default_rng(42)
    rows, plans = [], []
    for _ in range(trials):
        targets = turn_targets(design, rng.normal(size=3), 2 * math.pi)
        t, cpu = time.perf_counter(), time.process_time()
        plan = plan_iron(design, targets, own.model, limits=own.limits, tuning=tuning)
        elapsed, cpu = time.perf_counter() - t, time.process_time() - cpu
        n = len(plan.steps) - 1
        rows.append((elapsed, n / elapsed, cpu, n / cpu, n, len(plan.failures)))
        plans.append([(s.status, sorted(s.coils.items()), s.achieved.tolist()) for s in plan.steps])
    return rows, plans


def baseline(ref: str, design_file: str | None, trials: int) -> tuple[list, list]:
    """:func:`measure` run by the source tree at git commit ``ref`` in a child process."""
    with tempfile.TemporaryDirectory(prefix="bench_iron_planner_") as tmp:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", ref, "src"], check=True, capture_output=True)
        with tarfile.open(fileobj=__import__("io").BytesIO(archive.stdout)) as tar:
            tar.extractall(tmp, filter="data")
        env = dict(os.environ, PYTHONPATH=os.path.join(tmp, "src"))
        code = (f"import json, sys; sys.path.insert(0, {str(Path(__file__).parent)!r}); "
                f"from bench_iron_planner import measure; "
                f"print(json.dumps(measure({design_file!r}, {{trials}})))")
        subprocess.run([sys.executable, "-c", code.format(trials=0)], env=env, check=True, capture_output=True)
        out = subprocess.run([sys.executable, "-c", code.format(trials=trials)], env=env, check=True,
                             capture_output=True, text=True)
    rows, plans = json.loads(out.stdout.strip().splitlines()[-1])
    return rows, [[tuple(s) for s in p] for p in plans]


def _same(plan, other, tol: float = 1e-6) -> bool:
    """Whether two plans (:func:`measure`'s) have the same statuses and coils and landings within ``tol``."""
    a, b = json.loads(json.dumps(plan)), json.loads(json.dumps(other))  # tuples and lists alike
    if [s[:2] for s in a] != [s[:2] for s in b]:
        return False
    return float(np.abs(np.array([s[2] for s in a]) - np.array([s[2] for s in b])).max()) <= tol


def _table(label: str, rows: list) -> np.ndarray:
    print(f"{label}\n{'360° plan s':>12} {'steps/s':>8} {'CPU s':>7} {'steps/CPU s':>11} {'steps':>6} {'blocked':>7}")
    for r in rows:
        print(f"{r[0]:>12.2f} {r[1]:>8.1f} {r[2]:>7.2f} {r[3]:>11.1f} {int(r[4]):>6d} {int(r[5]):>7d}")
    d = np.array(rows, dtype=float)
    print(f"median: {np.median(d[:, 0]):.2f} s per 360° turn, {np.median(d[:, 1]):.1f} steps/s "
          f"({np.median(d[:, 3]):.1f} per CPU second); load {os.getloadavg()}")
    return d


def _summary(d: np.ndarray, trials: int) -> dict:
    return {"trials": trials, "turn 360 s": np.median(d[:, 0]), "steps per s": np.median(d[:, 1]),
            "turn 360 cpu s": np.median(d[:, 2]), "steps per cpu s": np.median(d[:, 3]), "steps": np.median(d[:, 4]),
            "blocked": int(d[:, 5].sum())}


def main() -> None:
    record = Record("iron_planner")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=5)
    parser.add_argument("--design", default=None, help="a design file (default the prototype as built)")
    parser.add_argument("--baseline", default=BASELINE, help="git commits of the baseline planners, comma-separated, or 'none'")
    args = parser.parse_args()
    print(f"# bench_iron_planner  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  load={os.getloadavg()}")
    design = None if args.design is None else str(Path(args.design).resolve())
    rows, plans = measure(design, args.trials)
    d = _table("this tree", rows)
    record.put("iron", _summary(d, args.trials))
    refs = [] if args.baseline == "none" else args.baseline.split(",")
    for ref in refs:
        base_rows, base_plans = baseline(ref, design, args.trials)
        b = _table(f"baseline {ref}", base_rows)
        same = [_same(p, q) for p, q in zip(plans, base_plans)]
        ratio = np.median(b[:, 2]) / np.median(d[:, 2])
        print(f"CPU time per 360° turn, baseline {ref} / this tree: {ratio:.2f}; plans the same: {sum(same)} of "
              f"{len(same)}")
        record.put("baseline" if ref == refs[0] else f"baseline {ref}",
                   dict(_summary(b, args.trials), ref=ref, cpu_ratio=ratio, same_plans=int(sum(same))))
    record.write()


if __name__ == "__main__":
    main()
