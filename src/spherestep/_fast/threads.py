"""BLAS threads where the numerics are many small matrix products.

spherestep's hot loops multiply many small matrices; OpenBLAS's default thread pool makes them slower, not
faster (the harmonic energy of the prototype ran up to 21× slower with 2 threads than with one, measured on a
2-core machine). :func:`single_blas_thread` wraps the package's long-running entry points (equilibria, planners,
tuning, simulation, state enumeration) so that BLAS uses ``SPHERESTEP_BLAS_THREADS`` threads (default 1) while
they run, through threadpoolctl, and restores the caller's setting afterwards. Nested calls pay nothing extra;
the outermost call pays about 30 µs (the first one a few ms to find NumPy's and SciPy's BLAS libraries). Code outside these entry points keeps the process's own setting (set
``OPENBLAS_NUM_THREADS=1`` for it, as the Makefile does).
"""

from __future__ import annotations

import functools
import os
import threading

_state = threading.local()
_controller = None


def blas_threads() -> int:
    """The BLAS thread count used inside spherestep's entry points: ``SPHERESTEP_BLAS_THREADS`` or 1."""
    value = os.environ.get("SPHERESTEP_BLAS_THREADS", "1")
    return int(value) if value.isdigit() and int(value) > 0 else 1


def single_blas_thread(func):
    """Decorator: run ``func`` with BLAS limited to :func:`blas_threads` threads (see the module docstring)."""

    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        global _controller
        if getattr(_state, "depth", 0):
            return func(*args, **kwargs)
        if _controller is None:
            import scipy.linalg  # noqa: F401  (loads SciPy's own OpenBLAS, so both libraries are controlled)
            from threadpoolctl import ThreadpoolController

            _controller = ThreadpoolController()
        _state.depth = 1
        try:
            with _controller.limit(limits=blas_threads(), user_api="blas"):
                return func(*args, **kwargs)
        finally:
            _state.depth = 0

    return wrapper
