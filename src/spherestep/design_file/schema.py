"""The design-file schema, version 2 (version 1, without the ``coil`` section, is still read): what a file may
hold, checked by pydantic, and its one error type.

Each section is a frozen pydantic model (``extra="forbid"``, strict types); lengths and angles are
:mod:`~spherestep.design_file.quantities`. :func:`translate` turns pydantic's first error into the field path
(``stator.cap_half_angle``) and a one-line message in this project's words. Whether the values make a motor
(coils in the cap, parts that fit, ...) is :class:`~spherestep.motor.MotorDesign`'s check, not the schema's.
"""

from __future__ import annotations

import functools
import math
import re
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (AfterValidator, BaseModel, BeforeValidator, ConfigDict, Discriminator, Field, Tag,
                      ValidationError, ValidationInfo, field_validator, model_validator)

from .. import packing as pk
from ..channels import MAX_COILS
from ..errors import InputError
from ..sphere import UNIT_TOL
from .quantities import parse_angle, parse_length, parse_tesla, parse_volts, parse_watts, show

SCHEMA_VERSION = 2  # 2 added the coil section; files of version 1 are read as they always were
MAX_REFINE = 4  # 4862 caps for the largest base packing; level 5 takes seconds and has 14 582
MAX_POLES = 10_000
MAX_BYTES = 8 * 2 ** 20
MAX_CHANNEL = 4095
MAX_INDEX = 1_000_000
DEFAULT_REMANENCE = 1.32
DEFAULT_AMPERE_TURNS = 1000.0
MATCH_TOL = 1e-12  # a saved centre is the named packing's cap when they agree this well


class DesignFileError(InputError):
    """A design file that cannot be read: ``source: field message`` on one line; ``field`` is the path."""

    def __init__(self, source: str, field: str | None, message: str):
        self.source = source
        self.field = field
        text = re.sub(r"\s*\n\s*", " ", f"{source}: {message}")
        super().__init__(text)



Length = Annotated[float, BeforeValidator(parse_length)]
Gap = Annotated[float, BeforeValidator(functools.partial(parse_length, allow_zero=True))]
Angle = Annotated[float, BeforeValidator(parse_angle)]
Tesla = Annotated[float, BeforeValidator(parse_tesla)]
Volts = Annotated[float, BeforeValidator(parse_volts)]
Watts = Annotated[float, BeforeValidator(parse_watts)]
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
                     f"received {show(value)}")


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
                         f"truncated-icosahedron; instead received {show(name)}")
    return name


def _printable(text: str) -> str:
    if not text.isprintable():
        raise ValueError(f"must be printable text on one line (no tabs, line breaks or control characters); "
                         f"instead received {show(text)}")
    return text


Name = Annotated[str, Field(min_length=1, max_length=200), AfterValidator(_printable)]
Text = Annotated[str, Field(min_length=1, max_length=2000), AfterValidator(_printable)]
PackingName = Annotated[str, BeforeValidator(lambda v: _packing_name(v) if isinstance(v, str) else v)]


class PolarityRule(_Model):
    """``primary``: sign of the base packing's poles; ``filled``: of the poles refinement added (default −primary)."""

    primary: Sign
    filled: Sign | None = None


def _polarity_form(value: Any) -> str | None:
    return "<list>" if isinstance(value, list) else "<rule>" if isinstance(value, dict) else None


Polarity = Annotated[
    Annotated[list[Sign], Tag("<list>")] | Annotated[PolarityRule, Tag("<rule>")],
    Discriminator(_polarity_form, custom_error_type="polarity_form",
                  custom_error_message="must be a list of +1/-1, one per rotor pole, or a rule like "
                                       "{primary: +1, filled: -1}"),
]


def _fit(value: str) -> str:
    if value != "fit":
        raise ValueError("must be 'fit', a list of cap indices of stator.packing or a list of coil directions; "
                         f"instead received {show(value)}")
    return value


def _coils_form(value: Any) -> str | None:
    if isinstance(value, str):
        return "<fit>"
    if isinstance(value, list):
        first = value[0] if value else 0
        return "<indices>" if isinstance(first, int) and not isinstance(first, bool) else "<directions>"
    return None


Coils = Annotated[
    Annotated[str, AfterValidator(_fit), Tag("<fit>")] | Annotated[list[Index], Tag("<indices>"), Field(min_length=1, max_length=MAX_POLES)] | Annotated[list[DirectionIn], Tag("<directions>"), Field(min_length=1, max_length=MAX_POLES)],
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
    """Sizes with units: rotor diameter, magnet and coil cylinders, the air gap, and the rotor's wall in front of
    the magnets (left out: 1/16 in)."""

    sphere_diameter: Length
    magnet_diameter: Length
    magnet_length: Length
    coil_diameter: Length
    coil_length: Length
    air_gap: Gap
    rotor_shell: Gap | None = None


class Overrides(_Model):
    """Lift the paper's limits: more than 32 coils, a stator cap of a hemisphere or more."""

    max_coils: Annotated[int, Field(ge=1, le=MAX_INDEX)] = MAX_COILS
    allow_hemisphere: bool = False


class CoilMaterial(_Model):
    """The cores' soft iron; a key left out keeps ``spherestep.motor.coil.IronMaterial``'s default. ``bh``: the
    normal B–H curve as ``[H, B]`` pairs in A/m and T (bare numbers), from ``[0, 0]``, increasing."""

    name: Name | None = None
    relative_permeability: float | None = None
    knee: Tesla | None = None
    bh: Annotated[list[Annotated[list[float], Field(min_length=2, max_length=2)]],
                  Field(min_length=2, max_length=MAX_POLES)] | None = None
    source: Text | None = None


class CoilSection(_Model):
    """Every stator coil as built (``spherestep.motor.coil.CoilSpec``): core, pot, winding, supply; a key left out
    keeps CoilSpec's default (the prototype's iron coil)."""

    core: Literal["air", "iron"] | None = None
    material: CoilMaterial | None = None
    pole_diameter: Length | None = None
    wall_thickness: Gap | None = None
    back_thickness: Gap | None = None
    wire_diameter: Length | None = None
    fill_factor: float | None = None
    supply_voltage: Volts | None = None
    supply_power: Watts | None = None
    coils_on: Annotated[int, Field(ge=1, le=MAX_INDEX)] | None = None
    ampere_turns: Annotated[float, Field(gt=0)] | None = None


class DesignSpec(_Model):
    """A design file, schema version 1 or 2 (angles in radians and lengths in metres once parsed); only version
    2 has ``coil`` (without it, the prototype's iron coil)."""

    schema_version: Literal[1, 2]
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
    coil: CoilSection | None = None
    fingerprint: Annotated[str, Field(pattern=r"^sha256:[0-9a-f]{16}$")] | None = None

    @field_validator("coil")
    @classmethod
    def _coil_needs_version_2(cls, value: CoilSection | None, info: ValidationInfo) -> CoilSection | None:
        if value is not None and info.data.get("schema_version") == 1:
            raise ValueError("is a section of schema version 2: set schema_version: 2 (a version 1 file has no "
                             "coil section; its coils are the prototype's iron coils)")
        return value


_SECTIONS: dict[str, type[BaseModel]] = {
    "": DesignSpec, "rotor": RotorSpec, "rotor.polarity": PolarityRule, "rotor.poles": Direction,
    "stator": StatorSpec, "stator.axis": Direction, "stator.coils": Direction, "dimensions": Dimensions,
    "overrides": Overrides, "coil": CoilSection, "coil.material": CoilMaterial,
}

EXAMPLES: dict[str, str] = {
    "schema_version": "2", "name": "prototype", "rotor": "{packing: truncated-icosahedron, refine: 1, polarity: "
    "{primary: +1, filled: -1}}", "rotor.packing": "truncated-icosahedron", "rotor.refine": "1",
    "rotor.poles": "[[0, 0, 1], {phi: 90 deg, theta: 90 deg}]", "rotor.polarity": "{primary: +1, filled: -1}",
    "rotor.polarity.primary": "+1", "rotor.polarity.filled": "-1", "stator": "{packing: truncated-cuboctahedron, "
    "refine: 1, axis: [0, 0, -1], cap_half_angle: 80 deg, coils: fit}", "stator.axis": "[0, 0, -1]",
    "stator.cap_half_angle": "80 deg", "stator.packing": "truncated-cuboctahedron", "stator.refine": "1",
    "stator.coils": "fit", "dimensions": "{sphere_diameter: 12 in, magnet_diameter: 1 in, magnet_length: 0.5 in, "
    "coil_diameter: 2 in, coil_length: 1.625 in, air_gap: 0.005 in}", "dimensions.sphere_diameter": "12 in",
    "dimensions.magnet_diameter": "1 in", "dimensions.magnet_length": "0.5 in", "dimensions.coil_diameter": "2 in",
    "dimensions.coil_length": "1.625 in", "dimensions.air_gap": "0.005 in", "dimensions.rotor_shell": "0.0625 in",
    "tolerance": "1 deg",
    "remanence": "1.32 T", "coil_ampere_turns": "1000", "channel_map": "[[0, 29], [1, 30], ...]",
    "overrides.max_coils": "40", "overrides.allow_hemisphere": "true", "failed_coils": "[3, 17]",
    "coil": "{core: iron}", "coil.core": "iron", "coil.material": "{name: AISI 1010, relative_permeability: 1000, "
    "knee: 1.5 T}", "coil.material.name": "AISI 1010", "coil.material.relative_permeability": "1000",
    "coil.material.knee": "1.5 T", "coil.material.bh": "[[0, 0], [238.7, 0.2003], [636.6, 1.0001], ...]",
    "coil.material.source": "vendor data sheet", "coil.pole_diameter": "1 in", "coil.wall_thickness": "0.125 in",
    "coil.back_thickness": "0.375 in", "coil.wire_diameter": "0.286 mm", "coil.fill_factor": "0.6",
    "coil.supply_voltage": "24 V", "coil.supply_power": "100 W", "coil.coils_on": "4", "coil.ampere_turns": "1000",
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


def translate(exc: ValidationError) -> tuple[str, str]:
    """``(field path, message)`` of the first error pydantic found, in this module's words; an unknown key comes
    before everything else (a misspelt ``colis`` is what the user wrote, the missing ``coils`` only follows from
    it)."""
    errors = exc.errors(include_url=False)
    err = next((e for e in errors if e["type"] == "extra_forbidden"), errors[0])
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
        return path, f"{shown}: keys must be strings; instead received {show(err['input'])}"
    if kind == "value_error":
        message = str(err["ctx"]["error"])
    elif kind in ("model_type", "model_attributes_type", "dict_type"):
        message = f"must be a mapping of keys; instead received {show(err['input'])}"
    else:
        message = re.sub(r"^\w+ should", "must", err["msg"]) + f"; instead received {show(err['input'])}"
    return path, f"{shown} {message}{_example(path)}"

