"""Torque evaluations per second for the prototype: direct ``magpylib.getFT`` against the torque map, measured
side by side in one run (medians of repeats).

Run: ``.venv/bin/python benchmarks/bench_magnetics.py``. Two drives: a stepper state's coils (2 coils on) and
random currents on all 29 coils. Direct getFT at 8 cells per magnet (the coarse mesh of the 1000-orientation
comparison, 4 % of the peak pair torque) and at 216 (the default, 0.6 %); the map (table at 1000 cells, 0.1 %)
in batches of 1000 and one orientation per call (the latency an integrator's step sees). ``evals/s`` counts
orientations; ``× direct216`` is the speed-up over direct getFT at 216 cells for the same drive; ``max |ΔT|``
is the largest difference from direct at 216 cells on the orientations both evaluated (N·m).
"""

from __future__ import annotations

import datetime
import os
import platform
import time

import magpylib
import numpy as np

from _timing import median_seconds
from spherestep import magnetics as mg
from spherestep import so3
from spherestep.motor import prototype


def one_at_a_time(f, R, c):
    for Ri, ci in zip(R, c):
        f(Ri[None], ci[None])


def main() -> None:
    rng = np.random.default_rng(0)
    design = prototype()
    start = time.perf_counter()
    mg.torque_map(design)
    build = time.perf_counter() - start
    f = mg.torque_function(design)
    R = so3.random(1000, rng)
    drives = {
        "state 0 (2 coils)": np.tile(mg.state_currents(design, 0), (len(R), 1)),
        "random, 29 coils": rng.choice([-1.0, 0.0, 1.0], size=(len(R), len(design.stator))),
    }
    print(f"bench_magnetics  {datetime.date.today()}  {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}, magpylib {magpylib.__version__}, "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"torque map build (151 getFT angles at 1000 cells, cached afterwards): {build:.2f} s\n")
    print(f"{'drive':<20} {'method':<26} {'batch':>6} {'s/call':>10} {'evals/s':>10} {'× direct216':>12} "
          f"{'max |ΔT| N·m':>13}")
    for name, c in drives.items():
        n216 = 2
        reference = mg.torque(design, R[:n216], c[:n216], meshing=216)
        rows = [
            ("direct getFT, 216 cells", n216, 1, lambda: mg.torque(design, R[:n216], c[:n216], meshing=216)),
            ("direct getFT, 8 cells", 20, 3, lambda: mg.torque(design, R[:20], c[:20], meshing=8)),
            ("map, batch", 1000, 7, lambda: f(R, c)),
            ("map, one per call", 200, 5, lambda: one_at_a_time(f, R[:200], c[:200])),
        ]
        base = None
        for label, batch, repeats, call in rows:
            t = median_seconds(repeats, call)
            rate = batch / t
            base = rate if base is None else base
            if label.startswith("direct getFT, 8"):
                diff = np.abs(mg.torque(design, R[:n216], c[:n216], meshing=8) - reference).max()
            elif label.startswith("map"):
                diff = np.abs(f(R[:n216], c[:n216]) - reference).max()
            else:
                diff = 0.0
            print(f"{name:<20} {label:<26} {batch:>6} {t:>10.4g} {rate:>10.4g} {rate / base:>12.4g} {diff:>13.3g}")


if __name__ == "__main__":
    main()
