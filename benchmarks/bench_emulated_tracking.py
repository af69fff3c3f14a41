"""The hardware path's tracking (issue 38 §4): the demo's fastest iron turn — 360° about (1, 0.5, 2) on the iron
prototype, the fastest plan (``move --axis 1,0.5,2 --angle 360 --emulate``) — on the emulated motor at 500 Hz,
the servo law with its lead (``spherestep.drive.session.LEAD`` periods: the state and target taken where the
command acts) against the baseline without it (lead 0), in the same run, interleaved.

Run: ``python benchmarks/bench_emulated_tracking.py [runs] [baseline_runs] [--lockstep]`` (default 20 and 5, on
the wall clock: the forked device behind a pseudo-terminal, as ``move --emulate``; ``--lockstep``: the simulated
clock, deterministic). Prints per run the max tracking error, the final error (held), the deadlines missed and
the load, then per setting the median, the 10th–90th percentiles and the worst, and the ratio of the medians.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np

import spherestep.drive.session as session
from spherestep.drive.hardware import drive_on_hardware
from spherestep.drive.turn import Turn, choose_model
from spherestep.motor import prototype

AXIS, ANGLE = (1.0, 0.5, 2.0), 360.0


def one(design, chosen, lead: float, lockstep: bool) -> tuple[float, float, int, int]:
    """``(max tracking °, final °, deadlines missed, times slowed)`` of one run with the law's ``lead`` periods."""
    session.LEAD = lead
    r = drive_on_hardware(Turn(design, AXIS, math.radians(ANGLE), chosen, math.radians(0.05)), duration=None,
                          port=None, emulate=True, rate=500.0, **({"lockstep": True} if lockstep else {}))
    d = r.details
    if d.outcome != "done":
        print(f"  run ended {d.outcome}: {d.message}")
    return math.degrees(r.max_tracking_error), math.degrees(r.final_error), d.missed, d.slowed


def summary(name: str, rows: list) -> float:
    a = np.array(rows, dtype=float)
    track, final = a[:, 0], a[:, 1]
    p10, p90 = np.percentile(track, [10, 90])
    print(f"{name}: {len(a)} runs; max tracking median {np.median(track):.3f}° (p10 {p10:.3f}, p90 {p90:.3f}, worst "
          f"{track.max():.3f}); final median {np.median(final):.4f}° (worst {final.max():.4f}); deadlines missed: "
          f"{int((a[:, 2] == 0).sum())} of {len(a)} runs none, worst {int(a[:, 2].max())}; slowed in "
          f"{int((a[:, 3] > 0).sum())}")
    return float(np.median(track))


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    runs = int(args[0]) if args else 20
    baseline_runs = int(args[1]) if len(args) > 1 else 5
    lockstep = "--lockstep" in sys.argv
    design = prototype()
    chosen = choose_model(design)
    lead = session.LEAD
    rows: dict[float, list] = {lead: [], 0.0: []}
    # interleaved: a baseline run after every runs/baseline_runs runs with the lead, so both see the same load
    plan = []
    every = max(1, runs // max(baseline_runs, 1))
    for done in range(1, runs + 1):
        plan.append(lead)
        if done % every == 0 and plan.count(0.0) < baseline_runs:
            plan.append(0.0)
    plan += [0.0] * (baseline_runs - plan.count(0.0))
    print(f"{'lockstep' if lockstep else 'wall clock'}, 500 Hz, {len(plan)} runs; load at start "
          f"{os.getloadavg()[0]:.2f} ({os.cpu_count()} cores)")
    for k, which in enumerate(plan):
        track, final, missed, slowed = one(design, chosen, which, lockstep)
        rows[which].append((track, final, missed, slowed))
        print(f"  run {k + 1:2d} lead {which:g}: max tracking {track:.3f}°, final {final:.4f}°, {missed} missed, "
              f"slowed {slowed}, load {os.getloadavg()[0]:.2f}", flush=True)
    with_lead = summary(f"lead {lead:g} periods", rows[lead])
    base = summary("lead 0 (baseline)", rows[0.0]) if rows[0.0] else math.nan
    print(f"tracking, median ratio baseline / lead: {base / with_lead:.2f}; load at end {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
