"""The integrated identification (issue 37 §4): one :func:`spherestep.drive.identify_motor` run per plant seed on the
emulated motor in lockstep, judged against the plant's known values.

The plant: ``--plant-error`` (default ``realistic``: per-coil spread ±20 %, two coils misplaced by 1°, inertia ×1.3,
damping 0.03 N·m·s/rad, friction 0.01 N·m, per-sensor offsets of 100 µT, the array turned 0.1°) with ``seed``.
``--holds`` holds (default 60). Reported per seed:

* wall time of the whole run (target ≤ 3 min; the load is printed: 2 cores shared);
* the array: the turn's error ``|log(Q_fit Q_trueᵀ)|`` and the offsets' RMS error, of the first pass (the design's
  wells) and of the second (the calibrated model's wells: the one saved);
* the sensor-caused orientation error in truth, statically: the emulated magnetometers (the array as built) set
  at rest at 30 random orientations (seed + 200), read (20 samples averaged) and solved by the nominal estimator
  and through the fitted calibration, each error less a perfect array's (targets: ≤ 0.01° after, 0.1° before);
* in closed loop: ``--check-holds`` holds (``servo_session`` on ``Trajectory.hold``
  for 1.5 s from 0.5° away) on the plant with the *calibrated* torque model, through the array's calibration and
  without it; the truth's distance to the target at the loop's last cycle (targets: ≤ 0.01° after, 0.1° before);
* the torque error at 200 held-out orientations (``control.torque_error``) before and after, each live coil's gain
  error (as ``bench_identification.gain_errors``);
* the rotor: inertia, damping and friction against the plant's (targets 5 %, 20 %, 20 %).

Run: ``OPENBLAS_NUM_THREADS=1 nice python benchmarks/bench_identify_motor.py --seeds 21 [--json PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np
from bench_identification import gain_errors, true_holds

from spherestep import so3
from spherestep.control import hold_orientations, torque_error
from spherestep.drive import Emulated
from spherestep.drive.identify import identify_motor
from spherestep.drive.plant import PlantError
from spherestep.magnetics import design_model
from spherestep.motor import prototype
from spherestep.sensing import ArrayCalibration, SensorErrors, default_array


def array_errors(fit: dict, truth) -> dict:
    """The turn's error (deg) and the offsets' RMS error (µT) of ``ArrayCalibration.to_dict()`` ``fit``."""
    cal = ArrayCalibration.from_dict(fit)
    return {"turn_error_deg": math.degrees(so3.distance(cal.rotation, truth.rotation)),
            "offset_rms_error_uT": 1e6 * float(np.sqrt(np.mean((cal.offsets - truth.offsets) ** 2)))}


def static_errors(design, own, array, truth, fit: dict, count: int = 30, seed: int = 200) -> dict:
    """The sensor-caused orientation error (deg) at ``count`` random orientations, read by the emulated array as
    built (``truth``) set at rest there: the nominal estimator's and the calibrated one's, each less a perfect
    array's."""
    from spherestep.drive.connect import emulated_motor
    from spherestep.sensing import field_model

    def reader(motor):
        def read(R):
            motor.R, motor.w[:], motor.alpha[:] = np.asarray(R, dtype=float), 0.0, 0.0
            return np.mean([motor.sense()[0] for _ in range(20)], axis=0) * array.part.lsb_T
        return read

    built = reader(emulated_motor(design, own.model, array, drive=own.limits, sensor_errors=truth))
    perfect = reader(emulated_motor(design, own.model, array, drive=own.limits))
    nominal = field_model(design, array.positions).estimator(array)
    calibrated = ArrayCalibration.from_dict(fit).estimator(design, array)
    before, after = [], []
    for R in so3.random(count, seed):
        m, base = built(R), so3.distance(nominal.solve(perfect(R), R).R, R)
        before.append(math.degrees(so3.distance(nominal.solve(m, R).R, R) - base))
        after.append(math.degrees(so3.distance(calibrated.solve(m, R).R, R) - base))
    return {"before_max_deg": max(before), "before_min_deg": min(before), "after_max_deg": max(after),
            "after_rms_deg": float(np.sqrt(np.mean(np.square(after))))}


def one(design, own, spec: str, holds_count: int, seed: int, check: int, rotor_stage: bool = True) -> dict:
    error = PlantError.parse(f"{spec},seed={seed}")
    plant, rotor = error.plant(own.model), error.rotor(design)
    truth = error.sensor_errors(default_array(design, 8))
    exact = SensorErrors(np.zeros((8, 3))) if truth is None else truth  # the truth the array's fit is judged on
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    cal, holds = identify_motor(design, Emulated(plant, rotor=rotor, sensor_errors=truth),
                                hold_orientations(holds_count, seed=seed), model=own.model, limits=own.limits,
                                rotor=rotor_stage)
    wall = time.perf_counter() - t0
    g = gain_errors(cal.model, plant)
    fit = cal.rotor or {}
    row = {"seed": seed, "plant": f"{spec},seed={seed}", "wall_s": wall, "load_start": load0,
           "load_end": os.getloadavg()[0], "holds": len(holds), "consistent": cal.consistent,
           "missing": list(cal.missing), "verdict": cal.judged,
           "torque_error_before": torque_error(own.model, plant), "torque_error_after": torque_error(cal.model, plant),
           "gain_error_max": float(np.nanmax(np.abs(g))), "gains_within_3pct": int(np.sum(np.abs(g) <= 0.03)),
           "live_coils": int(np.sum(np.isfinite(g))), "rotor_fit": fit,
           "rotor_true": {"inertia": rotor.inertia, "damping": rotor.damping, "friction": rotor.friction}}
    row["ratio"] = row["torque_error_before"] / row["torque_error_after"]
    if fit:
        row["rotor_error"] = {k: fit[f"{k}{u}"] / getattr(rotor, k) - 1.0 for k, u in
                              (("inertia", "_kg_m2"), ("damping", "_N_m_s"), ("friction", "_N_m")) if f"{k}{u}" in fit}
    if cal.sensors:
        row["array_first_pass"] = array_errors(cal.sensors["first_pass"], exact)
        row["array_second_pass"] = array_errors(cal.sensors["second_pass"], exact)
        row["array"] = array_errors(cal.sensors, exact)
        row["array_kept"] = cal.sensors["kept"]
        row["array_residual_uT"] = {k: 1e6 * cal.sensors[k]["residual_T"] for k in ("first_pass", "second_pass")}
        array = default_array(design, 8)
        row["static_first_pass"] = static_errors(design, own, array, truth, cal.sensors["first_pass"])
        row["static_second_pass"] = static_errors(design, own, array, truth, cal.sensors["second_pass"])
    if check:
        array_cal = ArrayCalibration.from_dict(cal.sensors) if cal.sensors else None
        after = true_holds(design, cal.model, own.limits, error, plant, check, seed + 100, array_cal)
        before = true_holds(design, cal.model, own.limits, error, plant, check, seed + 100)
        row.update(holds_truth_after_deg=after, holds_truth_uncalibrated_sensors_deg=before,
                   holds_within_0_05=int(sum(e <= 0.05 for e in after)))
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant-error", default="realistic")
    ap.add_argument("--holds", type=int, default=60)
    ap.add_argument("--seeds", type=int, nargs="+", default=[21])
    ap.add_argument("--check-holds", type=int, default=10)
    ap.add_argument("--no-rotor", action="store_true", help="leave out the rotor's stage (time)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    design = prototype()
    own = design_model(design)
    rows = []
    for seed in a.seeds:
        row = one(design, own, a.plant_error, a.holds, seed, a.check_holds, not a.no_rotor)
        rows.append(row)
        print(json.dumps({k: v for k, v in row.items() if k != "verdict"}, default=float), flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump({"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "rows": rows}, f, indent=1,
                      default=float)


if __name__ == "__main__":
    main()
