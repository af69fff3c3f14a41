"""Progress on stderr for commands that can run longer than two seconds.

On a terminal a Rich spinner (a bar when the work has a known size) that disappears at the end; otherwise — a pipe,
a log file, CI — plain lines ``spherestep: <stage> (12 s)``, one per stage and at most one every
:data:`PLAIN_EVERY` seconds within a stage, so a long run is never silent. ``--json`` and ``--quiet`` turn it off.

    with progress("building the torque model", enabled=not as_json) as say:
        say("mapping the capability", done=10, total=400)
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

PLAIN_EVERY = 10.0  # s between two plain lines of the same stage


class _Plain:
    """Periodic plain lines on stderr."""

    def __init__(self, first: str):
        self.start = time.monotonic()
        self.stage, self.shown = None, -PLAIN_EVERY
        self(first)

    def __call__(self, text: str, done: int | None = None, total: int | None = None) -> None:
        now = time.monotonic()
        if text == self.stage and now - self.shown < PLAIN_EVERY:
            return
        self.stage, self.shown = text, now
        count = f" {done}/{total}" if done is not None and total else ""
        print(f"spherestep: {text}{count} ({now - self.start:.0f} s)", file=sys.stderr, flush=True)


@contextmanager
def progress(first: str, *, enabled: bool = True) -> Iterator[Callable[..., None]]:
    """A ``say(text, done=None, total=None)`` for the work inside (module docstring)."""
    if not enabled:
        yield lambda text, done=None, total=None: None
        return
    from ..progress import listening  # the library's long work (e.g. an iron solve) reports here too

    if not sys.stderr.isatty():
        plain = _Plain(first)
        with listening(plain):
            yield plain
        return
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
               TimeElapsedColumn())
    with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
        task = bar.add_task(first, total=None)

        def say(text: str, done: int | None = None, total: int | None = None) -> None:
            bar.update(task, description=text, completed=done or 0, total=total)

        with listening(say):
            yield say
