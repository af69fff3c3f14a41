"""``spherestep demo`` (the main job on the built-in prototype) and ``spherestep plan``."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer

from .app import app
from .progress import progress
from .common import check_axis, console, design_from, number, parse_vector, print_json, usable

DEMO_AXIS = "1,0.5,2"
SHOWN_ESCAPE_STATES = 50  # escape-violating states listed on stdout (all of them are in summary.json)
ANGLE = number("a non-zero angle in degrees, at most 36000 (100 turns) in size", -36_000, 36_000, nonzero=True)


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


@app.command()
def demo(
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    axis: str = typer.Option(DEMO_AXIS, "--axis", callback=check_axis, help="Rotation axis X,Y,Z (fixed frame)."),
    angle: float = typer.Option(None, "--angle", callback=ANGLE, help="Rotation angle in degrees (default 360; "
                                                                     "90 with --quick)."),
    quick: bool = typer.Option(False, "--quick", help="A reduced run of the same job (a 90° turn, fewer capability "
                                                      "samples and relay rates): about 50 s."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON (the escape-violating states "
                                                       f"cut to the first {SHOWN_ESCAPE_STATES}, as it says; all "
                                                       "in summary.json)."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors."),
) -> None:
    """The main job on the built-in prototype (iron-cored coils, as the paper's): states, resolution, range,
    torque capability over SO(3), a commutated 360° turn about a tilted axis driven three ways (the paper's settled
    relay steps, ramped relay steps, the current-controlled servo) on the rotor's dynamics — on the design's own
    model (iron) and on air-cored coils for comparison — and the plan, figures, drives.json and the HTML report
    (report.html) in the output folder. Each drive is judged as `move` judges it (--tolerance's defaults) and the
    table, the console and summary.json's drives_judged say which did not do what they report; the demo still
    exits 0 then (a drive that fails to arrive is one of its results).

    Example: [bold]spherestep demo --out spherestep-out[/bold]
    """
    from ..demo import (DEMO_FILES, calibration_line, drive_lines, drives_judged_line, potential_plan_line,
                        robustness_line, run_demo)
    from ..motor import prototype
    from ..outputs import Outputs, output_folder

    out = output_folder(out, "--out")
    axis_vec = parse_vector(axis, "--axis")
    files = Outputs(out, DEMO_FILES)
    with files, progress("building the prototype", enabled=not (quiet or as_json)) as say:
        angle = (90.0 if quick else 360.0) if angle is None else angle
        info = run_demo(prototype(), out, axis_vec, angle, progress=say, quick=quick)
    for text in info["plan"].get("warnings", []):
        warn(text)
    states = info.pop("escape_violations") or []
    info["escape_violations"] = len(states)
    info["escape_violation_states"] = states[:SHOWN_ESCAPE_STATES]
    if len(states) > SHOWN_ESCAPE_STATES:
        info["escape_violation_states_note"] = (f"the first {SHOWN_ESCAPE_STATES} of {len(states)}; all of them in "
                                                f"{out / 'summary.json'}")
    info["files"] = [str(p) for p in files.paths]
    if as_json:
        print_json(info)
    elif not quiet:
        print_summary(info)
        p = info["plan"]
        axis_text = ", ".join(f"{a:.3f}" for a in p["axis"])
        console.print(f"commutated {angle:g}° about ({axis_text}): {p['steps']} steps, final error "
                      f"{p['error_final_deg']:.2f}°")
        for cap in (info["capability"], info["capability_other"]):
            r = cap["available_torque_N_m"]
            console.print(f"torque model {cap['model']}: torque available in every direction median "
                          f"{r[50]:.2f} N·m, 5th percentile {r[5]:.2f} N·m")
        iron = info["iron"]
        console.print(f"iron-cored coils: detent peak {-iron['detent_peak_Nm']:.2f} N·m at "
                      f"{iron['detent_peak_angle_deg']:.1f}°; unpowered the rotor holds {iron['unpowered_minima']} of "
                      f"{iron['unpowered_starts']} random poses")
        for line in drive_lines(info["drives"]) + drive_lines(info["drives_other"]):
            console.print(line)
        console.print(drives_judged_line(info["drives_judged"]))
        console.print(potential_plan_line(info["potential_plan"]))
        if info["robustness"]:
            console.print(robustness_line(info["robustness"]))
        if info["calibration"]:
            console.print(calibration_line(info["calibration"]))
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
    planner: str = typer.Option("auto", "--planner", help="auto (iron on an iron-cored design, geometric on air), "
                                "geometric, potential or iron (the minima of the design's own energy)."),
    rate: float = typer.Option(None, "--rate", callback=number("a positive number of steps per second (Hz), at most "
                                                                "1000", 0, 1000, low_open=True),
                               help="The rate `spherestep run` will stream the plan at (Hz): the iron planner then "
                                    "chooses only masks that keep every coil within run's thermal limits (5 s on, "
                                    "half of any 30 s)."),
) -> None:
    """Commutate a rotation about an axis on the prototype (or --design FILE): plan CSV/JSON (relay masks) and figures.

    The summary counts the steps asked for; `spherestep run` streams one frame more (the start is held too).

    Example: [bold]spherestep plan --axis 0,1,1 --angle 90 --steps 20 --out plan90 --design mymotor.yaml[/bold]

    Example: [bold]spherestep plan --axis 0,0,1 --angle 30 --rate 0.8 --design examples/designs/relays-iron.yaml[/bold]
    """
    from ..drive import relay_plan, relay_planner
    from ..drive.turn import PLANNERS
    from ..errors import bad_value
    from ..outputs import Outputs, output_folder

    if planner not in PLANNERS:
        raise bad_value("--planner", f"one of {', '.join(PLANNERS)}", planner)
    out = output_folder(out, "--out")
    axis_vec = parse_vector(axis, "--axis")
    design = usable(design_from(design_path), "--design", design_path)
    planner = relay_planner(design, planner)
    if rate is not None and planner != "iron":
        raise bad_value("--rate", f"given only with the iron planner (the {planner} planner does not weigh the "
                        "coils' heat); drop --rate", rate)
    heat = {}
    if rate is not None:
        from ..hardware import ThermalLimits

        heat = {"thermal": ThermalLimits(), "rate": rate}
    result = relay_plan(design, axis_vec, math.radians(angle), steps, planner, **heat)
    from ..demo import PLAN_FILES, write_plan_files

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
