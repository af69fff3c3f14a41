"""``spherestep gallery``: published spherical motors rebuilt as design files, measured by the same code."""

from __future__ import annotations

from pathlib import Path

import typer

from .app import app
from .common import console, number, print_json
from .progress import progress


def _deg(value) -> str:
    return "—" if value is None else f"{value:.2f}"


@app.command()
def gallery(
    as_json: bool = typer.Option(False, "--json", help="Print the whole table (sources, assumptions, metrics) as "
                                                      "JSON."),
    out: Path = typer.Option(None, "--out", help="Also write every design file, metrics.csv and gallery.json "
                                                 "into this folder."),
    measure: bool = typer.Option(False, "--measure", help="Measure every design now (about 50 s, the drive "
                                                          "included) instead of "
                                                          "printing the stored metrics."),
    samples: int = typer.Option(20_000, "--samples", callback=number("a whole number of orientations from 100 to 1000000",
                                                                     100, 1_000_000),
                                help="With --measure: orientations for the resolution."),
) -> None:
    """The gallery: our reading of the paper's prototype, the prototype as built at Johns Hopkins (80 magnets,
    16 coils), NCSU's Goldberg stator, a dodecahedral hobby motor and a gimbal-sized design, each measured by the
    same code (states, resolution, range, torque in every direction on the design's own model, magnet mass,
    coil power); and published machines of another kind kept as targets. Sources and assumptions:
    docs/gallery.md or --json.

    Example: [bold]spherestep gallery --out gallery[/bold]
    """
    from rich.table import Table

    from .. import gallery as gal
    from ..outputs import Outputs, output_folder

    if out is not None:
        out = output_folder(out, "--out")  # before the work: a bad location costs nothing
    measured = None
    if measure:
        measured = {}
        with progress("measuring the gallery", enabled=not as_json) as say:
            for k, e in enumerate(gal.entries()):
                say(f"measuring {e.key}", done=k, total=len(gal.entries()))
                measured[e.key] = gal.measure(e, samples=int(samples))
    table = gal.gallery_table(measured)
    written = []
    if out is not None:
        names = [f"{e.key}.yaml" for e in gal.entries()] + ["metrics.csv", "gallery.json"]
        with Outputs(out, names):
            written = gal.write_gallery(out, measured)
    if as_json:
        print_json(table | {"measured_now": measure, "files": [str(p) for p in written]})
        return
    drive_known = any(row["metrics"] is not None and (row["metrics"]["servo_turn_s"] is not None or
                                                      row["metrics"]["relay_landed_fraction"] is not None)
                      for row in table["entries"])
    view = Table(title="gallery of spherical motors (" + ("measured now" if measure else "stored metrics") + ")")
    for col in ("design", "poles/coils", "core", "states", "res°", "p95°", "all", "τ N·m", "τ p5", "magnets kg",
                "W/coil") + (("drive",) if drive_known else ()):
        view.add_column(col, justify="left" if col in ("design", "core", "all", "drive") else "right",
                        no_wrap=col == "design")
    for row in table["entries"]:
        m = row["metrics"]
        if m is None:
            view.add_row(row["key"], *["—"] * (len(view.columns) - 1))
            continue
        turn = "—" if m["servo_turn_s"] is None else f"{m['servo_turn_s']:.3g} s"
        relay = "—" if m["relay_steps"] is None else f"{m['relay_steps_on_plan']}/{m['relay_steps']}"
        drive = (f"{turn}, {relay}",) if drive_known else ()
        view.add_row(row["key"], f"{m['rotor_poles']}/{m['coils']}", m["core"], str(m["states"]),
                     _deg(m["resolution_median_deg"]), _deg(m["resolution_p95_deg"]),
                     "yes" if m["reaches_all"] else "no", f"{m['torque_median_N_m']:.3g}",
                     f"{m['torque_p5_N_m']:.2g}", f"{m['magnet_mass_kg']:.3g}",
                     "—" if m["coil_power_W"] is None else f"{m['coil_power_W']:.3g}", *drive)
    for t in table["targets"]:
        view.add_row(t["key"], *["n/a"] * (len(view.columns) - 1))
    console.print(view)
    for t in table["targets"]:
        console.print(f"target {t['key']}: {'; '.join(t['requirements'].values())} ({t['kind']})")
    console.print("res°, p95°: resolution, median and 95th percentile of the distance to the nearest state; all: "
                  "reaches all of SO(3); τ: torque available in every direction over SO(3) on the design's own "
                  "model (median, 5th percentile); W/coil: one coil at nominal current" + ("; drive: the servo's fastest 360° "
                  "turn about (1, 0.5, 2) (s; — where the planner refused the model) and the settled relay plan's "
                  "steps that settled on the plan, of all" if drive_known else "; the fastest servo turn and relay stepping: pending the drive room "
                                     "(spherestep.gallery.drive_metrics)"))
    if written:
        console.print(f"wrote {len(written)} files to {out}/")
