"""``spherestep sense``: the magnetometer array for a design, and how well it knows the rotor's orientation."""

from __future__ import annotations

import math

from pathlib import Path

import typer
from rich.table import Table

from ..outputs import output_folder
from .app import app
from .common import console, design_from, number, print_json, usable, write_json
from .progress import progress


@app.command()
def sense(
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    sensors: int = typer.Option(24, "--sensors", callback=number("a whole number of sensors from 1 to 200", 1, 200),
                                help="Number of 3-axis magnetometers (TMAG5273A2) placed greedily."),
    samples: int = typer.Option(100, "--samples", callback=number("a number of orientations from 1 to 10000", 1,
                                                                  10_000),
                                help="Orientations drawn uniformly on SO(3) for the accuracy estimate."),
    marked: bool = typer.Option(False, "--marked", help="Reverse one pole's polarity so the field has no symmetry."),
    seed: int = typer.Option(0, "--seed", callback=number("a whole number", 0), help="Random seed."),
    out: Path = typer.Option(Path("spherestep-sense"), "--out", help="Output folder (sensors.json)."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Place magnetometers in the stator (greedy, worst-case Fisher information over SO(3)), then estimate the
    rotor's orientation from simulated readings (magpylib, sensor noise, 4 coils energised and subtracted):
    RMS and worst error (degrees) against the Cramér–Rao bound. Writes the layout and results to sensors.json.

    Example: [bold]spherestep sense --sensors 12 --samples 200 --out sense[/bold]
    """
    import numpy as np

    from .. import sensing

    out = output_folder(out, "--out")  # before the work: a bad location costs nothing
    design = usable(design_from(design_path), path=design_path)
    if marked:
        design = sensing.marked_design(design)
    with progress(f"placing {sensors} magnetometers", enabled=not as_json) as say:
        placement = sensing.greedy_placement(design, int(sensors))
        array = placement.array()
        say(f"estimating the orientation at {samples} orientations")
        acc = sensing.accuracy(design, array, samples=int(samples), seed=seed)
        group = len(sensing.symmetry_group(design))
    summary = {"design": design.name, "part": array.part.to_dict(), "sensors": len(array),
               "symmetry_group_order": group, "worst_case_bound_deg": float(placement.bound_deg()[-1]),
               "accuracy": acc.to_dict(), "positions_m": array.positions.tolist(),
               "latitude_longitude_deg": np.degrees(np.stack([
                   np.arcsin(array.positions[:, 2] / np.linalg.norm(array.positions, axis=1)),
                   np.arctan2(array.positions[:, 1], array.positions[:, 0])], axis=1)).tolist()}
    written = write_json(out / "sensors.json", summary)
    if as_json:
        print_json(summary | {"files": [str(written)]})
        return
    table = Table(title=f"{design.name}: {len(array)} × {array.part.name}, {acc.samples} uniform orientations")
    for col in ("RMS error (°)", "worst error (°)", "Cramér–Rao RMS (°)", "worst-case bound (°)",
                "coil residual (µT RMS)", "time per estimate (ms)"):
        table.add_column(col, justify="right")
    table.add_row(f"{math.degrees(acc.rms):.4f}", f"{math.degrees(acc.worst):.4f}",
                  f"{math.degrees(acc.predicted_rms):.4f}",
                  f"{summary['worst_case_bound_deg']:.4f}", f"{acc.coil_residual_T * 1e6:.1f}",
                  f"{acc.seconds_per_estimate * 1e3:.2f}")
    console.print(table)
    if group > 1:
        console.print(f"the rotor's field is invariant under {group} rotations: from no prior the orientation is "
                      "known only up to them (use --marked, or track from a known start)")
    console.print(f"wrote {written}")
