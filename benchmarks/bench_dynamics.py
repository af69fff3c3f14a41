"""Simulated seconds per wall-clock second for the prototype's rotor (medians of repeats).

Run: ``.venv/bin/python benchmarks/bench_dynamics.py [--json PATH]``.

One plan step (the coils of a stepper state energised, the rotor released 3° off it) integrated for 2 s
(Yoshida 4th order: 3 torque evaluations per step) at the time step ``dynamics.tune`` chooses for the model
(a quarter period of its stiffest well, as ``spherestep simulate`` and the demo use), under the potential
model (``MotorPotential``), the magnets' torque map (``magnetics.TorqueMap``) and the iron model
(``magnetics.iron_model``). Each runs the compiled integrator (the models' ``packed_terms``,
``spherestep._fast.integrate``); the baseline in the same run is the same model and step through
``Rotor.step`` in NumPy (``Integrator(..., compiled=False)``), and the compiled run at ``dt = 5 ms`` and
``dt = 1 ms`` (the step that keeps the energy drift below 1e-6 over 10 s).
"""

from __future__ import annotations

import datetime
import os
import platform
import time

import numpy as np

from _record import Record
from spherestep import so3
from spherestep.dynamics import Integrator, tune
from spherestep.motor import coil_currents
from spherestep.magnetics import iron_model, torque_map
from spherestep.motor import prototype
from spherestep.potential import MotorPotential


def speed(model, rotor, dt: float, R0, c, repeats: int = 3, duration: float = 2.0, compiled: bool = True) -> float:
    Integrator(model, rotor, dt, compiled).run(R0, np.zeros(3), c, dt, record_every=10)  # compile / warm up
    runs = []
    for _ in range(repeats):
        start = time.perf_counter()
        Integrator(model, rotor, dt, compiled).run(R0, np.zeros(3), c, duration, record_every=10)
        runs.append(duration / (time.perf_counter() - start))
    return float(np.median(runs))


def main() -> None:
    record = Record("dynamics")  # --json PATH: the rows below stored for scripts/docs_numbers.py
    print(f"# bench_dynamics  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    design = prototype()
    states = design.states()
    c = coil_currents(states.coils(0), len(design.stator))
    R0 = so3.exp(np.radians([3.0, 0.0, 0.0])) @ states.rotations[0]
    print(f"{'model':>22} {'tuned dt':>9} {'x real time':>12} {'NumPy steps':>12} {'ratio':>7} {'dt 5 ms':>9} "
          f"{'dt 1 ms':>9}")
    models = (("potential", MotorPotential(design)), ("magnets' torque map", torque_map(design)),
              ("iron model", iron_model(design)))
    for name, model in models:  # each at its own tuning (the iron's wells measured at its rest poses)
        tuning = tune(design, model)
        tuned = speed(model, tuning.rotor, tuning.dt, R0, c)
        plain = speed(model, tuning.rotor, tuning.dt, R0, c, duration=0.5, compiled=False)
        fast, fine = speed(model, tuning.rotor, 5e-3, R0, c), speed(model, tuning.rotor, 1e-3, R0, c)
        print(f"{name:>22} {1000 * tuning.dt:>6.1f} ms {tuned:>12.1f} {plain:>12.1f} {tuned / plain:>6.1f}x "
              f"{fast:>9.1f} {fine:>9.1f}")
        record.put(name, {"dt ms": 1e3 * tuning.dt, "x real time": tuned, "numpy x real time": plain,
                          "dt 5 ms x real time": fast, "dt 1 ms x real time": fine})
    record.write()


if __name__ == "__main__":
    main()
