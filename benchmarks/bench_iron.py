"""Iron-cored coils, one run: time to build the iron torque map (method of moments: factorising a core and the
pair table), time per orientation of the map against the air-core map, and the FEM time per solve (read from
data/iron_fem.csv, written by scripts/fem_iron.py on the same machine: a FEM solve takes minutes and is not
repeated here).

Run: ``OPENBLAS_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/bench_iron.py [--level 0]`` (level 0 keeps the
factorisation to a few minutes on a loaded machine; the default map uses level 1).
"""

from __future__ import annotations

import datetime
import sys
import time
from pathlib import Path

import numpy as np

from _timing import median_seconds
from spherestep import so3
from spherestep.magnetics import _iron as iron
from spherestep.magnetics._ironforce import pair_tables
from spherestep.magnetics import iron_model, torque_map
from spherestep.magnetics._ironmap import read_table
from spherestep.motor import prototype
from spherestep.motor.coil import iron_coil


def main() -> None:
    level = int(sys.argv[sys.argv.index("--level") + 1]) if "--level" in sys.argv else 0
    design, coil = prototype(), iron_coil()
    geom = iron.CoreGeometry.of(design, coil)
    iron.core_solver.cache_clear()
    t0 = time.perf_counter()
    solver = iron.core_solver(geom, level)  # cached: pair_tables below reuses it
    t1 = time.perf_counter()
    a = np.radians(np.arange(0.0, 40.0, 1.0))
    t2 = time.perf_counter()
    pair_tables(design, coil, a, level)
    t3 = time.perf_counter()
    per_angle = (t3 - t2) / len(a)
    rng = np.random.default_rng(0)
    R = so3.random(1000, rng)
    c = rng.choice([-1.0, 0.0, 1.0], size=(1000, len(design.stator)))
    model = iron_model(design)  # the stored level-1 tables
    air = torque_map(design)
    t_iron = median_seconds(5, model.torque, R, c)
    t_air = median_seconds(5, air.torque, R, c)
    one_iron = median_seconds(50, model.torque, R[0], c[0])
    one_air = median_seconds(50, air.torque, R[0], c[0])
    fem_path = Path(__file__).resolve().parents[1] / "data" / "iron_fem.csv"
    fem = read_table(fem_path) if fem_path.exists() else None  # alpha, maxh, elements, detent, linear, mesh_s, solve_s
    print(f"# bench_iron {datetime.date.today()} ({len(solver.cells)} cells at level {level})")
    print("| what | time | ratio |")
    print("|---|---|---|")
    print(f"| MoM: factorise one core ({len(solver.cells)} cells) | {t1 - t0:.1f} s | |")
    print(f"| MoM: pair table, per angle (detent + linear) | {per_angle:.2f} s | |")
    print(f"| iron map: 1000 orientations | {1e3 * t_iron:.1f} ms | {t_iron / t_air:.2f} × air map |")
    print(f"| iron map: one orientation | {1e6 * one_iron:.0f} µs | {one_iron / one_air:.2f} × air map |")
    if fem is not None:
        solve = float(np.median(fem[:, 6]))
        mesh = float(np.median(fem[:, 5]))
        print(f"| FEM (NGSolve): mesh one angle | {mesh:.1f} s | |")
        print(f"| FEM (NGSolve): one solve | {solve:.1f} s | {solve / per_angle:.0f} × MoM per angle; "
              f"{solve / one_iron:.2g} × iron map per orientation |")


if __name__ == "__main__":
    main()
