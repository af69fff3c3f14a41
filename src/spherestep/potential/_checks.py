"""Input checks of the potential room: one place that raises the user-facing errors."""

from __future__ import annotations

import math

import numpy as np

from ..errors import bad_value
from ..statics import as_currents
from ..harmonics._checks import real_array  # noqa: F401  (one check for both rooms)

def currents(c, count: int, failed: tuple[int, ...], name: str = "currents") -> np.ndarray:
    """Coil currents ``(..., N)`` (:func:`spherestep.statics.as_currents`)."""
    return as_currents(c, count, failed, name)


def positive(x, name: str) -> float:
    """A finite positive real number."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.integer, np.floating)) or not math.isfinite(x) \
            or x <= 0:
        raise bad_value(name, "a finite positive number", x)
    return float(x)


def count(n, name: str, minimum: int = 0) -> int:
    """An integer ``>= minimum``."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < minimum:
        raise bad_value(name, f"an integer >= {minimum}", n)
    return int(n)


def fraction(x, name: str) -> float:
    """A real number in (0, 1)."""
    if isinstance(x, bool) or not isinstance(x, (int, float, np.floating)) or not 0 < x < 1:
        raise bad_value(name, "a number in (0, 1)", x)
    return float(x)


def samples(x, name: str) -> np.ndarray:
    """A 1-D array of finite reals."""
    arr = real_array(x, name)
    if arr.ndim != 1:
        raise bad_value(name, "a 1-D array of samples", f"shape {arr.shape}")
    return arr
