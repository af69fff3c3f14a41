"""The ``spherestep`` command: thin, parses, calls one library function, prints.

Exit status: 0 success; 2 a user mistake (bad option, bad file, unusable output location: one line on stderr,
``spherestep: error: …``); 1 a failure of the computation or of the machine (a full disk says "N of M files
written"), ``spherestep: failed: …``; 130 interrupted by Ctrl-C, 143 by SIGTERM (after all coils are off).
``--debug`` shows the traceback instead of the line. ``spherestep`` alone prints the usage (exit 0).

The command modules import only Typer and Rich at load time; the library loads inside the command that runs,
so ``spherestep --help`` stays fast.
"""

from __future__ import annotations

import errno
import _thread
import functools
import signal
import sys
import threading

import typer
from typer._click.exceptions import NoArgsIsHelpError  # Typer vendors Click; this one has no public alias

from ..errors import ComputationError, SpherestepError
from . import design, explore, export, forces, motor, packings, report, run, simulate  # noqa: F401 (registers)
from . import capability, move  # noqa: F401 (registers)
from . import sense  # noqa: F401 (registers)
from . import gallery  # noqa: F401 (registers)
from . import synthesize  # noqa: F401 (registers)
from . import calibrate  # noqa: F401 (registers)
from .app import app
from .progress import starting
from .signals import Terminated, exit_code, interrupt_for, interrupt_of, sigterm_as_interrupt, signal_name

DISK_FULL = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)
_QUIET = {"--json", "--quiet", "--help", "-h"}  # options after which nothing but the answer is printed


@functools.cache
def _command():
    """The Click command of the app, built once per process (every command registers at import)."""
    return typer.main.get_command(app)


def _error(kind: str, text: str) -> None:
    line = " ".join(str(text).split())  # one line, whatever the message held
    print(f"spherestep: {kind}: {line}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the console script; returns (and exits with) the status code."""
    args = list(sys.argv[1:] if argv is None else argv)
    if argv is None and signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        # started in the background by a non-interactive shell, SIGINT arrives ignored by inheritance: a user's
        # Ctrl-C (or a test's SIGINT) must still stop the run and switch the coils off
        signal.signal(signal.SIGINT, signal.default_int_handler)
    debug = "--debug" in args
    if debug:
        args.remove("--debug")
    command = _command()
    received = None
    sys.unraisablehook = _quiet_interrupts
    try:
        # the console script's start-up heartbeat (not for in-process calls: tests, embedding)
        with sigterm_as_interrupt() as received, starting(enabled=argv is None and not _QUIET.intersection(args)):
            result = command.main(args=args, prog_name="spherestep", standalone_mode=False)
        # outside standalone mode Typer returns the code of an Exit (130 for Ctrl-C) instead of exiting
        code = result if isinstance(result, int) else 0
        if code == 130 and received.name and not received.told:  # Typer's silent 130 for Ctrl-C or SIGTERM
            code = _interrupted(interrupt_for(received.name))
    except NoArgsIsHelpError as exc:  # `spherestep` or `spherestep design` alone: the usage
        print(exc.ctx.get_help())
        code = 0
    except typer.Exit as exc:
        code = exc.exit_code
    except typer.TyperException as exc:  # bad usage (exit_code 2): Click's errors, vendored by Typer
        if debug:
            raise
        _error("error", exc.format_message())
        code = exc.exit_code
    except ComputationError as exc:
        if debug:
            raise
        _error("failed", exc)
        code = 1
    except SpherestepError as exc:
        if debug:
            raise
        _error("error", exc)
        code = 2
    except (KeyboardInterrupt, typer.Abort) as exc:  # a re-raised interrupt says which signal it was
        code = _interrupted(interrupt_for(received.name) if received is not None and received.name == "SIGTERM"
                            else exc)
    except OSError as exc:  # a path the command did not check (it should have): still one line
        if debug:
            raise
        where = f" ({exc.filename})" if exc.filename else ""
        full = exc.errno in DISK_FULL
        _error("failed" if full else "error", f"{exc.strerror or exc}{where}")
        code = 1 if full else 2
    except MemoryError:
        if debug:
            raise
        _error("failed", "out of memory; ask for a smaller computation")
        code = 1
    except Exception as exc:  # a bug: one line and exit 1; --debug shows where
        if interrupt_of(exc) is not None:  # Ctrl-C inside a compiled call surfaces as SystemError
            code = _interrupted(interrupt_of(exc))
            return _exit(code, argv)
        if received is not None and received.name:  # the signal's interrupt was swallowed (e.g. by llvmlite's
            # callback during numba's first compile) and the run failed for it later: still the signal's exit
            code = _interrupted(interrupt_for(received.name))
            return _exit(code, argv)
        if debug:
            raise
        _error("failed", f"internal error {type(exc).__name__}: {exc} (run again with --debug for the traceback, "
                         "and report it)")
        code = 1
    return _exit(code, argv)


_UNRAISABLE = sys.unraisablehook
REDELIVER_AFTER = 0.01  # s: a swallowed interrupt's signal comes back after this hook has returned


def _quiet_interrupts(unraisable) -> None:
    """An interrupt raised where Python cannot propagate it (llvmlite's callback during numba's compile) is not
    printed as 'Exception ignored … Traceback', and it is not lost: a timer delivers its signal to the main thread
    again ``REDELIVER_AFTER`` s later (``_thread.interrupt_main``; at once, the handler would run inside this hook
    and be swallowed again), whose handler raises it at a bytecode out of reach of the callback (if it lands in
    one again, it comes back here), so the command stops and says so
    in one line. (Lost, a fresh install's ``calibrate`` ran on after a Ctrl-C during its first compile: seen in
    the fresh-clone CI.)"""
    exc = unraisable.exc_value
    if not isinstance(exc, KeyboardInterrupt):  # Terminated (SIGTERM) is one
        _UNRAISABLE(unraisable)
        return
    signum = signal.SIGTERM if isinstance(exc, Terminated) else signal.SIGINT
    timer = threading.Timer(REDELIVER_AFTER, _thread.interrupt_main, args=(signum,))
    timer.daemon = True
    timer.start()


def _interrupted(exc: BaseException) -> int:
    """One line for Ctrl-C (exit 130) or SIGTERM (exit 143)."""
    print(f"spherestep: interrupted ({signal_name(exc)})", file=sys.stderr)
    return exit_code(exc)


def _exit(code: int, argv) -> int:
    if argv is None:
        sys.exit(code)
    return code
