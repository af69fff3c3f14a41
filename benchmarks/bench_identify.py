"""The rotor and the sensors identified (issue 37 §1, §2) on plants with known values, held-out seeds.

The plant: the iron prototype's own torque model (the torque side is calibrated elsewhere), the rotor as built
``Rotor(1.3 I, b = 0.04 N·m·s/rad, f = 0.04 N·m)``, the Hall array (8 sensors) turned 0.1° about a random axis with
per-sensor offsets of 100 µT (``SensorErrors.random``, by seed).

* rotor: ``dynamics.rotor_excitation(seed, repeats=2)`` (6 trapezoidal turns of 120° at 1, 2.5 and 5 rad/s),
  ``drive.record_moves`` on the simulated servo (1 kHz, true orientations) and on the emulated motor in lockstep
  (500 Hz, the magnetometers' estimate, commanded currents; the array's errors left in: the rotor is identified
  after the sensors: the fit on the array as built, uncalibrated, and through its calibration are both shown),
  ``dynamics.fit_rotor`` (``lag=True`` on the emulated motor);
  relative errors and standard deviations;
* sensors: ``sensing.detent_wells`` (12 stiffest), ``drive.well_readings`` (4 visits each) on the emulated motor,
  ``sensing.calibrate_array_absolute``; the turn's error; then 10 holds (``control.calibration.hold_orientations``)
  in lockstep with and without the calibration, judged in truth.

Run: ``OPENBLAS_NUM_THREADS=1 nice python benchmarks/bench_identify.py [--seeds 5,6] [--json PATH]``. Wall times
are of this machine at the load printed (2 cores shared).
"""

from __future__ import annotations

import argparse
import math
import os
import time

import numpy as np
from _record import Record

from spherestep import so3
from spherestep.control import Trajectory
from spherestep.control.calibration import hold_orientations
from spherestep.drive import record_moves, servo_session, well_readings
from spherestep.dynamics import Rotor, fit_rotor, rotor_excitation
from spherestep.magnetics import design_model
from spherestep.motor import prototype
from spherestep.sensing import SensorErrors, calibrate_array_absolute, default_array, detent_wells


def _rel(fit, true: Rotor) -> dict:
    out = {}
    for name in ("inertia", "damping", "friction"):
        out[name] = getattr(fit, name)
        out[f"{name}_error"] = getattr(fit, name) / getattr(true, name) - 1.0
    out["std"] = list(fit.std)
    out["current_lag_s"] = fit.current_lag
    return out


def _holds(design, targets, err, rotor, cal) -> list[float]:
    out = []
    for T in targets:
        s = servo_session(design, Trajectory.hold(T), 0.6, emulate=True, lockstep=True, R0=T, sensor_errors=err,
                          plant_rotor=rotor, sensor_calibration=cal)
        out.append(math.degrees(s.final_error()))
    return out


def main() -> None:
    record = Record("identify")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--seeds", default="5,6", help="held-out seeds, comma-separated (development used 0-4)")
    args = p.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    design = prototype()
    own = design_model(design)
    array = default_array(design, 8)
    true = Rotor(1.3 * Rotor.from_design(design).inertia, 0.04, 0.04)
    print(f"load {os.getloadavg()[0]:.1f}; plant rotor I={true.inertia:.4f} b={true.damping} f={true.friction}")
    rows = []
    for seed in seeds:
        row = {"seed": seed}
        err = SensorErrors.random(array, offset_T=100e-6, bias_deg=0.1, seed=seed)
        moves = rotor_excitation(seed=seed, repeats=2)
        t = time.perf_counter()
        sim = record_moves(design, moves, plant_rotor=true)
        row["rotor_sim_record_s"] = time.perf_counter() - t
        t = time.perf_counter()
        row["rotor_sim"] = _rel(fit_rotor(own.model, sim), true)
        row["rotor_sim_fit_s"] = time.perf_counter() - t
        for key, errors in (("rotor_emulated", None), ("rotor_emulated_sensor_errors", err)):
            t = time.perf_counter()
            emu = record_moves(design, moves, plant_rotor=true, emulate=True, sensor_errors=errors)
            row[f"{key}_record_s"] = time.perf_counter() - t
            row[key] = _rel(fit_rotor(own.model, emu, lag=True), true)
        wells = detent_wells(own.model, 12, seed=seed)  # the sensors (then the rotor through them)
        t = time.perf_counter()
        wr = well_readings(design, wells, visits=4, plant_rotor=true, sensor_errors=err, seed=seed)
        row["wells_record_s"] = time.perf_counter() - t
        t = time.perf_counter()
        cal = calibrate_array_absolute(design, array, wr.readings, wr.references)
        row["sensors_fit_s"] = time.perf_counter() - t
        row["rest_offset_deg_max"] = float(np.degrees(so3.distance(wr.truth, wr.references)).max())
        row["turn_error_deg"] = math.degrees(so3.distance(cal.rotation, err.rotation))
        row["turn_std_deg"] = np.degrees(cal.rotation_std).tolist()
        row["offset_error_rms_T"] = float(np.sqrt(np.mean((cal.offsets - err.offsets) ** 2)))
        t = time.perf_counter()
        emu = record_moves(design, moves, plant_rotor=true, emulate=True, sensor_errors=err, sensor_calibration=cal)
        row["rotor_emulated_calibrated_sensors_record_s"] = time.perf_counter() - t
        row["rotor_emulated_calibrated_sensors"] = _rel(fit_rotor(own.model, emu, lag=True), true)
        targets = hold_orientations(10, seed=100 + seed)
        row["holds_truth_deg_uncalibrated"] = _holds(design, targets, err, true, None)
        row["holds_truth_deg_calibrated"] = _holds(design, targets, err, true, cal)
        rows.append(row)
        r = row
        print(f"seed {seed}: rotor sim I {r['rotor_sim']['inertia_error']:+.2%} b {r['rotor_sim']['damping_error']:+.2%} "
              f"f {r['rotor_sim']['friction_error']:+.2%}; emulated I {r['rotor_emulated']['inertia_error']:+.2%} "
              f"b {r['rotor_emulated']['damping_error']:+.2%} f {r['rotor_emulated']['friction_error']:+.2%} "
              f"(lag {r['rotor_emulated']['current_lag_s'] * 1e3:.2f} ms, {r['rotor_emulated_record_s']:.0f} s); "
              f"with the array's errors I {r['rotor_emulated_sensor_errors']['inertia_error']:+.2%} "
              f"b {r['rotor_emulated_sensor_errors']['damping_error']:+.2%} "
              f"f {r['rotor_emulated_sensor_errors']['friction_error']:+.2%}")
        print(f"  sensors: wells {r['wells_record_s']:.0f} s, fit {r['sensors_fit_s']:.2f} s, turn error "
              f"{r['turn_error_deg']:.4f}°, offsets {r['offset_error_rms_T'] * 1e6:.1f} µT RMS; holds in truth "
              f"max {max(r['holds_truth_deg_uncalibrated']):.3f}° uncalibrated, "
              f"{max(r['holds_truth_deg_calibrated']):.4f}° calibrated")
        c = r["rotor_emulated_calibrated_sensors"]
        print(f"  rotor through the calibrated sensors: I {c['inertia_error']:+.2%} b {c['damping_error']:+.2%} "
              f"f {c['friction_error']:+.2%}")
    print(f"load {os.getloadavg()[0]:.1f}")
    record.put("rows", rows)
    record.write()


if __name__ == "__main__":
    main()
