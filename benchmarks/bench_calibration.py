"""Calibration of the iron prototype's torque model against mismatched plants (issue 26 §1): the full table.

The controller's model is the design's own (``design_model``: iron, coupled, FEM table). The plants, the motor as
built (each an :class:`~spherestep.magnetics.IronTorqueMap`, so each can also be the exact controller):

* winding ×0.85 / ×1.15, detent ×0.8 / ×1.2 (and both ×0.85, ×1.2): the coupled model's pair tables scaled
  (``magnetics.mismatch.scaled_model``; the cores' coupling as modelled);
* shell −0.3 / +0.3 mm: the shell's pair tables (``magnetics.mismatch.shell_model``) with the coupling as modelled;
* coupled plant: the plant is the coupled model (the validated one: the motor as built), the controller and the
  calibration start from the pairwise model (``design_model(design, coupling=False)``), which misses the coupling;
* pairwise plant: the reverse (the plant without the coupling, the controller on the coupled model).

The fit has the coupling's gain as a parameter on every plant (``calibrate(..., coupling=True)``; by default only
a pairwise model's is fitted).

Per plant: ``drive.collect_holds`` on the simulated plant (the servo on the controller's model, 1 kHz, a random
walk of 25° moves), ``control.calibrate``, then

* the model's relative RMS torque error against the plant at 200 held-out random orientations with random currents
  (``control.torque_error``), before and after, and their ratio;
* the demo's 360° turn about (1, 0.5, 2) from the stepper state nearest the identity, on two plans made by
  ``control.plan_turn``: the fastest on the design's own model (the demo's, 1.47 s) and the robustness table's
  within ``MARGIN`` = 0.7 (2.27 s; on the pairwise model, as the coupled one is refused within it); each simulated at 1 kHz on the plant with the servo on the controller's model (before), on
  the calibrated one (after) and on the plant itself (exact: the plan's own tracking error); max tracking error.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_calibration.py [--holds 60] [--plants "a;b"] [--quick]
[--json data/calibration_table.json]`` (``--quick``: 12 holds, no turn). Holds are cached in
``$TMPDIR/spherestep-bench-calibration`` by plant and count.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import math
import os
import pickle
import platform
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from spherestep.commutation import turn_targets
from spherestep.control import calibrate, plan_turn, torque_error
from spherestep.drive import collect_holds
from spherestep.control.trajectory import MARGIN
from spherestep.dynamics import Rotor, simulate_servo
from spherestep.magnetics import design_model
from spherestep.magnetics.mismatch import scaled_model, shell_model
from spherestep.motor import prototype

AXIS = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])
VERSION = "v4"  # the holds' cache: bump when the plants or the collection change
PLANS = (("fastest", None), ("margin", MARGIN))  # plan_turn's default (the demo's) and the robustness table's


def plants(design) -> dict:
    """``{name: (plant, controller_model)}`` (module docstring)."""
    coupled = design_model(design).model
    pairwise = design_model(design, coupling=False).model
    out = {f"winding ×{s:g}": (scaled_model(coupled, winding=s), coupled) for s in (0.85, 1.15)}
    out.update({f"detent ×{s:g}": (scaled_model(coupled, detent=s), coupled) for s in (0.8, 1.2)})
    out["winding ×0.85, detent ×1.2"] = (scaled_model(coupled, winding=0.85, detent=1.2), coupled)
    out["coupled plant (controller pairwise)"] = (coupled, pairwise)
    out["pairwise plant (controller coupled)"] = (pairwise, coupled)
    for mm in (-0.3, 0.3):
        out[f"shell {mm:+g} mm"] = (replace(shell_model(design, mm * 1e-3), coupling=coupled.coupling), coupled)
    return out


def turn(design, controller, plant, limits, traj) -> tuple[float, float]:
    """Max and final tracking error (rad) of ``traj`` on ``plant`` with the servo on ``controller`` (1 kHz)."""
    run = simulate_servo(design, traj, plant, limits=limits, controller_model=controller, settle=0.3)
    return float(np.max(run.tracking_error)), float(run.tracking_error[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--holds", type=int, default=60)
    ap.add_argument("--plants", default="")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-turn", action="store_true")
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    holds_n = 12 if args.quick else args.holds
    design = prototype()
    own = design_model(design)
    model, limits = own.model, own.limits
    cache = Path(tempfile.gettempdir()) / "spherestep-bench-calibration"
    cache.mkdir(exist_ok=True)
    cases = plants(design)
    chosen = [p.strip() for p in args.plants.split(";") if p.strip()] or list(cases)
    start = turn_targets(design, AXIS, 2 * math.pi, steps=1)[0]
    inertia = Rotor.from_design(design).inertia
    # the fastest plan on the design's (coupled) model; within MARGIN the coupled model refuses the turn (the
    # coils cannot brake against its detent), so that plan is the robustness table's, on the pairwise model
    planner = {"fastest": model, "margin": design_model(design, coupling=False).model}
    trajs = {} if args.quick or args.no_turn else {
        k: plan_turn(planner[k], start, AXIS, 2 * math.pi, inertia, limits, margin=m) for k, m in PLANS}
    load = os.getloadavg()
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    print(f"# bench_calibration {stamp} {platform.machine()} {os.cpu_count()} CPUs, load {load[0]:.1f}; "
          f"{holds_n} holds per plant; the design's model: {own.label}")
    for k, traj in trajs.items():
        print(f"# plan '{k}' on the design's model: {traj.duration:.3f} s")
    rows = []
    head = "| plant | holds (s) | torque error before → after (ratio) | scales (detent, winding) |"
    head += "".join(f" {k} plan: before / after / exact |" for k in trajs)
    print(head + "\n|" + "---|" * (4 + len(trajs)), flush=True)
    for name in chosen:
        plant, ctrl = cases[name]
        key = cache / f"{hashlib.sha1(f'{VERSION}{name}'.encode()).hexdigest()[:12]}_{holds_n}.pkl"
        t0 = time.perf_counter()
        if key.is_file():  # the holds and the time their collection took, measured when they were collected
            holds, collect = pickle.loads(key.read_bytes())
        else:
            holds = collect_holds(design, plant, holds_n, model=ctrl, limits=limits)
            collect = time.perf_counter() - t0
            key.write_bytes(pickle.dumps((holds, collect)))
        t0 = time.perf_counter()
        cal = calibrate(design, ctrl, holds, coupling=True, gains=False, turns=False, held_out=False)  # issue 26: the
        # tables and the coupling gain alone, every hold fitted (the per-coil terms: bench_identification.py)
        fit = time.perf_counter() - t0
        e0 = torque_error(ctrl, plant, count=200)
        e1 = torque_error(cal.model, plant, count=200)
        row = {"plant": name, "holds": len(holds), "collect_s": collect, "fit_s": fit,
               "torque_error_before": e0, "torque_error_after": e1, "ratio": e0 / e1,
               "scale_detent": cal.scale_detent, "scale_winding": cal.scale_winding,
               "scale_std": list(cal.scale_std), "coupling_gain": cal.coupling_gain if cal.coupling else None,
               "coupling_std": cal.coupling_std, "consistent": cal.consistent,
               "residual_before_Nm": cal.residual_before, "residual_after_Nm": cal.residual_after,
               "unseen": list(cal.unseen), "turn": {}}
        cells = []
        for k, traj in trajs.items():
            res = {w: turn(design, c, plant, limits, traj)
                   for w, c in (("before", ctrl), ("after", cal.model), ("exact", plant))}
            row["turn"][k] = {"duration_s": traj.duration, **{f"{w}_max_deg": math.degrees(v[0])
                                                              for w, v in res.items()},
                              **{f"{w}_final_deg": math.degrees(v[1]) for w, v in res.items()}}
            cells.append(" / ".join(f"{math.degrees(res[w][0]):.3f}°" for w in ("before", "after", "exact")))
        rows.append(row)
        print(f"| {name} | {len(holds)} ({collect:.0f}) | {e0:.4f} → {e1:.4f} ({e0 / e1:.0f}×) | "
              f"{cal.scale_detent:.3f}±{cal.scale_std[0]:.3f}, {cal.scale_winding:.3f}±{cal.scale_std[1]:.3f} |"
              + "".join(f" {c} |" for c in cells), flush=True)
        print("  " + cal.summary().replace("\n", "\n  "), flush=True)
    if args.json:
        out = {"measured": stamp, "load": [round(x, 2) for x in load], "holds": holds_n,
               "controller": own.label, "axis": [1.0, 0.5, 2.0],
               "plans": {k: {"margin": m, "duration_s": trajs[k].duration, "planned_on": "pairwise" if k == "margin"
                         else "coupled"} for k, m in PLANS if k in trajs},
               "rows": rows, "load_after": [round(x, 2) for x in os.getloadavg()]}
        Path(args.json).write_text(json.dumps(out, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
