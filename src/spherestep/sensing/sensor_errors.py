"""How a built magnetometer array differs from its design: per-sensor offsets and gains, and the array turned.

Sensor ``s`` of the nominal array sits at ``x_s`` with axes ``A_s`` (:class:`~spherestep.sensing.SensorArray`).
As built, the whole array (the board carrying it) is turned by ``Q`` about the sphere's centre, and each chip adds
its own offset ``o_s`` and per-axis gain ``g_s`` (sensor frame), so it reads

    m_s = g_s ⊙ (Q A_s)ᵀ B(Q x_s) + o_s .

For the rotor's own field ``B(Q x; R) = Q B(x; Qᵀ R)``, so a turned array reads what the nominal one would read
with the rotor at ``Qᵀ R``: an estimator on the nominal array reports ``Qᵀ R`` — every hold off by the angle of
``Q`` in truth while the estimate says it is on target. On an iron stator the cores do not turn with the array,
so their share of the field is read at the turned positions as it is (the emulated motor's field model there).

:class:`SensorErrors` is the emulated motor's model of this (``drive.connect(..., sensor_errors=...)``); the
identification is :func:`spherestep.sensing.calibrate_array_absolute`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .array import SensorArray


@dataclass(frozen=True, eq=False)
class SensorErrors:
    """``offsets (S, 3)`` T (sensor frame, added to each reading), ``rotation (3, 3)`` the array's turn about the
    centre (fixed frame), ``gains (S, 3)`` per-axis scale of each reading (``None``: 1)."""

    offsets: np.ndarray
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    gains: np.ndarray | None = None

    def __post_init__(self):
        o = np.asarray(self.offsets, dtype=float)
        if o.ndim != 2 or o.shape[1] != 3 or not np.all(np.isfinite(o)):
            raise bad_value("offsets", "finite per-sensor offsets of shape (S, 3) in tesla", f"shape {o.shape}")
        object.__setattr__(self, "offsets", o)
        object.__setattr__(self, "rotation", so3.as_rotations(self.rotation, "rotation").reshape(3, 3))
        if self.gains is not None:
            g = np.asarray(self.gains, dtype=float)
            if g.shape != o.shape or not np.all(np.isfinite(g)) or np.any(g <= 0):
                raise bad_value("gains", f"positive per-axis gains of shape {o.shape} (or None)", f"shape {g.shape}")
            object.__setattr__(self, "gains", g)

    @classmethod
    def none(cls, array: SensorArray) -> SensorErrors:
        """No error: zero offsets, unit gains, no turn."""
        return cls(np.zeros((len(array), 3)))

    @classmethod
    def random(cls, array: SensorArray, *, offset_T: float = 100e-6, bias_deg: float = 0.1, gain: float = 0.0,
               seed=0) -> SensorErrors:
        """Offsets normal with σ ``offset_T`` (T) per axis, the array turned by ``bias_deg`` about a uniformly
        random axis, gains uniform in ``1 ± gain`` (0: exact), from ``seed`` (int or Generator)."""
        checks.non_negative(offset_T, "offset_T", "a standard deviation in tesla, ≥ 0")
        checks.non_negative(bias_deg, "bias_deg", "an angle in degrees, ≥ 0")
        checks.number(gain, "gain", low=0.0, high=1.0, high_open=True, expected="a relative spread in [0, 1)")
        rng = np.random.default_rng(seed)
        S = len(array)
        offsets = offset_T * rng.standard_normal((S, 3))
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        gains = 1.0 + gain * rng.uniform(-1.0, 1.0, (S, 3)) if gain else None
        return cls(offsets, so3.exp(math.radians(bias_deg) * axis), gains)

    @property
    def angle(self) -> float:
        """The array's turn (rad)."""
        return float(so3.distance(self.rotation, np.eye(3)))

    def check(self, array: SensorArray) -> None:
        """InputError naming ``sensor_errors`` unless these are for ``array``'s sensors."""
        if len(self.offsets) != len(array):
            raise bad_value("sensor_errors", f"offsets for the array's {len(array)} sensors",
                            f"{len(self.offsets)} sensors")

    def placed(self, array: SensorArray) -> SensorArray:
        """The array as built: positions ``Q x_s``, axes ``Q A_s``."""
        self.check(array)
        return SensorArray(array.positions @ self.rotation.T, self.rotation @ array.axes, array.part)

    def read(self, local) -> np.ndarray:
        """Readings ``g ⊙ b + o`` of the fields ``local (..., S, 3)`` in each built sensor's own axes."""
        b = np.asarray(local, dtype=float)
        return (b if self.gains is None else b * self.gains) + self.offsets

    def to_dict(self) -> dict:
        return {"offsets_T": self.offsets.tolist(), "rotation": self.rotation.tolist(),
                "angle_deg": math.degrees(self.angle), "gains": None if self.gains is None else self.gains.tolist()}
