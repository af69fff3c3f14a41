"""Signals for the command: SIGTERM unwinds like Ctrl-C, so every command switches coils off and cleans up the same
way for both (exit 130 for SIGINT, 143 for SIGTERM)."""

from __future__ import annotations

import signal
import threading
from contextlib import contextmanager

from ..outputs import interrupt_of, note_signal  # noqa: F401  (interrupt_of: the CLI's name for it; outputs' own)


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C (every coil switched off)."""


class Received:
    """The signal that arrived while inside :func:`sigterm_as_interrupt` (``name``: "SIGINT", "SIGTERM" or None) and
    whether the command already said so on stderr (``told``, set by :func:`told`)."""

    def __init__(self):
        self.name: str | None = None
        self.told = False


_CURRENT: list[Received] = []


def told() -> None:
    """The command printed its own interrupted line (the CLI then adds none)."""
    for received in _CURRENT:  # nested commands: every level knows
        received.told = True


def _raise_terminated(signum, frame):
    for received in _CURRENT:
        received.name = "SIGTERM"
    note_signal("SIGTERM")
    raise Terminated()


def _raise_interrupt(signum, frame):
    for received in _CURRENT:
        received.name = "SIGINT"
    note_signal("SIGINT")
    raise KeyboardInterrupt()


@contextmanager
def sigterm_as_interrupt():
    """While inside, SIGTERM raises :class:`Terminated` in the main thread (like Ctrl-C raises
    KeyboardInterrupt), and either is recorded in the :class:`Received` yielded (Typer turns an interrupt into a
    silent exit status 130; the CLI says which signal it was); the previous handlers are restored on leaving."""
    received = Received()
    if threading.current_thread() is not threading.main_thread():
        yield received
        return
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    previous_int = signal.getsignal(signal.SIGINT)
    if previous_int is signal.default_int_handler:  # not when ignored or when a caller installed its own
        signal.signal(signal.SIGINT, _raise_interrupt)
    if not _CURRENT:  # the outermost command: a fresh record
        note_signal(None)
    _CURRENT.append(received)
    try:
        yield received
    finally:
        _CURRENT.pop()
        if not _CURRENT:
            note_signal(None)
        signal.signal(signal.SIGTERM, previous)
        if previous_int is signal.default_int_handler:
            signal.signal(signal.SIGINT, previous_int)


