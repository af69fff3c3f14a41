"""A magnetometer array in the stator: where each 3-axis sensor sits, how it is turned, and the part it is.

Sensor ``s`` sits at ``x_s`` (fixed frame, metres) with axes ``A_s`` (a rotation whose columns are the sensor's
x, y, z axes in the fixed frame); it reads ``A_sᵀ B(x_s)``. The default frame puts the sensor's z axis along
the outward radius (the package lies flat on the stator shell, its sensitive point ``standoff`` above the
rotor's surface).

Where sensors can sit. The stator is the cup below the ball: coils occupy the directions within
``design.cap_half_angle`` of ``design.stator_axis``; a coil is a cylinder of diameter ``d_c`` and length ``l_c``
on its axis, its face ``g`` from the ball. A sensor collides with coil ``k`` if it lies radially within the coil
(``R_s + g ≤ x·v_k ≤ R_s + g + l_c``) and closer than ``d_c/2 + clearance`` to its axis (``clearance`` covers
half the package). Candidates are directions in the cap (the stator shell exists there) that are collision-free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import checks
from ..errors import bad_value
from .parts import TMAG5273A2, MagnetometerPart

STANDOFF = 0.010  # m, sensitive point above the rotor surface: max |B| 0.18 T there (< 0.266 T range)
CLEARANCE = 0.002  # m, from a coil's outer surface to the sensor's sensitive point (half an SOT-23 + margin)


def fibonacci_directions(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (the Fibonacci lattice on S²), ``(n, 3)``."""
    n = checks.count(n, "n", 1, expected="a positive integer")
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (1.0 + math.sqrt(5.0)) * i
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def radial_frames(positions) -> np.ndarray:
    """Sensor axes ``(S, 3, 3)`` with z along the outward radius and x along ``e × z`` for the fixed axis ``e``
    least aligned with z (columns are the sensor's axes in the fixed frame)."""
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    z = p / np.linalg.norm(p, axis=1, keepdims=True)
    e = np.eye(3)[np.argmin(np.abs(z), axis=1)]
    x = np.cross(e, z)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=2)


def coil_collisions(design, positions, clearance: float = CLEARANCE) -> np.ndarray:
    """Boolean ``(S,)``: sensor ``s`` lies inside a coil's cylinder grown by ``clearance`` (see module doc)."""
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    v = design.stator.centers
    axial = p @ v.T  # (S, N)
    lateral = np.sqrt(np.maximum(np.sum(p * p, axis=1)[:, None] - axial ** 2, 0.0))
    lo = design.radius + design.air_gap - clearance
    hi = design.radius + design.air_gap + design.coil_length + clearance
    inside = (axial >= lo) & (axial <= hi) & (lateral <= 0.5 * design.coil_diameter + clearance)
    return inside.any(axis=1)


def candidate_positions(design, count: int = 2000, standoff: float = STANDOFF,
                        clearance: float = CLEARANCE) -> np.ndarray:
    """Collision-free sensor positions ``(S, 3)`` at radius ``R_s + standoff`` in the stator's cap, from a
    Fibonacci lattice of ``count`` directions over the whole sphere."""
    checks.number(standoff, "standoff", low=design.air_gap, high=design.coil_length, low_open=True, high_open=True,
                  expected=f"metres between the air gap {design.air_gap:g} and the coil length")
    d = fibonacci_directions(count)
    in_cap = d @ design.stator_axis >= math.cos(design.cap_half_angle)
    p = d[in_cap] * (design.radius + standoff)
    return p[~coil_collisions(design, p, clearance)]


@dataclass(frozen=True, eq=False)
class SensorArray:
    """Magnetometers at ``positions (S, 3)`` (m, fixed frame) with axes ``axes (S, 3, 3)`` (columns: the
    sensor's x, y, z in the fixed frame), all of one ``part``."""

    positions: np.ndarray
    axes: np.ndarray
    part: MagnetometerPart = field(default=TMAG5273A2)

    def __post_init__(self):
        p = np.asarray(self.positions, dtype=float)
        if p.ndim != 2 or p.shape[1] != 3 or len(p) < 1 or not np.all(np.isfinite(p)):
            raise bad_value("positions", "finite sensor positions of shape (S, 3) in metres, S ≥ 1",
                            f"shape {p.shape}")
        a = np.asarray(self.axes, dtype=float)
        if a.shape != (len(p), 3, 3):
            raise bad_value("axes", f"one 3×3 rotation per sensor, shape ({len(p)}, 3, 3)", f"shape {a.shape}")
        if np.abs(np.swapaxes(a, 1, 2) @ a - np.eye(3)).max() > 1e-9 or np.linalg.det(a).min() < 0:
            raise bad_value("axes", "proper rotations (orthonormal columns, det +1)", "a matrix that is not")
        object.__setattr__(self, "positions", p)
        object.__setattr__(self, "axes", a)

    def __len__(self) -> int:
        return len(self.positions)

    @classmethod
    def at(cls, positions, part: MagnetometerPart = TMAG5273A2) -> SensorArray:
        """Sensors at ``positions`` with radial frames (:func:`radial_frames`)."""
        p = np.asarray(positions, dtype=float).reshape(-1, 3)
        return cls(p, radial_frames(p), part)

    def subset(self, indices) -> SensorArray:
        idx = np.asarray(indices, dtype=int)
        return SensorArray(self.positions[idx], self.axes[idx], self.part)

    def check_fits(self, design, clearance: float = CLEARANCE) -> None:
        """InputError naming ``positions`` if a sensor is inside the rotor or collides with a coil."""
        r = np.linalg.norm(self.positions, axis=1)
        inside = np.nonzero(r <= design.radius + design.air_gap)[0]
        if len(inside):
            raise bad_value("positions", f"outside the rotor and the air gap (radius > "
                            f"{design.radius + design.air_gap:.4g} m)", f"sensor {int(inside[0])} at {r[inside[0]]:.4g} m")
        hit = np.nonzero(coil_collisions(design, self.positions, clearance))[0]
        if len(hit):
            raise bad_value("positions", "clear of every coil", f"sensor {int(hit[0])} inside a coil")

    def to_dict(self) -> dict:
        return {"positions_m": self.positions.tolist(), "axes": self.axes.tolist(), "part": self.part.to_dict()}
