"""Timings of spherestep.potential for the prototype, measured side by side in one run (medians of repeats).

Run: ``.venv/bin/python benchmarks/bench_potential.py``. Rows: the energy of eq. (4) in the harmonic form
(Plancherel with the corrected eq. (16)), in the pairwise form, the torque, energy and torque together, the
Hessian, and brute-force quadrature over the sphere (the baseline: what eq. (4) costs without the paper's
harmonic analysis); batches of 1000 orientations, with a state's 4 coils energised and with random currents on
all 29 coils. Quadrature runs on 5 orientations and is scaled to 1000. ``ratio`` is quadrature time / row time,
``max rel diff`` the largest relative difference from the quadrature on the common orientations. Also: single
calls (the latency a simulation step sees), equilibria, and the energy on the full SO(3) grid.

BLAS threads matter for the harmonic form (many small matrix products): the header prints
``OPENBLAS_NUM_THREADS``; on a loaded 2-core machine one thread is several times faster.
"""

from __future__ import annotations

import datetime
import os
import platform
import time

import numpy as np
import scipy

from _timing import median_seconds
from spherestep import so3
from spherestep.motor import prototype
from spherestep.potential import MotorPotential, coil_currents
from spherestep.statics import equilibrium


def repeat_single(func, R, c, count: int = 2000):
    for i in range(count):
        func(R[i % len(R)], c)


def main() -> None:
    rng = np.random.default_rng(0)
    design = prototype()
    states = design.states()
    start = time.perf_counter()
    model = MotorPotential(design)
    build = time.perf_counter() - start
    K = 1000
    R = so3.random(K, rng)
    few = 5
    currents = {
        "state 0 (4 coils)": coil_currents(design, states.coils(0)),
        "random, 29 coils": rng.uniform(-1.0, 1.0, len(design.stator)),
    }
    rows = []
    for label, c in currents.items():
        quadrature = median_seconds(1, model.energy_quadrature, R[:few], c) * K / few
        reference = model.energy_quadrature(R[:few], c)
        tasks = (("energy (harmonic)", model.energy, 3), ("energy (pairwise)", model.energy_pairwise, 7),
                 ("torque", model.torque, 7), ("energy + torque", model.energy_and_torque, 7),
                 ("Hessian", model.hessian, 5))
        for name, func, reps in tasks:
            seconds = median_seconds(reps, func, R, c)
            if name.startswith("energy ("):
                error = float(np.max(np.abs(func(R[:few], c) - reference) / reference))
            else:
                error = float("nan")
            rows.append((f"{name}, {label}", seconds, quadrature, error))
        rows.append((f"energy (quadrature), {label}", quadrature, quadrature, 0.0))

    c4 = currents["state 0 (4 coils)"]
    single = median_seconds(3, repeat_single, model.energy_and_torque, R, c4) / 2000
    starts = states.rotations[:200]
    cs = np.stack([coil_currents(design, states.coils(i)) for i in range(200)])
    eq_time = median_seconds(3, equilibrium, model, starts, cs)
    grid_time = median_seconds(1, model.energy_grid, c4)

    threads = os.environ.get("OPENBLAS_NUM_THREADS", "unset")
    print(f"spherestep.potential benchmarks — {datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}, OPENBLAS_NUM_THREADS={threads}, "
          f"Python {platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}")
    print(f"prototype: {len(design.rotor)} poles, {len(design.stator)} coils, band limit L = {model.bandlimit}, "
          f"model built in {build:.2f} s; kernel table {model.kernel.intervals} intervals")
    print(f"{'task (1000 orientations)':<46} {'ms':>9} {'per second':>11} {'vs quadrature':>14} {'max rel diff':>13}")
    for task, seconds, quadrature, error in rows:
        print(f"{task:<46} {seconds * 1e3:>9.1f} {K / seconds:>11.0f} {quadrature / seconds:>13.0f}x {error:>13.1e}")
    print(f"{'single call energy + torque, 4 coils':<46} {single * 1e6:>8.0f}µs {1 / single:>11.0f}")
    print(f"{'equilibrium, 200 states (batched Newton)':<46} {eq_time * 1e3:>9.1f} {200 / eq_time:>11.0f}")
    print(f"{'energy_grid, L = 68 (137 × 69 × 137 rotations)':<46} {grid_time * 1e3:>9.1f} "
          f"{137 * 69 * 137 / grid_time:>11.0f}")


if __name__ == "__main__":
    main()
