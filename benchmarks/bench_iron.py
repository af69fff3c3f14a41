"""Iron-cored coils, one run. First the motor model (issue 28 §2), today's against the new side by side: energy +
torque per orientation of the pairwise model (compiled zonal sums), the coupled model's NumPy sums (pair splines
+ the coupling's series) and its tables (compiled, the design's own model now; the model's call and the packed
compiled call the integrator makes), the tables' cold build, the iron model's dynamics in multiples of real time
at its tuned step (``dynamics.tune``; Yoshida, 3 torque calls a step, 2 s simulated), and the capability map of
400 orientations (``control.torque_capability``). Then (unless ``--no-mom``) the time to build the iron torque
map by the method of moments (factorising a core and the pair table), time per orientation of the map against the
air-core map, and the FEM time per solve (read from data/iron_fem.csv, written by scripts/fem_iron.py on the same
machine: a FEM solve takes minutes and is not repeated here).

Cold (issue 28 §3, first; ``--cold-only`` runs only this): a new design's own model (``design_model``, coupled)
ready in a fresh process — the import, the model and its first ``E + τ`` with a coil on — for the prototype, the
prototype with a 0.95-in magnet (the shape table) and with every length ×1.5 (the scaling law), each in its own
subprocess with numba's on-disk cache warm (an unrecorded run first fills it), and the prototype once more with an
empty numba cache (a first run after installing: every kernel compiled). Wall and CPU seconds, with the load.

Run: ``OPENBLAS_NUM_THREADS=1 nice -n 5 .venv/bin/python benchmarks/bench_iron.py [--level 0] [--no-mom]
[--cold-only]`` (level 0 keeps the factorisation to a few minutes on a loaded machine; the default map uses level
1); ``--json PATH`` also stores the numbers for ``scripts/docs_numbers.py``.
"""

from __future__ import annotations

import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

from _record import Record
from _timing import median_seconds
from spherestep import so3
from spherestep.magnetics import _iron as iron
from spherestep.magnetics._ironforce import pair_tables
from spherestep.magnetics import iron_model, torque_map
from spherestep.magnetics._ironmap import read_table
from spherestep.motor import prototype
from spherestep.motor.coil import iron_coil

RECORD = Record("iron", argv=[])  # the run's record; from sys.argv (``--json PATH``) when run as a script


def model_timings() -> None:
    """The pairwise and the coupled model, side by side (module docstring)."""
    from bench_dynamics import speed

    from spherestep._fast.terms import terms_evaluate, workspace
    from spherestep.control import torque_capability
    from spherestep.dynamics import tune
    from spherestep.magnetics import _coupling, design_model
    from spherestep.motor import coil_currents

    design = prototype()
    states = design.states()
    c = coil_currents(states.coils(0), len(design.stator))
    rng = np.random.default_rng(0)
    R = so3.random(20, rng)
    pair = design_model(design, coupling=False)
    own = design_model(design)  # the coupled model: its tables are built on first use
    own.model.torque(R[0], c)  # (numba's functions loaded)
    _coupling._TABLES.clear()
    t0 = time.perf_counter()
    own = design_model(design)
    own.model.torque(R[0], c)
    build = time.perf_counter() - t0
    t0 = time.perf_counter()
    own.model.coupling._coupling_table()
    rebuild = time.perf_counter() - t0
    k = iter(range(10 ** 9))

    def one(model):
        i = next(k) % len(R)
        model.evaluate(R[i], c, 1)

    def exact(model):
        i = next(k) % len(R)
        model.exact_energy(R[i], c), model.exact_torque(R[i], c)

    packed = own.model.packed_terms(c)
    tau, H = np.empty(3), np.empty((3, 3))
    work, near = workspace(packed.poles)
    C = np.ascontiguousarray(packed.C)

    def compiled():
        i = next(k) % len(R)
        terms_evaluate(packed.params, packed.offsets, R[i], packed.coils, C, packed.poles, packed.P, packed.signs, 1,
                       tau, H, work, near)

    t_pair = median_seconds(200, one, pair.model)
    t_exact = median_seconds(10, exact, own.model)
    t_own = median_seconds(200, one, own.model)
    t_packed = median_seconds(2000, compiled)
    R0 = so3.exp(np.radians([3.0, 0.0, 0.0])) @ states.rotations[0]
    rows = []
    for name, dm in (("pairwise", pair), ("coupled (tables)", own)):
        tuning = tune(design, dm.model)
        factor = speed(dm.model, tuning.rotor, tuning.dt, R0, c)
        t0 = time.perf_counter()
        torque_capability(design, dm.model, dm.limits, samples=400, seed=0)
        rows.append((name, tuning.dt, factor, time.perf_counter() - t0))
    print(f"# bench_iron (model) {datetime.datetime.now().isoformat(timespec='minutes')} "
          f"load {os.getloadavg()[0]:.1f} ({own.label})")
    print("| what | time | ratio |")
    print("|---|---|---|")
    print(f"| E + τ, one orientation, pairwise (compiled sums) | {1e6 * t_pair:.0f} µs | 1 |")
    print(f"| E + τ, one orientation, coupled, NumPy sums | {1e6 * t_exact:.0f} µs | {t_exact / t_pair:.0f} × |")
    print(f"| E + τ, one orientation, coupled, tables (model call) | {1e6 * t_own:.0f} µs | "
          f"{t_own / t_pair:.2f} × |")
    print(f"| E + τ, one orientation, coupled, tables (packed compiled call) | {1e6 * t_packed:.1f} µs | "
          f"{t_packed / t_pair:.3f} × |")
    print(f"| coupled tables: cold build (first use; of which G on its grid) | {build:.1f} s ({rebuild:.1f} s) | |")
    for name, dt, factor, _ in rows:
        print(f"| dynamics, {name}, tuned dt {1e3 * dt:.2f} ms | {factor:.1f} × real time | |")
    for name, *_, cap in rows:
        print(f"| capability map, 400 orientations, {name} | {cap:.1f} s | |")
    RECORD.put("model", {"label": own.label, "E+tau pairwise us": 1e6 * t_pair, "E+tau coupled numpy us": 1e6 * t_exact,
                         "E+tau coupled tables us": 1e6 * t_own, "E+tau coupled packed us": 1e6 * t_packed,
                         "tables cold build s": build, "coupling grid s": rebuild,
                         "rows": [{"model": name, "dt ms": 1e3 * dt, "x real time": factor, "capability s": cap}
                                  for name, dt, factor, cap in rows]})


COLD_CODE = """
import json, os, sys, time
w0, c0 = time.perf_counter(), time.process_time()
import numpy as np
from dataclasses import replace
from spherestep.magnetics import design_model, scaled_design
from spherestep.motor import prototype
w1, c1 = time.perf_counter(), time.process_time()
p = prototype()
d = {"prototype": p, "magnet 0.95 in": replace(p, magnet_diameter=0.95 * 0.0254, name="magnet 0.95 in"),
     "x1.5": scaled_design(p, 1.5)}[sys.argv[1]]
own = design_model(d)
c = np.zeros(len(d.stator))
c[0] = 1.0
E, tau = own.model.evaluate(np.eye(3), c, 1)
w2, c2 = time.perf_counter(), time.process_time()
print(json.dumps({"label": own.label, "import s": w1 - w0, "model s": w2 - w1, "total s": w2 - w0,
                  "import cpu s": c1 - c0, "model cpu s": c2 - c1, "total cpu s": c2 - c0,
                  "load": os.getloadavg()[0]}))
"""


def cold_timings() -> None:
    """A new design's own model in a fresh process (module docstring): one subprocess per row."""
    import json
    import subprocess
    import tempfile

    rows = []
    cases = [("prototype", "warm-up"), ("prototype", None), ("magnet 0.95 in", None), ("x1.5", None),
             ("prototype", "empty")]
    for name, cache in cases:
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
        with tempfile.TemporaryDirectory() as empty:
            if cache == "empty":
                env["NUMBA_CACHE_DIR"] = empty
            out = subprocess.run([sys.executable, "-c", COLD_CODE, name], env=env, capture_output=True, text=True,
                                 check=True)
        row = json.loads(out.stdout.strip().splitlines()[-1])
        row.update({"design": name, "numba cache": cache or "warm"})
        if cache != "warm-up":
            rows.append(row)
    print(f"# bench_iron (cold) {datetime.datetime.now().isoformat(timespec='minutes')} "
          f"load {os.getloadavg()[0]:.1f}")
    print("| design (numba cache) | model | import | import + model (wall) | CPU | load |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['design']} ({r['numba cache']}) | {r['label']} | {r['import s']:.1f} s | {r['total s']:.1f} s | "
              f"{r['total cpu s']:.1f} s | {r['load']:.1f} |")
    RECORD.put("cold", rows)


def main() -> None:
    cold_timings()
    if "--cold-only" in sys.argv:
        return
    model_timings()
    if "--no-mom" in sys.argv:
        return
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
    RECORD.put("mom", {"level": level, "cells": len(solver.cells), "factorise s": t1 - t0, "per angle s": per_angle,
                       "iron map 1000 ms": 1e3 * t_iron, "air map 1000 ms": 1e3 * t_air,
                       "iron map one us": 1e6 * one_iron, "air map one us": 1e6 * one_air})
    if fem is not None:
        solve = float(np.median(fem[:, 6]))
        mesh = float(np.median(fem[:, 5]))
        RECORD.values["mom"].update({"fem mesh s": mesh, "fem solve s": solve})
        print(f"| FEM (NGSolve): mesh one angle | {mesh:.1f} s | |")
        print(f"| FEM (NGSolve): one solve | {solve:.1f} s | {solve / per_angle:.0f} × MoM per angle; "
              f"{solve / one_iron:.2g} × iron map per orientation |")


if __name__ == "__main__":
    RECORD = Record("iron")  # --json PATH: what this run measured, for scripts/docs_numbers.py
    main()
    RECORD.write()
