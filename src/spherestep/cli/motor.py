"""``spherestep demo`` (the main job on the built-in prototype) and ``spherestep plan``."""

from __future__ import annotations

import csv
import io
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
STEP_FRACTION = 0.35  # default desired step, as a fraction of the max step (finer steps land more reliably)


def metrics_for_people(design: MotorDesign, metrics) -> dict:
    """The design's summary and :class:`~spherestep.motor.metrics.DesignMetrics` with angles in degrees."""
    out = design.summary() | metrics.to_dict(degrees=True)
    states = out.pop("escape_violations") or []
    out["escape_violations"] = len(states)
    out["escape_violation_states"] = states[:50]
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


def design_from(path: Path | None) -> MotorDesign:
    """The design in the file at ``path``, or the built-in prototype."""
    return prototype() if path is None else MotorDesign.load(path)


def targets_for(design: MotorDesign, axis: np.ndarray, angle_deg: float, steps: int | None) -> np.ndarray:
    """A turn of ``angle_deg`` about ``axis`` from the stepper state nearest the identity, at ``steps`` equal
    steps (default: steps of :data:`STEP_FRACTION` of a max step)."""
    if not math.isfinite(angle_deg) or angle_deg == 0 or abs(angle_deg) > 36000:
        raise bad_value("--angle", "a non-zero angle in degrees, at most 36000 in size", angle_deg)
    states = design.states()
    start = states.rotations[int(states.nearest(np.eye(3))[1].ravel()[0])]
    angle = math.radians(angle_deg)
    n = steps if steps is not None else steps_for(abs(angle), STEP_FRACTION * design.max_step)
    return about_axis(axis, angle, n, start=start)


def commutate(design: MotorDesign, axis: np.ndarray, angle_deg: float, steps: int | None,
              planner: str = "geometric"):
    """Plan a turn (see :func:`targets_for`) with the geometric or the potential planner."""
    targets = targets_for(design, axis, angle_deg, steps)
    if planner == "potential":
        from ..commutation import plan_potential
        from ..potential import MotorPotential

        return plan_potential(design, targets, MotorPotential(design))
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


def trajectory_csv(sim, axis) -> str:
    """Time, unit quaternion (w, x, y, z), angular velocity, angle turned about the axis, energised coils."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(sim.orientations).as_quat(scalar_first=True)
    angle = np.degrees(so3.turned_angle(sim.orientations, axis))
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["t_s", "qw", "qx", "qy", "qz", "wx_rad_s", "wy_rad_s", "wz_rad_s", "turned_deg", "coils"])
    for t, qq, om, a, c in zip(sim.times, q, sim.angular_velocity, angle, sim.active_coils):
        coils = ";".join(f"{k}:{int(c[k]):+d}" for k in np.flatnonzero(c))
        w.writerow([f"{t:.6f}", *(f"{x:.12f}" for x in qq), *(f"{x:.9f}" for x in om), f"{a:.6f}", coils])
    return buf.getvalue()


def simulate_plan(design: MotorDesign, plan, axis: np.ndarray, out: Path, physics=None, tuning=None):
    """Run ``plan`` on the rotor under the magnets' torque map (tuned damping and dwell); write
    ``trajectory.csv`` and ``simulation.png``. Returns ``(simulation, summary dict, paths written)``."""
    from ..dynamics import simulate, tune
    from ..magnetics import torque_map

    physics = torque_map(design) if physics is None else physics
    tuning = tune(design, physics) if tuning is None else tuning
    sim = simulate(design, plan, physics, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    written = [write_text(out / "trajectory.csv", trajectory_csv(sim, axis)),
               plots.save_figure(plots.figure_simulation(sim, plan, axis, tuning.dwell), out / "simulation.png")]
    err = np.degrees(sim.step_errors)
    summary = {"steps": len(plan.steps) - 1, "executed": sim.executed, "dwell_s": tuning.dwell,
               "damping_N_m_s": tuning.rotor.damping, "settled_error_median_deg": float(np.median(err)),
               "settled_error_max_deg": float(err.max()),
               "steps_off_by_more_than_0_5_deg": sim.missed_steps.tolist(),
               "final_error_to_target_deg": math.degrees(float(so3.distance(sim.settled[-1], plan.targets[-1]))),
               "simulated_s": float(sim.times[-1])}
    return sim, summary, written


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
        progress.update(task, description="simulating the plan on the magnets' torque map")
        sim, info["simulation"], more = simulate_plan(design, plan, axis_vec, out)
        written += more
        progress.update(task, description="writing the HTML report")
        written.append(Path(write_report(out / "report.html", design, metrics, plan, simulation=sim,
                                         axis=axis_vec)["path"]))
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
        r = info["simulation"]
        console.print(f"simulated {r['simulated_s']:.0f} s on the magnets' torque map: {r['steps'] - len(r['steps_off_by_more_than_0_5_deg'])} "
                      f"of {r['steps']} steps settled within 0.5° of the plan (median {r['settled_error_median_deg']:.2f}°, "
                      f"max {r['settled_error_max_deg']:.2f}°); final pose {r['final_error_to_target_deg']:.2f}° from the target")
        console.print(f"wrote {len(written)} files to {out}/")


@app.command()
def plan(
    axis: str = typer.Option(..., "--axis", help="Rotation axis X,Y,Z in the fixed (stator) frame."),
    angle: float = typer.Option(..., "--angle", help="Rotation angle in degrees (sign gives the sense)."),
    steps: int = typer.Option(None, "--steps", min=1, max=100_000, help="Number of steps (default: 0.35 of a max step each)."),
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the plan summary as JSON."),
    design_path: Path = typer.Option(None, "--design", help="Design file (YAML/TOML); default the built-in prototype."),
) -> None:
    """Commutate a rotation about an axis on the prototype (or --design FILE): plan CSV/JSON (relay masks) and figures.

    Example: [bold]spherestep plan --axis 0,1,1 --angle 90 --steps 20 --out plan90 --design mymotor.yaml[/bold]
    """
    axis_vec = parse_vector(axis, "--axis")
    design = design_from(design_path)
    result = commutate(design, axis_vec, angle, steps)
    written = write_plan_outputs(design, result, axis_vec, out)
    summary = plan_summary(result) | {"files": [str(p) for p in written]}
    if as_json:
        print_json(summary)
    else:
        console.print(f"{summary['steps']} steps: {summary['moves']} moves, {summary['holds']} holds, "
                      f"{summary['blocked']} blocked; final error {summary['error_final_deg']:.2f}°; "
                      f"wrote {len(written)} files to {out}/")
