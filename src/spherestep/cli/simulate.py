"""``spherestep simulate``: commutate a rotation and run it on the simulated rotor."""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path

import numpy as np
import typer

from .. import so3
from ..atomic import write_text
from ..errors import bad_value
from .app import app
from .common import console, parse_vector, print_json
from .motor import commutate, design_from, simulate_plan, targets_for

PLANNERS = ("geometric", "potential")


def parse_coils(text: str | None, coil_count: int) -> list[int]:
    """``"3,7"`` → ``[3, 7]``; InputError naming ``--failed-coils`` otherwise."""
    if not text:
        return []
    try:
        coils = [int(k) for k in text.split(",")]
    except ValueError:
        raise bad_value("--failed-coils", "comma-separated coil numbers like 3,7", text) from None
    bad = [k for k in coils if not 0 <= k < coil_count]
    if bad:
        raise bad_value("--failed-coils", f"coil numbers 0..{coil_count - 1}", bad)
    return coils


@app.command()
def simulate(
    axis: str = typer.Option(..., "--axis", help="Rotation axis X,Y,Z in the fixed (stator) frame."),
    angle: float = typer.Option(..., "--angle", help="Rotation angle in degrees."),
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    planner: str = typer.Option("geometric", "--planner", help="geometric (Sec. III-A) or potential (Sec. III-B)."),
    steps: int = typer.Option(None, "--steps", min=1, max=10_000, help="Number of steps (default: 0.35 of a max step each)."),
    noise: float = typer.Option(0.0, "--noise", min=0.0, help="Closed loop: measurement noise σ in degrees."),
    missed: float = typer.Option(0.0, "--missed", min=0.0, max=0.99, help="Closed loop: fraction of missed steps."),
    failed_coils: str = typer.Option(None, "--failed-coils", help="Coils that do not work, e.g. 3,7."),
    seed: int = typer.Option(0, "--seed", help="Random seed for noise and missed steps."),
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Plan a rotation and run it on the rotor under the magnets' physical torque (magpylib torque map):
    trajectory CSV and a plot of desired vs achieved rotation angle. With --noise or --missed the loop is
    closed: the controller measures the orientation and re-plans from it.

    Example: [bold]spherestep simulate --axis 1,0.5,2 --angle 90 --missed 0.1 --noise 0.2 --out sim[/bold]
    """
    from ..dynamics import run_closed_loop, tune
    from ..magnetics import torque_map

    if planner not in PLANNERS:
        raise bad_value("--planner", f"one of {', '.join(PLANNERS)}", planner)
    axis_vec = parse_vector(axis, "--axis")
    design = design_from(design_path)
    failed = parse_coils(failed_coils, len(design.stator))
    if failed:
        design = design.without_coils(failed)
    with console.status("building the torque map and tuning the rotor"):
        physics = torque_map(design)
        tuning = tune(design, physics)
    summary = {"design": design.name, "planner": planner, "failed_coils": failed,
               "damping_N_m_s": tuning.rotor.damping, "dwell_s": tuning.dwell}
    if noise or missed:
        targets = targets_for(design, axis_vec, angle, steps)
        with console.status("running the closed loop"):
            run = run_closed_loop(design, targets, physics, dwell=tuning.dwell, noise=math.radians(noise),
                                  missed=missed, rotor=tuning.rotor, dt=tuning.dt, rng=seed)
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["step", "missed", "error_deg", "turned_desired_deg", "turned_true_deg"])
        for i, (m, e, d, a) in enumerate(zip(run.missed, np.degrees(run.errors),
                                              np.degrees(so3.turned_angle(run.targets, axis_vec)),
                                              np.degrees(so3.turned_angle(run.true, axis_vec)))):
            w.writerow([i, int(m), f"{e:.6f}", f"{d:.6f}", f"{a:.6f}"])
        written = [write_text(out / "closed_loop.csv", buf.getvalue())]
        summary |= {"closed_loop": True, "noise_deg": noise, "missed_fraction": missed,
                    "steps_taken": len(run.missed), "missed_steps": int(run.missed.sum()),
                    "final_error_deg": math.degrees(run.final_error)}
    else:
        plan = commutate(design, axis_vec, angle, steps, planner)
        with console.status("simulating"):
            _, result, written = simulate_plan(design, plan, axis_vec, out, physics, tuning)
        summary |= {"closed_loop": False} | result
    written.append(write_text(out / "simulation.json", json.dumps(summary, indent=1)))
    summary["files"] = [str(p) for p in written]
    if as_json:
        print_json(summary)
    elif summary["closed_loop"]:
        console.print(f"closed loop: {summary['steps_taken']} steps, {summary['missed_steps']} missed; final error "
                      f"{summary['final_error_deg']:.2f}°; wrote {len(written)} files to {out}/")
    else:
        console.print(f"{summary['steps']} steps; settled within {summary['settled_error_max_deg']:.2f}° of the plan "
                      f"(median {summary['settled_error_median_deg']:.2f}°): "
                      f"{'executed' if summary['executed'] else 'NOT executed'}; wrote {len(written)} files to {out}/")
