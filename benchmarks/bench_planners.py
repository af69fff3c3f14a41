"""The geometric (Sec. III-A) and potential (Sec. III-B) planners side by side on the same trajectories.

Run: ``.venv/bin/python benchmarks/bench_planners.py [--trials N] [--json PATH]``.

For each trial: a 360° turn about a random axis from a random stepper state of the prototype, at steps of
half a max step. Reported per planner: median and worst tracking error (Park distance of achieved to
desired, degrees), final error, steps (plan length), coils energised per step, blocked steps, and
throughput (plan steps per second, median over trials). Errors of the potential planner are measured at
its equilibria, those of the geometric planner at its states.
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
from spherestep.commutation import about_axis, plan_geometric, plan_potential, steps_for
from spherestep.motor import prototype
from spherestep.potential import MotorPotential


def main() -> None:
    record = Record("planners")  # --json PATH: the rows below stored for scripts/docs_numbers.py
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=10)
    args = parser.parse_args()
    print(f"# bench_planners  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}")
    design = prototype()
    states = design.states()
    model = MotorPotential(design)
    rng = np.random.default_rng(42)
    rows = {"geometric": [], "potential": []}
    for _ in range(args.trials):
        axis = rng.normal(size=3)
        start = states.rotations[rng.integers(len(states))]
        T = about_axis(axis, 2 * math.pi, steps_for(2 * math.pi, 0.5 * design.max_step), start=start)
        for name, run in (("geometric", lambda: plan_geometric(design, T)),
                          ("potential", lambda: plan_potential(design, T, model))):
            t = time.perf_counter()
            plan = run()
            elapsed = time.perf_counter() - t
            err = np.degrees(plan.errors)
            rows[name].append((np.median(err), err.max(), err[-1], len(plan.steps) - 1,
                               np.mean([len(s.coils) for s in plan.steps]), len(plan.failures),
                               (len(plan.steps) - 1) / elapsed))
    print(f"{'planner':>10} {'median err °':>12} {'worst err °':>11} {'final err °':>11} {'steps':>6} "
          f"{'coils/step':>10} {'blocked':>7} {'steps/s':>8}")
    for name, data in rows.items():
        d = np.array(data)
        print(f"{name:>10} {np.median(d[:, 0]):>12.2f} {d[:, 1].max():>11.2f} {np.median(d[:, 2]):>11.2f} "
              f"{np.median(d[:, 3]):>6.0f} {d[:, 4].mean():>10.2f} {int(d[:, 5].sum()):>7d} {np.median(d[:, 6]):>8.0f}")
        record.put(name, {"trials": args.trials, "median error deg": np.median(d[:, 0]), "worst error deg": d[:, 1].max(),
                          "final error deg": np.median(d[:, 2]), "steps": np.median(d[:, 3]),
                          "coils per step": d[:, 4].mean(), "blocked": int(d[:, 5].sum()),
                          "steps per s": np.median(d[:, 6])})
    record.write()


if __name__ == "__main__":
    main()
