"""Progress on stderr for commands that can run longer than two seconds.

On a terminal a Rich spinner (a bar when the work has a known size) with the elapsed time, ticking every second,
that disappears at the end; otherwise — a pipe, a log file, CI — plain lines ``spherestep: <stage> (12 s)``, one
per stage and at most one every :data:`PLAIN_EVERY` seconds within a stage, and a heartbeat thread that repeats
the stage (``… still working``) when :data:`PLAIN_EVERY` seconds passed without a line, so no stretch of 10 s or
more is silent even inside one long call. ``--json`` and ``--quiet`` turn it off. Before a command's first stage
(the libraries load, the design's model is built: 25–50 s under a load of 16–20), :func:`starting` keeps the same
heartbeat, silent unless that stretch reaches :data:`PLAIN_EVERY` − 1.5 s, so a quick refusal stays one line.

    with progress("building the torque model", enabled=not as_json) as say:
        say("mapping the capability", done=10, total=400)
"""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

PLAIN_EVERY = 10.0  # s between two plain lines of the same stage


class _Plain:
    """Periodic plain lines on stderr, and a heartbeat (:meth:`beat`) for the stretches between them."""

    def __init__(self, first: str, *, quiet: bool = False):
        self.start = time.monotonic()
        self.stage, self.shown = None, -PLAIN_EVERY
        self.lock = threading.Lock()
        self.stop = threading.Event()
        if quiet:  # the stage without its line: the heartbeat speaks only if the stretch grows long
            self.stage, self.shown = first, self.start
        else:
            self(first)

    def _print(self, text: str, now: float) -> None:
        self.shown = now
        print(f"spherestep: {text} ({now - self.start:.0f} s)", file=sys.stderr, flush=True)

    def __call__(self, text: str, done: int | None = None, total: int | None = None) -> None:
        now = time.monotonic()
        with self.lock:
            if text == self.stage and now - self.shown < PLAIN_EVERY:
                return
            self.stage = text
            self._print(text + (f" {done}/{total}" if done is not None and total else ""), now)

    def beat(self) -> None:
        """Until :attr:`stop` is set: repeat the stage when 8.5 s passed without a line (under
        :data:`PLAIN_EVERY`)."""
        while not self.stop.wait(0.25):
            now = time.monotonic()
            with self.lock:  # 1.5 s early: a compiled call holding the GIL can delay the thread by a second or so
                if now - self.shown >= PLAIN_EVERY - 1.5:
                    self._print(f"{self.stage} … still working", now)


_STARTING: list[_Plain] = []  # the start-up heartbeat while it runs (at most one: the console script's)


def _beating(plain: _Plain) -> threading.Thread:
    heart = threading.Thread(target=plain.beat, name="spherestep-progress", daemon=True)
    heart.start()
    return heart


def _end_starting() -> None:
    for plain in _STARTING:
        plain.stop.set()


@contextmanager
def starting(*, enabled: bool = True) -> Iterator[None]:
    """Around a whole command: the heartbeat of its start-up, until its first :func:`progress` or its end."""
    if not enabled:
        yield
        return
    plain = _Plain("starting: loading the libraries and the design", quiet=True)
    _STARTING.append(plain)
    heart = _beating(plain)
    try:
        yield
    finally:
        plain.stop.set()
        heart.join()
        _STARTING.remove(plain)


@contextmanager
def progress(first: str, *, enabled: bool = True) -> Iterator[Callable[..., None]]:
    """A ``say(text, done=None, total=None)`` for the work inside (module docstring)."""
    _end_starting()  # the command speaks for itself from here
    if not enabled:
        yield lambda text, done=None, total=None: None
        return
    from ..progress import listening  # the library's long work (e.g. an iron solve) reports here too

    if not sys.stderr.isatty():
        plain = _Plain(first)
        heart = _beating(plain)
        try:
            with listening(plain):
                yield plain
        finally:
            plain.stop.set()
            heart.join()
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
