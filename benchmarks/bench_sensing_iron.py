"""Sensing on the iron prototype: the cores' field model (spherestep.sensing.iron) against the direct solves, its
cost per estimator update, and what ignoring the cores costs, static and in the servo loop (``--sensor hall``).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_sensing_iron.py [--quick]``. Times are medians
of repeated calls (``_timing.median_seconds``); errors are geodesic angles in degrees. The direct references are
``src/spherestep/data/sensing_iron_reference.csv`` (``scripts/sensing_iron_table.py reference``).
"""

from __future__ import annotations

import datetime
import math
import os
import platform
import sys
import time
from importlib import resources

import numpy as np

from _timing import median_seconds
from spherestep import so3
from spherestep.motor import prototype
from spherestep.sensing import HallSensor, default_array, iron

QUICK = "--quick" in sys.argv


def model_accuracy(design, array):
    print("\n## The cores' field against direct method-of-moments solves (whole rotor, 3 orientations, 24 sensors)")
    path = resources.files("spherestep.data") / "sensing_iron_reference.csv"
    rows = np.array([[float(v) for v in line.split(",")] for line in
                     [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")][1:]])[:, 2:]
    rows = rows.reshape(3, 24, 15)
    alone, ref, ind, first, joint = (rows[..., 3 * i:3 * i + 3] for i in range(5))
    core, _ = iron.iron_fields(design, array.positions)
    rotor = iron.FieldTable.build(design, array.positions)
    R = so3.random(3, 26)
    model = core.field(R)
    err = model - ref
    total = rotor.field(R) + ref
    print("| compared | max |ΔB| (µT) | RMS ΔB (µT) | relative RMS (of the cores' field) | of the total field |")
    print("|---|---|---|---|---|")
    print(f"| stored table vs direct (29 cores, coupled) | {np.abs(err).max() * 1e6:.2f} | "
          f"{np.sqrt(np.mean(err ** 2)) * 1e6:.2f} | {np.sqrt(np.sum(err ** 2) / np.sum(ref ** 2)):.2e} | "
          f"{np.sqrt(np.sum(err ** 2) / np.sum(total ** 2)):.2e} |")
    for name, d, base in (("direct: coupled vs each core alone (the coupling's size)", ref - alone, ref),
                          ("2 cores nearest sensor 8: one moment system vs each alone", joint - ind, joint),
                          ("2 cores nearest sensor 8: one moment system vs dipole coupling", joint - first, joint)):
        print(f"| {name} | {np.abs(d).max() * 1e6:.2f} | {np.sqrt(np.mean(d ** 2)) * 1e6:.2f} | "
              f"{np.sqrt(np.sum(d ** 2) / np.sum(base ** 2)):.2e} | — |")
    hall = HallSensor(design, array, noise_T=1e-12)
    worst = 0.0
    for k, Rk in enumerate(R):  # noiseless readings from the direct field (+ the 2-core higher orders): model error
        B = rotor.field(Rk) + ref[k] + (joint[k] - first[k])
        m = np.einsum("sji,sj->si", array.axes, B)
        worst = max(worst, so3.distance(hall.estimator.solve(m, Rk).R, Rk))
    print(f"orientation error from the model's error alone (noiseless readings of the direct field, 3 orientations):"
          f" worst {math.degrees(worst):.5f}°")
    print(f"cores' field at the sensors: max {np.abs(ref).max() * 1e3:.2f} mT, RMS {np.sqrt(np.mean(ref ** 2)) * 1e3:.2f}"
          f" mT; rotor's own: max {np.abs(rotor.field(R)).max() * 1e3:.1f} mT")
    coils = iron.IronCoilField.build(design, array.positions).per_coil
    from spherestep.sensing import CoilField

    air = CoilField.build(design, array.positions).per_coil
    print(f"coils per unit current at the sensors: iron (winding + own core) max {np.abs(coils).max() * 1e3:.2f} mT, "
          f"air-core model max {np.abs(air).max() * 1e3:.2f} mT")


def timing(design, array):
    print("\n## Time per call (median, one orientation, 24 sensors)")
    on = HallSensor(design, array, seed=2)
    off = HallSensor(design, array, seed=2, cores=False)
    rng = np.random.default_rng(2)
    R = so3.random(1, rng)[0]
    c = np.zeros(len(design.stator))
    c[[1, 5, 9, 20]] = [1, -1, 1, -1]
    m = on.readings(R, c)
    R_prev = so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8])) @ R
    core = on.core_field
    rows = [("rotor table: field + Jacobian", lambda: on.rotor_table.field_and_jacobian(R)),
            ("cores: field", lambda: core.field(R)),
            ("cores: field + Jacobian", lambda: core.field_and_jacobian(R)),
            ("update without the cores (track, 1 Gauss–Newton step)", lambda: off.estimator.track(m, R_prev, c)),
            ("**update with the cores (track, 1 Gauss–Newton step)**", lambda: on.estimator.track(m, R_prev, c))]
    print("| call | median (µs) | rate (1/s) |\n|---|---|---|")
    for name, f in rows:
        t = median_seconds(30 if QUICK else 200, f)
        print(f"| {name} | {t * 1e6:.0f} | {1 / t:,.0f} |")


def static_error(design, array):
    n = 40 if QUICK else 200
    print(f"\n## Estimation error, {n} Haar-random orientations (noise 0.1 mT, 4 coils on at ±1, 1 % current error;"
          " LM from 0.06° off, readings hold rotor + cores + iron coils)")
    c = np.zeros(len(design.stator))
    c[[1, 5, 9, 20]] = [1, -1, 1, -1]
    print("| estimator | RMS (°) | worst (°) |\n|---|---|---|")
    for label, cores in (("models the cores (default on iron)", True), ("ignores the cores (`cores=False`)", False)):
        s = HallSensor(design, array, current_error=0.01, seed=4, cores=cores)
        errs = []
        for R in so3.random(n, 7):
            R0 = so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8])) @ R
            errs.append(so3.distance(s.estimator.solve(s.readings(R, c), R0, c).R, R))
        e = np.degrees(errs)
        print(f"| {label} | {np.sqrt(np.mean(e ** 2)):.4f} | {e.max():.4f} |")


def in_the_loop(design):
    from spherestep.control import Trajectory, plan_turn
    from spherestep.drive.turn import Turn, choose_model
    from spherestep.dynamics import Rotor, simulate_servo

    chosen = choose_model(design)
    axis, angle = np.array([1.0, 0.0, 0.0]), math.radians(90.0)
    job = Turn(design, axis, angle, chosen)
    rotor = Rotor.from_design(design)
    turn = plan_turn(chosen.model, job.start, axis, angle, rotor.inertia, chosen.limits, damping=rotor.damping)
    runs = [("90° turn about x (the drive's fastest)", turn, 0.5)]
    if not QUICK:
        runs.append(("hold at the turn's start", Trajectory.hold(job.start), 0.5))
    print(f"\n## In the loop: the servo on the iron model ({chosen.label}) with the Hall array, 1 kHz, 1 % current "
          "error (the drive's `--sensor hall`)")
    warm = HallSensor(design, current_error=0.01, seed=0, rate=1000.0, start=job.start)  # compile and cache first
    simulate_servo(design, Trajectory.hold(job.start), chosen.model, limits=chosen.limits, rotor=rotor, sensor=warm,
                   settle=0.05)
    print("| run | estimator | sensor error RMS (°) | worst (°) | tracking max (°) | final (°) | s per simulated s |")
    print("|---|---|---|---|---|---|---|")
    for name, traj, settle in runs:
        for label, cores in (("cores modelled", True), ("cores ignored", False)):
            sensor = HallSensor(design, current_error=0.01, seed=0, rate=1000.0, start=traj.start, cores=cores)
            t0 = time.perf_counter()
            run = simulate_servo(design, traj, chosen.model, limits=chosen.limits, rotor=rotor, sensor=sensor,
                                 settle=settle)
            wall = time.perf_counter() - t0
            e = np.degrees(so3.distance(run.estimates, run.orientations))
            final = np.degrees(so3.distance(run.orientations[-1], traj.end))
            print(f"| {name} | {label} | {np.sqrt(np.mean(e ** 2)):.4f} | {e.max():.4f} | "
                  f"{np.degrees(run.tracking_error.max()):.4f} | {final:.4f} | {wall / run.times[-1]:.1f} |")


def main():
    design = prototype()
    array = default_array(design)
    print(f"# bench_sensing_iron — {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, "
          f"{platform.machine()}, {os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}, Python "
          f"{platform.python_version()}")
    t0 = time.perf_counter()
    iron.iron_fields(design, array.positions)
    print(f"stored table read and prefiltered in {time.perf_counter() - t0:.2f} s")
    model_accuracy(design, array)
    timing(design, array)
    static_error(design, array)
    in_the_loop(design)


if __name__ == "__main__":
    main()
