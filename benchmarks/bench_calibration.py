"""Calibration of the iron prototype's torque model against mismatched plants (issue 26 §1).

For each plant (winding ×0.85/×1.15, detent ×0.8/×1.2, the coupled model, and the shell plants when their tables
exist): ``control.collect_holds`` on the simulated plant (the servo on the design's own model, 250 Hz, a random walk
of 25° moves), ``control.calibrate``, then

* the model's relative RMS torque error against the plant at 200 held-out random orientations with random currents
  within the limits, before (the design's model) and after (the calibrated one), and their ratio;
* the demo's 360° turn about (1, 0.5, 2) from the stepper state nearest the identity, planned by
  ``control.plan_turn`` on the controller's model (the fixed 3 s turn where the planner refuses it), simulated at
  1 kHz on the plant with the controller on the design's model and on the calibrated one: max tracking error.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_calibration.py [--holds 40] [--plants "a;b"] [--quick]``
(``--quick``: 12 holds, no turn). Holds are cached in ``$TMPDIR/spherestep-bench-calibration`` by plant and count.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import math
import os
import pickle
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from spherestep.commutation import turn_targets
from spherestep.control import calibrate, collect_holds, plan_turn, torque_error
from spherestep.dynamics import Rotor, simulate_servo
from spherestep.errors import InputError
from spherestep.magnetics import design_model
from spherestep.magnetics.mismatch import MISMATCH_CASES, CoupledPlant
from spherestep.motor import prototype

AXIS = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])


def turn(design, controller, plant, limits, traj) -> float:
    """Max tracking error (rad) of ``traj`` on ``plant`` with the servo on ``controller`` (1 kHz)."""
    run = simulate_servo(design, traj, plant, limits=limits, controller_model=controller, settle=0.3)
    return float(np.max(run.tracking_error))


def planned(model, start, inertia, limits):
    """The demo's turn planned by ``plan_turn`` on ``model``, or None where the planner refuses it."""
    try:
        return plan_turn(model, start, AXIS, 2 * math.pi, inertia, limits)
    except InputError:
        return None


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--holds", type=int, default=40)
    ap.add_argument("--plants", default="")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-turn", action="store_true")
    args = ap.parse_args()
    holds_n = 12 if args.quick else args.holds
    design = prototype()
    own = design_model(design)
    model, limits = own.model, own.limits
    cache = Path(tempfile.gettempdir()) / "spherestep-bench-calibration"
    cache.mkdir(exist_ok=True)
    cases = {c.name: c for c in MISMATCH_CASES}
    chosen = [p.strip() for p in args.plants.split(";") if p.strip()] or list(cases)
    start = turn_targets(design, AXIS, 2 * math.pi, steps=1)[0]
    inertia = Rotor.from_design(design).inertia
    nominal_turn = None if args.quick or args.no_turn else planned(model, start, inertia, limits)
    print(f"# bench_calibration {datetime.date.today()} {platform.machine()} {os.cpu_count()} CPUs; "
          f"{holds_n} holds per plant")
    if nominal_turn is not None:
        base = turn(design, model, model, limits, nominal_turn)
        print(f"# the turn planned on the design's model ({nominal_turn.duration:.2f} s), plant = model: max tracking "
              f"error {math.degrees(base):.3f}°")
    print("| plant | holds | collect s | fit s | torque error before | after | ratio | scales (detent, winding) |"
          " turn max err before | after | turn planned on |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name in chosen:
        plant, _ = cases[name].build(design)
        truth = plant.coupled if isinstance(plant, CoupledPlant) else plant  # held-out: the exact coupled model
        key = cache / f"{hashlib.sha1(name.encode()).hexdigest()[:12]}_{holds_n}.pkl"
        t0 = time.perf_counter()
        if key.is_file():
            holds = pickle.loads(key.read_bytes())
            collect = float("nan")
        else:
            holds = collect_holds(design, plant, holds_n, model=model, limits=limits)
            collect = time.perf_counter() - t0
            key.write_bytes(pickle.dumps(holds))
        t0 = time.perf_counter()
        cal = calibrate(design, model, holds)
        fit = time.perf_counter() - t0
        e0 = torque_error(model, truth, count=200)
        e1 = torque_error(cal.model, truth, count=200)
        before = after = float("nan")
        which = "-"
        if nominal_turn is not None:
            before = turn(design, model, plant, limits, nominal_turn)
            traj = planned(cal.model, start, inertia, limits)
            which = "calibrated model" if traj is not None else "design's model (refused on the calibrated)"
            after = turn(design, cal.model, plant, limits, nominal_turn if traj is None else traj)
        print(f"| {name} | {len(holds)} | {collect:.0f} | {fit:.1f} | {e0:.4f} | {e1:.4f} | {e0 / e1:.1f}x | "
              f"{cal.scale_detent:.3f}±{cal.scale_std[0]:.3f}, {cal.scale_winding:.3f}±{cal.scale_std[1]:.3f} | "
              f"{math.degrees(before):.3f}° | {math.degrees(after):.3f}° | {which} |", flush=True)
        print("  " + cal.summary().replace("\n", "\n  "), flush=True)


if __name__ == "__main__":
    main()
