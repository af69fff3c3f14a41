"""``spherestep capability``: the torque the drive can give in every direction, over SO(3)."""

from __future__ import annotations

from pathlib import Path

import typer
from rich.table import Table

from ..outputs import output_folder
from .app import app
from .common import check_core, console, design_from, number, print_json, usable, write_json
from .progress import progress


@app.command()
def capability(
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    samples: int = typer.Option(1000, "--samples", callback=number("a whole number of orientations from 1 to "
                                                                   "200000", 1, 200_000),
                                help="Orientations drawn uniformly on SO(3)."),
    seed: int = typer.Option(0, "--seed", callback=number("a whole number ≥ 0 (a random seed)", 0, 2 ** 63 - 1),
                             help="Random seed of the orientations."),
    threshold: float = typer.Option(1.0, "--threshold", callback=number("N·m", 0, 1000, what="a torque"),
                                    help="Torque (N·m) whose coverage of SO(3) the plot marks."),
    core: str = typer.Option(None, "--core", callback=check_core,
                             help="air or iron: override the core the design file states (default: the design's)."),
    out: Path = typer.Option(Path("spherestep-capability"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Torque available in every direction (N·m) and the conditioning of the torque-per-current matrix over SO(3),
    on the design's own torque model (its coil's core and winding, 24 V / 100 W supply): percentiles, coverage, a
    map (capability.png) and a summary (capability.json).

    Example: [bold]spherestep capability --samples 2000 --out cap[/bold]
    """
    from .. import plots
    from ..control import figure_capability, torque_capability
    from ..magnetics import design_model
    from ..outputs import Outputs

    out = output_folder(out, "--out")  # before the work: a bad location costs nothing
    design = usable(design_from(design_path), path=design_path)
    with progress("building the torque model", enabled=not as_json) as say:
        own = design_model(design, core)
        say(f"mapping the torque capability at {samples} orientations ({own.label})")
        cap = torque_capability(design, own.model, own.limits, samples=int(samples), seed=seed)
        say("writing capability.json and capability.png")
        summary = {"model": own.label} | cap.to_dict() | {"threshold_N_m": threshold,
                                                           "fraction_at_threshold": cap.fraction_at_least(threshold)}
        with Outputs(out, ("capability.json", "capability.png")):  # complete or absent (Ctrl-C, a full disk)
            written = [write_json(out / "capability.json", summary),
                       plots.save_figure(figure_capability(cap, threshold), out / "capability.png")]
    if as_json:
        print_json(summary | {"files": [str(p) for p in written]})
        return
    table = Table(title=f"torque capability over SO(3), {len(cap.radius)} uniform orientations, model {own.label}")
    table.add_column("percentile", justify="right")
    table.add_column("torque in every direction (N·m)", justify="right")
    table.add_column("σ_min of K (N·m per unit current)", justify="right")
    table.add_column("condition number", justify="right")
    r, s, k = summary["available_torque_N_m"], summary["sigma_min_N_m_per_unit_current"], summary["condition_number"]
    for q in r:
        table.add_row(f"{q}", f"{r[q]:.3f}", f"{s[q]:.3f}", f"{k[q]:.2f}")
    console.print(table)
    for key, frac in summary["fraction_at_least"].items():
        console.print(f"at least {key.replace('_N_m', ' N·m')} in every direction: {100 * frac:.1f} % of SO(3)")
    console.print(f"wrote {len(written)} files to {out}/")
