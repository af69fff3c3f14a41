"""Input checks of the potential room beyond :mod:`spherestep.checks` (which holds the shared contracts)."""

from __future__ import annotations

import numpy as np

from ..checks import real_array
from ..errors import bad_value


def samples(x, name: str) -> np.ndarray:
    """A 1-D array of finite reals (:func:`spherestep.checks.real_array`)."""
    arr = real_array(x, name)
    if arr.ndim != 1:
        raise bad_value(name, "a 1-D array of samples", f"shape {arr.shape}")
    return arr
