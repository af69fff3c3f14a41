"""``spherestep demo`` (the main job on the built-in prototype) and ``spherestep plan``."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer

from .app import app
from .common import check_axis, console, design_from, number, parse_vector, print_json, usable, write_json

DEMO_AXIS = "1,0.5,2"
SHOWN_ESCAPE_STATES = 50  # escape-violating states listed on stdout (all of them are in summary.json)
PLAN_FILES = ("plan.csv", "plan.json", "commutation_steps.png", "motor_3d.png", "plan_error.png")
SIMULATION_FILES = ("trajectory.csv", "simulation.png")
ANGLE = number("a non-zero angle in degrees, at most 36000 (100 turns) in size", -36_000, 36_000, nonzero=True)


def metrics_for_people(design, metrics) -> dict:
    """The design's summary and :class:`~spherestep.motor.metrics.DesignMetrics` with angles in degrees: the
    count of escape-violating states and every one of them listed."""
    out = design.summary() | metrics.to_dict(degrees=True)
    states = out.pop("escape_violations") or []
    out["escape_violations"] = len(states)
    out["escape_violation_states"] = states
    return out


def print_summary(info: dict) -> None:
    """Rich table of a design's summary and metrics."""
    from rich.table import Table

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


def warn(text: str) -> None:
    """A warning on stderr: the result exists but must not be taken for a clean success."""
    print(f"spherestep: warning: {text}", file=sys.stderr)


def write_plan_files(design, plan, axis, out: Path) -> None:
    """The plan (CSV, JSON) and its figures (:data:`PLAN_FILES`) into ``out``."""
    from .. import plots

    plan.to_csv(out / "plan.csv")
    plan.to_json(out / "plan.json")
    plots.save_figure(plots.figure_steps(design, plan, axis), out / "commutation_steps.png")
    plots.save_figure(plots.figure_motor_3d(design, plan.steps[0].achieved), out / "motor_3d.png")
    plots.save_figure(plots.figure_plan_error(plan), out / "plan_error.png")


def simulate_and_write(design, plan, axis, out: Path, physics=None, tuning=None):
    """Run ``plan`` on the rotor under the magnets' torque map (tuned damping, dwell and time step); write
    :data:`SIMULATION_FILES`. Returns ``(simulation, summary dict)``."""
    from .. import plots, so3
    from ..dynamics import simulate, tune
    from ..magnetics import torque_map

    physics = torque_map(design) if physics is None else physics
    tuning = tune(design, physics) if tuning is None else tuning
    sim = simulate(design, plan, physics, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    sim.to_csv(out / "trajectory.csv", axis)
    plots.save_figure(plots.figure_simulation(sim, plan, axis, tuning.dwell), out / "simulation.png")
    summary = sim.summary() | {
        "dwell_s": tuning.dwell, "damping_N_m_s": tuning.rotor.damping,
        "final_error_to_target_deg": math.degrees(float(so3.distance(sim.settled[-1], plan.targets[-1])))}
    return sim, summary


@app.command()
def demo(
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    axis: str = typer.Option(DEMO_AXIS, "--axis", callback=check_axis, help="Rotation axis X,Y,Z (fixed frame)."),
    angle: float = typer.Option(360.0, "--angle", callback=ANGLE, help="Rotation angle in degrees."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON (the escape-violating states "
                                                       f"cut to the first {SHOWN_ESCAPE_STATES}, as it says; all "
                                                       "in summary.json)."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors."),
) -> None:
    """The main job on the built-in prototype: states, resolution, range, a commutated 360° turn about a
    tilted axis, and the plan, figures and HTML report (report.html) in the output folder.

    Example: [bold]spherestep demo --out spherestep-out[/bold]
    """
    from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    from ..commutation import turn
    from ..motor import prototype
    from ..outputs import Outputs, output_folder

    out = output_folder(out, "--out")
    axis_vec = parse_vector(axis, "--axis")
    from ..report import write_report  # plotly loads once the command line is known to be good
    files = Outputs(out, PLAN_FILES + SIMULATION_FILES + ("report.html", "summary.json"))
    with files, Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=console,
                         disable=quiet or as_json, transient=True) as progress:
        task = progress.add_task("building the prototype", total=None)
        design = prototype()
        progress.update(task, description="enumerating stepper states")
        design.states()
        progress.update(task, description="measuring resolution, range and escape directions")
        metrics = design.metrics()
        info = metrics_for_people(design, metrics)
        progress.update(task, description="commutating")
        plan = turn(design, axis_vec, angle)
        progress.update(task, description="writing plan and figures")
        write_plan_files(design, plan, axis_vec, out)
        progress.update(task, description="simulating the plan on the magnets' torque map")
        sim, info["simulation"] = simulate_and_write(design, plan, axis_vec, out)
        progress.update(task, description="writing the HTML report")
        write_report(out / "report.html", design, metrics, plan, simulation=sim, axis=axis_vec)
        summary = plan.summary(max_step=design.max_step)
        info["plan"] = summary.to_dict() | {"axis": (axis_vec / math.sqrt(axis_vec @ axis_vec)).tolist(),
                                            "angle_deg": angle}
        info["files"] = [str(p) for p in files.paths]
        write_json(out / "summary.json", info)
    for text in summary.warnings:
        warn(text)
    shown = info["escape_violation_states"][:SHOWN_ESCAPE_STATES]
    if len(shown) < info["escape_violations"]:
        info["escape_violation_states"] = shown
        info["escape_violation_states_note"] = (f"the first {len(shown)} of {info['escape_violations']}; all of "
                                                f"them in {out / 'summary.json'}")
    if as_json:
        print_json(info)
    elif not quiet:
        print_summary(info)
        axis_text = ", ".join(f"{a:.3f}" for a in info["plan"]["axis"])
        console.print(f"commutated {angle:g}° about ({axis_text}): {summary.line()}")
        r = info["simulation"]
        console.print(f"simulated {r['simulated_s']:.0f} s on the magnets' torque map: "
                      f"{r['steps'] - len(r['missed_steps'])} of {r['steps']} steps settled within "
                      f"{r['tolerance_deg']:g}° of the plan (median {r['settled_error_median_deg']:.2f}°, max "
                      f"{r['settled_error_max_deg']:.2f}°); final pose {r['final_error_to_target_deg']:.2f}° from "
                      "the target")
        console.print(f"wrote {len(files.paths)} files to {out}/")


@app.command()
def plan(
    axis: str = typer.Option(..., "--axis", callback=check_axis, help="Rotation axis X,Y,Z in the fixed (stator) "
                                                                      "frame."),
    angle: float = typer.Option(..., "--angle", callback=ANGLE, help="Rotation angle in degrees (sign gives the "
                                                                     "sense)."),
    steps: int = typer.Option(None, "--steps", callback=number("a whole number of steps, 1 to 100000", 1, 100_000),
                              help="Number of steps (default: each 0.35 of a max step; a step longer than the "
                                   "design's max step is warned about)."),
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the plan summary as JSON."),
    design_path: Path = typer.Option(None, "--design", help="Design file (YAML/TOML); default the built-in prototype."),
) -> None:
    """Commutate a rotation about an axis on the prototype (or --design FILE): plan CSV/JSON (relay masks) and figures.

    The summary counts the steps asked for; `spherestep run` streams one frame more (the start is held too).

    Example: [bold]spherestep plan --axis 0,1,1 --angle 90 --steps 20 --out plan90 --design mymotor.yaml[/bold]
    """
    from ..commutation import turn
    from ..outputs import Outputs, output_folder

    out = output_folder(out, "--out")
    axis_vec = parse_vector(axis, "--axis")
    design = usable(design_from(design_path), "--design", design_path)
    result = turn(design, axis_vec, angle, steps)
    files = Outputs(out, PLAN_FILES)
    with files:
        write_plan_files(design, result, axis_vec, out)
    summary = result.summary(max_step=design.max_step)
    for text in summary.warnings:
        warn(text)
    if as_json:
        print_json(summary.to_dict() | {"files": [str(p) for p in files.paths]})
    else:
        console.print(f"{summary.line()}; wrote {len(files.paths)} files to {out}/")
