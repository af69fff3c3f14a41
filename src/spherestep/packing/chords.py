"""Chords and arcs on the unit sphere: the packings' KD-trees measure chords ``2 sin(a/2)``, the caps arcs ``a``."""

from __future__ import annotations

import numpy as np


def chord(angle) -> np.ndarray:
    """Chord length ``2 sin(a/2)`` of an arc ``a`` on the unit sphere."""
    return 2.0 * np.sin(0.5 * np.minimum(angle, np.pi))


def arc_from_chord(c) -> np.ndarray:
    """Arc ``2 asin(c/2)`` of a chord ``c``."""
    return 2.0 * np.arcsin(np.clip(0.5 * c, 0.0, 1.0))
