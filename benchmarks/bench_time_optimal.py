"""The fastest turn with the detent (issue 25 §3): planning time (medians) and what it plans, on the prototype's
iron and air cores, for the demo's 360° turn about (1, 0.5, 2) from the stepper state nearest the identity.

Prints per core: the trapezoid of today (``plan_trapezoid``, refused on iron), the time-optimal turn
(``fastest_turn``: path, duration, planning time median of ``--repeat`` runs), the bang-bang bound with the detent
(``bang_bang_time``: the time-optimal law at margin 1 on the turn's own path) and the ratio; with ``--servo`` the
servo's tracking of both (``simulate_servo`` with 0.02° sensor noise, the design's model as plant and belief).

``--headroom`` and ``--smooth`` override the planner's budget for the coils' ``L di/dt`` (``fastest_turn``'s
``HEADROOM``, ``SMOOTH``); the iron core's limits carry its own inductance (0.65 H).

    python benchmarks/bench_time_optimal.py [--repeat 3] [--servo] [--headroom 0.08] [--smooth 2]
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--servo", action="store_true")
    parser.add_argument("--headroom", type=float, default=None)
    parser.add_argument("--smooth", type=float, default=None)
    args = parser.parse_args()

    from spherestep.commutation import turn
    from spherestep.control import bang_bang_time, fastest_turn, plan_trapezoid
    from spherestep.dynamics import Rotor
    from spherestep.dynamics.servo import simulate_servo
    from spherestep.errors import InputError
    from spherestep.magnetics import design_model
    from spherestep.motor import prototype
    from spherestep.sensing.sensor import NoisySensor

    design = prototype()
    axis = np.array([1.0, 0.5, 2.0])
    R0 = turn(design, axis, 360.0).targets[0]
    inertia = Rotor.from_design(design).inertia
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load {os.getloadavg()[0]:.1f}")
    print(f"{'core':5} {'planner':13} {'time (s)':>9} {'plan (s)':>9} {'bound (s)':>9} {'ratio':>6}  path")
    for core in ("iron", "air"):
        dm = design_model(design, core)
        try:
            trap = plan_trapezoid(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits)
        except InputError as error:
            trap = None
            print(f"{core:5} {'trapezoid':13} {'refused':>9}  {str(error)[:70]}")
        times, ft = [], None
        for _ in range(args.repeat):
            t = time.perf_counter()
            ft = fastest_turn(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits, headroom=args.headroom,
                              smooth=args.smooth)
            times.append(time.perf_counter() - t)
        t = time.perf_counter()
        bound = bang_bang_time(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits)
        bound_time = time.perf_counter() - t
        if trap is not None:
            print(f"{core:5} {'trapezoid':13} {trap.duration:9.3f} {'':>9} {bound:9.3f} {trap.duration / bound:6.2f}")
        print(f"{core:5} {'time-optimal':13} {ft.duration:9.3f} {statistics.median(times):9.2f} {bound:9.3f} "
              f"{ft.duration / bound:6.2f}  {ft.path} ({len(ft.candidates)} paths tried; the bound took "
              f"{bound_time:.1f} s)")
        if args.servo:
            for name, traj in (("trapezoid", None if trap is None else trap), ("time-optimal", ft.trajectory)):
                if traj is None:
                    continue
                run = simulate_servo(design, traj, dm.model, limits=dm.limits,
                                     sensor=NoisySensor(math.radians(0.02), rng=0))
                err = np.degrees(run.tracking_error)
                print(f"      servo on the {name}: max tracking {err.max():.3f}°, final {err[-1]:.4f}°, "
                      f"peak power {run.power.max():.1f} W (copper {run.copper_power.max():.1f} W), "
                      f"mean {run.power.mean():.1f} W, "
                      f"reachable {run.reachable.mean():.3f}")


if __name__ == "__main__":
    main()
