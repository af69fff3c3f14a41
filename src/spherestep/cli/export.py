"""``spherestep export FILE --out DIR``: manufacturing tables and the 3-D layout of a design."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import app
from .common import input_file

FILES = ("magnets.csv", "coils.csv", "layout.json", "layout.stl", "spherestep_config.h")


@app.command("export")
def export(
    file: Path = typer.Argument(..., help="Design file (.yaml, .yml or .toml)."),
    out: Path = typer.Option(..., "--out", help="Output folder (created if missing)."),
    unit: str = typer.Option("mm", "--unit", help="Length unit of the tables and the STL: mm or in."),
    sphere: bool = typer.Option(False, "--sphere", help="Add the rotor ball to the STL."),
) -> None:
    """Magnet positions (magnets.csv), coil mounting axes and saddle angles (coils.csv), both in layout.json,
    the parts as an STL (layout.stl), and the firmware's coil constants for the design's winding
    (spherestep_config.h, for the Teensy sketch; docs/hardware.md); definitions in docs/design-files.md.

    Example: [bold]spherestep export mymotor.yaml --out build --unit in[/bold]
    """
    from ..errors import bad_value
    from ..export import UNITS, write_exports
    from ..motor import MotorDesign
    from ..outputs import Outputs, output_folder

    if unit not in UNITS:
        raise bad_value("--unit", f"one of {', '.join(UNITS)}", unit)
    out = output_folder(out, "--out")
    design = MotorDesign.load(input_file(file, "FILE"))
    with Outputs(out, FILES):
        written = write_exports(design, out, unit=unit, sphere=sphere)
    print(f"wrote {len(written)} files to {out}/: {len(design.rotor)} magnets, {len(design.stator)} coils, "
          f"unit {unit}")
