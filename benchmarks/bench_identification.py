"""Identification of the motor as built (issue 37 §4) on the emulated motor: one calibration per plant seed.

For each seed: the plant ``--plant-error`` (default the torque terms of ``realistic``: per-coil spread ±20 %, two
coils misplaced by 1°), ``--holds`` holds collected on the lockstep emulated motor (the servo on the design's own
model), the fit (tables, per-coil gains and placements, judged on every fifth hold held out), then:

* wall time of the collection and of the fit (the calibration's ≤ 3 min target is their sum);
* the torque error at 200 random orientations and currents (``control.torque_error``, seed 1: none of them fitted)
  of the design's model and of the calibrated one (target ≥ 10× lower);
* each live coil's gain error: the calibrated ``K(R)``'s column against the plant's, ``Σ K_fit·K_plant / Σ
  K_plant²`` over 50 random orientations (target within 3 %) — the torque the coil gives, whatever the
  parameterisation;
* ``--check-holds`` holds on the plant with the calibrated model (``servo_session`` on ``Trajectory.hold`` for 1.5 s
  from 0.5° away, the truth at the loop's last cycle; target 20 of 20 within 0.05°);
* the same holds fitted without the per-coil terms (gains and placements): the verdict (target: refused, naming the
  per-coil spread).

``--part saturation`` (or ``all``): the plant with its windings saturating too (``saturation=`` ``--knee``, per unit:
each winding's torque ``knee tanh(c/knee)``; the holds' currents reach 0.5–0.95 per unit, RMS 0.27), the full fit
(tables, gains, placements) and its diagnosis (target: refused, naming saturation with the knee its refit finds).

Seeds: ``--tune-seed`` (the one the thresholds were looked at on) and ``--seeds`` (held out). JSON with ``--json``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from dataclasses import replace

import numpy as np

from spherestep import so3
from spherestep.control import Trajectory, hold_orientations, torque_error
from spherestep.control.identify import calibrate, diagnose
from spherestep.drive import Emulated, collect_holds
from spherestep.drive.plant import PlantError
from spherestep.drive.session import servo_session
from spherestep.magnetics import design_model
from spherestep.motor import prototype
from spherestep.sensing import default_array

TORQUE_TERMS = "winding-spread=0.2,coil-offset=1,misplaced=2"


def gain_errors(model, plant, count: int = 50, seed: int = 4) -> np.ndarray:
    """Per live coil ``Σ K_fit·K_plant / Σ K_plant² − 1`` over ``count`` random orientations (dead coils: nan)."""
    R = so3.random(count, seed)
    Kp, Kf = np.asarray(plant.torque_matrix(R)), np.asarray(model.torque_matrix(R))
    den = np.sum(Kp * Kp, axis=(0, 1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.sum(Kf * Kp, axis=(0, 1)) / den - 1.0
    out[den < 1e-12 * den.max()] = np.nan
    out[list(plant.failed)] = np.nan
    return out


def true_holds(design, model, limits, error, plant, count: int, seed: int, array_cal=None) -> list[float]:
    """``count`` holds on the emulated ``plant`` with the servo on ``model``, reading the array through
    ``array_cal`` (None: the nominal array): the truth's distance (deg) to the target at the loop's last cycle."""
    rng = np.random.default_rng(seed)
    array = default_array(design, 8)
    out = []
    for target in so3.random(count, rng):
        axis = rng.standard_normal(3)
        start = so3.exp(math.radians(0.5) * axis / np.linalg.norm(axis)) @ target
        s = servo_session(design, Trajectory.hold(target), 1.5, emulate=True, lockstep=True, model=model,
                          drive=limits, R0=start, plant=plant, plant_rotor=error.rotor(design),
                          sensor_errors=error.sensor_errors(array), sensor_calibration=array_cal)
        out.append(math.degrees(s.final_error()))
    return out


def one(design, own, spec: str, holds_count: int, seed: int, check: int) -> dict:
    error = PlantError.parse(f"{spec},seed={seed}")
    plant = error.plant(own.model)
    t0 = time.perf_counter()
    holds = collect_holds(design, Emulated(plant, rotor=error.rotor(design),
                                           sensor_errors=error.sensor_errors(default_array(design, 8))),
                          hold_orientations(holds_count, seed=seed), model=own.model, limits=own.limits)
    t1 = time.perf_counter()
    cal = calibrate(design, own.model, holds)
    t2 = time.perf_counter()
    if cal.consistent is False:
        cal = replace(cal, missing=diagnose(design, own.model, holds, cal, gains=True, turns=True))
    before, after = torque_error(own.model, plant), torque_error(cal.model, plant)
    g = gain_errors(cal.model, plant)
    plain = calibrate(design, own.model, holds, gains=False, turns=False)
    missing = diagnose(design, own.model, holds, plain, gains=False, turns=False) if plain.consistent is False else ()
    moved = np.nonzero(np.linalg.norm(plant.turns, axis=1))[0]
    row = {"seed": seed, "plant": f"{spec},seed={seed}", "holds": len(holds), "discarded": holds.discarded,
           "max_hold_offset_deg": holds.to_dict()["max_hold_offset_deg"],
           "collect_s": t1 - t0, "fit_s": t2 - t1, "torque_error_before": before, "torque_error_after": after,
           "ratio": before / after, "gain_error_max": float(np.nanmax(np.abs(g))),
           "gains_within_3pct": int(np.sum(np.abs(g) <= 0.03)), "live_coils": int(np.sum(np.isfinite(g))),
           "placements_true_deg": {int(k): float(np.degrees(np.linalg.norm(plant.turns[k]))) for k in moved},
           "placements_error_deg": {int(k): float(np.degrees(np.linalg.norm(cal.turns[k] - plant.turns[k])))
                                    for k in moved},
           "verdict": cal.judged, "missing": list(cal.missing),
           "without_gains": {"consistent": plain.consistent, "missing": list(missing), "judged": plain.judged}}
    if check:
        errs = true_holds(design, cal.model, own.limits, error, plant, check, seed + 100)
        row["holds_in_truth_deg"] = errs
        row["holds_within_0.05"] = int(sum(e <= 0.05 for e in errs))
    return row


def saturation_row(design, own, spec: str, knee: float, holds_count: int, seed: int) -> dict:
    """The saturating plant's holds, the full fit's verdict and diagnosis, and the fit with the saturation term."""
    plant_spec = f"{spec},saturation={knee:g},seed={seed}"
    error = PlantError.parse(plant_spec)
    plant = error.plant(own.model)
    t0 = time.perf_counter()
    holds = collect_holds(design, Emulated(plant, rotor=error.rotor(design)), hold_orientations(holds_count, seed=seed),
                          model=own.model, limits=own.limits)
    t1 = time.perf_counter()
    cal = calibrate(design, own.model, holds)
    t2 = time.perf_counter()
    missing = diagnose(design, own.model, holds, cal, gains=True, turns=True) if cal.consistent is False else ()
    t3 = time.perf_counter()
    return {"seed": seed, "plant": plant_spec, "holds": len(holds), "collect_s": t1 - t0, "fit_s": t2 - t1,
            "diagnose_s": t3 - t2, "consistent": cal.consistent, "missing": list(missing),
            "named_saturation": any("saturation" in m for m in missing), "verdict": cal.judged,
            "torque_error_before": torque_error(own.model, plant), "torque_error_after": torque_error(cal.model, plant)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant-error", default=TORQUE_TERMS)
    ap.add_argument("--holds", type=int, default=60)
    ap.add_argument("--tune-seed", type=int, default=11)
    ap.add_argument("--seeds", type=int, nargs="*", default=[21])
    ap.add_argument("--check-holds", type=int, default=20)
    ap.add_argument("--part", choices=("targets", "saturation", "all"), default="targets")
    ap.add_argument("--knee", type=float, default=0.7, help="the saturating plant's knee, per unit current")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    design = prototype()
    own = design_model(design)
    rows, saturation = [], []
    for seed in ([a.tune_seed] + list(a.seeds)) if a.part != "targets" else []:
        load = os.getloadavg()[0]
        row = saturation_row(design, own, a.plant_error, a.knee, a.holds, seed)
        row.update(tuned=seed == a.tune_seed, load_start=load, load_end=os.getloadavg()[0])
        saturation.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "verdict"}, default=float), flush=True)
    for seed in ([a.tune_seed] + list(a.seeds)) if a.part != "saturation" else []:
        load = os.getloadavg()[0]
        row = one(design, own, a.plant_error, a.holds, seed, a.check_holds)
        row.update(tuned=seed == a.tune_seed, load_start=load, load_end=os.getloadavg()[0])
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k not in ("verdict", "without_gains")}, default=float))
        print(f"  verdict {row['verdict']}; without gains: {row['without_gains']['consistent']} "
              f"{row['without_gains']['missing']}", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            out = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "rows": rows, "saturation": saturation}
            json.dump({k: v for k, v in out.items() if v}, f, indent=1, default=float)


if __name__ == "__main__":
    main()
