"""numba's ``njit`` for the fast path, and one progress line when it compiles rather than loads from its cache.

Every kernel is ``@njit(cache=True)``: numba compiles a kernel on its first call in a fresh clone (or after its
file changed) and writes the machine code beside the source (``_fast/__pycache__/*.nbi, *.nbc``; under
``NUMBA_CACHE_DIR`` when set, or numba's user-wide cache when the tree is read-only); every later process loads it
(milliseconds). numba checks only the source file of the function it loads: a kernel that calls one in another
file keeps the callee's machine code from when it was cached, so changing a kernel means touching (e.g. the
docstring of) every file whose kernels call it, or clearing ``_fast/__pycache__``. The first compilation of a process is announced once, through :func:`spherestep.progress.report`
(the CLI's progress lines; the first compilation while someone listens): "compiling the fast kernels once (about N s; cached for later runs)", N the
:data:`FIRST_COMPILE_SECONDS` measured (benchmarks/bench_first_run.py, stored in data/bench_first_run.json).
"""

from __future__ import annotations

import threading

from numba import njit
from numba.core import event

FIRST_COMPILE_SECONDS = 25  # s: measured, data/bench_first_run.json (a test holds the two within 50 %)
_told = threading.Event()


class _FirstCompile(event.Listener):
    """Tells the listening caller once per process that numba is compiling (not loading from its cache)."""

    def on_start(self, ev) -> None:
        if not _told.is_set():
            from ..progress import report

            if report(f"compiling the fast kernels once (about {FIRST_COMPILE_SECONDS} s; cached for later runs)"):
                _told.set()  # told once; a compilation nobody listened to leaves it for the next

    def on_end(self, ev) -> None:
        pass


event.register("numba:compile", _FirstCompile())

__all__ = ["FIRST_COMPILE_SECONDS", "njit"]
