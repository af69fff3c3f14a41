"""The Typer application that every command module adds its commands to."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="spherestep",
    help="Design and commutate spherical stepper motors (Chirikjian & Stein, 1999).\n\n"
         "Example: [bold]spherestep demo --out spherestep-out[/bold]",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)


def _version(value: bool) -> None:
    if value:
        from .. import __version__

        print(f"spherestep {__version__}")
        raise typer.Exit(0)


@app.callback()
def _options(version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                          help="Print the version and exit.")) -> None:
    """Design and commutate spherical stepper motors (Chirikjian & Stein, 1999)."""
