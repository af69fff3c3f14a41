"""``spherestep packings`` (the table of distinct packings) and ``spherestep packing NAME`` (export one)."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import app
from .common import console, print_json, write_json

MAX_TARGET = 5000  # caps; about what the design files' most refinement levels (4) give


@app.command()
def packings(
    all_: bool = typer.Option(False, "--all", help="List all 21 constructions, redundant ones too."),
    as_json: bool = typer.Option(False, "--json", help="Print JSON instead of a table."),
) -> None:
    """Table of the distinct packings of congruent kissing caps (Sec. II-B-3).

    Example: [bold]spherestep packings --json[/bold]
    """
    from rich.table import Table

    from .. import packing as pk

    base = pk.semiregular()
    rows = base if all_ else sorted(pk.distinct(base), key=lambda p: ("TOI".index(p.family), len(p)))
    data = [p.summary() for p in rows]
    if as_json:
        print_json({"count": len(rows), "constructions": len(base), "packings": data})
        return
    table = Table(title=f"{len(rows)} distinct packings of {len(base)} constructions" if not all_ else "21 constructions")
    table.add_column("name", no_wrap=True)
    for col in ("family", "caps", "radius°", "density", "min sep°", "sym"):
        table.add_column(col, justify="left" if col == "family" else "right", no_wrap=True)
    for d in data:
        table.add_row(d["name"], d["family"], str(d["caps"]), f"{d['radius_max_deg']:.4f}", f"{d['density']:.4f}",
                      f"{d['min_separation_deg']:.4f}", str(d["symmetry_order"]))
    console.print(table)


@app.command()
def packing(
    name: str = typer.Argument(..., help="A packing name, e.g. truncated-icosahedron (see `spherestep packings --all`)."),
    refine: int = typer.Option(None, "--refine", min=0, help="Refinement levels (fill every hole K times), at most "
                                                           "as many as design files allow (4)."),
    target: int = typer.Option(None, "--target", min=1, max=MAX_TARGET, help=f"Refine until at least N caps "
                                                                             f"(N ≤ {MAX_TARGET})."),
    radius: str = typer.Option("1 m", "--radius", help='Sphere radius with unit, e.g. "6 in"; x, y, z use its unit.'),
    out: Path = typer.Option(..., "--out", help="Output file, .csv or .json."),
) -> None:
    """Export one packing's cap centres: φ, θ (degrees), x, y, z (in the radius' unit) and angular radius.

    Example: [bold]spherestep packing truncated-icosahedron --refine 1 --radius "6 in" --out rotor.csv[/bold]
    """
    import numpy as np

    from .. import packing as pk
    from ..atomic import write_text
    from ..design_file import MAX_REFINE
    from ..errors import bad_value
    from ..outputs import Outputs, output_file
    from ..sphere import angles
    from ..units import in_unit, length_and_unit

    if refine is not None and target is not None:
        raise bad_value("--refine/--target", "only one of the two", "both")
    if refine is not None and refine > MAX_REFINE:
        raise bad_value("--refine", f"0..{MAX_REFINE} refinement levels, as in design files (each level roughly "
                        "triples the caps)", refine)
    metres, unit = length_and_unit(radius, "--radius", unit_required=True)
    if not (np.isfinite(metres) and metres > 0):
        raise bad_value("--radius", 'a finite positive length such as "6 in"', radius)
    out = output_file(out, "--out", suffixes=(".csv", ".json"))
    p = pk.by_name(name)
    if refine is not None or target is not None:
        p = pk.refine(p, levels=refine, target=target)
    phi, theta = angles(p.centers)
    xyz = in_unit(metres, unit) * p.centers
    rows = np.column_stack([np.degrees(np.mod(phi, 2 * np.pi)), np.degrees(theta), xyz, np.degrees(p.radii)])
    with Outputs(out.parent, [out.name]):
        if out.suffix.lower() == ".csv":
            lines = [f"phi_deg,theta_deg,x_{unit},y_{unit},z_{unit},radius_deg"]
            lines += [",".join(f"{v:.12g}" for v in row) for row in rows]
            write_text(out, "\n".join(lines) + "\n")
        else:
            write_json(out, {"name": p.label, "family": p.family, "unit": unit, "caps": [
                dict(zip(("phi_deg", "theta_deg", "x", "y", "z", "radius_deg"), map(float, row))) for row in rows]})
    console.print(f"wrote {len(p)} caps of {p.label} to {out}")
