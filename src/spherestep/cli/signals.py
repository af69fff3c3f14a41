"""Signals for the command: SIGTERM unwinds like Ctrl-C, so every command switches coils off and cleans up the same
way for both (exit 130 for SIGINT, 143 for SIGTERM). The handlers live here; the record of what arrived, the
interrupt each raises and the exit codes are :mod:`spherestep.interrupts`' (one registry)."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from ..interrupts import (Terminated, exit_code, interrupt_for, interrupt_of, last_signal,  # noqa: F401
                          note_signal, signal_name)


class Received:
    """The signal that arrived while inside :func:`sigterm_as_interrupt` (``name``: "SIGINT", "SIGTERM" or None,
    read from :func:`spherestep.interrupts.last_signal`) and whether the command already said so on stderr
    (``told``, set by :func:`told`)."""

    def __init__(self):
        self.told = False
        self._left: tuple[str | None] | None = None  # the name when the block was left (the record is reset then)

    @property
    def name(self) -> str | None:
        return last_signal() if self._left is None else self._left[0]


_CURRENT: list[Received] = []


def told() -> None:
    """The command printed its own interrupted line (the CLI then adds none)."""
    for received in _CURRENT:  # nested commands: every level knows
        received.told = True


def _raise(signum, frame):
    name = signal.Signals(signum).name
    note_signal(name)
    raise interrupt_for(name)


@contextmanager
def sigterm_as_interrupt():
    """While inside, SIGTERM raises :class:`Terminated` in the main thread (like Ctrl-C raises
    KeyboardInterrupt), and either is recorded in the :class:`Received` yielded (Typer turns an interrupt into a
    silent exit status 130; the CLI says which signal it was); the previous handlers are restored on leaving."""
    received = Received()
    if threading.current_thread() is not threading.main_thread():  # no handlers there: nothing is received
        received._left = (None,)
        yield received
        return
    previous = signal.signal(signal.SIGTERM, _raise)
    previous_int = signal.getsignal(signal.SIGINT)
    if previous_int is signal.default_int_handler:  # not when ignored or when a caller installed its own
        signal.signal(signal.SIGINT, _raise)
    if not _CURRENT:  # the outermost command: a fresh record
        note_signal(None)
    _CURRENT.append(received)
    try:
        yield received
    finally:
        received._left = (last_signal(),)
        _CURRENT.pop()
        if not _CURRENT:
            note_signal(None)
        signal.signal(signal.SIGTERM, previous)
        if previous_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous_int)


