"""Timings of spherestep.potential for the prototype: the exact forms, the fast path and ducc0, side by side.

Run: ``.venv/bin/python benchmarks/bench_potential.py [--json PATH]`` (``OPENBLAS_NUM_THREADS=1`` recommended on
a shared machine; the header prints it).

Table (batches of 1000 random orientations, random currents on all 29 coils and a state's 4 coils): the energy
of eq. (4) in the harmonic form (Plancherel with the corrected eq. (16)), the pairwise form (energy, energy +
torque, energy + torque + Hessian, the torque matrix ``K(R)``), the same through the fast path (the rotor
function ``F`` at the coils' body-frame directions, :mod:`spherestep.rotor_field`), and the anchor: ducc0's
``synthesis_general`` of ``F`` alone at the same points (library time only, positions precomputed).
``vs ducc0`` is row time / anchor time, ``vs exact`` the matching exact row's time / row time, ``max rel diff``
the largest difference from the exact pairwise form (energy: relative; torque: relative to the torque
reference; ``K``: relative to its peak). Quadrature over the sphere (the brute-force baseline) runs on 5
orientations and is scaled to 1000.

Then single calls (the latency a simulation step sees; and the compiled call alone, without input checks), ducc0 with 1 and 2 threads and BLAS with 1 and 2
threads, equilibria of 10⁴ starts, the potential planner (steps/s over one 360° turn) and the dynamics
(multiples of real time at the tuned step), each with the fast path and the exact forms.
"""

from __future__ import annotations

import datetime
import math
import os
import platform
import time

import numpy as np
import scipy
from threadpoolctl import threadpool_limits

from _record import Record
from _timing import median_seconds
from spherestep import so3
from spherestep.motor import prototype
from spherestep.potential import MotorPotential, coil_currents
from spherestep.statics import equilibrium

K = 1000


def repeat_single(func, R, c, count: int = 300):
    for i in range(count):
        func(R[i % len(R)], c)


def anchor(model: MotorPotential, R: np.ndarray, c: np.ndarray):
    """ducc0's synthesis of ``F`` at the energised coils' body-frame directions (positions precomputed)."""
    from ducc0.sht import synthesis_general

    field = model.rotor_field
    x = (model.coils[np.flatnonzero(c)] @ R).reshape(-1, 3)
    phi = np.arctan2(x[:, 1], x[:, 0])
    loc = np.stack([np.arccos(np.clip(x[:, 2], -1, 1)), np.where(phi < 0, phi + 2 * np.pi, phi)], axis=-1)
    return lambda: synthesis_general(alm=field.alm, spin=0, lmax=field.lmax, loc=loc, epsilon=field.epsilon,
                                     nthreads=field.nthreads)


def main() -> None:
    record = Record("potential")  # --json PATH: the rows below stored for scripts/docs_numbers.py
    rng = np.random.default_rng(0)
    design = prototype()
    states = design.states()
    start = time.perf_counter()
    fast = MotorPotential(design)
    fast.rotor_field  # noqa: B018  (built on first use; timed with the model)
    build = time.perf_counter() - start
    exact = MotorPotential(design, fast=False)
    R = so3.random(K, rng)
    currents = {"29 coils": rng.uniform(-1.0, 1.0, len(design.stator)),
                "4 coils": coil_currents(design, states.coils(0))}
    rows = []
    for label, c in currents.items():
        E0, t0, H0 = exact.evaluate_pairwise(R, c, 2)
        ref = exact.torque_reference(c)
        anchor_time = median_seconds(5, anchor(fast, R, c))
        quadrature = median_seconds(1, exact.energy_quadrature, R[:5], c) * K / 5
        tasks = [
            ("energy, harmonic (exact)", lambda: exact.energy_harmonic(R, c), None, "E"),
            ("energy, pairwise (exact)", lambda: exact.energy_pairwise(R, c), None, "E"),
            ("energy + torque, pairwise (exact)", lambda: exact.evaluate_pairwise(R, c, 1), None, "E"),
            ("E, τ, Hessian, pairwise (exact)", lambda: exact.evaluate_pairwise(R, c, 2), None, "E"),
            ("energy, fast", lambda: fast.energy(R, c), "energy, pairwise (exact)", "E"),
            ("torque, fast", lambda: fast.torque(R, c), "energy + torque, pairwise (exact)", "T"),
            ("energy + torque, fast", lambda: fast.energy_and_torque(R, c), "energy + torque, pairwise (exact)",
             "ET"),
            ("E, τ, Hessian, fast", lambda: fast.evaluate(R, c, 2), "E, τ, Hessian, pairwise (exact)", "ETH"),
        ]
        if label == "29 coils":
            tasks[4:4] = [("K(R), pairwise (exact)", lambda: exact.torque_matrix_pairwise(R), None, "K")]
            tasks.append(("K(R), fast", lambda: fast.torque_matrix(R), "K(R), pairwise (exact)", "K"))
        times = {}
        for name, func, versus, kind in tasks:
            seconds = median_seconds(3, func)
            times[name] = seconds
            out = func()
            if kind == "E":
                diff = np.max(np.abs((out[0] if isinstance(out, tuple) else out) - E0) / np.abs(E0))
            elif kind == "T":
                diff = np.max(np.linalg.norm(out - t0, axis=-1) / ref)
            elif kind in ("ET", "ETH"):
                diff = max(np.max(np.abs(out[0] - E0) / np.abs(E0)), np.max(np.linalg.norm(out[1] - t0, axis=-1) / ref))
                if kind == "ETH":
                    diff = max(diff, np.max(np.abs(out[2] - H0)) / np.max(np.abs(H0)))
            else:
                K0 = exact.torque_matrix_pairwise(R)
                diff = np.max(np.abs(out - K0)) / np.max(np.abs(K0))
            ratio = times[versus] / seconds if versus else float("nan")
            rows.append((f"{name}, {label}", seconds, seconds / anchor_time, ratio, diff))
        rows.append((f"ducc0 synthesis of F (anchor), {label}", anchor_time, 1.0, float("nan"), float("nan")))
        rows.append((f"quadrature (5 orientations, scaled), {label}", quadrature, quadrature / anchor_time,
                     float("nan"), float("nan")))

    c4, c29 = currents["4 coils"], currents["29 coils"]
    single = [(f"single call {what}, {label}", median_seconds(3, repeat_single, func, R, c) / 300)
              for label, c in (("4 coils", c4), ("29 coils", c29))
              for what, func in (("energy + torque, fast", fast.energy_and_torque),
                                 ("energy + torque, pairwise", lambda r, cc: exact.evaluate_pairwise(r, cc, 1)),
                                 ("torque, fast", fast.torque),
                                 ("E, τ, Hessian, fast", lambda r, cc: fast.evaluate(r, cc, 2)),
                                 ("energy + torque, the compiled call alone", _compiled_call(fast)))]

    two = MotorPotential(design, nthreads=2)
    threads = [("ducc0 1 thread, energy + torque, 29 coils", median_seconds(3, fast.energy_and_torque, R, c29)),
               ("ducc0 2 threads, energy + torque, 29 coils", median_seconds(3, two.energy_and_torque, R, c29))]
    for n in (1, 2):
        with threadpool_limits(limits=n, user_api="blas"):
            threads.append((f"BLAS {n} thread(s), harmonic energy (exact), 29 coils",
                            median_seconds(3, exact.energy_harmonic, R, c29)))
            threads.append((f"BLAS {n} thread(s), E, τ, Hessian fast, 29 coils",
                            median_seconds(3, fast.evaluate, R, c29, 2)))

    # equilibria of 10⁴ starts: every state's coils, the start turned 2° off the state
    count = 10_000
    pick = rng.integers(len(states), size=count)
    starts = so3.exp(np.radians(2.0) * _unit(rng, count)) @ states.rotations[pick]
    table = np.stack([coil_currents(design, states.coils(i)) for i in range(len(states))])
    cs = table[pick]
    eq_fast = median_seconds(1, equilibrium, fast, starts, cs)
    eq_exact = median_seconds(1, equilibrium, exact, starts[:1000], cs[:1000]) * count / 1000
    converged = float(np.mean(equilibrium(fast, starts, cs).converged))

    planner = {name: _planner(design, model) for name, model in (("fast", fast), ("exact", exact))}
    dynamics = {name: _dynamics(design, model) for name, model in (("fast", fast), ("exact", exact))}

    print(f"spherestep.potential benchmarks — {datetime.date.today()}, {platform.machine()}, {os.cpu_count()} cores, "
          f"load average {os.getloadavg()[0]:.1f}, OPENBLAS_NUM_THREADS="
          f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, Python {platform.python_version()}, "
          f"NumPy {np.__version__}, SciPy {scipy.__version__}, ducc0 {_ducc0_version()}")
    print(f"prototype: {len(design.rotor)} poles, {len(design.stator)} coils, band limit L = {fast.bandlimit}, "
          f"model + rotor function built in {build:.2f} s; ducc0 epsilon {fast.rotor_field.epsilon:g}, "
          f"direct sum below {fast.rotor_field.direct_below} points")
    print(f"{'task (1000 orientations)':<52} {'µs/orient.':>10} {'per second':>11} {'vs ducc0':>9} "
          f"{'vs exact':>9} {'max rel diff':>13}")
    for task, seconds, vs_anchor, vs_exact, diff in rows:
        print(f"{task:<52} {seconds / K * 1e6:>10.2f} {K / seconds:>11.0f} {vs_anchor:>8.2f}x {vs_exact:>8.1f}x "
              f"{diff:>13.1e}")
    for task, seconds in single:
        print(f"{task:<52} {seconds * 1e6:>9.0f}µs {1 / seconds:>11.0f}")
    for task, seconds in threads:
        print(f"{task:<52} {seconds / K * 1e6:>10.2f} {K / seconds:>11.0f}")
    print(f"{'equilibria of 10⁴ starts, fast':<52} {eq_fast:>9.2f}s {count / eq_fast:>11.0f}  "
          f"({100 * converged:.1f} % converged)")
    print(f"{'equilibria of 10⁴ starts, exact (1000 run, scaled)':<52} {eq_exact:>9.2f}s {count / eq_exact:>11.0f}")
    for name in ("fast", "exact"):
        print(f"{'potential planner, 360° turn, ' + name:<52} {planner[name]:>8.0f} steps/s")
    for name in ("fast", "exact"):
        dt, factor = dynamics[name]
        print(f"{'dynamics at the tuned step, ' + name:<52} {factor:>8.1f}x real time (dt {1e3 * dt:.2f} ms)")
    record.put("batch us per orientation", {task: 1e6 * seconds / K for task, seconds, *_ in rows})
    record.put("batch vs exact", {task: vs for task, _, _, vs, _ in rows})
    record.put("single us", {task: 1e6 * seconds for task, seconds in single})
    record.put("equilibria 1e4 s", {"fast": eq_fast, "exact": eq_exact, "converged": converged})
    record.put("planner steps per s", planner)
    record.put("dynamics", {name: {"dt ms": 1e3 * dt, "x real time": f} for name, (dt, f) in dynamics.items()})
    record.write()


def _compiled_call(model: MotorPotential):
    """One orientation's compiled call (``RotorField.single``) with checked inputs: what a single call costs
    without its input contracts and Python frames."""
    evaluate, params, offsets, poles, polarity, work, near = model.rotor_field.single
    torque, H, sign = np.empty(3), np.empty((3, 3)), np.array([-2.0])
    return lambda r, c: evaluate(params, offsets, r, model.coils, c[None], poles, polarity, sign, 1, torque, H, work,
                                 near)


def _unit(rng, count):
    v = rng.normal(size=(count, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _planner(design, model) -> float:
    from spherestep.commutation import about_axis, plan_potential, steps_for

    states = design.states()
    T = about_axis([1.0, 2.0, 3.0], 2 * math.pi, steps_for(2 * math.pi, 0.5 * design.max_step),
                   start=states.rotations[0])
    plan_potential(design, T, model)  # warm: the states' KD-tree, numba's cache
    return (len(T) - 1) / median_seconds(3, plan_potential, design, T, model)


def _dynamics(design, model) -> tuple[float, float]:
    from spherestep.dynamics import Integrator, tune
    from spherestep.motor import coil_currents

    states = design.states()
    tuning = tune(design, model)
    c = coil_currents(states.coils(0), len(design.stator))
    R0 = so3.exp(np.radians([3.0, 0.0, 0.0])) @ states.rotations[0]
    duration = 5.0
    Integrator(model, tuning.rotor, tuning.dt).run(R0, np.zeros(3), c, tuning.dt)  # compile / warm up
    start = time.perf_counter()
    Integrator(model, tuning.rotor, tuning.dt).run(R0, np.zeros(3), c, duration, record_every=10)
    return tuning.dt, duration / (time.perf_counter() - start)


def _ducc0_version() -> str:
    import ducc0

    return ducc0.__version__


if __name__ == "__main__":
    main()
