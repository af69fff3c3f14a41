"""A builder's specification (issue 29 §1): what the motor must do, as a YAML or TOML file checked by pydantic.

Every quantity carries its unit (``"12 in"``, ``"30 deg"``, ``"0.5 N m"``, ``"0.4 s"``, ``"2 kg"``, ``"24 V"``,
``"100 W"``), converted once to SI (metres, radians, N·m, s, kg, V, W). A mistake raises :class:`SpecError` (an
:class:`~spherestep.errors.InputError`) with one line that names the file and the field path, the way design files
do (:mod:`spherestep.design_file`, whose syntax reader and quantity parsers, ``parse_scaled`` among them, this
module reuses). Every field is
described in docs/synthesis.md.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError, model_validator

from ..design_file.load import parse_data, read_text
from ..design_file.quantities import parse_angle, parse_length, parse_scaled, parse_volts, parse_watts, show
from ..design_file.schema import Direction, DirectionIn
from ..errors import InputError

SPEC_VERSION = 1
# units as matched (lower case: a spec's units are read case-folded), and the ones a message lists
TORQUE_UNITS = {"n m": 1.0, "nm": 1.0, "n·m": 1.0, "n*m": 1.0, "mn m": 1e-3, "mn·m": 1e-3, "mnm": 1e-3}
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "min": 60.0}
MASS_UNITS = {"kg": 1.0, "g": 1e-3}
TORQUE_NAMES = ("N m", "N·m", "Nm", "mN m")


class SpecError(InputError):
    """A specification that cannot be read: ``source: field message`` on one line; ``field`` is the path."""

    def __init__(self, source: str, field: str | None, message: str):
        self.source = source
        self.field = field
        super().__init__(re.sub(r"\s*\n\s*", " ", f"{source}: {message}"))


def parse_torque(value: Any) -> float:
    """N·m of ``"0.5 N m"`` (also ``N·m``, ``Nm``, ``mN m``); the unit required, case-folded; positive."""
    return parse_scaled(value, "torque", TORQUE_UNITS, "0.5 N m", unit_required=True, fold_case=True,
                        names=TORQUE_NAMES)


def parse_seconds(value: Any) -> float:
    """Seconds of ``"0.4 s"`` (also ``ms``, ``min``); the unit required, case-folded; positive."""
    return parse_scaled(value, "time", TIME_UNITS, "0.4 s", unit_required=True, fold_case=True)


def parse_mass(value: Any) -> float:
    """Kilograms of ``"2 kg"`` (also ``g``); the unit required, case-folded; positive."""
    return parse_scaled(value, "mass", MASS_UNITS, "2 kg", unit_required=True, fold_case=True)


Length = Annotated[float, BeforeValidator(parse_length)]
Angle = Annotated[float, BeforeValidator(parse_angle)]
Torque = Annotated[float, BeforeValidator(parse_torque)]
Seconds = Annotated[float, BeforeValidator(parse_seconds)]
Mass = Annotated[float, BeforeValidator(parse_mass)]
Volts = Annotated[float, BeforeValidator(parse_volts)]
Watts = Annotated[float, BeforeValidator(parse_watts)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True, allow_inf_nan=False)


class Envelope(_Model):
    """Size: the ball's diameter range, how far the stator may reach out from the ball's surface, a mass limit."""

    ball_diameter: Annotated[list[Length], Field(min_length=2, max_length=2)]
    stator_reach: Length | None = None
    mass_limit: Mass | None = None

    @model_validator(mode="after")
    def _ordered(self):
        low, high = self.ball_diameter
        if low > high:
            raise ValueError(f"must have ball_diameter as [smallest, largest]; instead received "
                             f"[{1e3 * low:.4g} mm, {1e3 * high:.4g} mm]")
        return self


class TorqueSpec(_Model):
    """Torque: ``every_direction`` available over ``over_fraction`` of the range (servo), ``step`` holding torque
    of a relay state (relays)."""

    every_direction: Torque | None = None
    over_fraction: float = Field(0.95, gt=0.0, le=1.0)
    step: Torque | None = None


class RangeSpec(_Model):
    """A cone of half-angle ``cone`` about ``axis`` (the output axis in the rotor, fixed frame at rest)."""

    cone: Angle = Field(le=math.pi)
    axis: DirectionIn = Field(default_factory=lambda: Direction(x=0.0, y=0.0, z=1.0))


class Speed(_Model):
    """A rest-to-rest ``turn`` (angle) about ``axis`` (fixed frame) ``within`` a time."""

    turn: Angle
    within: Seconds
    axis: DirectionIn = Field(default_factory=lambda: Direction(x=0.0, y=0.0, z=1.0))


class Precision(_Model):
    """``servo_hold``: the largest holding error of the servo at rest; ``relay_resolution``: the median distance
    from an orientation to the nearest stepper state."""

    servo_hold: Angle | None = None
    relay_resolution: Angle | None = None


class Supply(_Model):
    voltage: Volts
    power: Watts


class Sensing(_Model):
    """A Hall (magnetometer) array of at most ``hall_parts`` parts estimates the orientation."""

    hall_parts: int = Field(ge=3, le=200)


class Spec(_Model):
    """The specification (docs/synthesis.md, field by field). SI units inside."""

    spec_version: Literal[1]
    name: str = Field("spec", min_length=1, max_length=200, pattern=r"^[^\n\r]+$")
    envelope: Envelope
    torque: TorqueSpec = TorqueSpec()
    range: Literal["all"] | RangeSpec = "all"
    speed: Speed | None = None
    precision: Precision = Precision()
    supply: Supply = Supply(voltage=24.0, power=100.0)
    max_coils: int = Field(32, ge=2, le=200)
    core: Literal["air", "iron", "either"] = "either"
    drive: Literal["servo", "relays", "both"] = "servo"
    single_coil_failure: bool = False
    sensing: Sensing | None = None
    baseline: str | None = Field(None, min_length=1)
    prefer: Literal["mass", "power", "time", "precision", "torque", "coils", "change"] = "mass"

    def inconsistency(self) -> tuple[str, str] | None:
        """``(field, message)`` of the first pair of fields that contradict each other, or None."""
        if self.torque.step is not None and not self.relays:
            return "torque.step", ("must be left out unless drive is relays or both (a relay state's holding "
                                   f"torque); instead received drive: {self.drive}")
        if self.precision.servo_hold is not None and not self.servo:
            return "precision.servo_hold", ("must be left out unless drive is servo or both; instead received "
                                            f"drive: {self.drive}")
        if self.precision.relay_resolution is not None and not self.relays:
            return "precision.relay_resolution", ("must be left out unless drive is relays or both; instead "
                                                  f"received drive: {self.drive}")
        if self.torque.every_direction is not None and not self.servo:
            return "torque.every_direction", ("must be left out unless drive is servo or both (relays: give "
                                              f"torque.step); instead received drive: {self.drive}")
        if self.prefer == "change" and self.baseline is None:
            return "baseline", "must be given (a design file, or 'prototype') with prefer: change; instead received none"
        if self.sensing is not None and not self.servo:
            return "sensing", f"must be left out unless drive is servo or both; instead received drive: {self.drive}"
        return None

    # --- what the search reads -----------------------------------------------------------------------
    @property
    def servo(self) -> bool:
        return self.drive in ("servo", "both")

    @property
    def relays(self) -> bool:
        return self.drive in ("relays", "both")

    @property
    def cores(self) -> tuple[str, ...]:
        return ("air", "iron") if self.core == "either" else (self.core,)

    @property
    def range_axis(self) -> np.ndarray | None:
        return None if self.range == "all" else self.range.axis.vector

    @property
    def digest(self) -> str:
        """16 hex digits of the spec's content (the search's results are keyed by it)."""
        return hashlib.sha256(json.dumps(self.model_dump(mode="json"), sort_keys=True).encode()).hexdigest()[:16]

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready, SI units (lengths m, torques N·m, times s, masses kg), angles in degrees when ``degrees``."""
        out = self.model_dump(mode="json")
        if degrees:
            for path in (("speed", "turn"), ("precision", "servo_hold"), ("precision", "relay_resolution"),
                         ("range", "cone")):
                node = out
                for key in path[:-1]:
                    node = node.get(key) if isinstance(node, dict) else None
                if isinstance(node, dict) and node.get(path[-1]) is not None:
                    node[path[-1] + "_deg"] = math.degrees(node.pop(path[-1]))
        return out


@functools.cache
def _sections() -> dict[str, type[_Model]]:
    return {"": Spec, "envelope": Envelope, "torque": TorqueSpec, "range": RangeSpec, "speed": Speed,
            "precision": Precision, "supply": Supply, "sensing": Sensing}


def _dotted(loc) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        elif part in ("RangeSpec", "literal['all']", "function-after[_consistent(), Spec]"):
            continue
        else:
            out += ("." if out else "") + str(part)
    return out


def _translate(exc: ValidationError) -> tuple[str, str]:
    """``(field path, one-line message)`` of pydantic's first error."""
    errors = exc.errors(include_url=False)
    err = next((e for e in errors if "literal['all']" not in map(str, e["loc"])), errors[0])
    path = _dotted(err["loc"])
    shown = path or "the specification"
    kind = err["type"]
    if kind == "missing":
        return path, f"{shown} is missing; add it (docs/synthesis.md lists every field)"
    if kind == "extra_forbidden":
        parent = path.rsplit(".", 1)[0] if "." in path else ""
        model = _sections().get(re.sub(r"\[\d+\]", "", parent))
        known = f" (known here: {', '.join(model.model_fields)})" if model else ""
        return path, f"{shown} is not a known key; remove it or correct its spelling{known}"
    if kind == "value_error":
        message = str(err["ctx"]["error"])
    elif path == "range":
        message = f"must be 'all' or a mapping {{cone: 40 deg, axis: [0, 0, 1]}}; instead received {show(err['input'])}"
    elif kind in ("model_type", "model_attributes_type", "dict_type"):
        message = f"must be a mapping of keys; instead received {show(err['input'])}"
    else:
        message = re.sub(r"^\w+ should", "must", err["msg"]) + f"; instead received {show(err['input'])}"
    return path, f"{shown} {message}"


def validate_spec(data: Any, source: str = "<spec>") -> Spec:
    """The :class:`Spec` of parsed YAML/TOML ``data``; SpecError naming ``source`` and the field otherwise."""
    if not isinstance(data, dict):
        raise SpecError(source, None, f"must be a mapping of keys (spec_version, envelope, ...); instead received "
                                      f"{show(data)}")
    try:
        spec = Spec.model_validate(data)
    except ValidationError as exc:
        field, message = _translate(exc)
        raise SpecError(source, field or None, message) from None
    wrong = spec.inconsistency()
    if wrong is not None:
        raise SpecError(source, wrong[0], f"{wrong[0]} {wrong[1]}")
    return spec


def parse_spec(text: str, fmt: str = "yaml", source: str = "<spec>") -> Spec:
    """The :class:`Spec` written in ``text`` (``fmt`` 'yaml' or 'toml')."""
    if not text.strip():
        raise SpecError(source, None, "is empty; start from an example in examples/specs/")
    try:
        data = parse_data(text, fmt, source)
    except InputError as exc:  # the design file's syntax reader: keep its words, this file's name
        raise SpecError(source, None, str(exc).split(": ", 1)[-1]) from None
    return validate_spec(data, source)


def load_spec(path) -> Spec:
    """Read a specification file: TOML when its name ends in ``.toml``, YAML otherwise."""
    path = Path(path)
    try:
        text = read_text(path)
    except InputError as exc:
        raise SpecError(str(path), None, str(exc).split(": ", 1)[-1].replace(
            "create it with `spherestep design new " + str(path) + "`", "start from examples/specs/")) from None
    spec = parse_spec(text, "toml" if path.suffix.lower() == ".toml" else "yaml", str(path))
    if spec.baseline not in (None, "prototype") and not Path(spec.baseline).is_absolute():
        spec = spec.model_copy(update={"baseline": str(path.parent / spec.baseline)})  # beside the spec file
    return spec
