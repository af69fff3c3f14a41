"""``spherestep design new | validate | show``: write, check and summarise design files."""

from __future__ import annotations

from pathlib import Path

import typer

from ..errors import InputError, bad_value
from .app import app
from .common import console, input_file, print_json, usable

design_app = typer.Typer(
    name="design",
    help="Design files (YAML, or TOML to read): a motor's poles, coils, dimensions and wiring "
         "(docs/design-files.md).\n\nExample: [bold]spherestep design new mymotor.yaml[/bold]",
    no_args_is_help=True,
    rich_markup_mode="rich",
)
app.add_typer(design_app, name="design")


@design_app.command("new")
def new(
    file: Path = typer.Argument(..., help="Design file to write (.yaml or .yml)."),
    source: str = typer.Option("prototype", "--from", help="'prototype' (the built-in design, with comments) or "
                                                         "an existing design file to copy."),
    force: bool = typer.Option(False, "--force", help="Overwrite FILE if it exists."),
    core: str = typer.Option(None, "--core", help="The coils' core, air or iron (default: as in --from; the "
                                                  "prototype's are iron); the winding and supply stay."),
) -> None:
    """Write a starting design file.

    Example: [bold]spherestep design new mymotor.yaml --from prototype --core air[/bold]
    """
    from dataclasses import replace

    from .. import design_file
    from ..atomic import write_text
    from ..motor import MotorDesign
    from ..outputs import Outputs, output_file

    if core is not None and core not in ("air", "iron"):
        raise bad_value("--core", "air or iron", core)
    if file.suffix.lower() == ".toml":
        raise InputError(f"FILE {str(file)!r}: design files are written as YAML; use a name ending in .yaml")
    file = output_file(file, "FILE", suffixes=(".yaml", ".yml"), force=force)
    if source == "prototype":
        text = design_file.prototype_text()
        design = MotorDesign.loads(text, source="prototype")
    else:
        design = MotorDesign.load(input_file(Path(source), "--from"))
        text = design.dumps()
    if core is not None and core != design.coil.core:
        design = replace(design, coil=replace(design.coil, core=core))
        text = design.dumps()
    with Outputs(file.parent, [file.name], "FILE"):
        write_text(file, text)
    print(f"wrote {file}: design {design.name!r}, {len(design.rotor)} poles, {len(design.stator)} coils "
          f"({design.coil.core} core)")


@design_app.command("validate")
def validate(file: Path = typer.Argument(..., help="Design file (.yaml, .yml or .toml).")) -> None:
    """Check a design file: 'valid: N poles, M coils' and, for iron cores, the rotor shell and where the iron
    model comes from (the stored tables' ranges) (exit 0), or one line naming the field and the fix (exit 2).
    Every check a command runs on a design is run here, stepper states included.

    Example: [bold]spherestep design validate mymotor.yaml[/bold]
    """
    from ..motor import MotorDesign

    from ..magnetics import iron_source

    design = usable(MotorDesign.load(input_file(file, "FILE")), "FILE", file)
    print(f"valid: {len(design.rotor)} poles, {len(design.stator)} coils")
    if design.coil.core == "iron":
        print(f"iron: rotor shell {design.rotor_shell * 1e3:.5g} mm; model from {iron_source(design, design.coil)}")


def _cell(value) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return ", ".join(_cell(v) for v in value) or "none"
    return str(value)


@design_app.command("show")
def show(
    file: Path = typer.Argument(..., help="Design file (.yaml, .yml or .toml)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Summary of a design: packings, pole and coil counts, dimensions (mm), tolerance and step (degrees), and
    the coil as built (core, turns, resistance, nominal current, ampere-turns, power per coil, supply).

    Example: [bold]spherestep design show mymotor.yaml --json[/bold]
    """
    from rich.table import Table

    from ..motor import MotorDesign

    info = MotorDesign.load(input_file(file, "FILE")).summary()
    if as_json:
        print_json(info)
        return
    # the title on its own line, never wrapped (a table's title breaks a long file name mid-word)
    console.print(f"{info['name']} ({file})", soft_wrap=True, markup=False, highlight=False)
    table = Table()
    table.add_column("field", no_wrap=True)
    table.add_column("value", justify="right", no_wrap=True)
    for key, value in info.items():
        if isinstance(value, dict):  # the coil as built
            for name, item in value.items():
                table.add_row(f"{key} {name}", _cell(item))
        else:
            table.add_row(key, _cell(value))
    console.print(table)
