"""The sensing chain on the prototype, measured in one run: table accuracy, time per update, accuracy against
sensor count, global start, symmetry, the marker's cost, and a 1 kHz tracking run with the IMU alternatives.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_sensing.py [--quick]``, or one section with
``--timing``, ``--model-error``, ``--servo``, ``--calibration``, ``--docs`` (the README's: time per call and the
default array's accuracy; ``--json PATH`` stores them). Times are medians of
repeated calls (``_timing.median_seconds``); ``× magpylib`` compares one estimator update with one magpylib
evaluation of the rotor's field at the same sensors (what a per-iteration magpylib estimator would pay at
least once per iteration). Errors are geodesic angles in degrees.
"""

from __future__ import annotations

import datetime
import math
import statistics
import platform
import sys
import time

import magpylib
import numpy as np

from _record import Record
from _timing import median_seconds
from spherestep import sensing, so3
from spherestep.magnetics import rotor_collection
from spherestep.motor import prototype

RECORD = Record("sensing", argv=[])  # the run's record; from sys.argv (``--json PATH``) when run as a script


def table_accuracy(design, array):
    print("\n## Field table against magpylib (200 Haar-random orientations, 24 sensors)")
    R = so3.random(200, 1)
    exact = np.asarray(rotor_collection(design, R).getB(array.positions))
    print("| nodes | max |ΔB| (T) | RMS ΔB (T) | build (s) |\n|---|---|---|---|")
    for n in (4097, 16385, 65537):
        t0 = time.perf_counter()
        table = sensing.FieldTable.build(design, array.positions, nodes=n)
        build = time.perf_counter() - t0
        d = table.field(R) - exact
        print(f"| {n} | {np.abs(d).max():.2e} | {np.sqrt(np.mean(d ** 2)):.2e} | {build:.3f} |")
    print(f"max |B| at the sensors: {np.abs(exact).max() * 1e3:.1f} mT")


def one_step_case(design, array):
    """The tracking step's case: ``(table, coils, est, R, c, m, R_prev)`` — the field tables, the estimator with the
    coils' field, a random orientation ``R`` with 4 coils on (``c``), its noisy reading ``m``, and the prior
    ``R_prev`` 1 ms earlier at 1 rad/s. Also docs_numbers' sensing-notes."""
    table = sensing.FieldTable.build(design, array.positions)
    coils = sensing.CoilField.build(design, array.positions)
    est = sensing.Estimator(table, array.axes, array.part, (coils,))
    rng = np.random.default_rng(2)
    R = so3.random(1, rng)[0]
    c = np.zeros(len(design.stator))
    c[[1, 5, 9, 20]] = [1, -1, 1, -1]
    m = sensing.sense(array, table.field(R) + coils.field(c), rng)
    R_prev = so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8])) @ R  # 1 rad/s for 1 ms
    return table, coils, est, R, c, m, R_prev


def timing(design, array):
    print("\n## Time per call (median, one orientation, 24 sensors)")
    table, coils, est, R, c, m, R_prev = one_step_case(design, array)
    rotor = rotor_collection(design)
    rows = [("magpylib rotor field (1 call)", lambda: rotor.getB(array.positions)),
            ("table field", lambda: table.field(R)),
            ("table field + Jacobian", lambda: table.field_and_jacobian(R)),
            ("track: 1 Gauss–Newton step (update)", lambda: est.track(m, R_prev, c)),
            ("solve: LM to 1e-10 rad from 0.06°", lambda: est.solve(m, R_prev, c))]
    t_mag = median_seconds(50, rows[0][1])
    print("| call | median (µs) | rate (1/s) | × magpylib |\n|---|---|---|---|")
    for name, f in rows:
        t = t_mag if f is rows[0][1] else median_seconds(300, f)
        print(f"| {name} | {t * 1e6:.0f} | {1 / t:.0f} | {t_mag / t:.1f} |")
        RECORD.values.setdefault("timing us", {})[name] = t * 1e6
    e = est.track(m, R_prev, c)
    print(f"one-step tracking error: {math.degrees(so3.distance(e.R, R)):.4f}°; "
          f"after solve: {math.degrees(so3.distance(est.solve(m, R_prev, c).R, R)):.4f}°")


def accuracy_vs_count(design, placement, samples):
    print(f"\n## Accuracy against sensor count ({samples} Haar-random orientations each; magpylib readings; "
          "4 random coils at ±1 with 1 % RMS current error, subtracted at the commanded currents; "
          "TMAG5273A2 noise 0.1 mT, LSB, saturation)")
    cand = placement.candidates
    print("| sensors | layout | RMS (°) | worst (°) | Cramér–Rao RMS (°) | worst-case bound (°) | coil residual RMS (µT) |")
    print("|---|---|---|---|---|---|---|")
    for k in (3, 4, 6, 8, 12, 16, 24):
        greedy = placement.array(k)
        spread = sensing.SensorArray.at(cand[np.linspace(0, len(cand) - 1, k).astype(int)])
        for name, arr in (("greedy", greedy), ("spread", spread)):
            a = sensing.accuracy(design, arr, samples=samples, seed=k)
            bound = placement.bound_deg()[k - 1] if name == "greedy" else float("nan")
            print(f"| {k} | {name} | {math.degrees(a.rms):.4f} | {math.degrees(a.worst):.4f} | {math.degrees(a.predicted_rms):.4f} | "
                  f"{bound:.4f} | {a.coil_residual_T * 1e6:.1f} |")


def global_start_rows(design, array, trials: int, seed: int = 3) -> list[dict]:
    """Global starts from no prior: ``trials`` Haar-random orientations per rotor (the prototype, up to its 60
    symmetries; the marked rotor, exactly) and per number of readings averaged (1, 32); a row per case with the
    successes (error < 0.05°), the median time and the failures' errors (°). Also docs_numbers' sensing-notes."""
    rng = np.random.default_rng(seed)
    marked = sensing.marked_design(design)
    rows = []
    for d, name, G in ((design, "prototype, up to its 60 symmetries", sensing.symmetry_group(design)),
                       (marked, "marked, exact", None)):
        table = sensing.FieldTable.build(d, array.positions)
        est = sensing.Estimator(table, array.axes, array.part)
        near = sensing.symmetry_group(d, polarity=False) if G is None else None
        for avg in (1, 32):
            ok, times, fails = 0, [], []
            for _ in range(trials):
                R = so3.random(1, rng)[0]
                m = np.mean([sensing.sense(array, table.field(R), rng) for _ in range(avg)], axis=0)
                t0 = time.perf_counter()
                e = est.initialise(m, near_symmetry=near)
                times.append(time.perf_counter() - t0)
                err = so3.distance(e.R[None], R @ G).min() if G is not None else so3.distance(e.R, R)
                ok += bool(err < math.radians(0.05))
                if err >= math.radians(0.05):
                    fails.append(round(math.degrees(float(err)), 1))
            rows.append({"rotor": name, "averaged": avg, "success": ok, "median_s": statistics.median(times),
                         "failures_deg": fails})
    return rows


def global_start(design, array, trials):
    print(f"\n## Global start from no prior ({trials} Haar-random orientations, 24 sensors, 2000-rotation grid)")
    print("| rotor | readings averaged | success (error < 0.05°) | median time (s) | errors of failures (°) |")
    print("|---|---|---|---|---|")
    for r in global_start_rows(design, array, trials):
        print(f"| {r['rotor']} | {r['averaged']} | {r['success']}/{trials} | {r['median_s']:.2f} | "
              f"{r['failures_deg']} |")


def symmetry(design, array):
    print("\n## Symmetry")
    G = sensing.symmetry_group(design)
    R = so3.random(5, 4)
    spread = max(np.abs(B - B[0]).max() for B in
                 (sensing.rotor_field(design, array.positions, Ri @ G) for Ri in R))
    angles = np.degrees(so3.angle(G[1:]))
    print(f"group order {len(G)}; smallest turn between copies {angles.min():.1f}°; largest reading "
          f"difference over the 60 copies (magpylib, 5 orientations, 24 sensors): {spread:.1e} T")
    marked = sensing.marked_design(design)
    table = sensing.FieldTable.build(marked, array.positions)
    Gp = sensing.symmetry_group(marked, polarity=False)
    Rs = so3.random(300, 5)
    d = np.array([np.sqrt(np.sum((table.field(Ri @ Gp[1:]) - table.field(Ri)) ** 2, axis=(1, 2))).min()
                  for Ri in Rs]) / array.part.effective_noise_T
    print(f"marked rotor: the nearest wrong copy differs by |Δm|/σ = {np.min(d):.1f} (min), "
          f"{np.percentile(d, 5):.1f} (5 %), {np.median(d):.1f} (median) over 300 orientations")


def marker(design):
    print("\n## What the marker costs the motor (torque map)")
    t0 = time.perf_counter()
    e = sensing.marker_effect(design, sensing.marked_design(design), states=2, samples=300)
    for key, value in e.to_dict().items():
        print(f"- {key}: {value}")
    print(f"({time.perf_counter() - t0:.0f} s)")


LOOP_LABELS = {"hall": "hall (array, 1 GN step)", "imu": "imu alone (BMI270+BMM150 MEKF)",
               "fused": "fused (gyro + array, MEKF)"}


def loop_rows(design, array) -> dict[str, dict]:
    """A 2-s run at 1 kHz (1 rad/s about a random axis, 3 coils on, 1 % current error, known start) per sensor
    (``hall``, ``imu``, ``fused``): RMS and worst error after the first 0.1 s (°) and the time per sample (µs).
    Also docs_numbers' sensing-notes."""
    rng = np.random.default_rng(6)
    dt, axis = 1e-3, rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R0 = so3.random(1, rng)[0]
    path = [R0 @ so3.exp(axis * dt * k) for k in range(2000)]
    c = np.zeros(len(design.stator))
    c[[3, 7, 11]] = [1, -1, 1]
    sensors = {"hall": sensing.HallSensor(design, array=array, current_error=0.01, seed=1),
               "imu": sensing.ImuSensor(design, dt, seed=2),
               "fused": sensing.FusedSensor(
                   design, sensing.HallSensor(design, array=array, current_error=0.01, seed=3), dt, seed=4)}
    rows = {}
    for name, s in sensors.items():
        R_est, err = R0, []
        t0 = time.perf_counter()
        for k, R in enumerate(path):
            R_est = s.estimate(R, c, R0 if k == 0 else (R_est if name == "hall" else None))
            err.append(so3.distance(R_est, R))
        e = np.degrees(np.array(err[100:]))
        rows[name] = {"rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max()),
                      "us_per_sample": (time.perf_counter() - t0) / len(path) * 1e6}
    return rows


def loop(design, array):
    print("\n## A 2-s run at 1 kHz (1 rad/s about a random axis; 3 coils on; 1 % current error; known start)")
    print("| sensor | RMS (°) | worst (°) | time per sample (µs) |\n|---|---|---|---|")
    for name, r in loop_rows(design, array).items():
        print(f"| {LOOP_LABELS[name]} | {r['rms_deg']:.4f} | {r['worst_deg']:.4f} | {r['us_per_sample']:.0f} |")


def model_error(design, array, samples=100):
    print(f"\n## Model errors the noise study leaves out ({samples} Haar-random orientations, 24 sensors, no noise, "
          "estimator with the nominal model, LM from the truth)")
    rng = np.random.default_rng(7)
    R = so3.random(samples, rng)
    table = sensing.FieldTable.build(design, array.positions)
    est = sensing.Estimator(table, array.axes, array.part)

    def errors(B, axes=array.axes):
        m = np.einsum("sji,ksj->ksi", axes, B)
        return np.degrees([so3.distance(est.solve(m[k], R[k]).R, R[k]) for k in range(samples)])

    cases = []
    moved = sensing.SensorArray(array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape), array.axes)
    cases.append(("sensor positions off by 0.2 mm RMS per axis", errors(sensing.rotor_field(design, moved.positions, R))))
    rotor = rotor_collection(design)
    for child in rotor.children:
        child.polarization = np.asarray(child.polarization) * (1.0 + rng.normal(0.0, 0.01))
    rotor.orientation = __import__("scipy").spatial.transform.Rotation.from_matrix(R)
    cases.append(("magnet remanence spread 1 % RMS", errors(np.asarray(rotor.getB(array.positions)))))
    gain = 1.0 + rng.normal(0.0, 0.01, (len(array), 3))
    exact = sensing.rotor_field(design, array.positions, R)
    m = np.einsum("sji,ksj->ksi", array.axes, exact) * gain
    cases.append(("sensor gains off by 1 % RMS per axis", np.degrees(
        [so3.distance(est.solve(m[k], R[k]).R, R[k]) for k in range(samples)])))
    print("| error source | RMS orientation error (°) | worst (°) |\n|---|---|---|")
    for name, e in cases:
        print(f"| {name} | {np.sqrt(np.mean(e ** 2)):.4f} | {e.max():.4f} |")


def calibration(design, array, poses=200, tests=100):
    print(f"\n## Self-calibration ({poses} readings at unknown Haar-random poses; sensors 0.2 mm RMS off per axis, "
          f"gains 1 %, offsets 50 µT; noise 0.1 mT; 5 rounds; then {tests} new orientations)")
    rng = np.random.default_rng(1)
    true_pos = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(array), 3)), rng.normal(0.0, 50e-6, (len(array), 3))
    R = so3.random(poses, rng)
    m = sensing.sense(array, sensing.rotor_field(design, true_pos, R), rng) * gain + offset
    nominal = sensing.Estimator(sensing.FieldTable.build(design, array.positions), array.axes, array.part)
    start = np.stack([nominal.solve(m[k], R[k]).R for k in range(poses)])
    t0 = time.perf_counter()
    cal = sensing.calibrate(design, array, m, start, rounds=5, cores=False)  # rotor-only readings (no cores)
    took = time.perf_counter() - t0
    est = sensing.Estimator(sensing.FieldTable.build(design, cal.array.positions), array.axes, array.part)
    Rt = so3.random(tests, rng)
    mt = sensing.sense(array, sensing.rotor_field(design, true_pos, Rt), rng) * gain + offset
    E0 = np.stack([so3.log(nominal.solve(mt[k], Rt[k]).R @ Rt[k].T) for k in range(tests)])
    E1 = np.stack([so3.log(est.solve(cal.correct(mt[k]), Rt[k]).R @ Rt[k].T) for k in range(tests)])
    rms = lambda E: math.degrees(np.sqrt(np.mean(np.sum(E ** 2, axis=1))))  # noqa: E731
    print(f"time {took:.1f} s; residual per channel by round (µT): {[round(r * 1e6, 1) for r in cal.residual_T]}")
    print(f"position error RMS per axis: {1e3 * np.sqrt(np.mean((array.positions - true_pos) ** 2)):.3f} mm → "
          f"{1e3 * np.sqrt(np.mean((cal.array.positions - true_pos) ** 2)):.3f} mm")
    print(f"orientation error RMS: nominal model {rms(E0):.4f}°, calibrated {rms(E1):.4f}° "
          f"= a common turn of {math.degrees(np.linalg.norm(E1.mean(0))):.4f}° + scatter {rms(E1 - E1.mean(0)):.4f}°")


def servo(design, array):
    print("\n## In the loop: simulate_servo along a 20° turn (magnets' torque map, 1 kHz, known start, 0.15 s settle)")
    from spherestep.control import Trajectory
    from spherestep.dynamics import simulate_servo
    from spherestep.magnetics import torque_map

    tmap = torque_map(design)
    R0 = so3.random(1, 4)[0]
    traj = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), acceleration=10.0)
    sensors = {"ideal": sensing.IdealSensor(),
               "hall (24 × TMAG5273A2, 1 % current error)": sensing.HallSensor(design, array=array,
                                                                                current_error=0.01, seed=1, start=R0),
               "fused (gyro + array)": sensing.FusedSensor(design, sensing.HallSensor(
                   design, array=array, current_error=0.01, seed=2), 1e-3, seed=3, start=R0),
               "imu alone": sensing.ImuSensor(design, 1e-3, seed=4)}
    print("| sensor | max tracking error (°) | final error (°) | estimate error RMS (°) | wall time (s) |")
    print("|---|---|---|---|---|")
    for name, inner in sensors.items():
        t0 = time.perf_counter()
        run = simulate_servo(design, traj, tmap, sensor=inner, settle=0.15)
        est = so3.distance(run.estimates, run.orientations)
        print(f"| {name} | {math.degrees(run.tracking_error.max()):.4f} | {math.degrees(run.final_error):.4f} | "
              f"{math.degrees(np.sqrt(np.mean(est ** 2))):.4f} | {time.perf_counter() - t0:.1f} |")


def docs(design, array, samples: int = 300):
    """The numbers the README quotes: time per call, and the accuracy of the default array (24 sensors)."""
    timing(design, array)
    a = sensing.accuracy(design, array, samples=samples, seed=len(array))
    print(f"default array ({len(array)} sensors), {samples} Haar-random orientations: RMS {math.degrees(a.rms):.4f}°, "
          f"worst {math.degrees(a.worst):.4f}°")
    RECORD.put("accuracy", {"sensors": len(array), "samples": samples, "rms deg": math.degrees(a.rms),
                            "worst deg": math.degrees(a.worst)})


def main() -> None:
    quick = "--quick" in sys.argv
    if "--docs" in sys.argv:
        design = prototype()
        docs(design, sensing.default_array(design))
        return
    if "--timing" in sys.argv:
        design = prototype()
        timing(design, sensing.default_array(design))
        return
    if "--calibration" in sys.argv:
        design = prototype()
        calibration(design, sensing.default_array(design))
        return
    if "--servo" in sys.argv:
        design = prototype()
        servo(design, sensing.default_array(design))
        return
    if "--model-error" in sys.argv:
        design = prototype()
        model_error(design, sensing.default_array(design))
        return
    print(f"# bench_sensing — {datetime.date.today()}, {platform.machine()}, Python {platform.python_version()}, "
          f"NumPy {np.__version__}, magpylib {magpylib.__version__}")
    design = prototype()
    t0 = time.perf_counter()
    placement = sensing.greedy_placement(design, 24)
    print(f"greedy placement of 24 sensors from {len(placement.candidates)} candidates: "
          f"{time.perf_counter() - t0:.1f} s")
    array = placement.array(24)
    table_accuracy(design, array)
    timing(design, array)
    symmetry(design, array)
    global_start(design, array, 10 if quick else 50)
    accuracy_vs_count(design, placement, 50 if quick else 300)
    loop(design, array)
    model_error(design, array, 30 if quick else 100)
    servo(design, array)
    calibration(design, array, 60 if quick else 200, 30 if quick else 100)
    if not quick:
        marker(design)


if __name__ == "__main__":
    RECORD = Record("sensing")  # --json PATH: what this run measured, for scripts/docs_numbers.py
    main()
    RECORD.write()
