"""The design grid of a sweep: rotor packing × stator packing × refinement levels × stator cap × tolerance.

A :class:`DesignPoint` is one motor to evaluate, named by every parameter that changes its metrics; its
:attr:`~DesignPoint.key` is a hash of them, stable across processes and runs, so results can be matched to
designs and a sweep resumed. A :class:`Grid` lists the values of each axis and the pairing rule of
Sec. II-B-3: the rotor and the stator come from different symmetry families, and their primary circles are
nearly the same size. Same-family pairs are kept for contrast (``same_family=True``), flagged in the table by
``family_rule == "same"``.

Families are the symmetry groups of the packings themselves (rotation group of order 12, 24 or 60: T, O,
I), not the family they were constructed in: the tetrahedral octahedron, cuboctahedron and truncated
octahedron are the octahedral ones turned (:func:`spherestep.packing.distinct`), so they count as O.

Parts (rotor magnets and stator coils) are the prototype's (Sec. IV-A: 12-in rotor, 2-in × 1.625-in coils,
0.005-in gap; 1-in × 0.5-in magnets) where they fit, and shrink where the packing is finer: a magnet's
diameter is at most ``fill`` × the room between the two closest poles, ``2R tan(d_min/2)``; a coil's at most
``fill`` × the stator's primary cap (coils go on the caps at least as wide as the coil, as in
:meth:`spherestep.packing.Packing.within_cap`). Parts that would shrink below ``magnet_diameter_min`` or
``coil_diameter_min`` do not fit.
"""

from __future__ import annotations

import functools
import hashlib
import itertools
import json
import math
from dataclasses import asdict, dataclass, fields

from .. import checks
from .. import packing as pk
from ..design_file import MAX_REFINE
from ..errors import bad_value
from ..units import length

KEY_VERSION = 2  # bump when the metrics of a design change meaning, so old results are not reused (2: the torques on
#                  the design's own model, the core a parameter)
CORES = ("air", "iron")  # the coils' core (the prototype's pot-core coil, iron_coil(), with this core)
FAMILY_OF_ORDER = {12: "T", 24: "O", 60: "I"}
MAX_SAMPLES = 1_000_000
MAX_TORQUE_STATES = 1000


@functools.cache
def distinct_names() -> tuple[str, ...]:
    """The 16 pairwise non-congruent base packings (of the 21), in :func:`spherestep.packing.names` order."""
    return tuple(p.name for p in pk.distinct([pk.by_name(n) for n in pk.names()]))


@functools.cache
def symmetry_family(name: str) -> str:
    """'T', 'O' or 'I': the rotation group of base packing ``name`` (order 12, 24 or 60)."""
    return FAMILY_OF_ORDER[pk.by_name(name).symmetry_order()]


@functools.cache
def primary_radius(name: str) -> float:
    """Angular radius (rad) of the primary circles of base packing ``name`` (all its caps are equal)."""
    return float(pk.by_name(name).radii[0])


def primary_ratio(rotor: str, stator: str) -> float:
    """Larger over smaller primary radius of the two packings (1 when the primary circles are equal)."""
    a, b = primary_radius(rotor), primary_radius(stator)
    return max(a, b) / min(a, b)


@dataclass(frozen=True)
class DesignPoint:
    """One motor of a sweep. Angles in degrees (a table for people), lengths in metres.

    ``rotor``, ``stator``: base packing names, refined ``rotor_level`` / ``stator_level`` times; poles of the
    base packing are north-out (+1), those refinement added south-out (−1), as in the prototype. Coils sit on
    the stator caps within ``cap_half_angle_deg`` of ``stator_axis`` that are wide enough for a coil.
    ``tol_deg``: how close a pole must be to a coil to count as held. ``samples`` random orientations
    (``seed``) measure the resolution; ``torque_states`` stepper states drawn at random (``seed``) measure the
    holding torque on the design's own model (:func:`spherestep.magnetics.design_model`; 0: not measured). The
    part sizes follow the rule in the module docstring. ``core``: the coils' core, ``"iron"`` (the prototype's
    pot-core coil, :func:`spherestep.motor.coil.iron_coil`, the default of every design) or ``"air"`` (the same
    winding without the iron); the torques are measured on that design's own model.
    """

    rotor: str
    rotor_level: int
    stator: str
    stator_level: int
    cap_half_angle_deg: float
    tol_deg: float = 1.0
    samples: int = 2000
    seed: int = 0
    torque_states: int = 8
    stator_axis: tuple[float, float, float] = (0.0, 0.0, -1.0)
    sphere_diameter: float = length("12 in")
    air_gap: float = length("0.005 in")
    magnet_diameter_max: float = length("1 in")
    magnet_diameter_min: float = length("0.25 in")
    magnet_length: float = length("0.5 in")
    coil_diameter_max: float = length("2 in")
    coil_diameter_min: float = length("0.5 in")
    coil_length: float = length("1.625 in")
    fill: float = 0.9
    core: str = "iron"

    def __post_init__(self):
        if self.core not in CORES:
            raise bad_value("core", "'air' or 'iron'", self.core)
        for label in ("rotor", "stator"):
            name = getattr(self, label)
            if name not in pk.names():
                raise bad_value(label, f"a packing name, one of {', '.join(pk.names())}", name)
        for label in ("rotor_level", "stator_level"):
            level = checks.count(getattr(self, label), label, 0, MAX_REFINE,
                                 expected=f"a refinement level 0..{MAX_REFINE}")
            object.__setattr__(self, label, level)
        checks.number(self.cap_half_angle_deg, "cap_half_angle_deg", low=0.0, high=90.0, low_open=True,
                      high_open=True, expected="an angle in (0, 90) degrees (less than a hemisphere)")
        checks.number(self.tol_deg, "tol_deg", low=0.0, high=math.degrees(0.5), low_open=True, high_open=True,
                      expected=f"an angle in (0, {math.degrees(0.5):.4g}) degrees")
        for label, low, high, expected in (
                ("samples", 1, MAX_SAMPLES, f"an integer in 1..{MAX_SAMPLES}"),
                ("seed", 0, None, "a non-negative integer"),
                ("torque_states", 0, MAX_TORQUE_STATES,
                 f"an integer in 0..{MAX_TORQUE_STATES} (0: no holding torque)")):
            object.__setattr__(self, label, checks.count(getattr(self, label), label, low, high, expected=expected))
        checks.number(self.fill, "fill", low=0.0, high=1.0, low_open=True, expected="a fraction in (0, 1]")
        for label in ("sphere_diameter", "magnet_diameter_max", "magnet_diameter_min", "magnet_length",
                      "coil_diameter_max", "coil_diameter_min", "coil_length"):
            checks.positive(getattr(self, label), label, "a finite positive length in metres")
        checks.non_negative(self.air_gap, "air_gap", "a finite non-negative length in metres")
        checks.axis(self.stator_axis, "stator_axis")  # the axis is kept as given (it is part of the point's key)
        object.__setattr__(self, "stator_axis", tuple(float(x) for x in self.stator_axis))
        for f in fields(self):
            if f.type == "float":
                object.__setattr__(self, f.name, float(getattr(self, f.name)))

    @property
    def params(self) -> dict:
        """Every parameter as a JSON-ready dict (the input of :attr:`key` and of :meth:`from_params`)."""
        out = asdict(self)
        out["stator_axis"] = list(self.stator_axis)
        return out

    @functools.cached_property
    def key(self) -> str:
        """16 hex digits of the SHA-256 of the parameters (canonical JSON): equal for equal designs."""
        text = json.dumps({"version": KEY_VERSION} | self.params, sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    @classmethod
    def from_params(cls, params: dict | str) -> DesignPoint:
        """The point of a :attr:`params` dict (or its JSON text), as stored in the results table."""
        data = json.loads(params) if isinstance(params, str) else dict(params)
        data["stator_axis"] = tuple(data["stator_axis"])
        return cls(**data)

    @property
    def rotor_family(self) -> str:
        return symmetry_family(self.rotor)

    @property
    def stator_family(self) -> str:
        return symmetry_family(self.stator)

    @property
    def family_rule(self) -> str:
        """'different' when rotor and stator come from different symmetry families (Sec. II-B-3), else 'same'."""
        return "same" if self.rotor_family == self.stator_family else "different"

    @property
    def label(self) -> str:
        """Short text for people: ``rotor/Lr × stator/Ls, cap C°, tol T°``."""
        return (f"{self.rotor}/L{self.rotor_level} × {self.stator}/L{self.stator_level}, "
                f"cap {self.cap_half_angle_deg:g}°, tol {self.tol_deg:g}°")


def _tuple(value, label: str, check) -> tuple:
    """``value`` as a non-empty tuple of distinct items, each returned by ``check(item)`` (which raises an
    InputError naming ``label``)."""
    try:
        items = tuple(value)
    except TypeError:
        raise bad_value(label, "a list of values", value) from None
    if not items:
        raise bad_value(label, "at least one value", value)
    if len(set(items)) != len(items):
        raise bad_value(label, "distinct values", value)
    return tuple(check(item) for item in items)


def _name(label: str):
    """The item check of a list of packing names."""
    def check(item):
        if not isinstance(item, str) or item not in pk.names():
            raise bad_value(label, f"packing names, each one of {', '.join(pk.names())}", item)
        return item
    return check


@dataclass(frozen=True)
class Grid:
    """The axes of a sweep and the pairing rule (see the module docstring).

    Every combination of ``rotors`` × ``rotor_levels`` × ``stators`` × ``stator_levels`` ×
    ``cap_half_angles_deg`` × ``tolerances_deg`` is a design, except pairs whose primary circles differ by
    more than ``primary_ratio_max`` (None: no limit) and, unless ``same_family``, pairs from one family.
    ``rotors`` and ``stators`` default to the 16 distinct base packings (:func:`distinct_names`); ``core`` is
    every design's (:class:`DesignPoint`).
    """

    rotors: tuple[str, ...] | None = None
    stators: tuple[str, ...] | None = None
    rotor_levels: tuple[int, ...] = (0, 1, 2)
    stator_levels: tuple[int, ...] = (0, 1)
    cap_half_angles_deg: tuple[float, ...] = (60.0, 80.0)
    tolerances_deg: tuple[float, ...] = (1.0,)
    primary_ratio_max: float | None = 1.25
    same_family: bool = True
    samples: int = 2000
    seed: int = 0
    torque_states: int = 8
    core: str = "iron"

    def __post_init__(self):
        for label in ("rotors", "stators"):
            value = getattr(self, label)
            object.__setattr__(self, label, _tuple(distinct_names() if value is None else value, label, _name(label)))
        for label in ("rotor_levels", "stator_levels"):
            level = functools.partial(checks.count, name=label, minimum=0, maximum=MAX_REFINE,
                                      expected=f"refinement levels 0..{MAX_REFINE}")
            object.__setattr__(self, label, _tuple(getattr(self, label), label, level))
        caps = _tuple(self.cap_half_angles_deg, "cap_half_angles_deg", functools.partial(
            checks.number, name="cap_half_angles_deg", low=0.0, high=90.0, low_open=True, high_open=True,
            expected="angles in (0, 90) degrees"))
        tols = _tuple(self.tolerances_deg, "tolerances_deg", functools.partial(
            checks.number, name="tolerances_deg", low=0.0, high=math.degrees(0.5), low_open=True, high_open=True,
            expected=f"angles in (0, {math.degrees(0.5):.4g}) degrees"))
        object.__setattr__(self, "cap_half_angles_deg", caps)  # floats, from checks.number
        object.__setattr__(self, "tolerances_deg", tols)
        if self.primary_ratio_max is not None:
            checks.number(self.primary_ratio_max, "primary_ratio_max", low=1.0,
                          expected="a ratio of at least 1, or None for no limit")
        # samples, seed and torque_states are checked by DesignPoint; here too, so an empty grid refuses them
        DesignPoint(self.rotors[0], 0, self.stators[0], 0, self.cap_half_angles_deg[0], self.tolerances_deg[0],
                    samples=self.samples, seed=self.seed, torque_states=self.torque_states, core=self.core)

    def pairs(self) -> list[tuple[str, str]]:
        """The (rotor, stator) packing pairs the rule admits, in grid order."""
        out = []
        for rotor, stator in itertools.product(self.rotors, self.stators):
            if not self.same_family and symmetry_family(rotor) == symmetry_family(stator):
                continue
            limit = self.primary_ratio_max
            if limit is not None and primary_ratio(rotor, stator) > limit * (1 + 1e-12):
                continue
            out.append((rotor, stator))
        return out

    def points(self) -> list[DesignPoint]:
        """Every design of the grid, in a fixed order (rotor, rotor level, stator, stator level, cap, tol)."""
        out = []
        for rotor, stator in self.pairs():
            for rl, sl, cap, tol in itertools.product(self.rotor_levels, self.stator_levels,
                                                      self.cap_half_angles_deg, self.tolerances_deg):
                out.append(DesignPoint(rotor, rl, stator, sl, cap, tol, samples=self.samples, seed=self.seed,
                                       torque_states=self.torque_states, core=self.core))
        return sorted(out, key=lambda p: (self.rotors.index(p.rotor), p.rotor_level, self.stators.index(p.stator),
                                          p.stator_level, p.cap_half_angle_deg, p.tol_deg))


def default_grid(**changes) -> Grid:
    """The sweep of ``spherestep explore``: the 16 distinct packings as rotor and stator, rotors refined 0–2
    times and stators 0–1 times, stator caps of 60° and 80°, tolerance 1°, primary circles within a ratio of
    1.25, same-family pairs kept for contrast; resolution from 2000 orientations, holding torque from 8 states."""
    return Grid(**changes)


def quick_grid(**changes) -> Grid:
    """A tiny sweep (12 designs, seconds): the paper's rotor, the truncated icosahedron, and the dodecahedron,
    unrefined, over the truncated cuboctahedron (the paper's stator) and the truncated octahedron (both O) and
    the same-family rhombicosidodecahedron, stators unrefined and refined once, in a 60° cap."""
    base = dict(rotors=("truncated-icosahedron", "dodecahedron"),
                stators=("truncated-cuboctahedron", "truncated-octahedron", "rhombicosidodecahedron"),
                rotor_levels=(0,), stator_levels=(0, 1), cap_half_angles_deg=(60.0,), primary_ratio_max=1.8)
    return Grid(**(base | changes))
