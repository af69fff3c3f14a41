"""``spherestep demo`` (the main job on the built-in prototype) and ``spherestep plan``."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import typer
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from .. import plots, so3
from ..atomic import write_text
from ..commutation import about_axis, plan_geometric, steps_for
from ..errors import bad_value
from ..motor import MotorDesign, prototype
from .app import app
from .common import console, parse_vector, print_json

DEMO_AXIS = "1,0.5,2"


def metrics_for_people(design: MotorDesign, metrics: dict) -> dict:
    """The design's summary and metrics with angles in degrees."""
    out = design.summary()
    for key, value in metrics.items():
        if key in ("resolution_median", "resolution_p95", "resolution_max", "max_step"):
            out[f"{key}_deg"] = math.degrees(value)
        elif key == "escape_violations":
            out["escape_violations"] = len(value)
            out["escape_violation_states"] = value[:50]
        else:
            out[key] = value
    return out


def print_summary(info: dict) -> None:
    """Rich table of a design's summary and metrics."""
    table = Table(title=f"{info['name']}: rotor {info['rotor']} ({info['rotor_poles']} poles), "
                        f"stator {info['stator']} ({info['coils']} coils)")
    table.add_column("metric", no_wrap=True)
    table.add_column("value", justify="right", no_wrap=True)
    rows = [
        ("stator cap half-angle", f"{info['cap_half_angle_deg']:.1f}°"),
        ("stepper states", f"{info['states']}"),
        ("resolution median / 95% / max", f"{info['resolution_median_deg']:.2f}° / {info['resolution_p95_deg']:.2f}° / "
                                          f"{info['resolution_max_deg']:.2f}°"),
        ("max step (two coils)", f"{info['max_step_deg']:.2f}°"),
        ("range: orientations within one step of a state", f"{100 * info['range_fraction']:.2f}%"),
        ("state graph components", f"{info['state_graph_components']}"),
        ("reaches all of SO(3)", "yes" if info["reaches_all"] else "no"),
        ("states with a 45° direction of no escape", f"{info['escape_violations']} of {info['states']}"),
        ("rotor inertia isotropy (max/min)", f"{info['rotor_inertia_isotropy']:.6f}"),
    ]
    for name, value in rows:
        table.add_row(name, value)
    console.print(table)


def commutate(design: MotorDesign, axis: np.ndarray, angle_deg: float, steps: int | None):
    """Plan a rotation of ``angle_deg`` about ``axis`` from the state nearest the identity."""
    if not math.isfinite(angle_deg) or angle_deg == 0 or abs(angle_deg) > 36000:
        raise bad_value("--angle", "a non-zero angle in degrees, at most 36000 in size", angle_deg)
    states = design.states()
    start = states.rotations[int(states.nearest(np.eye(3))[1].ravel()[0])]
    angle = math.radians(angle_deg)
    n = steps if steps is not None else steps_for(abs(angle), 0.5 * design.max_step)
    targets = about_axis(axis, angle, n, start=start)
    return plan_geometric(design, targets)


def write_plan_outputs(design: MotorDesign, plan, axis: np.ndarray, out: Path) -> list[Path]:
    """Plan (CSV, JSON) and its figures into ``out``; returns the paths written."""
    written = [out / "plan.csv", out / "plan.json"]
    plan.to_csv(written[0])
    plan.to_json(written[1])
    figures = {
        "commutation_steps.png": plots.figure_steps(design, plan, axis),
        "motor_3d.png": plots.figure_motor_3d(design, plan.steps[0].achieved),
        "plan_error.png": plots.figure_plan_error(plan),
    }
    for name, fig in figures.items():
        written.append(plots.save_figure(fig, out / name))
    return written


def plan_summary(plan) -> dict:
    """Counts and errors of a plan (degrees)."""
    err = np.degrees(plan.errors)
    achieved = plan.achieved
    return {
        "steps": len(plan.steps) - 1,
        "moves": int(np.sum(so3.distance(achieved[:-1], achieved[1:]) > 0)),
        "settle_steps": sum(s.status.startswith("settle") for s in plan.steps),
        "holds": sum(s.status == "hold" for s in plan.steps),
        "detours": sum(s.status.startswith("detour") for s in plan.steps),
        "blocked": len(plan.failures),
        "error_median_deg": float(np.median(err)),
        "error_max_deg": float(err.max()),
        "error_final_deg": float(err[-1]),
        "max_coils_per_step": max(len(s.coils) for s in plan.steps),
    }


@app.command()
def demo(
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    axis: str = typer.Option(DEMO_AXIS, "--axis", help="Rotation axis X,Y,Z (fixed frame)."),
    angle: float = typer.Option(360.0, "--angle", help="Rotation angle in degrees."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors."),
) -> None:
    """The main job on the built-in prototype: states, resolution, range, a commutated 360° turn about a
    tilted axis, and the plan, figures and HTML report (report.html) in the output folder.

    Example: [bold]spherestep demo --out spherestep-out[/bold]
    """
    from ..report import write_report  # plotly loads only when a report is written

    axis_vec = parse_vector(axis, "--axis")
    with Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console,
                  disable=quiet or as_json, transient=True) as progress:
        task = progress.add_task("building the prototype", total=None)
        design = prototype()
        progress.update(task, description="enumerating stepper states")
        design.states()
        progress.update(task, description="measuring resolution, range and escape directions")
        metrics = design.metrics()
        info = metrics_for_people(design, metrics)
        progress.update(task, description="commutating")
        plan = commutate(design, axis_vec, angle, None)
        progress.update(task, description="writing plan and figures")
        written = write_plan_outputs(design, plan, axis_vec, out)
        progress.update(task, description="writing the HTML report")
        written.append(Path(write_report(out / "report.html", design, metrics, plan, axis=axis_vec)["path"]))
    info["plan"] = plan_summary(plan) | {"axis": (axis_vec / np.linalg.norm(axis_vec)).tolist(), "angle_deg": angle}
    written.append(write_text(out / "summary.json", json.dumps(info, indent=1)))
    info["files"] = [str(p) for p in written]
    if as_json:
        print_json(info)
    elif not quiet:
        print_summary(info)
        p = info["plan"]
        console.print(f"commutated {angle:g}° about ({', '.join(f'{a:.3f}' for a in info['plan']['axis'])}): "
                      f"{p['steps']} steps, {p['moves']} moves, {p['holds']} holds, {p['blocked']} blocked; "
                      f"error median {p['error_median_deg']:.2f}°, max {p['error_max_deg']:.2f}°, "
                      f"final {p['error_final_deg']:.2f}°")
        console.print(f"wrote {len(written)} files to {out}/")


@app.command()
def plan(
    axis: str = typer.Option(..., "--axis", help="Rotation axis X,Y,Z in the fixed (stator) frame."),
    angle: float = typer.Option(..., "--angle", help="Rotation angle in degrees (sign gives the sense)."),
    steps: int = typer.Option(None, "--steps", min=1, max=100_000, help="Number of steps (default: half a max step each)."),
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the plan summary as JSON."),
    design_path: Path = typer.Option(None, "--design", help="Design file (YAML/TOML); default the built-in prototype."),
) -> None:
    """Commutate a rotation about an axis on the prototype (or --design FILE): plan CSV/JSON (relay masks) and figures.

    Example: [bold]spherestep plan --axis 0,1,1 --angle 90 --steps 20 --out plan90 --design mymotor.yaml[/bold]
    """
    axis_vec = parse_vector(axis, "--axis")
    design = prototype() if design_path is None else MotorDesign.load(design_path)
    result = commutate(design, axis_vec, angle, steps)
    written = write_plan_outputs(design, result, axis_vec, out)
    summary = plan_summary(result) | {"files": [str(p) for p in written]}
    if as_json:
        print_json(summary)
    else:
        console.print(f"{summary['steps']} steps: {summary['moves']} moves, {summary['holds']} holds, "
                      f"{summary['blocked']} blocked; final error {summary['error_final_deg']:.2f}°; "
                      f"wrote {len(written)} files to {out}/")
