"""The ``spherestep`` command: thin, parses and prints, calls the library.

Errors a user can cause (:class:`~spherestep.errors.SpherestepError`, bad options) print one line on stderr
and exit with status 2; a failed computation exits 1; ``--debug`` shows the traceback instead.
"""

from __future__ import annotations

import sys

import typer
from typer.exceptions import TyperException

from ..errors import ComputationError, SpherestepError
from . import design, export, motor, packings, report, simulate  # noqa: F401  (registers commands)
from . import explore, forces, run  # noqa: F401
from .app import app


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns (and exits with) the status code."""
    args = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in args
    if debug:
        args.remove("--debug")
    command = typer.main.get_command(app)
    try:
        result = command.main(args=args, prog_name="spherestep", standalone_mode=False)
        # outside standalone mode Typer returns the code of an Exit (130 for Ctrl-C) instead of exiting
        code = result if isinstance(result, int) else 0
    except typer.Exit as exc:
        code = exc.exit_code
    except TyperException as exc:  # bad usage (exit_code 2) and Typer's own errors
        if debug:
            raise
        print(f"spherestep: error: {exc.format_message()}", file=sys.stderr)
        code = exc.exit_code
    except ComputationError as exc:
        if debug:
            raise
        print(f"spherestep: failed: {exc}", file=sys.stderr)
        code = 1
    except SpherestepError as exc:
        if debug:
            raise
        print(f"spherestep: error: {exc}", file=sys.stderr)
        code = 2
    except (KeyboardInterrupt, typer.Abort):
        print("spherestep: interrupted", file=sys.stderr)
        code = 130
    if argv is None:
        sys.exit(code)
    return code
