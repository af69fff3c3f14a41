"""The servo against a plant it does not know exactly (issue 25 §2): the table of mismatch cases on the iron
prototype, with and without the disturbance observer, side by side in one run.

For each case of :data:`spherestep.magnetics.mismatch.MISMATCH_CASES` (controller = the design's own model, the
coupled iron model; plant = that model with the winding ×0.85/×1.15, the detent ×0.8/×1.2, both ×0.85/×1.2, or
the rotor's shell 0.3 mm thinner/thicker; and the pairwise model as the controller against the coupled plant)
:func:`spherestep.dynamics.robustness.robustness_row`: 20 holds of random orientations (seed 0), each judged over
1.0–1.2 s, and the demo's 360° turn about (1, 0.5, 2) from the stepper state nearest the identity planned by
``plan_turn`` on the pairwise model within the robust margin (``MARGIN`` = 0.7: the coupled model is refused
within it; then, apart, with plan_turn's default 0.9 on the controller's model, the fastest turn), 0.5 s of
settling, 0.02° sensor noise. Targets: every hold and the turn's end within 0.05°, the turn's tracking error
≤ 0.5°, mean power ≤ 100 W. Then the exact model (plant = model) for reference, and the coupled plant's
surrogate error against the full coupled model.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_servo_robust.py [--holds N] [--cases "a;b"] [--quick]
[--json F]`` (about 10 minutes at load 1; the coupled plant's rows take the longest: its anchors cost 7
coupled-model evaluations each). ``--controller pairwise``: every case with the pairwise model as the controller
(the table before 2026-11-26 04:00 UTC).
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import time
from dataclasses import replace

import numpy as np

from spherestep import so3
from spherestep.control.trajectory import MARGIN
from spherestep.dynamics.robustness import robustness_row, turn_run
from spherestep.magnetics.mismatch import MISMATCH_CASES, CoupledPlant, MismatchCase
from spherestep.motor import prototype


def coupled_surrogate_error(design, offsets_deg=(0.5, 1.0, 1.5), count: int = 3, seed: int = 1) -> dict:
    """Largest |Δ_plant − Δ_full| (N·m) at ``offsets_deg`` from an anchor, with |Δ| for scale."""
    from spherestep.magnetics import iron_model

    plant = CoupledPlant(iron_model(design, coupling=True))
    rng = np.random.default_rng(seed)
    out = {}
    scale = 0.0
    for A in so3.random(count, seed):
        plant.torque(A, np.zeros(plant.coil_count))  # the anchor
        scale = max(scale, float(np.linalg.norm(plant.coupling_torque(A))))
        for off in offsets_deg:
            v = rng.normal(size=3)
            R = so3.exp(math.radians(off) * v / np.linalg.norm(v)) @ A
            approx = plant.torque(R, np.zeros(plant.coil_count)) - plant.pairwise.torque(R, np.zeros(plant.coil_count))
            out[off] = max(out.get(off, 0.0), float(np.linalg.norm(approx - plant.coupling_torque(R))))
    return {"max_coupling_torque_Nm": scale, "error_Nm_at_deg": out}


def hold_reach(design, cases, holds: int, seed: int = 0) -> None:
    """Which of the table's hold orientations the *plant* can hold at all within the limits
    (:func:`spherestep.dynamics.robustness.plant_can_hold`): the holds no controller can meet."""
    from spherestep.dynamics.robustness import plant_can_hold
    from spherestep.magnetics import design_model

    limits = design_model(design).limits
    targets = so3.random(holds, seed)
    print("# holds the plant itself can reach (zero torque within the limits)")
    for case in cases:
        plant, _ = case.build(design)
        missing = []
        for k, R in enumerate(targets):
            reachable, unmet = plant_can_hold(plant, R, limits)
            if not reachable:
                missing.append(f"#{k} ({unmet:.3f} N·m unmet)")
        print(f"{case.name:>28} | {holds - len(missing)}/{holds} reachable" +
              (f"; not: {', '.join(missing)}" if missing else ""), flush=True)


def fast_plan(design, cases) -> None:
    """The same turn planned with ``plan_turn``'s default margin (``TURN_MARGIN`` = 0.9, the fastest turn of §3)
    on each case, the observer on: what the speed costs in robustness (printed; the ``--json`` rows are the
    table's)."""
    from spherestep.dynamics import Rotor
    from spherestep.magnetics import design_model

    limits, rotor = design_model(design).limits, Rotor.from_design(design)
    print("# the fastest plan (plan_turn's default margin), observer on")
    for case in cases:
        plant, model = case.build(design)
        t0 = time.process_time()
        traj, run = turn_run(design, plant, model, limits, rotor)
        s = run.summary()
        print(f"{case.name:>28} | T {traj.duration:.3f} s  final {math.degrees(s.final_error):.4f}°  max track "
              f"{math.degrees(s.max_tracking_error):.3f}°  P {s.mean_power:.1f} W  reach {s.reachable_fraction:.3f}"
              f"  CPU {time.process_time() - t0:.0f} s", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--holds", type=int, default=20)
    ap.add_argument("--cases", default="", help="case names separated by ;")
    ap.add_argument("--quick", action="store_true", help="4 holds, no coupled plant")
    ap.add_argument("--json", default="")
    ap.add_argument("--no-fast", action="store_true", help="skip the turns planned with plan_turn's default margin")
    ap.add_argument("--reach-only", action="store_true", help="only which holds the plants can reach (no runs)")
    ap.add_argument("--controller", choices=("coupled", "pairwise"), default="coupled",
                    help="pairwise: every case with the pairwise model as the controller (module docstring)")
    args = ap.parse_args()
    print(f"# bench_servo_robust  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}", flush=True)
    design = prototype()
    holds = 4 if args.quick else args.holds
    cases = list(MISMATCH_CASES) + [MismatchCase("exact model")]
    if args.controller == "pairwise":
        cases = [replace(c, controller="pairwise") for c in cases]
    if args.cases:
        wanted = set(args.cases.split(";"))
        cases = [c for c in cases if c.name in wanted]
    if args.quick:
        cases = [c for c in cases if not c.coupling]
    if args.reach_only:
        hold_reach(design, cases, holds)
        return
    head = (f"{'case':>28} | {'observer':>8} {'holds ok':>8} {'worst hold°':>11} {'T s':>6} {'final°':>8} "
            f"{'max track°':>10} {'P W':>6} {'reach':>6} {'pass':>5} {'CPU s':>6}")
    print(head)
    print("-" * len(head))
    rows = []
    for case in cases:
        for label, wd in (("off", 0.0), ("on", None)):
            t0 = time.process_time()
            row = robustness_row(design, case, holds=holds, disturbance_bandwidth=wd, margin=MARGIN)
            cpu = time.process_time() - t0
            d = row.to_dict()
            rows.append({"observer": label, **d})
            print(f"{case.name:>28} | {label:>8} {d['holds_within']:>4}/{d['holds']:<3} {d['worst_hold_deg']:>11.4f} "
                  f"{d['turn_time_s']:>6.3f} {d['final_error_deg']:>8.4f} {d['max_tracking_error_deg']:>10.3f} "
                  f"{d['mean_power_W']:>6.1f} {d['reachable_fraction']:>6.3f} {'yes' if row.passed else 'NO':>5} "
                  f"{cpu:>6.0f}", flush=True)
    hold_reach(design, cases, holds)
    if not args.no_fast:
        fast_plan(design, cases)
    if not args.quick and not args.cases:
        err = coupled_surrogate_error(design)
        print(f"# coupled plant: coupling torque up to {err['max_coupling_torque_Nm']:.3f} N·m; first-order surrogate "
              "error " + ", ".join(f"{v:.4f} N·m at {k:g}°" for k, v in err["error_Nm_at_deg"].items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
