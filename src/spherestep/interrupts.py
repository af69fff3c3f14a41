"""The one record of the signals a command received, and the one mapping of a signal to its interrupt and exit code.

Ctrl-C (SIGINT) raises ``KeyboardInterrupt``; SIGTERM raises :class:`Terminated`, a ``KeyboardInterrupt``, so both
unwind the same way (every coil switched off, partial outputs removed). The handlers that raise them are installed
by the CLI (:func:`spherestep.cli.signals.sigterm_as_interrupt`), which records each signal here
(:func:`note_signal`); a room that sees an interrupt only as a result (the servo loop's ``INTERRUPT`` outcome) or
after it was swallowed (llvmlite's callback during numba's first compile) asks :func:`last_signal` and raises
:func:`interrupt_for` it. Exit status: :data:`EXIT_CODES` (128 + the signal's number), :func:`exit_code`.
"""

from __future__ import annotations

import signal

EXIT_CODES = {"SIGINT": 128 + signal.SIGINT, "SIGTERM": 128 + signal.SIGTERM}  # 130, 143

_SIGNALS: list[str] = []  # the signals received while a command runs


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C (every coil switched off)."""


def note_signal(name: str | None) -> None:
    """Record that the running command received signal ``name`` (None: a new command starts, forget them): a
    failure after it is an interrupt even when the ``KeyboardInterrupt`` itself was swallowed (llvmlite's
    callback during numba's first compile drops it, and the compile fails later with an unrelated error)."""
    if name is None:
        _SIGNALS.clear()
    else:
        _SIGNALS.append(name)


def last_signal() -> str | None:
    """The last signal recorded since the command started ("SIGINT", "SIGTERM"), or None."""
    return _SIGNALS[-1] if _SIGNALS else None


def signal_name(interrupt: BaseException) -> str:
    """"SIGTERM" for a :class:`Terminated`, else "SIGINT"."""
    return "SIGTERM" if isinstance(interrupt, Terminated) else "SIGINT"


def interrupt_for(name: str | None) -> KeyboardInterrupt:
    """The interrupt signal ``name`` raises: :class:`Terminated` for "SIGTERM", else ``KeyboardInterrupt``."""
    return Terminated() if name == "SIGTERM" else KeyboardInterrupt()


def exit_code(interrupt: BaseException) -> int:
    """The exit status of a command stopped by ``interrupt``: 143 for SIGTERM, 130 for Ctrl-C."""
    return EXIT_CODES[signal_name(interrupt)]


def interrupt_of(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The Ctrl-C or SIGTERM behind ``exc``: itself, or one in its chain of causes (a compiled numba call
    interrupted mid-way surfaces as ``SystemError`` with the ``KeyboardInterrupt`` as its context)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None
