"""Design files: a :class:`~spherestep.motor.MotorDesign` as a versioned YAML (or TOML) document.

Schema version 1 is described field by field in ``docs/design-files.md``. In short::

    schema_version: 1
    name: prototype
    rotor:   {packing: truncated-icosahedron, refine: 1, polarity: {primary: +1, filled: -1}}
    stator:  {packing: truncated-cuboctahedron, refine: 1, axis: [0, 0, -1], cap_half_angle: 80 deg, coils: fit}
    dimensions: {sphere_diameter: 12 in, magnet_diameter: 1 in, magnet_length: 0.5 in,
                 coil_diameter: 2 in, coil_length: 1.625 in, air_gap: 0.005 in}

Every length and angle carries its unit (``"12 in"``, ``"25.4 mm"``, ``"80 deg"``, ``"1.4 rad"``), converted once
here to metres and radians. :func:`load` reads a file, :func:`save` writes one; ``save`` then ``load`` gives back
the same design (centres to 1e-12, everything else exactly), because ``save`` writes lengths and angles as the
shortest decimal that converts back to the same float. Every mistake in a file raises :class:`DesignFileError`
(an :class:`~spherestep.errors.InputError`) whose one-line message names the file, the field path such as
``stator.cap_half_angle``, and the fix.

See also :mod:`spherestep.units` (lengths), :func:`spherestep.motor.prototype` (the design of
``data/prototype.yaml``).
"""

from __future__ import annotations

import functools
import math
import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal, Union

import numpy as np
import yaml
from pydantic import (AfterValidator, BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag,
                      ValidationError, field_validator, model_validator)

from . import packing as pk
from .atomic import write_text
from .errors import InputError
from .motor.design import MAX_COILS, MotorDesign, check_fits, default_channel_map
from .motor.prototype import stator_in_cap
from .sphere import UNIT_TOL
from .units import METRES_PER_UNIT

SCHEMA_VERSION = 1
MAX_REFINE = 4  # 4862 caps for the largest base packing; level 5 takes seconds and has 14 582
MAX_POLES = 10_000
MAX_BYTES = 8 * 2 ** 20
MAX_CHANNEL = 4095
MAX_INDEX = 1_000_000
DEFAULT_REMANENCE = 1.32
DEFAULT_AMPERE_TURNS = 1000.0
MATCH_TOL = 1e-12  # a saved centre is the named packing's cap when they agree this well

LENGTH_UNITS = METRES_PER_UNIT
ANGLE_UNITS = ("deg", "°", "rad")
TESLA_UNITS = {"T": 1.0, "mT": 1e-3}
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*$")
_HEADER = "# spherestep design file; every field is described in docs/design-files.md\n"


class DesignFileError(InputError):
    """A design file that cannot be read: ``source: field message`` on one line; ``field`` is the path."""

    def __init__(self, source: str, field: str | None, message: str):
        self.source = source
        self.field = field
        text = re.sub(r"\s*\n\s*", " ", f"{source}: {message}")
        super().__init__(text)


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# --- quantities with units ---------------------------------------------------------------------------------

def _split(value: Any, what: str, example: str) -> tuple[float, str]:
    """``(number, unit)`` of a string like ``"12 in"``; ValueError saying what was expected otherwise."""
    match = _QUANTITY.match(value) if isinstance(value, str) else None
    if match is None or not match.group(2):
        raise ValueError(f"must be {what} with its unit, like {example!r}; instead received {_show(value)}")
    return float(match.group(1)), match.group(2)


def _length(value: Any, *, allow_zero: bool = False) -> float:
    number, unit = _split(value, "a length", "12 in")
    unit = unit.lower()
    if unit not in LENGTH_UNITS:
        raise ValueError(f"must be a length with unit one of m, cm, mm, um, in, ft, like '12 in'; instead received "
                         f"{_show(value)}")
    metres = number * LENGTH_UNITS[unit]
    if not math.isfinite(metres) or metres < 0 or (metres == 0 and not allow_zero):
        raise ValueError(f"must be a finite {'non-negative' if allow_zero else 'positive'} length; "
                         f"instead received {_show(value)}")
    return metres


def _angle(value: Any) -> float:
    number, unit = _split(value, "an angle", "80 deg")
    unit = unit.lower()
    if unit not in ANGLE_UNITS:
        raise ValueError(f"must be an angle with unit deg or rad, like '80 deg'; instead received {_show(value)}")
    radians = number if unit == "rad" else math.radians(number)
    if not math.isfinite(radians):
        raise ValueError(f"must be a finite angle; instead received {_show(value)}")
    return radians


def _tesla(value: Any) -> float:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        tesla = float(value)
    else:
        number, unit = _split(value, "a flux density", "1.32 T")
        if unit not in TESLA_UNITS:
            raise ValueError(f"must be a flux density in T or mT, like '1.32 T'; instead received {_show(value)}")
        tesla = number * TESLA_UNITS[unit]
    if not (math.isfinite(tesla) and tesla > 0):
        raise ValueError(f"must be a finite positive flux density, like '1.32 T'; instead received {_show(value)}")
    return tesla


def _shortest(guess: float, target: float, back) -> str | None:
    """The shortest decimal ``text`` of ``guess`` with ``back(float(text)) == target`` exactly, or None."""
    for digits in range(1, 18):
        text = repr(float(f"{guess:.{digits}g}")).removesuffix(".0")
        if back(float(text)) == target:
            return text
    return None


def length_text(metres: float) -> str:
    """``metres`` as the shortest exact string in inches, millimetres or metres (``"12 in"``)."""
    for unit in ("in", "mm", "m"):
        factor = LENGTH_UNITS[unit]
        text = _shortest(metres / factor, metres, lambda x, f=factor: x * f)
        if text is not None:
            return f"{text} {unit}"
    return f"{metres!r} m"


def angle_text(radians: float) -> str:
    """``radians`` as the shortest exact string in degrees (``"80 deg"``), else in radians."""
    text = _shortest(math.degrees(radians), radians, math.radians)
    return f"{text} deg" if text is not None else f"{radians!r} rad"


def tesla_text(tesla: float) -> str:
    """``tesla`` as an exact string ``"1.32 T"``."""
    return f"{_shortest(tesla, tesla, float)} T"


Length = Annotated[float, BeforeValidator(_length)]
Gap = Annotated[float, BeforeValidator(functools.partial(_length, allow_zero=True))]
Angle = Annotated[float, BeforeValidator(_angle)]
Tesla = Annotated[float, BeforeValidator(_tesla)]
Sign = Literal[1, -1]
Index = Annotated[int, Field(ge=0, le=MAX_INDEX)]
Channel = Annotated[int, Field(ge=0, le=MAX_CHANNEL)]


# --- the schema --------------------------------------------------------------------------------------------

class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)


def _vector_form(value: Any) -> Any:
    """A list ``[x, y, z]`` becomes ``{x, y, z}``; a mapping passes; anything else is an error."""
    if isinstance(value, list):
        if len(value) != 3:
            raise ValueError(f"must be a unit vector [x, y, z] (three numbers); instead received {len(value)} "
                             "numbers")
        return dict(zip("xyz", value))
    if isinstance(value, dict):
        return value
    raise ValueError("must be a unit vector [x, y, z] or a mapping {phi: 90 deg, theta: 45 deg}; instead "
                     f"received {_show(value)}")


class Direction(_Model):
    """A point on the sphere: ``x, y, z`` (a unit vector) or ``phi, theta``; ``radius`` of its cap (optional)."""

    x: float | None = None
    y: float | None = None
    z: float | None = None
    phi: Angle | None = None
    theta: Angle | None = None
    radius: Angle | None = None

    @model_validator(mode="after")
    def _one_form(self):
        xyz = (self.x, self.y, self.z)
        angles = (self.phi, self.theta)
        if all(v is not None for v in xyz) and all(v is None for v in angles):
            norm = math.sqrt(sum(v * v for v in xyz))
            if abs(norm - 1.0) > UNIT_TOL:
                raise ValueError(f"must be a unit vector (|v| = 1 within {UNIT_TOL:g}): divide it by its norm, or "
                                 f"give phi and theta; instead received a vector of norm {norm:.12g}")
        elif not (all(v is not None for v in angles) and all(v is None for v in xyz)):
            raise ValueError("must give either x, y and z (a unit vector) or phi and theta (angles with units), "
                             "not a mix")
        if self.radius is not None and not 0 < self.radius <= math.pi:
            raise ValueError(f"must have a radius in (0, 180] deg; instead received {math.degrees(self.radius):.6g} deg")
        return self

    @property
    def vector(self) -> np.ndarray:
        """The unit vector, ``u(φ, θ) = (cos φ sin θ, sin φ sin θ, cos θ)`` for the angle form."""
        if self.x is not None:
            return np.array([self.x, self.y, self.z], dtype=float)
        s = math.sin(self.theta)
        return np.array([math.cos(self.phi) * s, math.sin(self.phi) * s, math.cos(self.theta)])


DirectionIn = Annotated[Direction, BeforeValidator(_vector_form)]


def _packing_name(name: str) -> str:
    if name not in pk.names():
        raise ValueError(f"must be a packing name listed by `spherestep packings --all`, such as "
                         f"truncated-icosahedron; instead received {_show(name)}")
    return name


def _printable(text: str) -> str:
    if not text.isprintable():
        raise ValueError(f"must be printable text on one line (no tabs, line breaks or control characters); "
                         f"instead received {_show(text)}")
    return text


Name = Annotated[str, Field(min_length=1, max_length=200), AfterValidator(_printable)]
PackingName = Annotated[str, BeforeValidator(lambda v: _packing_name(v) if isinstance(v, str) else v)]


class PolarityRule(_Model):
    """``primary``: sign of the base packing's poles; ``filled``: of the poles refinement added (default −primary)."""

    primary: Sign
    filled: Sign | None = None


def _polarity_form(value: Any) -> str | None:
    return "<list>" if isinstance(value, list) else "<rule>" if isinstance(value, dict) else None


Polarity = Annotated[
    Union[Annotated[list[Sign], Tag("<list>")], Annotated[PolarityRule, Tag("<rule>")]],
    Discriminator(_polarity_form, custom_error_type="polarity_form",
                  custom_error_message="must be a list of +1/-1, one per rotor pole, or a rule like "
                                       "{primary: +1, filled: -1}"),
]


def _fit(value: str) -> str:
    if value != "fit":
        raise ValueError("must be 'fit', a list of cap indices of stator.packing or a list of coil directions; "
                         f"instead received {_show(value)}")
    return value


def _coils_form(value: Any) -> str | None:
    if isinstance(value, str):
        return "<fit>"
    if isinstance(value, list):
        first = value[0] if value else 0
        return "<indices>" if isinstance(first, int) and not isinstance(first, bool) else "<directions>"
    return None


Coils = Annotated[
    Union[Annotated[str, AfterValidator(_fit), Tag("<fit>")],
          Annotated[list[Index], Tag("<indices>"), Field(min_length=1, max_length=MAX_POLES)],
          Annotated[list[DirectionIn], Tag("<directions>"), Field(min_length=1, max_length=MAX_POLES)]],
    Discriminator(_coils_form, custom_error_type="coils_form",
                  custom_error_message="must be 'fit', a list of cap indices of stator.packing, or a list of "
                                       "coil directions"),
]


class RotorSpec(_Model):
    """The rotor's poles: a named packing refined ``refine`` times, or an explicit list; their polarities."""

    packing: PackingName | None = None
    refine: Annotated[int, Field(ge=0, le=MAX_REFINE)] | None = None
    poles: Annotated[list[DirectionIn], Field(min_length=1, max_length=MAX_POLES)] | None = None
    name: Name | None = None
    polarity: Polarity

    @model_validator(mode="after")
    def _one_form(self):
        if (self.packing is None) == (self.poles is None):
            raise ValueError("needs either packing (with refine) or poles, not both and not neither")
        if self.packing is None and (self.refine is not None or isinstance(self.polarity, PolarityRule)):
            raise ValueError("with explicit poles takes no refine and needs polarity as a list of +1/-1 per pole")
        if self.packing is not None and self.name is not None:
            raise ValueError("takes a name only with explicit poles (a named packing is named by packing)")
        return self


class StatorSpec(_Model):
    """The stator: a cap about ``axis`` and the coils in it (named packing + rule or indices, or directions)."""

    axis: DirectionIn
    cap_half_angle: Angle
    packing: PackingName | None = None
    refine: Annotated[int, Field(ge=0, le=MAX_REFINE)] | None = None
    name: Name | None = None
    coils: Coils

    @field_validator("axis")
    @classmethod
    def _axis(cls, value: Direction) -> Direction:
        if value.radius is not None:
            raise ValueError("takes no radius: give [x, y, z] or {phi, theta}")
        return value

    @field_validator("cap_half_angle")
    @classmethod
    def _cap(cls, value: float) -> float:
        if not 0 < value < math.pi:
            raise ValueError(f"must be between 0 and 180 deg; instead received {math.degrees(value):.6g} deg")
        return value

    @model_validator(mode="after")
    def _consistent(self):
        by_packing = self.coils == "fit" or (isinstance(self.coils, list) and isinstance(self.coils[0], int))
        if self.packing is None and by_packing:
            raise ValueError("needs packing (and refine) when coils is 'fit' or a list of cap indices; or give "
                             "coils as a list of directions")
        if self.packing is not None and not by_packing:
            raise ValueError("with coils as directions takes no packing: remove packing and refine, or give "
                             "coils as 'fit' or a list of cap indices")
        if self.packing is None and self.refine is not None:
            raise ValueError("takes refine only with packing")
        if self.packing is not None and self.name is not None:
            raise ValueError("takes a name only with coils as directions")
        return self


class Dimensions(_Model):
    """Sizes with units: rotor diameter, magnet and coil cylinders, the air gap."""

    sphere_diameter: Length
    magnet_diameter: Length
    magnet_length: Length
    coil_diameter: Length
    coil_length: Length
    air_gap: Gap


class Overrides(_Model):
    """Lift the paper's limits: more than 32 coils, a stator cap of a hemisphere or more."""

    max_coils: Annotated[int, Field(ge=1, le=MAX_INDEX)] = MAX_COILS
    allow_hemisphere: bool = False


class DesignSpec(_Model):
    """A design file, schema version 1 (angles in radians and lengths in metres once parsed)."""

    schema_version: Literal[1]
    name: Name = "design"
    rotor: RotorSpec
    stator: StatorSpec
    dimensions: Dimensions
    tolerance: Angle | None = None
    remanence: Tesla = DEFAULT_REMANENCE
    coil_ampere_turns: Annotated[float, Field(gt=0)] = DEFAULT_AMPERE_TURNS
    channel_map: Annotated[list[Annotated[list[Channel], Field(min_length=2, max_length=2)]],
                           Field(max_length=MAX_POLES)] | None = None
    overrides: Overrides = Overrides()
    failed_coils: Annotated[list[Index], Field(max_length=MAX_POLES)] = []

    @field_validator("tolerance")
    @classmethod
    def _tolerance(cls, value):
        if value is not None and not 0 < value < 0.5:
            raise ValueError(f"must be an angle between 0 and {math.degrees(0.5):.4g} deg, like '1 deg'; instead "
                             f"received {math.degrees(value):.6g} deg")
        return value


_SECTIONS: dict[str, type[BaseModel]] = {
    "": DesignSpec, "rotor": RotorSpec, "rotor.polarity": PolarityRule, "rotor.poles": Direction,
    "stator": StatorSpec, "stator.axis": Direction, "stator.coils": Direction, "dimensions": Dimensions,
    "overrides": Overrides,
}

EXAMPLES: dict[str, str] = {
    "schema_version": "1", "name": "prototype", "rotor": "{packing: truncated-icosahedron, refine: 1, polarity: "
    "{primary: +1, filled: -1}}", "rotor.packing": "truncated-icosahedron", "rotor.refine": "1",
    "rotor.poles": "[[0, 0, 1], {phi: 90 deg, theta: 90 deg}]", "rotor.polarity": "{primary: +1, filled: -1}",
    "rotor.polarity.primary": "+1", "rotor.polarity.filled": "-1", "stator": "{packing: truncated-cuboctahedron, "
    "refine: 1, axis: [0, 0, -1], cap_half_angle: 80 deg, coils: fit}", "stator.axis": "[0, 0, -1]",
    "stator.cap_half_angle": "80 deg", "stator.packing": "truncated-cuboctahedron", "stator.refine": "1",
    "stator.coils": "fit", "dimensions": "{sphere_diameter: 12 in, magnet_diameter: 1 in, magnet_length: 0.5 in, "
    "coil_diameter: 2 in, coil_length: 1.625 in, air_gap: 0.005 in}", "dimensions.sphere_diameter": "12 in",
    "dimensions.magnet_diameter": "1 in", "dimensions.magnet_length": "0.5 in", "dimensions.coil_diameter": "2 in",
    "dimensions.coil_length": "1.625 in", "dimensions.air_gap": "0.005 in", "tolerance": "1 deg",
    "remanence": "1.32 T", "coil_ampere_turns": "1000", "channel_map": "[[0, 29], [1, 30], ...]",
    "overrides.max_coils": "40", "overrides.allow_hemisphere": "true", "failed_coils": "[3, 17]",
}


def _dotted(loc) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif not (isinstance(part, str) and part.startswith("<")):  # a tag of a union, not a key
            out += f".{part}" if out else str(part)
    return out


def _generic(path: str) -> str:
    """``path`` without list indices (``rotor.poles[3].x`` → ``rotor.poles.x``), as :data:`_SECTIONS` is keyed."""
    return re.sub(r"\[\d+\]", "", path)


def _example(path: str) -> str:
    """``; for example key: value`` for a field (not for entries of lists, whose messages say enough)."""
    example = None if "[" in path else EXAMPLES.get(path)
    return f"; for example {path.rsplit('.', 1)[-1]}: {example}" if example else ""


def _translate(exc: ValidationError) -> tuple[str, str]:
    """``(field path, message)`` of the first error pydantic found, in this module's words."""
    err = exc.errors(include_url=False)[0]
    path = _dotted(err["loc"])
    kind = err["type"]
    shown = path or "the design"
    if kind == "missing":
        return path, f"{shown} is missing; add it{_example(path)}"
    if kind == "extra_forbidden":
        parent = _generic(path).rsplit(".", 1)[0] if "." in path else ""
        model = _SECTIONS.get(parent)
        known = f" (known here: {', '.join(model.model_fields)})" if model else ""
        return path, f"{shown} is not a known key; remove it or correct its spelling{known}"
    if kind == "invalid_key":
        return path, f"{shown}: keys must be strings; instead received {_show(err['input'])}"
    if kind == "value_error":
        message = str(err["ctx"]["error"])
    elif kind in ("model_type", "model_attributes_type", "dict_type"):
        message = f"must be a mapping of keys; instead received {_show(err['input'])}"
    else:
        message = re.sub(r"^\w+ should", "must", err["msg"]) + f"; instead received {_show(err['input'])}"
    return path, f"{shown} {message}{_example(path)}"


# --- from a spec to a MotorDesign --------------------------------------------------------------------------

@functools.lru_cache(maxsize=None)
def named_packing(name: str, level: int) -> pk.Packing:
    """``refine(by_name(name), levels=level)``, computed once per process (packings are immutable)."""
    return pk.refine(pk.by_name(name), levels=level)


def _rotor(spec: RotorSpec, magnet_angle: float, source: str) -> tuple[pk.Packing, np.ndarray]:
    if spec.packing is not None:
        rotor = named_packing(spec.packing, spec.refine or 0)
        rule = spec.polarity
        base = len(named_packing(spec.packing, 0))
        if isinstance(rule, PolarityRule):
            filled = -rule.primary if rule.filled is None else rule.filled
            return rotor, np.where(np.arange(len(rotor)) < base, rule.primary, filled)
    else:
        centres = np.array([d.vector for d in spec.poles])
        radii = np.array([magnet_angle if d.radius is None else d.radius for d in spec.poles])
        rotor = pk.Packing(centres, radii, name=spec.name or "custom")
    if len(spec.polarity) != len(rotor):
        raise DesignFileError(source, "rotor.polarity", f"rotor.polarity must have one +1/-1 per rotor pole "
                              f"({len(rotor)}); instead received {len(spec.polarity)} values")
    return rotor, np.array(spec.polarity)


def _stator(spec: DesignSpec, coil_angle: float, source: str) -> pk.Packing:
    st = spec.stator
    axis = st.axis.vector
    if st.packing is None:
        centres = np.array([d.vector for d in st.coils])
        radii = np.array([coil_angle if d.radius is None else d.radius for d in st.coils])
        return pk.Packing(centres, radii, name=st.name or "custom")
    full = named_packing(st.packing, st.refine or 0)
    if st.coils == "fit":
        stator = stator_in_cap(full, axis, st.cap_half_angle, min_radius=coil_angle)
        if len(stator) == 0:
            raise DesignFileError(source, "stator.coils", f"stator.coils 'fit' selects no cap of {full.label}: none "
                                  f"within stator.cap_half_angle is as wide as a coil ({math.degrees(coil_angle):.3g}"
                                  " deg); widen the cap, use smaller coils or another packing")
        return stator
    idx = np.array(st.coils)
    bad = np.flatnonzero(idx >= len(full))
    if len(bad):
        k = int(bad[0])
        raise DesignFileError(source, f"stator.coils[{k}]", f"stator.coils[{k}] must be a cap index 0..{len(full) - 1}"
                              f" of {full.label}; instead received {int(idx[k])}")
    unique, first = np.unique(idx, return_index=True)
    if len(unique) != len(idx):
        k = int(np.setdiff1d(np.arange(len(idx)), first)[0])
        raise DesignFileError(source, f"stator.coils[{k}]", f"stator.coils[{k}] repeats cap {int(idx[k])}; list each "
                              "cap once")
    return pk.Packing(full.centers[idx], full.radii[idx], name=full.name, family=full.family, level=full.level)


def build(spec: DesignSpec, source: str = "<design>") -> MotorDesign:
    """The :class:`MotorDesign` of a validated spec; DesignFileError naming the field when it is not a motor."""
    dims = spec.dimensions
    if dims.magnet_diameter >= dims.sphere_diameter or dims.coil_diameter >= dims.sphere_diameter:
        raise DesignFileError(source, "dimensions", "dimensions.magnet_diameter and coil_diameter must be smaller "
                              "than dimensions.sphere_diameter")
    magnet_angle = math.atan(0.5 * dims.magnet_diameter / (0.5 * dims.sphere_diameter))
    coil_angle = math.atan(0.5 * dims.coil_diameter / (0.5 * dims.sphere_diameter + dims.air_gap))
    cap = spec.stator.cap_half_angle
    if cap >= math.pi / 2 and not spec.overrides.allow_hemisphere:
        raise DesignFileError(source, "stator.cap_half_angle", "stator.cap_half_angle must be under 90 deg (a stator "
                              "smaller than a hemisphere leaves the rotor its range of motion, Sec. IV); set "
                              f"overrides.allow_hemisphere: true to allow it; instead received "
                              f"{math.degrees(cap):.6g} deg")
    rotor, polarity = _rotor(spec.rotor, magnet_angle, source)
    stator = _stator(spec, coil_angle, source)
    if len(stator) > spec.overrides.max_coils:
        raise DesignFileError(source, "stator.coils", f"stator.coils gives {len(stator)} coils, more than "
                              f"{spec.overrides.max_coils} (four 8-relay boards drive 32, Sec. IV-B); set "
                              f"overrides.max_coils: {len(stator)} to allow them, or narrow the cap")
    axis = spec.stator.axis.vector
    off = np.degrees(np.arccos(np.clip(stator.centers @ (axis / np.linalg.norm(axis)), -1, 1)) - cap)
    if np.any(off > 1e-9):
        k = int(np.argmax(off))
        raise DesignFileError(source, f"stator.coils[{k}]", f"stator.coils[{k}] lies {off[k]:.4g} deg outside the "
                              "stator cap; remove it or widen stator.cap_half_angle")
    try:
        design = MotorDesign(
            rotor=rotor, polarity=polarity, stator=stator, stator_axis=axis, cap_half_angle=cap,
            sphere_diameter=dims.sphere_diameter, magnet_diameter=dims.magnet_diameter,
            magnet_length=dims.magnet_length, coil_diameter=dims.coil_diameter, coil_length=dims.coil_length,
            air_gap=dims.air_gap, tol=spec.tolerance, remanence=spec.remanence,
            coil_ampere_turns=spec.coil_ampere_turns, name=spec.name,
            channel_map=None if spec.channel_map is None else np.array(spec.channel_map, dtype=int).reshape(-1, 2),
            allow_hemisphere=spec.overrides.allow_hemisphere, max_coils=spec.overrides.max_coils,
            failed_coils=tuple(spec.failed_coils),
        )
    except InputError as exc:  # what is left to MotorDesign (channel_map, failed_coils) it names as the file does
        raise DesignFileError(source, str(exc).split(" ", 1)[0], str(exc)) from None
    try:
        check_fits(design)
    except InputError as exc:
        field = "rotor" if str(exc).startswith("rotor") else "stator.coils"
        size = "dimensions.magnet_diameter" if field == "rotor" else "dimensions.coil_diameter"
        raise DesignFileError(source, field, f"{exc}; see {field} and {size}") from None
    return design


def from_dict(data: Any, source: str = "<design>") -> MotorDesign:
    """The design of a parsed document (a mapping); DesignFileError for every mistake."""
    if not isinstance(data, dict):
        raise DesignFileError(source, None, "must hold a mapping of keys (schema_version, name, rotor, stator, "
                              f"dimensions, ...) at the top level; instead received {type(data).__name__} "
                              f"{_show(data)}")
    try:
        spec = DesignSpec.model_validate(data)
    except ValidationError as exc:
        raise DesignFileError(source, *_translate(exc)) from None
    return build(spec, source)


# --- reading and writing files -----------------------------------------------------------------------------

class _Loader(yaml.SafeLoader):
    """Safe YAML that refuses a key given twice in one mapping (the later one would silently win)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                key = (key_node.tag, key_node.value)
                if key in seen:
                    raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key_node.value!r}",
                                                            key_node.start_mark)
                seen.add(key)
        return super().construct_mapping(node, deep=deep)


def parse(text: str, fmt: str = "yaml", source: str = "<design>") -> Any:
    """Parse the text of a design file (``fmt`` 'yaml' or 'toml') into Python data; DesignFileError on syntax."""
    if "\x00" in text:
        raise DesignFileError(source, None, "is a binary file, not a design file; give a YAML or TOML text file")
    if not text.strip():
        raise DesignFileError(source, None, "is empty; start from `spherestep design new FILE`")
    if fmt == "toml":
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DesignFileError(source, None, f"TOML syntax error: {exc}; fix the syntax") from None
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise DesignFileError(source, None, f"YAML syntax error{where}: {exc.problem or exc.context}; fix the "
                              "syntax") from None
    except (yaml.YAMLError, ValueError, TypeError, OverflowError, RecursionError) as exc:
        raise DesignFileError(source, None, f"is not valid YAML ({type(exc).__name__}: {exc}); fix the syntax") \
            from None
    if data is None:
        raise DesignFileError(source, None, "is empty; start from `spherestep design new FILE`")
    return data


def loads(text: str, fmt: str = "yaml", source: str = "<design>") -> MotorDesign:
    """The design written in ``text`` (YAML or TOML)."""
    return from_dict(parse(text, fmt, source), source)


def read_text(path: str | Path) -> str:
    """The text of a design file; DesignFileError when it is missing, a folder, too large or not UTF-8."""
    path = Path(path)
    try:
        if path.is_dir():
            raise DesignFileError(str(path), None, "is a folder; give a design file (.yaml, .yml or .toml)")
        if path.stat().st_size > MAX_BYTES:
            raise DesignFileError(str(path), None, f"is larger than {MAX_BYTES // 2 ** 20} MiB; a design file is "
                                  "a short text file")
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DesignFileError(str(path), None, f"does not exist; create it with `spherestep design new {path}`") \
            from None
    except OSError as exc:
        raise DesignFileError(str(path), None, f"could not be read ({exc.strerror or exc})") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DesignFileError(str(path), None, "is not UTF-8 text (a binary file?); give a YAML or TOML design "
                              "file") from None


def load(path: str | Path) -> MotorDesign:
    """Read a design file: TOML when its name ends in ``.toml``, YAML otherwise."""
    path = Path(path)
    fmt = "toml" if path.suffix.lower() == ".toml" else "yaml"
    return loads(read_text(path), fmt, str(path))


def _match(packing: pk.Packing, full: pk.Packing) -> np.ndarray | None:
    """Indices of ``packing``'s caps in ``full`` when each agrees with one cap to :data:`MATCH_TOL`, else None."""
    dist, idx = full.tree.query(packing.centers)
    if np.any(dist > MATCH_TOL) or np.any(np.abs(full.radii[idx] - packing.radii) > MATCH_TOL) or \
            len(np.unique(idx)) != len(idx):
        return None
    return idx


def _named_source(packing: pk.Packing) -> pk.Packing | None:
    """The named packing (at ``packing.level``) that ``packing`` was cut from, if it names one."""
    if packing.name in pk.names() and 0 <= packing.level <= MAX_REFINE:
        return named_packing(packing.name, packing.level)
    return None


def _poles(packing: pk.Packing, default_radius: float) -> list:
    """Explicit entries: ``[x, y, z]``, or ``{x, y, z, radius}`` where the radius is not the default."""
    out = []
    for c, r in zip(packing.centers.tolist(), packing.radii.tolist()):
        out.append(c if abs(r - default_radius) <= 1e-15 else dict(zip("xyz", c), radius=angle_text(r)))
    return out


def _rotor_dict(design: MotorDesign) -> dict:
    rotor, polarity = design.rotor, design.polarity.tolist()
    full = _named_source(rotor)
    if full is not None and len(full) == len(rotor) and np.array_equal(_match(rotor, full), np.arange(len(rotor))):
        base = len(named_packing(rotor.name, 0))
        primary, filled = set(polarity[:base]), set(polarity[base:])
        if len(primary) == 1 and len(filled) <= 1:
            rule = {"primary": primary.pop()}
            rule["filled"] = filled.pop() if filled else -rule["primary"]
            return {"packing": rotor.name, "refine": rotor.level, "polarity": rule}
        return {"packing": rotor.name, "refine": rotor.level, "polarity": polarity}
    return {"name": rotor.label, "poles": _poles(rotor, design.magnet_angle), "polarity": polarity}


def _stator_dict(design: MotorDesign) -> dict:
    stator = design.stator
    head = {"axis": design.stator_axis.tolist(), "cap_half_angle": angle_text(design.cap_half_angle)}
    full = _named_source(stator)
    idx = None if full is None else _match(stator, full)
    if idx is None:
        return head | {"name": stator.label, "coils": _poles(stator, design.coil_angle)}
    fit = stator_in_cap(full, design.stator_axis, design.cap_half_angle, min_radius=design.coil_angle)
    fits = len(fit) == len(stator) and np.array_equal(_match(fit, full), idx)
    return {"packing": stator.name, "refine": stator.level} | head | {"coils": "fit" if fits else idx.tolist()}


def to_dict(design: MotorDesign) -> dict:
    """The document of ``design``: named packings and rules where they reproduce it, explicit lists otherwise."""
    data = {
        "schema_version": SCHEMA_VERSION,
        "name": design.name,
        "rotor": _rotor_dict(design),
        "stator": _stator_dict(design),
        "dimensions": {f: length_text(float(getattr(design, f))) for f in Dimensions.model_fields},
    }
    if design.tol is not None:
        data["tolerance"] = angle_text(float(design.tol))
    data["remanence"] = tesla_text(float(design.remanence))
    data["coil_ampere_turns"] = float(design.coil_ampere_turns)
    if not np.array_equal(design.channel_map, default_channel_map(len(design.stator))):
        data["channel_map"] = design.channel_map.tolist()
    overrides = {}
    if design.max_coils != MAX_COILS:
        overrides["max_coils"] = int(design.max_coils)
    if design.allow_hemisphere:
        overrides["allow_hemisphere"] = True
    if overrides:
        data["overrides"] = overrides
    if design.failed_coils:
        data["failed_coils"] = list(design.failed_coils)
    return data


class _Dumper(yaml.SafeDumper):
    """Block mappings, except short mappings of scalars; lists of scalars on one line."""

    def represent_list(self, data):
        flow = all(not isinstance(v, (list, dict)) for v in data)
        return self.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)

    def represent_dict(self, data):
        flow = len(data) <= 4 and all(not isinstance(v, (list, dict)) for v in data.values())
        return self.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=flow)


_Dumper.add_representer(list, _Dumper.represent_list)
_Dumper.add_representer(dict, _Dumper.represent_dict)


def dumps(design: MotorDesign) -> str:
    """``design`` as the YAML text of a design file (checked to load back before it is returned)."""
    data = to_dict(design)
    from_dict(data, source=f"design {design.name!r}")
    return _HEADER + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=110)


def save(design: MotorDesign, path: str | Path) -> Path:
    """Write ``design`` to ``path`` as YAML, atomically; InputError for a TOML name or a design load would refuse."""
    path = Path(path)
    if path.suffix.lower() == ".toml":
        raise DesignFileError(str(path), None, "design files are written as YAML; use a name ending in .yaml")
    return write_text(path, dumps(design))


def prototype_text() -> str:
    """The text of the design file shipped with the package, ``spherestep/data/prototype.yaml``."""
    return resources.files("spherestep").joinpath("data/prototype.yaml").read_text(encoding="utf-8")
