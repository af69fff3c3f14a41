"""Timings of stepper-state enumeration and of the geometric planner (medians of repeats).

Run: ``.venv/bin/python benchmarks/bench_motor.py [--quick] [--levels 1 2 3] [--json PATH]`` (a level ≥ 3
rotor is enumerated once).

Designs: the prototype (92-pole rotor, 29 coils) and the same stator with the rotor refined further
(truncated icosahedron at level 2: 272 poles; ``--levels 1 2 3`` adds 812 poles: 3.6 million states in about
4 minutes on a 2-core machine). The number of states grows like the number of (pole pair, coil pair)
matches, i.e. with the square of the rotor's poles at a fixed tolerance; level 4 (2432 poles) and beyond
were not run. Finer rotors need a tolerance below
half their pole spacing, so ``tol`` is ``min(1°, ¼ · rotor min separation)``, printed per row. Planner
throughput is steps per second of ``plan_geometric`` over a 360° turn at steps of half a max step.
The baseline measured in the same run is the same enumeration with the held pairs found by a dense
``(K, M, N)`` dot product instead of the voxel lookup, on the prototype.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
from dataclasses import replace

import numpy as np

from _record import Record
from _timing import median_seconds
from spherestep import packing as pk
from spherestep.commutation import about_axis, plan_geometric, steps_for
from spherestep.motor import PolarityRule, prototype
from spherestep.motor import states as st


def dense_held_pairs(R, u, v, tol, grid=None):
    """Baseline: every pole against every coil, ``(K, M, N)`` dot products in chunks."""
    out = []
    for start in range(0, len(R), 256):
        dots = np.einsum("kij,mj,ni->kmn", R[start:start + 256], u, v, optimize=True)
        s, j, k = np.nonzero(dots >= np.cos(tol))
        out.append(np.stack([start + s, j, k]))
    return tuple(np.hstack(out))


def main() -> None:
    record = Record("motor")  # --json PATH: the numbers below stored for scripts/docs_numbers.py
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat")
    parser.add_argument("--levels", type=int, nargs="+", default=[1, 2], help="rotor refinement levels")
    args = parser.parse_args()
    repeats = 1 if args.quick else 3
    print(f"# bench_motor  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  numpy={np.__version__}")
    base = prototype()
    levels = args.levels
    print(f"{'rotor poles':>11} {'coils':>5} {'tol °':>6} {'states':>9} {'enumerate s':>11} {'plan steps/s':>12}")
    for level in levels:
        rotor = pk.named("truncated-icosahedron", level)
        tol = min(math.radians(1.0), 0.25 * rotor.min_separation())
        design = base if level == 1 else replace(  # the prototype's polarity rule on the finer rotor
            base, rotor=rotor, polarity=PolarityRule(1, -1).signs(len(rotor), len(pk.named(rotor.name))), tol=tol,
            magnet_diameter=base.sphere_diameter * math.tan(0.5 * rotor.min_separation()) * 0.9)
        t_enum = median_seconds(repeats if level < 3 else 1, st.find_states, design, design.state_tol)  # 812 poles: once
        states = design.states()
        T = about_axis([1, 0.5, 2], 2 * math.pi, steps_for(2 * math.pi, 0.5 * design.max_step),
                       start=states.rotations[0])
        t_plan = median_seconds(repeats, plan_geometric, design, T)
        print(f"{len(rotor):>11} {len(design.stator):>5} {math.degrees(tol):>6.3f} {len(states):>9} "
              f"{t_enum:>11.3f} {(len(T) - 1) / t_plan:>12.0f}")
        record.values.setdefault("levels", []).append(
            {"poles": len(rotor), "coils": len(design.stator), "tol deg": math.degrees(tol), "states": len(states),
             "enumerate s": t_enum, "enumerate repeats": repeats if level < 3 else 1,
             "plan steps per s": (len(T) - 1) / t_plan})
    fast = median_seconds(repeats, st.find_states, base, base.state_tol)
    original = st.held_pairs
    st.held_pairs = dense_held_pairs
    try:
        dense = median_seconds(repeats, st.find_states, base, base.state_tol)
    finally:
        st.held_pairs = original
    print(f"baseline (prototype): voxel lookup {fast:.3f} s, dense dot products {dense:.3f} s, ratio {dense / fast:.1f}x")
    record.put("baseline", {"voxel s": fast, "dense s": dense})
    record.write()


if __name__ == "__main__":
    main()
