"""The input contracts every room shares: positive numbers, counts, fractions, axes, coil currents, real arrays.

Each function takes the value and the ``name`` the user knows it by, returns the value in the form the code
uses (a ``float``, an ``int``, a unit vector, a float array), and otherwise raises
:class:`~spherestep.errors.InputError` through :func:`~spherestep.errors.bad_value` — "``name`` must be …;
instead received …" — naming the field, so the CLI prints one line and exits 2. Rotations and points have their
own contracts in :func:`spherestep.so3.as_rotations` and :mod:`spherestep.sphere`.

``bool`` is refused wherever a number is expected (``True`` is an ``int`` in Python, never a length).
"""

from __future__ import annotations

import math
from numbers import Integral, Real

import numpy as np

from .errors import bad_value

SMALL_SUM = 64  # currents summed as Python floats up to this many (NumPy's reduction costs more below it)
AXIS_MIN_NORM = 1e-150  # an axis shorter than this cannot be normalised without underflow in its square


def _real(value) -> bool:
    return isinstance(value, Real) and not isinstance(value, bool)


def number(value, name: str, *, low: float = -math.inf, high: float = math.inf, low_open: bool = False,
           high_open: bool = False, expected: str | None = None) -> float:
    """A finite real number in ``[low, high]`` (an end excluded with ``low_open``/``high_open``) as ``float``."""
    ok = _real(value) and math.isfinite(value)
    if ok:
        x = float(value)
        ok = (x > low if low_open else x >= low) and (x < high if high_open else x <= high)
    if not ok:
        if expected is None:
            lo = "" if low == -math.inf else (f"> {low:g}" if low_open else f">= {low:g}")
            hi = "" if high == math.inf else (f"< {high:g}" if high_open else f"<= {high:g}")
            expected = "a finite number" + (" " + " and ".join(s for s in (lo, hi) if s) if lo or hi else "")
        raise bad_value(name, expected, value)
    return float(value)


def positive(value, name: str, expected: str = "a finite positive number") -> float:
    """A finite real ``> 0`` as ``float``."""
    return number(value, name, low=0.0, low_open=True, expected=expected)


def non_negative(value, name: str, expected: str = "a finite non-negative number") -> float:
    """A finite real ``>= 0`` as ``float``."""
    return number(value, name, low=0.0, expected=expected)


def fraction(value, name: str, *, closed: bool = False, expected: str | None = None) -> float:
    """A real in ``(0, 1)`` (``closed``: ``[0, 1]``) as ``float``."""
    expected = expected or ("a fraction from 0 to 1" if closed else "a fraction strictly between 0 and 1")
    return number(value, name, low=0.0, high=1.0, low_open=not closed, high_open=not closed, expected=expected)


def count(value, name: str, minimum: int = 1, maximum: int | None = None, expected: str | None = None) -> int:
    """An integer (Python or NumPy, not ``bool``) in ``[minimum, maximum]`` as ``int``."""
    ok = isinstance(value, Integral) and not isinstance(value, bool) and value >= minimum \
        and (maximum is None or value <= maximum)
    if not ok:
        if expected is None:
            expected = f"an integer >= {minimum}" if maximum is None else f"an integer from {minimum} to {maximum}"
        raise bad_value(name, expected, value)
    return int(value)


def sign(value, name: str, expected: str = "+1 or -1") -> int:
    """A polarity: a real equal to ``+1`` or ``-1`` (not ``bool``) as ``int``."""
    if not (_real(value) and value in (-1, 1)):
        raise bad_value(name, expected, value)
    return int(value)


def axis(value, name: str = "axis") -> np.ndarray:
    """A rotation axis: a finite non-zero 3-vector, returned as a unit vector ``(3,)``. An axis too short to
    normalise (``|n| < 1e-150``, whose square underflows) is refused like zero, without a NumPy warning."""
    try:
        n = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise bad_value(name, "a non-zero 3-vector X,Y,Z", value) from None
    if n.shape != (3,) or not np.all(np.isfinite(n)):
        raise bad_value(name, "a finite non-zero 3-vector X,Y,Z", value)
    scale = float(np.abs(n).max())
    if not scale >= AXIS_MIN_NORM:
        raise bad_value(name, "a non-zero 3-vector X,Y,Z (not all components zero or below 1e-150)", value)
    m = n / scale
    return m / math.sqrt(float(m @ m))


def currents(value, coil_count: int, failed: tuple[int, ...] = (), name: str = "currents") -> np.ndarray:
    """The one contract for coil currents: a float array ``(..., coil_count)``, finite, zero on the ``failed``
    coils; returned without a copy when it already is one."""
    try:
        arr = value if isinstance(value, np.ndarray) and value.dtype == float else np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise bad_value(name, "an array of real numbers", type(value).__name__) from None
    if arr.ndim < 1 or arr.shape[-1] != coil_count:
        raise bad_value(name, f"one current per stator coil, shape (..., {coil_count})", f"shape {arr.shape}")
    # the sum is finite unless an entry is not (or the sum overflows); a few currents sum fastest as floats
    total = sum(arr.ravel().tolist()) if arr.size <= SMALL_SUM else arr.sum()
    if not math.isfinite(total) and not np.isfinite(arr).all():
        raise bad_value(name, "finite real numbers", "NaN or infinite entries")
    if failed and np.any(arr[..., list(failed)] != 0):
        raise bad_value(name, f"zero on the failed coils {list(failed)} (they cannot be energised)",
                        "a non-zero current on a failed coil")
    return arr


def real_array(value, name: str) -> np.ndarray:
    """A float array of finite real numbers, any shape."""
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise bad_value(name, "real numbers", value) from None
    if not np.all(np.isfinite(arr)):
        raise bad_value(name, "finite real numbers", value)
    return arr
