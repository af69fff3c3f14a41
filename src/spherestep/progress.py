"""Progress of long library work, told to whoever listens (the CLI's bar on stderr), without printing.

A library function that can run for minutes (e.g. the moment-method solve of a design's iron tables) calls
:func:`report`; a caller that shows progress wraps the work in :func:`listening`. Nobody listening: nothing
happens. The listener is a context variable, so threads and nested calls each see their own.

    with listening(lambda text, done=None, total=None: print(text, done, total)):
        iron_model(design)          # "iron: the pair tables by the moment method 3 10" ...
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar

_SAY: ContextVar[Callable[..., None] | None] = ContextVar("spherestep_progress", default=None)


@contextmanager
def listening(say: Callable[..., None]) -> Iterator[None]:
    """Within the block, :func:`report` calls ``say(text, done=None, total=None)``."""
    token = _SAY.set(say)
    try:
        yield
    finally:
        _SAY.reset(token)


def report(text: str, done: int | None = None, total: int | None = None) -> bool:
    """Tell the :func:`listening` caller, if any, how the work stands (``done`` of ``total`` steps); whether
    anyone was listening."""
    say = _SAY.get()
    if say is not None:
        say(text, done=done, total=total)
    return say is not None
