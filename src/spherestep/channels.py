"""Relay channels of the coil drivers (Sec. IV-B): the channel map, validated in one place.

Coil ``k`` is switched by two relays, ``channel_map[k] = (enable, polarity)``: the enable relay powers the
coil, the polarity relay reverses its current. The paper's prototype has four 8-relay boards, so at most
:data:`MAX_COILS` coils unless a design lifts the limit. A channel map is an ``(N, 2)`` read-only integer
array of distinct non-negative channels; :func:`as_channel_map` is the one check, used by the motor design,
plan files and the coil driver.
"""

from __future__ import annotations

import numpy as np

from .errors import bad_value

MAX_COILS = 32  # four 8-relay boards (Sec. IV-B)


def default_channel_map(coil_count: int) -> np.ndarray:
    """Coil ``k`` → enable channel ``k``, polarity channel ``coil_count + k`` (shape ``(N, 2)``)."""
    k = np.arange(coil_count)
    return np.stack([k, coil_count + k], axis=1)


def as_channel_map(value, coil_count: int | None = None, name: str = "channel_map") -> np.ndarray:
    """``value`` as a read-only ``(N, 2)`` integer array of distinct non-negative (enable, polarity) channels,
    ``N = coil_count`` when given; otherwise the project's one-line InputError naming ``name``."""
    try:
        cmap = np.asarray(value)
    except (TypeError, ValueError):
        cmap = np.asarray(None)
    rows = "N" if coil_count is None else str(coil_count)
    if cmap.ndim != 2 or cmap.shape[1] != 2 or (coil_count is not None and cmap.shape[0] != coil_count):
        raise bad_value(name, f"{rows} pairs of non-negative integer channels (enable, polarity), one per coil",
                        f"shape {cmap.shape}")
    if cmap.size and (not np.issubdtype(cmap.dtype, np.integer) or np.any(cmap < 0)):
        raise bad_value(name, f"{rows} pairs of non-negative integer channels (enable, polarity), one per coil",
                        cmap.tolist())
    if len(np.unique(cmap.ravel())) != cmap.size:
        raise bad_value(name, "distinct channels for every coil's enable and polarity (no relay shared)",
                        cmap.tolist())
    cmap = cmap.astype(int)
    cmap.setflags(write=False)
    return cmap
