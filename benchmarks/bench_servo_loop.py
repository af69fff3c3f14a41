"""Host CPU per control period of the simulated servo loop (``dynamics.simulate_servo`` at 1 kHz) on the prototype's
air-core torque map and on its iron model: a hold at a random orientation and a 20° turn, each 0.3 s simulated;
and of the servo law alone (``control.ServoLaw.step``: observer, feedback, cached ``K(R)``/bias, allocation) on the
turn's measurements (0.02° noise), with how often its ``K(R)`` was re-evaluated.

Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_servo_loop.py``. Prints CPU ms per period (process time, so a
busy machine does not inflate it) and the ratio of simulated to CPU time."""

from __future__ import annotations

import datetime
import math
import os
import platform
import time

import numpy as np

from spherestep import so3
from spherestep.control import GeometricPD, ServoLaw, Trajectory
from spherestep.dynamics import simulate_servo
from spherestep.magnetics import iron_model, torque_map
from spherestep.motor import prototype


def cpu_per_period(design, model, trajectory, settle: float, repeats: int = 3) -> float:
    runs = []
    for _ in range(repeats):
        start = time.process_time()
        run = simulate_servo(design, trajectory, model, settle=settle)
        runs.append((time.process_time() - start) / len(run.times))
    return float(np.median(runs))


def law_cpu_per_period(model, trajectory, steps: int = 300, repeats: int = 3, reuse: float = 2e-3
                       ) -> tuple[float, int]:
    """CPU s per :meth:`ServoLaw.step` along ``trajectory`` at 1 kHz with 0.02° noise, and K(R) evaluations
    (``reuse=0``: K(R) and the bias every period, as the simulation's loop did before the law had its cache)."""
    R = trajectory.sample(np.arange(steps) * 1e-3)[0]
    noise = so3.exp(np.random.default_rng(0).normal(0.0, math.radians(0.02), (steps, 3)))
    runs = []
    for _ in range(repeats):
        law = ServoLaw(model, trajectory, GeometricPD(0.0724), reuse=reuse)
        start = time.process_time()
        for k in range(steps):
            law.step(k * 1e-3, noise[k] @ R[k])
        runs.append((time.process_time() - start) / steps)
    return float(np.median(runs)), law.cache.evaluations


def main() -> None:
    print(f"# bench_servo_loop  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    design = prototype()
    R0 = so3.random(1, 3)[0]
    cases = {"hold 0.3 s": (Trajectory.turn(R0, [0.0, 0.0, 1.0], 0.0, 1.0), 0.3),
             "turn 20°": (Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), 20.0), 0.3)}
    print(f"{'model':>28} {'case':>12} {'CPU ms/period':>14} {'x real time':>12}")
    for name, model in (("air core (torque_map)", torque_map(design)), ("iron (iron_model)", iron_model(design))):
        simulate_servo(design, cases["hold 0.3 s"][0], model, settle=0.01)  # first calls
        for case, (traj, settle) in cases.items():
            sec = cpu_per_period(design, model, traj, settle)
            print(f"{name:>28} {case:>12} {1e3 * sec:>14.3f} {1e-3 / sec:>12.2f}")
        sec, evaluations = law_cpu_per_period(model, cases["turn 20°"][0])
        print(f"{name:>28} {'law.step':>12} {1e3 * sec:>14.3f} {'':>12}  (K(R) evaluated {evaluations} times in 300)")
        sec, evaluations = law_cpu_per_period(model, cases["turn 20°"][0], reuse=0.0)
        print(f"{name:>28} {'law, K each':>12} {1e3 * sec:>14.3f} {'':>12}  (K(R) and bias every period: before)")


if __name__ == "__main__":
    main()
