"""``spherestep synthesize``: designs for a specification, verified by full simulation (issue 29)."""

from __future__ import annotations

import sys
from pathlib import Path

import typer

from .app import app
from .common import console, input_file, number, print_json
from .progress import progress
from .signals import Terminated, interrupt_of, sigterm_as_interrupt, told

TABLE_WIDTH = 220  # columns of the finalists' table when stdout is not a terminal


@app.command()
def synthesize(
    spec: Path = typer.Argument(..., help="The specification file (YAML or TOML; docs/synthesis.md, "
                                          "examples/specs/)."),
    out: Path = typer.Option(..., "--out", help="Folder for the results store, the finalists' design files, the "
                                                "tables, pareto.png and report.html."),
    budget: str = typer.Option("quick", "--budget", help="quick (seconds to a minute), normal (minutes) or "
                                                         "thorough (also other part sizes with iron)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a running Dask scheduler, tcp://HOST:PORT "
                                                           "(its workers must have spherestep installed)."),
    workers: int = typer.Option(None, "--workers", callback=number("a whole number of workers ≥ 1", 1),
                                help="Local worker processes (default: the CPU count)."),
    threads: bool = typer.Option(False, "--threads", help="Local workers as threads in this process."),
    resume: bool = typer.Option(False, "--resume", help="Continue the search stored in --out (stored candidates "
                                                        "are not evaluated again)."),
    seed: int = typer.Option(0, "--seed", callback=number("a non-negative whole number", 0), help="Random seed."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Search the paper's constructions for motors that meet SPEC: candidates through a ladder of fidelity
    (geometry → states → capability on the design's own model → relay stepping where asked) on Dask, the Pareto
    set of what the spec leaves free, the finalists verified by full simulation (their design files loaded fresh)
    against every requirement, and an HTML report beside the gallery.

    Example: [bold]spherestep synthesize examples/specs/camera-gimbal.yaml --out gimbal --budget quick[/bold]
    """
    from ..errors import bad_value
    from ..outputs import output_folder
    from ..synthesis import BUDGETS, load_spec
    from ..synthesis import synthesize as run

    if budget not in BUDGETS:
        raise bad_value("--budget", f"one of {', '.join(BUDGETS)}", budget)
    spec_value = load_spec(input_file(spec, "SPEC"))
    out = output_folder(out, "--out")
    try:
        with sigterm_as_interrupt(), progress(f"synthesizing for {spec_value.name!r}", enabled=not as_json) as say:
            result = run(spec_value, out, budget=budget, scheduler=scheduler, workers=workers, threads=threads,
                         resume=resume, seed=int(seed), progress=say)
    except BaseException as exc:
        interrupt = interrupt_of(exc)
        if interrupt is None:
            raise
        signame = "SIGTERM" if isinstance(interrupt, Terminated) else "SIGINT"
        print(f"spherestep: interrupted ({signame}): the cluster is stopped; the candidates evaluated so far are "
              f"stored in {str(out)!r}: continue with spherestep synthesize {spec} --out {out} --budget {budget} "
              "--resume", file=sys.stderr)
        told()
        raise typer.Exit(143 if isinstance(interrupt, Terminated) else 130) from None
    if as_json:
        print_json(result.to_dict())
        return
    from rich.console import Console
    from rich.table import Table

    view = Table(title=f"finalists for {spec_value.name} ({budget} budget, {len(result.table)} candidates, "
                       f"{result.seconds:.0f} s)")
    for col in ("#", "layout", "magnets/coils", "meets", "binds", "file"):
        view.add_column(col, no_wrap=col in ("layout", "file"))  # whole: a cut layout lost the stator's level
    for n, f in enumerate(result.finalists, start=1):
        v = f.verification
        b = v.binding
        view.add_row(str(n), f"{f.row['rotor']}/L{f.row['rotor_level']} × {f.row['stator']}/L{f.row['stator_level']}"
                     f", {f.row['cap_deg']:g}°, {f.row['sphere_diameter_mm']:.4g} mm, {f.row['core']}",
                     f"{f.row['rotor_poles']}/{f.row['coils']}", "yes" if v.met else
                     "no: " + ", ".join(c.name for c in v.checks if not c.met), "—" if b is None else b.name,
                     Path(f.path).name)
    # a pipe or a log has no width to keep to: the whole rows (at the common console's 120 columns the verdicts and
    # counts were cut to "6…")
    (console if console.is_terminal else Console(width=TABLE_WIDTH)).print(view)
    console.print(result.statement)
    console.print(f"wrote {len(result.written)} files to {out}/ (report.html, pareto.png, finalists/)")
