"""`MotorDesign`: where the rotor's magnets and the stator's coils are, and how big they are (Sec. II-B-3, IV).

Frames: rotor poles ``u_j`` are unit vectors in the rotor (body) frame; stator coils ``v_k`` in the fixed
frame. At orientation ``R`` pole ``j`` points along ``R u_j``. Polarity ``+1`` means the magnet's north
pole faces outwards; a coil driven with polarity ``s`` attracts poles of polarity ``s``. Lengths are metres.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np

from ..errors import InputError, bad_value
from ..packing import Packing
from ..sphere import _as_points

MAX_COILS = 32  # four 8-relay boards (Sec. IV-B)
DEFAULT_TOL = math.radians(1.0)  # a pole within 1° of a coil's axis sits on it (2.7 mm on a 12-in rotor)


def default_channel_map(coil_count: int) -> np.ndarray:
    """Coil ``k`` → enable channel ``k``, polarity channel ``coil_count + k`` (shape ``(N, 2)``)."""
    k = np.arange(coil_count)
    return np.stack([k, coil_count + k], axis=1)


@dataclass(frozen=True, eq=False)
class MotorDesign:
    """A spherical stepper motor.

    ``rotor``: packing of permanent-magnet poles (body frame); ``polarity``: ±1 per pole; ``stator``:
    packing of the coils actually present (fixed frame), all within ``cap_half_angle`` (radians) of
    ``stator_axis``. Dimensions in metres: ``sphere_diameter``, magnet ``magnet_diameter`` × ``magnet_length``,
    coil ``coil_diameter`` × ``coil_length``, ``air_gap`` between rotor surface and coil faces. ``tol``
    (radians) is how close a pole must sit to a coil to count as held; ``channel_map`` gives each coil its
    (enable, polarity) relay channel. ``allow_hemisphere`` and ``max_coils`` lift the paper's limits.
    """

    rotor: Packing
    polarity: np.ndarray
    stator: Packing
    stator_axis: np.ndarray
    cap_half_angle: float
    sphere_diameter: float
    magnet_diameter: float
    magnet_length: float
    coil_diameter: float
    coil_length: float
    air_gap: float
    tol: float | None = None
    remanence: float = 1.32
    coil_ampere_turns: float = 1000.0
    name: str = "design"
    channel_map: np.ndarray | None = None
    allow_hemisphere: bool = False
    max_coils: int = MAX_COILS
    failed_coils: tuple[int, ...] = field(default=())

    def __post_init__(self):
        polarity = np.asarray(self.polarity)
        if polarity.shape != (len(self.rotor),) or not np.all(np.isin(polarity, (-1, 1))):
            raise bad_value("polarity", f"{len(self.rotor)} values, each +1 or -1 (one per rotor pole)",
                            f"shape {polarity.shape}" if polarity.shape != (len(self.rotor),) else polarity.tolist())
        axis = _as_points(self.stator_axis, "stator_axis")
        if axis.shape != (3,):
            raise bad_value("stator_axis", "one unit 3-vector", f"shape {axis.shape}")
        for label in ("cap_half_angle",):
            value = getattr(self, label)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0 < value < math.pi):
                raise bad_value(label, "an angle in (0, π) radians", value)
        if self.cap_half_angle >= math.pi / 2 and not self.allow_hemisphere:
            raise bad_value("cap_half_angle", "under 90° (a stator covering less than a hemisphere gives the wide "
                            "range of motion, Sec. IV); set allow_hemisphere to override",
                            f"{math.degrees(self.cap_half_angle):.4g}°")
        for label in ("sphere_diameter", "magnet_diameter", "magnet_length", "coil_diameter", "coil_length",
                      "remanence", "coil_ampere_turns"):
            value = getattr(self, label)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
                raise bad_value(label, "a finite positive number (metres for lengths)", value)
        if isinstance(self.air_gap, bool) or not isinstance(self.air_gap, (int, float)) or \
                not math.isfinite(self.air_gap) or self.air_gap < 0:
            raise bad_value("air_gap", "a finite non-negative length in metres", self.air_gap)
        if self.magnet_diameter >= self.sphere_diameter or self.coil_diameter >= self.sphere_diameter:
            raise bad_value("magnet_diameter/coil_diameter", "smaller than the sphere's diameter",
                            (self.magnet_diameter, self.coil_diameter))
        if len(self.stator) > self.max_coils:
            raise bad_value("stator", f"at most {self.max_coils} coils (four 8-relay boards, Sec. IV-B); raise "
                            "max_coils to override", f"{len(self.stator)} coils")
        off = np.degrees(np.arccos(np.clip(self.stator.centers @ axis, -1, 1))) - math.degrees(self.cap_half_angle)
        if np.any(off > 1e-9):
            k = int(np.argmax(off))
            raise bad_value(f"stator coil {k}", f"within the stator cap ({math.degrees(self.cap_half_angle):.4g}° "
                            "about stator_axis)", f"{off[k]:.4g}° outside it")
        if self.tol is not None and not (isinstance(self.tol, (int, float)) and 0 < self.tol < 0.5):
            raise bad_value("tol", "an angle in (0, 0.5) radians", self.tol)
        cmap = default_channel_map(len(self.stator)) if self.channel_map is None else np.asarray(self.channel_map)
        if cmap.shape != (len(self.stator), 2) or not np.issubdtype(cmap.dtype, np.integer) or np.any(cmap < 0):
            raise bad_value("channel_map", f"{len(self.stator)} pairs of non-negative integer channels "
                            "(enable, polarity), one per coil", f"shape {cmap.shape}")
        if len(np.unique(cmap.ravel())) != cmap.size:
            raise bad_value("channel_map", "distinct channels for every coil's enable and polarity", cmap.tolist())
        bad = [k for k in self.failed_coils if not 0 <= k < len(self.stator)]
        if bad:
            raise bad_value("failed_coils", f"coil indices 0..{len(self.stator) - 1}", bad)
        object.__setattr__(self, "polarity", polarity.astype(int))
        object.__setattr__(self, "stator_axis", axis / np.linalg.norm(axis))
        object.__setattr__(self, "channel_map", cmap.astype(int))
        object.__setattr__(self, "failed_coils", tuple(sorted(set(int(k) for k in self.failed_coils))))

    # --- design files ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path) -> "MotorDesign":
        """Read a design file, YAML or ``.toml`` (see :mod:`spherestep.design_file`)."""
        from ..design_file import load

        return load(path)

    def save(self, path):
        """Write this design to a YAML design file, atomically; returns the path."""
        from ..design_file import save

        return save(self, path)

    # --- geometry -------------------------------------------------------------------------------------
    @property
    def radius(self) -> float:
        """Rotor radius (m)."""
        return 0.5 * self.sphere_diameter

    @property
    def magnet_angle(self) -> float:
        """Angular radius (rad) of a rotor magnet's face seen from the centre: ``atan(d_m / 2 / R)``."""
        return math.atan(0.5 * self.magnet_diameter / self.radius)

    @property
    def coil_angle(self) -> float:
        """Angular radius (rad) of a coil face at ``R + gap`` seen from the centre: ``atan(d_c / 2 / (R + g))``."""
        return math.atan(0.5 * self.coil_diameter / (self.radius + self.air_gap))

    @property
    def state_tol(self) -> float:
        """Tolerance (rad) for a pole to sit on a coil: ``tol`` if set, else :data:`DEFAULT_TOL` (1°)."""
        return self.tol if self.tol is not None else DEFAULT_TOL

    @property
    def max_step(self) -> float:
        """Largest step (Park distance, rad) a pair of energised coils can pull the rotor through.

        A coil pulls a magnet while their faces overlap, i.e. while the pole is within
        ``coil_angle + magnet_angle`` of the coil's axis; a rotation by ``θ`` moves no pole by more than ``θ``,
        so from any orientation within that Park distance of a state, the state's holding poles are under
        their coils' faces.
        """
        return self.coil_angle + self.magnet_angle

    @property
    def active_coils(self) -> np.ndarray:
        """Indices of the coils that work (all but ``failed_coils``)."""
        return np.setdiff1d(np.arange(len(self.stator)), np.array(self.failed_coils, dtype=int))

    def without_coils(self, coils) -> "MotorDesign":
        """The same motor with the given coils failed (they are never energised)."""
        return replace(self, failed_coils=tuple(self.failed_coils) + tuple(int(k) for k in coils))

    def inertia(self, shell_mass: float = 0.6, magnet_density: float = 7500.0) -> np.ndarray:
        """Rotor inertia tensor (kg·m²): a thin shell ``(2/3) m R²`` plus point magnets at ``R − l/2``."""
        r = self.radius - 0.5 * self.magnet_length
        m = magnet_density * math.pi * (0.5 * self.magnet_diameter) ** 2 * self.magnet_length
        u = self.rotor.centers
        return (2.0 / 3.0) * shell_mass * self.radius ** 2 * np.eye(3) + m * r ** 2 * (len(u) * np.eye(3) - u.T @ u)

    # --- stepper states and metrics ---------------------------------------------------------------------
    @cached_property
    def _states(self):
        from .states import find_states

        return find_states(self, self.state_tol)

    def states(self, tol: float | None = None):
        """The stepper states (:class:`~spherestep.motor.states.StepperStates`) at ``tol`` (default the design's)."""
        if tol is None or tol == self.state_tol:
            return self._states
        from .states import find_states

        if not (isinstance(tol, (int, float)) and 0 < tol < 0.5):
            raise bad_value("tol", "an angle in (0, 0.5) radians", tol)
        return find_states(self, float(tol))

    def metrics(self, samples: int = 20_000, seed: int = 0, escape: bool = True) -> dict:
        """Design metrics (see :func:`spherestep.motor.metrics.design_metrics`)."""
        from .metrics import design_metrics

        return design_metrics(self, samples=samples, seed=seed, escape=escape)

    def summary(self) -> dict:
        """Poles, coils and dimensions as a JSON-ready dict (degrees and millimetres for people)."""
        return {
            "name": self.name,
            "rotor": self.rotor.label,
            "rotor_poles": len(self.rotor),
            "stator": self.stator.label,
            "coils": len(self.stator),
            "failed_coils": list(self.failed_coils),
            "cap_half_angle_deg": math.degrees(self.cap_half_angle),
            "sphere_diameter_mm": 1e3 * self.sphere_diameter,
            "magnet_mm": [1e3 * self.magnet_diameter, 1e3 * self.magnet_length],
            "coil_mm": [1e3 * self.coil_diameter, 1e3 * self.coil_length],
            "air_gap_mm": 1e3 * self.air_gap,
            "state_tol_deg": math.degrees(self.state_tol),
            "max_step_deg": math.degrees(self.max_step),
            "rotor_inertia_isotropy": self.rotor.inertia_isotropy(),
        }


def check_fits(design: MotorDesign) -> None:
    """Raise InputError when magnets or coils overlap physically (their faces closer than their sizes)."""
    from ..packing.core import arc_from_chord

    for label, pk, half in (("rotor", design.rotor, design.magnet_angle), ("stator", design.stator, design.coil_angle)):
        if len(pk) < 2:
            continue
        dist, idx = pk.tree.query(pk.centers, k=2)
        sep = arc_from_chord(dist[:, 1])
        k = int(np.argmin(sep))
        if sep[k] < 2 * half - 1e-12:
            raise InputError(f"{label} poles {k} and {int(idx[k, 1])} overlap: centres {np.degrees(sep[k]):.3f}° "
                             f"apart but each face spans {np.degrees(half):.3f}°; use smaller parts or fewer poles")
