"""The iron-aware relay planner (issue 39) on the prototype's own iron model: planning speed.

Run: ``.venv/bin/python benchmarks/bench_iron_planner.py [--trials N] [--json PATH]``.

For each trial: a 360° turn about a random axis (seeded) from the stepper state nearest the identity, the default
steps (0.35 of a max step), planned by :func:`spherestep.commutation.plan_iron` with the prototype's iron model, its
limits and the iron relay tuning (each chosen landing is integrated once on the tuned rotor). Reported: median plan
time for the 360° turn (s), median planning steps per second (wall, and per CPU second: on a loaded machine the
wall clock counts others' work), steps per plan, blocked steps. Targets (issue 39):
≥ 200 steps/s, a 360° turn ≤ 5 s. The first call (numba compiles, the iron tables load) is left out.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import time

import numpy as np

from _record import Record
from spherestep.commutation import iron_tuning, plan_iron, turn_targets
from spherestep.magnetics import design_model
from spherestep.motor import MotorDesign, prototype


def main() -> None:
    record = Record("iron_planner")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=5)
    parser.add_argument("--design", default=None, help="a design file (default the prototype as built)")
    args = parser.parse_args()
    print(f"# bench_iron_planner  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  load={os.getloadavg()}")
    design = prototype() if args.design is None else MotorDesign.load(args.design)
    own = design_model(design)
    tuning = iron_tuning(design, own.model)
    warm = turn_targets(design, (0, 0, 1), math.radians(10))
    plan_iron(design, warm, own.model, limits=own.limits, tuning=tuning)
    rng = np.random.default_rng(42)
    rows = []
    for _ in range(args.trials):
        axis = rng.normal(size=3)
        targets = turn_targets(design, axis, 2 * math.pi)
        t, cpu = time.perf_counter(), time.process_time()
        plan = plan_iron(design, targets, own.model, limits=own.limits, tuning=tuning)
        elapsed, cpu = time.perf_counter() - t, time.process_time() - cpu
        n = len(plan.steps) - 1
        rows.append((elapsed, n / elapsed, cpu, n / cpu, n, len(plan.failures)))
    d = np.array(rows)
    print(f"{'360° plan s':>12} {'steps/s':>8} {'CPU s':>7} {'steps/CPU s':>11} {'steps':>6} {'blocked':>7}")
    for r in rows:
        print(f"{r[0]:>12.2f} {r[1]:>8.1f} {r[2]:>7.2f} {r[3]:>11.1f} {r[4]:>6d} {r[5]:>7d}")
    print(f"median: {np.median(d[:, 0]):.2f} s per 360° turn, {np.median(d[:, 1]):.1f} steps/s "
          f"({np.median(d[:, 3]):.1f} per CPU second); load {os.getloadavg()}")
    record.put("iron", {"trials": args.trials, "turn 360 s": np.median(d[:, 0]), "steps per s": np.median(d[:, 1]),
                        "turn 360 cpu s": np.median(d[:, 2]), "steps per cpu s": np.median(d[:, 3]),
                        "steps": np.median(d[:, 4]), "blocked": int(d[:, 5].sum())})
    record.write()


if __name__ == "__main__":
    main()
