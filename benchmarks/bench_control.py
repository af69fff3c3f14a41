"""The control room's speed and the three drive modes, in one run.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_control.py`` (about 5–10 minutes on a shared
2-core machine; ``--quick`` skips the three-mode comparison; ``--json PATH`` also stores the numbers).

1. Allocation for the prototype's 29 coils (``K(R)`` of the magnets' torque map at 100 uniform orientations,
   requests of 0.2–1.8 N·m within reach): median time per call of ``allocate_matrix`` (dual Newton), and in the
   same run the unconstrained minimum-norm right inverse ``pinv(K) t`` (a lower bound: no limits at all) and the
   same QP solved by Clarabel (the general interior-point solver). Also: out-of-reach requests (the SOCP path)
   and relay allocation. Allocations per second = 1 / median.
2. Closed-loop simulation at 1 kHz control (10 kHz PWM) holding an orientation: simulated seconds per wall
   second; and the hold's precision at five random orientations with 0.02° sensor noise.
3. The capability map: 1000 orientations (400 directions each).
4. The demo's 360° turn about (1, 0.5, 2) driven three ways (:func:`spherestep.drive.compare_drives`).
"""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import sys
import time

import numpy as np

from _record import Record
from _timing import median_seconds
from spherestep import so3
from spherestep.control import DriveLimits, allocate_matrix, allocate_relay, torque_capability
from spherestep.drive import compare_drives
from spherestep.dynamics import hold
from spherestep.sensing import NoisySensor
from spherestep.magnetics import torque_map
from spherestep.motor import prototype


def clarabel_qp(K, t, u):
    """min ½‖c‖² s.t. K c = t, |c| ≤ u by Clarabel (the general solver the fast path is measured against)."""
    import clarabel
    from scipy import sparse

    n = K.shape[1]
    eye = sparse.identity(n, format="csc")
    A = sparse.vstack([sparse.csc_matrix(K), eye, -eye], format="csc")
    b = np.concatenate([t, u, u])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    solver = clarabel.DefaultSolver(sparse.identity(n, format="csc"), np.zeros(n), A, b,
                                    [clarabel.ZeroConeT(3), clarabel.NonnegativeConeT(2 * n)], settings)
    return np.asarray(solver.solve().x)


def per_call(func, cases, repeats: int = 5) -> float:
    """Median over ``repeats`` of the mean wall time per case (s)."""
    return median_seconds(repeats, lambda: [func(*c) for c in cases]) / len(cases)


def cpu_per_call(func, cases, repeats: int = 5) -> float:
    """Median over ``repeats`` of the mean CPU time of this process per case (s): on a machine shared with other
    jobs it counts only the time this process ran, not the time it waited for a core."""
    runs = []
    for _ in range(repeats + 1):
        start = time.process_time()
        for c in cases:
            func(*c)
        runs.append((time.process_time() - start) / len(cases))
    return float(np.median(runs[1:]))


def main() -> None:
    record = Record("control")  # --json PATH: the numbers below stored for scripts/docs_numbers.py
    quick = "--quick" in sys.argv
    print(f"# bench_control  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    design = prototype()
    tmap = torque_map(design)
    limits = DriveLimits()
    u = np.ones(tmap.coil_count)
    K = tmap.torque_matrix(so3.random(100, 1))
    rng = np.random.default_rng(2)
    T = rng.normal(size=(100, 3))
    T *= rng.uniform(0.2, 1.8, size=(100, 1)) / np.linalg.norm(T, axis=1, keepdims=True)
    cases = [(K[k], T[k]) for k in range(100)]
    far = [(K[k], T[k] * 4.0 / np.linalg.norm(T[k])) for k in range(20)]
    fast = per_call(lambda k, t: allocate_matrix(k, t, limits), cases)
    pinv = per_call(lambda k, t: np.linalg.pinv(k) @ t, cases)
    clar = per_call(lambda k, t: clarabel_qp(k, t, u), cases[:30], repeats=3)
    cone = per_call(lambda k, t: allocate_matrix(k, t, limits), far, repeats=3)
    relay = per_call(lambda k, t: allocate_relay(k, t, limits), cases[:5], repeats=3)
    cpu = {name: cpu_per_call(f, cs, r) for name, f, cs, r in (
        ("newton", lambda k, t: allocate_matrix(k, t, limits), cases, 5),
        ("pinv", lambda k, t: np.linalg.pinv(k) @ t, cases, 5),
        ("clarabel", lambda k, t: clarabel_qp(k, t, u), cases[:30], 3))}
    agree = max(float(np.abs(allocate_matrix(k, t, limits)[0].currents - clarabel_qp(k, t, u)).max())
                for k, t in cases[:30])
    print("\n## allocation, 29 coils (median per call)")
    print(f"{'method':>42} {'µs/call':>10} {'calls/s':>10} {'vs newton':>10}")
    for name, sec in (("allocate_matrix (dual Newton, exact)", fast), ("pinv(K) t (no limits, lower bound)", pinv),
                      ("Clarabel QP (same problem)", clar), ("out of reach (Clarabel SOCP + Newton)", cone),
                      ("relay {-1,0,1}, ≤ 4 coils (exhaustive)", relay)):
        print(f"{name:>42} {1e6 * sec:>10.1f} {1 / sec:>10.0f} {sec / fast:>10.2f}")
    print(f"CPU time per call (µs): Newton {1e6 * cpu['newton']:.1f}, pinv {1e6 * cpu['pinv']:.1f}, "
          f"Clarabel {1e6 * cpu['clarabel']:.1f}")
    print(f"largest difference Newton vs Clarabel currents: {agree:.2e} (per unit)")
    record.put("allocation us", {"newton": 1e6 * fast, "pinv": 1e6 * pinv, "clarabel": 1e6 * clar,
                                 "out of reach": 1e6 * cone, "relay": 1e6 * relay})
    record.put("allocation cpu us", {k: 1e6 * v for k, v in cpu.items()})
    record.put("newton vs clarabel", agree)

    print("\n## closed loop at 1 kHz (hold, 0.2 s simulated)")
    R = so3.random(1, 3)[0]
    start = time.perf_counter()
    hold(design, R, tmap, duration=0.2)
    wall = time.perf_counter() - start
    Kt = median_seconds(20, tmap.torque_matrix, R)
    tq = median_seconds(20, tmap.torque, R, np.full(29, 0.1))
    print(f"simulated/wall = {0.2 / wall:.3f} x real time ({1e3 * wall / 201:.1f} ms per control period); "
          f"per period: 2 K(R) ({1e3 * Kt:.2f} ms each) + 4 torque ({1e3 * tq:.2f} ms each) evaluations")

    print("\n## holding arbitrary orientations (0.02° sensor noise, 0.3 s each, error over the last 0.15 s)")
    worst = []
    for k, Rk in enumerate(so3.random(5, 7)):
        run = hold(design, Rk, tmap, duration=0.3, sensor=NoisySensor(math.radians(0.02), rng=k))
        worst.append(math.degrees(float(run.tracking_error[run.times >= 0.15].max())))
    print(f"largest error per orientation (°): {', '.join(f'{w:.4f}' for w in worst)}")

    print("\n## capability map")
    start = time.perf_counter()
    cap = torque_capability(design, tmap, samples=1000, seed=0)
    record.put("capability 1000 s", time.perf_counter() - start)
    print(f"1000 orientations: {time.perf_counter() - start:.1f} s; available torque percentiles (N·m) "
          f"{ {k: round(v, 3) for k, v in cap.percentiles().items()} }; "
          f"≥ 1 N·m on {100 * cap.fraction_at_least(1.0):.1f} %, ≥ 1.5 N·m on {100 * cap.fraction_at_least(1.5):.1f} %")

    record.put("closed loop", {"x real time": 0.2 / wall, "ms per period": 1e3 * wall / 201, "K(R) ms": 1e3 * Kt,
                               "torque ms": 1e3 * tq, "hold worst deg": worst})
    if quick:
        record.write()
        return
    print("\n## the demo's 360° turn about (1, 0.5, 2), three ways")
    start = time.perf_counter()
    comparison = compare_drives(design, model=tmap, damped_servo=True)
    compared = time.perf_counter() - start
    print(f"(compared in {compared:.0f} s wall)")
    print(f"{'mode':>24} {'time s':>9} {'final °':>9} {'max track °':>12} {'peak W':>8} {'mean W':>8}")
    for r in comparison.results:
        d = r.to_dict()
        mode = r.mode + (" (tuned damping)" if r.mode == "servo" and r.details.damping else "")
        print(f"{mode:>24} {r.time:>9.3f} {d['final_error_deg']:>9.4f} {d['max_tracking_error_deg']:>12.3f} "
              f"{r.peak_power:>8.1f} {r.mean_power:>8.1f}")
    print(f"bang-bang bound {comparison.bound:.3f} s; servo / bound = {comparison.ratio:.2f}; ramped pull-out "
          f"{comparison.pull_out_rate:.1f} steps/s")
    print(json.dumps(comparison.to_dict(), allow_nan=False))
    record.put("compare drives s", compared)
    record.write()


if __name__ == "__main__":
    main()
