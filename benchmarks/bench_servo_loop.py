"""Host CPU per control period of the servo law and of the simulated servo loop, with a per-part breakdown, on
the prototype's air-core torque map and on its iron model — now, and with today's (before issue 27) paths in the
same run.

* The law's parts on a 20° turn at 1 kHz with 0.02° noise, each timed alone over the turn's 300 periods:
  *estimate* (the observer's predict and correct), *feedback* (the trajectory and the geometric PD), *K(R) and
  bias* (one evaluation: :class:`~spherestep.control.ModelCache`, compiled, against the model's own
  ``torque_matrix`` + ``torque``), *allocation* (warm-started; the compiled Newton against the NumPy reference)
  and, out of reach, the *closest reachable* torque (the compiled bisection against Clarabel); the
  *magnetometer update* (the Hall tracker, :meth:`spherestep.sensing.Estimator.track_until` as
  :class:`~spherestep.hardware.FieldTracker` calls it, 8 magnetometers); then :meth:`ServoLaw.step` whole, with how
  often ``K(R)`` was re-evaluated, and in the worst case (re-evaluated every period).
* ``simulate_servo`` per 1 kHz period (hold and 20° turn, 0.3 s): the plant through the compiled affine form now,
  the models' own methods before, and the largest difference of the two runs' orientations.
* The emulated motor's tick: one device control step with the coils and rotor advanced, and one magnetometer read.

"Before" is the same code with the compiled pieces swapped for the reference ones (a model wrapper without packed
terms; the NumPy Newton and Clarabel). Run: ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_servo_loop.py``.
Prints CPU µs (process time, so a busy machine does not inflate it much) and the load average; ``--json PATH``
also stores them (``scripts/docs_numbers.py bench`` renders docs/hardware.md's and docs/control.md's tables).
"""

from __future__ import annotations

import contextlib
import datetime
import math
import os
import platform
import time

import numpy as np

from _record import Record
from spherestep import so3
from spherestep._fast import allocation as fast_alloc
from spherestep.control import GeometricPD, ModelCache, ServoLaw, Trajectory
from spherestep.control import allocation as alloc_module
from spherestep.dynamics import simulate_servo
from spherestep.electrics import DriveLimits
from spherestep.magnetics import iron_model, torque_map
from spherestep.motor import prototype

PERIODS = 300


class Unpacked:
    """``model`` without its compiled form (``packed_terms`` None): the paths before the fast ones."""

    def __init__(self, model):
        self.model = model
        self.coil_count, self.failed, self.has_bias = model.coil_count, model.failed, model.has_bias
        self.affine_in_currents = False  # declared with packed_terms: none

    def __getattr__(self, name):
        return getattr(self.model, name)

    def packed_terms(self, currents):
        return None


@contextlib.contextmanager
def reference_allocation():
    """The allocation's NumPy Newton and Clarabel fallback in place of the compiled ones."""
    saved = fast_alloc.solve_box, fast_alloc.solve_reachable
    fast_alloc.solve_box = alloc_module.least_power_box
    fast_alloc.solve_reachable = lambda K, t, u, rho, lower=None: None
    try:
        yield
    finally:
        fast_alloc.solve_box, fast_alloc.solve_reachable = saved


def cpu_us(func, n: int) -> float:
    """CPU µs per call of ``func(k)`` for ``k < n`` (one warm-up call first)."""
    func(0)
    start = time.process_time()
    for k in range(n):
        func(k)
    return 1e6 * (time.process_time() - start) / n


def turn_data(trajectory, steps: int = PERIODS):
    R = trajectory.sample(np.arange(steps) * 1e-3)[0]
    noise = so3.exp(np.random.default_rng(0).normal(0.0, math.radians(0.02), (steps, 3)))
    return np.einsum("kab,kbc->kac", noise, R)


def law_parts(model, trajectory, measured) -> dict:
    """CPU µs of each part of one period (module docstring)."""
    law = ServoLaw(model, trajectory, GeometricPD(0.0724))
    law.step(0.0, measured[0])
    obs = law.observer
    out = {}

    def estimate(k):
        obs.predict(np.zeros(3), 1e-3)
        obs.correct(measured[k % len(measured)])
    out["estimate"] = cpu_us(estimate, PERIODS)
    states = [(obs.R.copy(), obs.w.copy())] * PERIODS
    out["feedback"] = cpu_us(lambda k: law.controller.torque(states[k][0], states[k][1], *trajectory.at(k * 1e-3)),
                             PERIODS)
    cache = ModelCache(model, reuse=0.0)
    out["K(R) and bias"] = cpu_us(lambda k: cache.at(measured[k]), PERIODS)
    K, b = (a.copy() for a in cache.at(measured[0]))
    tau = b + K @ np.full(model.coil_count, 0.05)
    lam = [None]

    def allocate(k):
        a, lam[0] = alloc_module.allocate_matrix(K, tau * (1 + 1e-3 * k), law.limits, bias=b, lam0=lam[0])
    out["allocation"] = cpu_us(allocate, PERIODS)
    from spherestep._fast.allocation import voltage_box

    lim = law.limits
    box = (np.zeros(model.coil_count), np.zeros(model.coil_count))
    w = np.array([1.0, 0.5, 2.0]) * (1.5 / (lim.resistance * lim.nominal_current ** 2))  # 3.4 rad/s, per-unit volts
    lam2 = [None]

    def allocate_box(k):  # the law's: the supply box from ω, then the allocation within it
        voltage_box(K, w * (1 + 1e-3 * k), np.zeros(model.coil_count), lim.per_unit_bound,
                    lim.supply_voltage / (lim.resistance * lim.nominal_current), 0.0, box[0], box[1])
        a, lam2[0] = alloc_module.allocate_matrix(K, tau * (1 + 1e-3 * k), lim, bias=b, lam0=lam2[0], bounds=box)
    out["supply box + allocation"] = cpu_us(allocate_box, PERIODS)
    far = tau * 40.0  # out of reach
    out["closest reachable"] = cpu_us(lambda k: alloc_module.allocate_matrix(K, far * (1 + 1e-3 * k), law.limits,
                                                                            bias=b), 30)
    return out


def step_us(model, trajectory, measured, reuse: float = 2e-3) -> tuple[float, int]:
    law = ServoLaw(model, trajectory, GeometricPD(0.0724), reuse=reuse)
    us = cpu_us(lambda k: law.step(k * 1e-3, measured[k]), PERIODS)
    return us, law.cache.evaluations


def tracker_us(design, trajectory) -> float:
    from spherestep.hardware import FieldTracker
    from spherestep.sensing import default_array, field_model

    sensors = default_array(design, 8)
    model = field_model(design, sensors.positions)  # the session's: the cores' field on an iron design
    table, estimator = model.table, model.estimator(sensors)
    R = trajectory.sample(np.arange(PERIODS) * 1e-3)[0]
    rng = np.random.default_rng(1)
    fields = [np.einsum("sab,sa->sb", sensors.axes, table.field(r)) + sensors.part.noise_T *
              rng.standard_normal((len(sensors), 3)) for r in R]

    class State:
        def __init__(self, field):
            self.field, self.currents = field, np.zeros(len(design.stator))
    states = [State(f) for f in fields]
    tracker = FieldTracker(estimator, R[0], DriveLimits())
    return cpu_us(lambda k: tracker(states[k], R[k]), PERIODS)


def simulate_us(design, model, trajectory, settle: float) -> tuple[float, np.ndarray]:
    simulate_servo(design, trajectory, model, settle=0.01)
    start = time.process_time()
    run = simulate_servo(design, trajectory, model, settle=settle)
    return 1e6 * (time.process_time() - start) / len(run.times), run.orientations


def emulator_tick_us(design, model) -> tuple[float, float]:
    from spherestep.drive.connect import emulated_motor
    from spherestep.hardware import LockstepLink
    from spherestep.sensing import default_array

    motor = emulated_motor(design, model, default_array(design, 8), drive=DriveLimits(), R0=np.eye(3))
    link = LockstepLink(motor)
    link.drive(np.full(motor.i.shape, 0.2))
    step = cpu_us(lambda k: link.sleep(motor.period), 500)
    sense = cpu_us(lambda k: motor.sense(), 500)
    return step, sense


def main() -> None:
    record = Record("servo_loop")  # --json PATH: the numbers below stored for scripts/docs_numbers.py
    print(f"# bench_servo_loop  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  load={os.getloadavg()[0]:.1f}  "
          f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    design = prototype()
    R0 = so3.random(1, 3)[0]
    turn = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), 20.0)
    hold = Trajectory.turn(R0, [0.0, 0.0, 1.0], 0.0, 1.0)
    measured = turn_data(turn)
    models = {"air": torque_map(design), "iron": iron_model(design)}
    print("\nthe law, one period (CPU µs): now | before")
    for name, model in models.items():
        now = law_parts(model, turn, measured)
        with reference_allocation():
            before = law_parts(Unpacked(model), turn, measured)
        for part in now:
            print(f"  {name:>5} {part:>20} {now[part]:9.1f} | {before[part]:9.1f}")
        record.put(f"law {name}", {part: [now[part], before[part]] for part in now})
        step, evaluations = step_us(model, turn, measured)
        worst, _ = step_us(model, turn, measured, reuse=0.0)
        with reference_allocation():
            step_b, _ = step_us(Unpacked(model), turn, measured)
            worst_b, _ = step_us(Unpacked(model), turn, measured, reuse=0.0)
        print(f"  {name:>5} {'law.step (turn)':>20} {step:9.1f} | {step_b:9.1f}   (K(R) evaluated {evaluations} "
              f"times in {PERIODS})")
        print(f"  {name:>5} {'law.step, K each':>20} {worst:9.1f} | {worst_b:9.1f}")
        record.values[f"law {name}"].update({"law.step (turn)": [step, step_b], "law.step, K each": [worst, worst_b],
                                             "K evaluations": [evaluations, PERIODS]})
    tracker = tracker_us(design, turn)
    print(f"  {'':>5} {'magnetometer update':>20} {tracker:9.1f}   (Hall tracker, 8 magnetometers)")
    record.put("magnetometer update", tracker)
    print("\nsimulate_servo, one 1 kHz period (CPU µs): now | before | x real time now | max |ΔR| (rad)")
    for name, model in models.items():
        for case, traj in (("hold", hold), ("turn 20°", turn)):
            now, R_now = simulate_us(design, model, traj, 0.3)
            before, R_before = simulate_us(design, Unpacked(model), traj, 0.3)
            diff = float(so3.distance(R_now, R_before).max())
            print(f"  {name:>5} {case:>9} {now:9.1f} | {before:9.1f} | {1e3 / now:6.2f} | {diff:.1e}")
            record.put(f"simulate {name} {case.split()[0]}", {"now": now, "before": before, "max dR rad": diff})
    print("\nthe emulated motor's tick (CPU µs): device step with coils and rotor | magnetometer read")
    for name, model in models.items():
        step, sense = emulator_tick_us(design, model)
        print(f"  {name:>5} {step:9.1f} | {sense:9.1f}")
        record.put(f"emulator {name}", {"device step": step, "magnetometer read": sense})
    print(f"# load at the end {os.getloadavg()[0]:.1f}")
    record.write()


if __name__ == "__main__":
    main()
