"""``spherestep explore``: sweep rotor × stator packings on Dask, propose the Pareto set within a coil budget."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import typer

from ..errors import ComputationError, InputError, bad_value
from .app import app
from .common import check_core, console, number, print_json

OPTION_OF = {  # library field -> the option that sets it, so a refusal names what the user typed
    "rotors": "--rotors", "stators": "--stators", "rotor_levels": "--rotor-levels", "stator_levels": "--stator-levels",
    "cap_half_angles_deg": "--caps", "tolerances_deg": "--tols", "primary_ratio_max": "--primary-ratio",
    "samples": "--samples", "torque_states": "--holding-torque-states", "budget_coils": "--budget-coils",
    "max_rotor_poles": "--max-rotor-poles", "max_candidates": "--max-candidates",
    "max_lookup_voxels": "--max-lookup-voxels", "workers": "--workers", "scheduler": "--scheduler",
}


def _as_option(exc: InputError) -> InputError:
    """The library's error with its field (``exc.field``) renamed to the option that sets it."""
    text = str(exc)
    if exc.field in OPTION_OF and text.startswith(exc.field):
        error = InputError(OPTION_OF[exc.field] + text[len(exc.field):])
        error.field = OPTION_OF[exc.field]
        return error
    return exc


def _split(text: str, option: str, convert, example: str) -> tuple:
    items = [t.strip() for t in text.split(",")]
    try:
        values = tuple(convert(t) for t in items)
    except ValueError:
        raise bad_value(option, f"comma-separated values like {example}", text) from None
    if any(isinstance(v, float) and not math.isfinite(v) for v in values):
        raise bad_value(option, f"finite numbers like {example}", text)
    return values


def _names(text: str) -> str:
    if not text:
        raise ValueError(text)
    return text


def build_grid(quick: bool, rotors, stators, rotor_levels, stator_levels, caps, tols, primary_ratio, same_family,
               samples, torque_states, core=None):
    """The grid of the command line: the default or ``--quick`` one, with the given axes replaced (``core``:
    every design's coils, default iron as the prototype's)."""
    from ..explore.grid import default_grid, quick_grid

    changes = {"same_family": same_family}
    for value, field, option, convert, example in (
            (rotors, "rotors", "--rotors", _names, "truncated-icosahedron,dodecahedron"),
            (stators, "stators", "--stators", _names, "truncated-cuboctahedron,cube"),
            (rotor_levels, "rotor_levels", "--rotor-levels", int, "0,1,2"),
            (stator_levels, "stator_levels", "--stator-levels", int, "0,1"),
            (caps, "cap_half_angles_deg", "--caps", float, "60,80"),
            (tols, "tolerances_deg", "--tols", float, "0.5,1")):
        if value is not None:
            changes[field] = _split(value, option, convert, example)
    if primary_ratio is not None:
        if primary_ratio.strip().lower() == "none":
            changes["primary_ratio_max"] = None
        else:
            try:
                changes["primary_ratio_max"] = float(primary_ratio)
            except ValueError:
                raise bad_value("--primary-ratio", "a ratio of at least 1 (like 1.25), or 'none'", primary_ratio) \
                    from None
    if samples is not None:
        changes["samples"] = samples
    if torque_states is not None:
        changes["torque_states"] = torque_states
    if core is not None:
        changes["core"] = core
    try:
        return (quick_grid if quick else default_grid)(**changes)
    except InputError as exc:
        raise _as_option(exc) from None


def print_front(front, budget: int) -> None:
    """Rich table of the proposed designs (their files are numbered as the rows)."""
    from rich import box
    from rich.table import Table

    torque = "holding_torque_median_Nm" in front.columns and front["holding_torque_median_Nm"].notna().any()
    table = Table(title=f"Pareto set within {budget} coils (design files numbered as the rows)", box=box.SIMPLE_HEAD,
                  show_edge=False, pad_edge=False, collapse_padding=True)
    names = ["#", "rotor", "stator", "cap/tol", "coils", "median", "95%", "escape"] + (["hold N·m"] if torque else [])
    for name in names + ["families"]:
        table.add_column(name, justify="left" if name in ("rotor", "stator", "families") else "right", no_wrap=True)
    for rank, (_, row) in enumerate(front.iterrows(), start=1):
        cells = [str(rank), f"{row['rotor']}/L{row['rotor_level']}", f"{row['stator']}/L{row['stator_level']}",
                 f"{row['cap_half_angle_deg']:g}°/{row['tol_deg']:g}°", str(row["coils"]),
                 f"{row['resolution_median_deg']:.2f}°", f"{row['resolution_p95_deg']:.2f}°",
                 f"{100 * row['escape_violations'] / row['states']:.0f}%"]
        if torque:
            cells.append(f"{row['holding_torque_median_Nm']:.3f}")
        same = " same" if row["family_rule"] == "same" else ""
        cells.append(f"{row['rotor_family']}/{row['stator_family']}{same}")
        table.add_row(*cells)
    console.print(table)


@app.command()
def explore(
    out: Path = typer.Option(..., "--out", help="Output folder: results/ (Parquet parts, for resuming), results.csv, "
                                               "pareto.csv, pareto.png and designs/."),
    budget_coils: int = typer.Option(32, "--budget-coils", help="Most coils a proposed design may have (four 8-relay "
                                                               "boards drive 32, Sec. IV-B)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a running Dask scheduler, tcp://HOST:PORT "
                                                           "(its workers must have spherestep installed)."),
    threads: bool = typer.Option(False, "--threads", help="Local workers as threads in this process, not processes."),
    workers: int = typer.Option(None, "--workers", callback=number("a whole number of workers ≥ 1", 1), help="Local workers (processes, or threads with --threads); "
                                                       "default: the CPU count."),
    quick: bool = typer.Option(False, "--quick", help="A tiny grid (12 designs, seconds) instead of the default "
                                                     "one (648 designs, minutes)."),
    rotors: str = typer.Option(None, "--rotors", help="Rotor packings, comma-separated (default: the 16 distinct)."),
    stators: str = typer.Option(None, "--stators", help="Stator packings, comma-separated (default: the 16 distinct)."),
    rotor_levels: str = typer.Option(None, "--rotor-levels", help="Rotor refinement levels (default 0,1,2)."),
    stator_levels: str = typer.Option(None, "--stator-levels", help="Stator refinement levels (default 0,1)."),
    caps: str = typer.Option(None, "--caps", help="Stator cap half-angles in degrees (default 60,80)."),
    tols: str = typer.Option(None, "--tols", help="State tolerances in degrees (default 1)."),
    primary_ratio: str = typer.Option(None, "--primary-ratio", help="Largest ratio of rotor and stator primary "
                                                                   "circle radii (default 1.25; 'none': any)."),
    same_family: bool = typer.Option(True, "--same-family/--no-same-family",
                                     help="Keep rotor and stator pairs from one symmetry family, for contrast."),
    samples: int = typer.Option(None, "--samples", help="Random orientations per design for the resolution "
                                                       "(default 2000)."),
    torque_states: int = typer.Option(None, "--holding-torque-states",
                                      help="Stepper states per design whose holding torque is computed on the "
                                           "physical model (default 8; 0: none, a faster sweep)."),
    core: str = typer.Option(None, "--core", callback=check_core,
                             help="air or iron: the designs' coil cores (default: iron, the prototype's pot-core coil); "
                                  "the torques are measured on each design's own model."),
    max_rotor_poles: int = typer.Option(300, "--max-rotor-poles", help="Record larger rotors as too large."),
    max_candidates: int = typer.Option(200_000, "--max-candidates",
                                       help="Record designs whose state enumeration starts from more alignments as "
                                            "too large (memory ~0.4 GB and ~10 s per 100 000)."),
    max_lookup_voxels: int = typer.Option(4_000_000, "--max-lookup-voxels",
                                          help="Record designs whose state lookup grid needs more voxels (a "
                                               "tolerance close to half the pole spacing) as too large."),
    partial_range: bool = typer.Option(False, "--partial-range", help="Also propose designs that do not reach every "
                                                                     "orientation."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    quiet: bool = typer.Option(False, "--quiet", help="Print nothing but errors."),
) -> None:
    """Sweep rotor × stator packings (different symmetry families, Sec. II-B-3, and same-family pairs for
    contrast) × refinement × stator cap × tolerance on Dask; write the results, the Pareto set of resolution,
    coil count and holding torque within the coil budget, its plot, and the proposed designs' files. Run it
    again with the same --out to resume: finished designs are not evaluated again.

    Example: [bold]spherestep explore --budget-coils 32 --out explore-out --workers 2[/bold]
    """
    from rich.console import Console
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn,
                               TimeElapsedColumn, TimeRemainingColumn)

    from .progress import progress as progress_lines

    from ..explore.build import Limits
    from ..outputs import output_folder

    grid = build_grid(quick, rotors, stators, rotor_levels, stator_levels, caps, tols, primary_ratio, same_family,
                      samples, torque_states, core)
    try:
        limits = Limits(budget_coils=budget_coils, max_rotor_poles=max_rotor_poles, max_candidates=max_candidates,
                        max_lookup_voxels=max_lookup_voxels)
    except InputError as exc:
        raise _as_option(exc) from None
    points = grid.points()
    if not points:
        raise InputError("the grid is empty: no rotor and stator pair passes --primary-ratio and --same-family; "
                         "widen --primary-ratio or add packings")
    out = output_folder(out, "--out")  # before Dask starts
    for sub in ("results", "designs"):
        if (out / sub).exists() and not (out / sub).is_dir():
            raise InputError(f"--out {str(out)!r} holds a file named {sub!r} where the sweep keeps a folder; move it "
                             "or give another --out")
    from ..explore.outputs import propose  # pandas, pyarrow and Dask load once the command line is known good
    from ..explore.run import dask_client, run_sweep
    from ..explore.store import ResultStore

    store = ResultStore(out / "results")
    show = not (quiet or as_json)
    plain = show and not sys.stderr.isatty()  # a pipe, a log, CI: plain periodic lines on stderr (issue 27 §4)
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn())
    count = {"done": 0, "todo": None}

    def started(total: int, todo: int) -> None:
        count["todo"] = todo
        progress.update(task, total=todo, description=f"{total - todo} of {total} stored; evaluating")
        say(f"{total - todo} of {total} designs stored; evaluating the rest")

    def finished(row) -> None:
        count["done"] += 1
        progress.update(task, advance=1, description=f"{row['rotor']} × {row['stator']}: {row['status']}")
        say("evaluating designs", count["done"], count["todo"])

    with Progress(*columns, console=Console(stderr=True), disable=not show or plain, transient=True) as progress:
        task = progress.add_task("starting Dask", total=None)
        try:  # the plain lines once Dask is up: a refused --scheduler stays one line
            with dask_client(scheduler, threads=threads, workers=workers) as client, \
                    progress_lines("reading stored results", enabled=plain) as say:
                progress.update(task, description="reading stored results")
                summary = run_sweep(points, store, client, limits, on_start=started, on_result=finished)
        except InputError as exc:
            raise _as_option(exc) from None
        progress.update(task, description="writing the table, the Pareto set and the design files", total=None)
        say("writing the table, the Pareto set and the design files")
        table = store.read().set_index("key")
        table = table.loc[[p.key for p in points if p.key in table.index]].reset_index()
        proposal = propose(table, out, limits, require_reach_all=not partial_range)
    counts = table["status"].value_counts().to_dict()
    info = {
        "designs": summary.total, "stored_before": summary.stored_before, "evaluated": summary.evaluated,
        "lost": len(summary.lost), "seconds": summary.seconds, "status_counts": {k: int(v) for k, v in counts.items()},
        "budget_coils": budget_coils, "core": grid.core,
        "models": {k: int(v) for k, v in table["model"].value_counts().items()} if "model" in table else {},
        "pareto": json.loads(proposal.front.drop(columns=["params"]).to_json(orient="records")),
        "files": {"results": str(proposal.results), "pareto": str(proposal.pareto), "figure": str(proposal.figure),
                  "designs": [str(p) for p in proposal.designs]},
    }
    if as_json:
        print_json(info)
    elif not quiet:
        status = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
        console.print(f"{summary.total} designs: {summary.stored_before} stored before, {summary.evaluated} evaluated "
                      f"in {summary.seconds:.0f} s ({status})")
        if grid.torque_states:
            models = ", ".join(f"{n} on {m}" for m, n in info["models"].items()) or "none"
            bare = int(((table["status"] == "ok") & table["model"].isna()).sum())
            console.print(f"torques on the designs' own models: {models}"
                          + (f"; {bare} measured designs without them (their reason says why)" if bare else ""))
        if len(proposal.front):
            print_front(proposal.front, budget_coils)
        else:
            console.print(f"no measured design within {budget_coils} coils "
                          f"{'' if partial_range else 'reaches every orientation '}(see {proposal.results})")
        console.print(f"wrote {proposal.results}, {proposal.pareto}, {proposal.figure} and "
                      f"{len(proposal.designs)} design files in {out / 'designs'}/")
    if summary.lost:
        first = next(iter(summary.lost.values()))
        raise ComputationError(f"{len(summary.lost)} designs were lost to worker failures (first: {first}); run the "
                               "same command again to evaluate them")
