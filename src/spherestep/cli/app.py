"""The Typer application that every command module adds its commands to."""

from __future__ import annotations

import typer

app = typer.Typer(
    name="spherestep",
    help="Design and commutate spherical stepper motors (Chirikjian & Stein, 1999).",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)
