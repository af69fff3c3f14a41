"""Input checks shared by the harmonics modules: one place that raises the user-facing errors."""

from __future__ import annotations

import numpy as np

from ..checks import real_array
from ..errors import bad_value


def degrees(l, name: str = "l") -> np.ndarray:
    """``l`` as an int64 array of non-negative integers (integral floats are accepted)."""
    arr = np.asarray(l)
    if arr.dtype == bool or arr.dtype.kind not in "iuf":
        raise bad_value(name, "non-negative integers", l)
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr)):
            raise bad_value(name, "non-negative integers", l)
    if np.any(arr < 0):
        raise bad_value(name, "non-negative integers", l)
    return arr.astype(np.int64)


def degree(l, name: str = "l") -> int:
    """A single non-negative integer degree."""
    arr = degrees(l, name)
    if arr.ndim != 0:
        raise bad_value(name, "a single non-negative integer", l)
    return int(arr)


def orders(m, l: np.ndarray, name: str = "m") -> np.ndarray:
    """``m`` as an int64 array of integers with ``|m| <= l`` (elementwise, after broadcasting)."""
    arr = np.asarray(m)
    if arr.dtype == bool or arr.dtype.kind not in "iuf":
        raise bad_value(name, "integers with |" + name + "| <= l", m)
    if arr.dtype.kind == "f" and (not np.all(np.isfinite(arr)) or np.any(arr != np.round(arr))):
        raise bad_value(name, "integers with |" + name + "| <= l", m)
    arr = arr.astype(np.int64)
    try:
        too_big = np.abs(arr) > l
    except ValueError:
        raise bad_value(name, "an array that broadcasts against l", f"shape {arr.shape}") from None
    if np.any(too_big):
        raise bad_value(name, "integers with |" + name + "| <= l", m)
    return arr


def cosines(x, name: str = "x") -> np.ndarray:
    """``x`` as a float array of finite values in ``[-1, 1]``."""
    arr = real_array(x, name)
    if np.any(np.abs(arr) > 1.0):
        raise bad_value(name, "values in [-1, 1]", x)
    return arr


def angles(a, name: str) -> np.ndarray:
    """A float array of finite angles (radians)."""
    return real_array(a, name)


def polar(theta, name: str = "theta") -> np.ndarray:
    """A float array of polar angles in ``[0, π]``."""
    arr = real_array(theta, name)
    if np.any((arr < 0.0) | (arr > np.pi)):
        raise bad_value(name, "polar angles in [0, π] (radians)", theta)
    return arr


def coefficients_s2(flm, name: str = "flm") -> tuple[np.ndarray, int]:
    """Spherical coefficients ``(..., L+1, 2L+1)``; returns the complex array and ``L``."""
    arr = _complex(flm, name)
    if arr.ndim < 2 or arr.shape[-1] != 2 * arr.shape[-2] - 1:
        raise bad_value(name, "coefficients of shape (..., L+1, 2L+1)", f"shape {arr.shape}")
    return arr, arr.shape[-2] - 1


def coefficients_so3(fhat, name: str = "fhat") -> tuple[np.ndarray, int]:
    """SO(3) coefficients ``(..., L+1, 2L+1, 2L+1)``; returns the complex array and ``L``."""
    arr = _complex(fhat, name)
    if arr.ndim < 3 or arr.shape[-1] != arr.shape[-2] or arr.shape[-1] != 2 * arr.shape[-3] - 1:
        raise bad_value(name, "coefficients of shape (..., L+1, 2L+1, 2L+1)", f"shape {arr.shape}")
    return arr, arr.shape[-3] - 1


def samples_s2(f, name: str = "f") -> tuple[np.ndarray, int]:
    """Samples on the S² grid, ``(..., L+1, 2L+1)``; returns the complex array and ``L``."""
    arr = _complex(f, name)
    if arr.ndim < 2 or arr.shape[-2] < 1 or arr.shape[-1] != 2 * arr.shape[-2] - 1:
        raise bad_value(name, "samples on the S² grid, shape (..., L+1, 2L+1)", f"shape {arr.shape}")
    return arr, arr.shape[-2] - 1


def samples_so3(f, name: str = "f") -> tuple[np.ndarray, int]:
    """Samples on the SO(3) grid, ``(..., 2L+1, L+1, 2L+1)`` over ``(α, β, γ)``; returns the array and ``L``."""
    arr = _complex(f, name)
    if (arr.ndim < 3 or arr.shape[-2] < 1 or arr.shape[-1] != 2 * arr.shape[-2] - 1
            or arr.shape[-3] != arr.shape[-1]):
        raise bad_value(name, "samples on the SO(3) grid, shape (..., 2L+1, L+1, 2L+1)", f"shape {arr.shape}")
    return arr, arr.shape[-2] - 1


def _complex(a, name: str) -> np.ndarray:
    try:
        arr = np.asarray(a, dtype=complex)
    except (TypeError, ValueError):
        raise bad_value(name, "an array of numbers", a) from None
    if not np.all(np.isfinite(arr)):
        raise bad_value(name, "finite numbers", "NaN or infinite entries")
    return arr
