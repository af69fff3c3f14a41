"""Lengths with units, converted once at the boundary to SI metres.

Accepted: a number (metres) or a string ``"<number> <unit>"`` with unit one of m, cm, mm, um, in, ft
(also ``"12in"``, ``'12"'``).
"""

from __future__ import annotations

import dataclasses
import math
import re

from . import checks
from .errors import bad_value

METRES_PER_UNIT: dict[str, float] = {
    "m": 1.0,
    "cm": 1e-2,
    "mm": 1e-3,
    "um": 1e-6,
    "in": 0.0254,
    '"': 0.0254,
    "inch": 0.0254,
    "ft": 0.3048,
}

_UNIT_NAMES = ", ".join(u for u in METRES_PER_UNIT if u != '"')
_QUANTITY = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(\S*)\s*$")


def split_quantity(text: str) -> tuple[float, str] | None:
    """``(number, unit)`` of a string ``"<number> <unit>"`` (``"12 in"``, ``"12in"``, ``"80°"``; the unit as
    written, ``""`` when there is none), or None when ``text`` is not a number followed by one word."""
    match = _QUANTITY.match(text) if isinstance(text, str) else None
    return None if match is None else (float(match.group(1)), match.group(2))


def length(value: float | str, name: str = "length", *, allow_zero: bool = False) -> float:
    """Return ``value`` in metres; raise an InputError naming ``name`` when it is not a finite positive length."""
    return length_and_unit(value, name, allow_zero=allow_zero)[0]


def length_and_unit(value: float | str, name: str = "length", *, allow_zero: bool = False,
                    unit_required: bool = False) -> tuple[float, str]:
    """``(metres, unit)`` of ``value``; the unit is the one written (``"m"`` for a bare number, which
    ``unit_required`` refuses, as design files do)."""
    if not isinstance(value, str):
        kind = "non-negative" if allow_zero else "positive"
        return checks.number(value, name, low=0.0, low_open=not allow_zero,
                             expected=f"a finite {kind} length such as 0.3 (metres) or \"12 in\""), "m"
    quantity = split_quantity(value)
    unit = quantity[1].lower() if quantity else ""
    if quantity is None or (unit and unit not in METRES_PER_UNIT):
        raise bad_value(name, f"a length like '12 in' with unit one of {_UNIT_NAMES}", value)
    if unit_required and not unit:
        raise bad_value(name, f"a length with its unit, such as '6 in' or '0.15 m' (a bare number is refused, as in "
                        f"design files; units {_UNIT_NAMES})", value)
    unit = {'"': "in", "inch": "in"}.get(unit, unit or "m")
    metres = quantity[0] * METRES_PER_UNIT[unit]
    if not math.isfinite(metres) or metres < 0 or (metres == 0 and not allow_zero):
        raise bad_value(name, "a finite positive length", value)
    return metres, unit


def in_unit(metres, unit: str):
    """Convert metres to ``unit`` (one of :data:`METRES_PER_UNIT`)."""
    if unit not in METRES_PER_UNIT:
        raise bad_value("unit", f"one of {', '.join(sorted(METRES_PER_UNIT))}", unit)
    return metres / METRES_PER_UNIT[unit]


def result_dict(result, degrees: bool = True) -> dict:
    """A frozen-dataclass result as a JSON-ready dict, angles for people: an angle field, named ``*_rad`` (not a
    rate ``*_per_rad``), becomes ``*_deg`` in degrees when ``degrees`` (None stays None); tuples become lists.
    The one ``to_dict`` of the results (``DesignMetrics``, ``CoilFailure``, ``StateTorque``)."""
    out = {}
    for f in dataclasses.fields(result):
        value = getattr(result, f.name)
        value = list(value) if isinstance(value, tuple) else value
        if degrees and f.name.endswith("_rad") and not f.name.endswith("_per_rad"):
            out[f.name.removesuffix("_rad") + "_deg"] = None if value is None else math.degrees(value)
        else:
            out[f.name] = value
    return out


def in_radians(summary: dict) -> dict:
    """A summary written for people (angles ``*_deg``) with its angles in radians (``*_rad``) instead: the
    ``degrees=False`` form of the run summaries (``ServoRun``, ``RampedRun``)."""
    return {(k.removesuffix("_deg") + "_rad" if k.endswith("_deg") else k):
            (math.radians(v) if k.endswith("_deg") and v is not None else v) for k, v in summary.items()}
