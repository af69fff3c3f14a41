"""Input checks of the potential room: one place that raises the user-facing errors."""

from __future__ import annotations

import math

import numpy as np

from .. import so3
from ..errors import bad_value
from ..harmonics._checks import real_array  # noqa: F401  (one check for both rooms)

def rotations(R, name: str = "R") -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` (:func:`spherestep.so3.as_rotations`)."""
    return so3.as_rotations(R, name)


def currents(c, count: int, failed: tuple[int, ...], name: str = "currents") -> np.ndarray:
    """Coil currents ``(..., N)``: finite reals, zero on failed coils."""
    arr = c if isinstance(c, np.ndarray) and c.dtype == float else real_array(c, name)
    if not np.isfinite(arr).all():
        raise bad_value(name, "finite real numbers", "NaN or infinite entries")
    if arr.ndim < 1 or arr.shape[-1] != count:
        raise bad_value(name, f"one current per stator coil, shape (..., {count})", f"shape {arr.shape}")
    if failed and np.any(arr[..., list(failed)] != 0):
        raise bad_value(name, f"zero on the failed coils {list(failed)} (they cannot be energised)",
                        "a non-zero current on a failed coil")
    return arr


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
