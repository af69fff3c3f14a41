"""``spherestep report``: one self-contained HTML report on a design and a commutated rotation."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from .app import app
from .common import check_axis, console, design_from, parse_vector, print_json, usable
from .motor import ANGLE, DEMO_AXIS
from .progress import progress


@app.command()
def report(
    file: Path = typer.Argument(None, help="Design file (YAML/TOML); default the built-in prototype."),
    out: Path = typer.Option(Path("report.html"), "-o", "--out", help="HTML file to write."),
    axis: str = typer.Option(DEMO_AXIS, "--axis", callback=check_axis, help="Rotation axis X,Y,Z of the commutation shown (fixed frame)."),
    angle: float = typer.Option(360.0, "--angle", callback=ANGLE, help="Rotation angle in degrees (sign gives the sense)."),
    as_json: bool = typer.Option(False, "--json", help="Print a JSON summary of what was written."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors."),
) -> None:
    """Write one HTML file that works offline: the motor in 3-D, packing and design metrics, the resolution
    histogram, and a commutated rotation as a table and an animation (Fig. 10 view and 3-D) with a step slider.

    Example: [bold]spherestep report mymotor.yaml -o report.html --axis 0,1,1 --angle 90[/bold]
    """
    from ..commutation import turn
    from ..outputs import Outputs, output_file

    out = output_file(out, "--out", suffixes=(".html", ".htm"))
    axis_vec = parse_vector(axis, "--axis")
    design = usable(design_from(file, "FILE"), "FILE", file)
    from ..report import write_report  # plotly loads once the command line is known to be good
    with progress("enumerating stepper states", enabled=not (quiet or as_json)) as say:
        plan = turn(design, axis_vec, math.radians(angle))
        with Outputs(out.parent, [out.name]):
            info = write_report(out, design, plan=plan, axis=axis_vec, progress=say)
    info |= {"design": design.name, "axis": (axis_vec / (axis_vec @ axis_vec) ** 0.5).tolist(), "angle_deg": angle}
    if as_json:
        print_json(info)
    elif not quiet:
        console.print(f"wrote {info['path']} ({info['bytes'] / 2 ** 20:.1f} MiB): {', '.join(info['sections'])}; "
                      f"{info.get('plan_steps', 0)} plan steps, {info['frames']} animation frames")
