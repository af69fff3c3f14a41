"""Desired motions as rotations sampled at equal Park distance (Sec. III-A).

A trajectory is an array ``(n + 1, 3, 3)`` of desired orientations ``R_0 … R_n`` with
``D(R_{i−1}, R_i)`` the same for every ``i`` (:func:`spherestep.so3.resample`). Rotations about an axis
act in the fixed (stator) frame: ``R(t) = ROT[n, t·angle] R_0``.
"""

from __future__ import annotations

import math

import numpy as np

from .. import checks, so3
from ..errors import bad_value

KEY_SPACING = math.pi / 2  # keys of a long turn are at most 90° apart, well inside the geodesic's uniqueness


def steps_for(length: float, step: float) -> int:
    """Number of equal steps of at most ``step`` radians covering ``length`` radians (at least one)."""
    step = checks.positive(step, "step", "a positive angle")
    length = checks.non_negative(length, "length", "a finite angle ≥ 0 in radians")
    return max(1, math.ceil(length / step - 1e-9))


def about_axis(axis, angle: float, steps: int, start=None) -> np.ndarray:
    """``steps + 1`` orientations turning ``angle`` radians (any size, sign gives the sense) about the
    fixed-frame ``axis`` from ``start`` (default identity), equally spaced."""
    checks.axis(axis)  # refused here when zero or too short to normalise; so3.rot normalises it
    angle = checks.number(angle, "angle", expected="a finite angle")
    steps = checks.count(steps, "steps", expected="a positive whole number of steps")
    start = np.eye(3) if start is None else so3.as_rotations(start, "start")
    if start.shape != (3, 3):
        raise bad_value("start", "one rotation matrix (3, 3)", f"shape {start.shape}")
    pieces = max(1, math.ceil(abs(angle) / KEY_SPACING))
    keys = so3.rot(axis, np.linspace(0.0, angle, pieces + 1)) @ start
    if angle == 0:
        return np.repeat(start[None], steps + 1, axis=0)
    return so3.resample(keys, steps)


def through(keys, steps: int) -> np.ndarray:
    """``steps + 1`` orientations on the piecewise geodesic through ``keys (m, 3, 3)``, equally spaced."""
    return so3.resample(so3.as_rotations(keys, "keys"),
                        checks.count(steps, "steps", expected="a positive whole number of steps"))


def check_targets(targets) -> np.ndarray:
    """``targets`` as at least two proper rotations ``(n+1, 3, 3)`` (:func:`spherestep.so3.as_rotations`);
    InputError naming ``targets`` otherwise."""
    targets = so3.as_rotations(targets, "targets")
    if targets.ndim != 3 or len(targets) < 2:
        raise bad_value("targets", "at least two rotations, shape (n+1, 3, 3)", f"shape {targets.shape}")
    return targets
