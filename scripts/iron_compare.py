"""What the validated whole-motor iron model changes (issue 28 §4): the prototype on the pairwise model (pole–core
pair tables summed) beside the coupled one (pairs + the cores' coupling, within 3.4 % of the patch FEM; the design's
own model), measured the same way on each:

* unpowered: equilibria with every coil off from 12 Haar-random starts (seed 0): minima, median holding torque
  (:func:`spherestep.statics.holding_torque`);
* stepper states: 12 sampled geometric states with their coils on at nominal current, the equilibrium each model
  rests at: minima, median and largest distance (of the minima) from the geometric state, median holding torque
  (these two from :func:`spherestep.magnetics.iron_summary` with ``model=`` the model compared);
* capability: the torque available in every direction at 400 random orientations (median, 5th percentile;
  :func:`spherestep.control.torque_capability` with the design's limits);
* the demo's servo turn (360° about (1, 0.5, 2), the fastest plan on that model, ideal sensor).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/iron_compare.py [--json data/iron_compare.json]

prints the markdown table of docs/magnetics.md, "Pairwise against the validated model" (the renderer is
``docs_numbers.iron_compare_table``; ``python scripts/docs_numbers.py iron`` runs this and rewrites the docs).
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

from spherestep.control import torque_capability
from spherestep.drive import drive_turn
from spherestep.magnetics import design_model, iron_summary
from spherestep.motor import prototype

from docs_numbers import iron_compare_table  # scripts/, beside this file


def measure(design, coupling: bool, seed: int = 0) -> dict:
    own = design_model(design, coupling=coupling)
    model = own.model
    iron = iron_summary(design, states=12, starts=12, seed=seed, model=model).to_dict(degrees=True)
    cap = torque_capability(design, model, own.limits, samples=400, seed=seed)
    run = drive_turn(design, (1.0, 0.5, 2.0), 2.0 * math.pi, mode="servo", model=model, limits=own.limits)
    return {"model": own.label, "unpowered_minima": iron["unpowered_minima"],
            "unpowered_starts": iron["unpowered_starts"],
            "unpowered_holding_median_Nm": iron["unpowered_holding_median_Nm"],
            "state_minima": iron["iron_states_minima"], "states": iron["states_sampled"],
            "state_offset_median_deg": iron["iron_offset_median_deg"],
            "state_offset_max_deg": iron["iron_offset_max_deg"],
            "state_holding_median_Nm": iron["iron_holding_median_Nm"],
            "capability_median_Nm": float(np.median(cap.radius)),
            "capability_p5_Nm": float(np.percentile(cap.radius, 5)),
            "servo_time_s": float(run.time), "servo_final_deg": math.degrees(run.final_error),
            "servo_tracking_deg": math.degrees(run.max_tracking_error), "servo_mean_W": float(run.mean_power)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="also store the measurements here")
    args = ap.parse_args()
    design = prototype()
    t = time.time()
    rows = {name: measure(design, coupling) for name, coupling in (("pairwise", False), ("coupled", True))}
    print(f"# iron_compare {time.strftime('%Y-%m-%dT%H:%M')} ({time.time() - t:.0f} s)")
    print(iron_compare_table(rows))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
