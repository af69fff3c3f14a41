"""Quantities with units in design files: ``"12 in"``, ``"80 deg"``, ``"1.32 T"``, ``"24 V"``, ``"100 W"`` → SI,
and back.

Reading lengths and angles requires the unit (a bare number is refused, so a file never mixes metres and inches
silently); the length units are :data:`spherestep.units.METRES_PER_UNIT`. A flux density, voltage or power may be
a bare number in its SI unit (T, V, W), which no other unit of the file could be mistaken for. :func:`parse_scaled`
is the one reader of a quantity in a table of units, with the rules as options (a builder's specification,
:mod:`spherestep.synthesis.spec`, requires the unit for torques, times and masses). Writing gives the
shortest decimal that converts back to the same float, so a saved design loads back bit for bit. The parsers raise ``ValueError`` with a
message saying what was expected (the schema turns it into a :class:`DesignFileError` naming the field).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from .. import units
from ..units import METRES_PER_UNIT

LENGTH_UNITS = METRES_PER_UNIT
ANGLE_UNITS = ("deg", "°", "rad")
TESLA_UNITS = {"T": 1.0, "mT": 1e-3}
VOLT_UNITS = {"V": 1.0, "mV": 1e-3, "kV": 1e3}
WATT_UNITS = {"W": 1.0, "mW": 1e-3, "kW": 1e3}


def show(value: Any) -> str:
    """``repr(value)``, cut to 60 characters for a one-line message."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


# --- quantities with units ---------------------------------------------------------------------------------

def split_quantity(value: Any, what: str, example: str) -> tuple[float, str]:
    """``(number, unit)`` of a string like ``"12 in"`` (:func:`spherestep.units.split_quantity`), the unit
    required; ValueError saying what was expected otherwise."""
    quantity = units.split_quantity(value)
    if quantity is None or not quantity[1]:
        raise ValueError(f"must be {what} with its unit, like {example!r}; instead received {show(value)}")
    return quantity


def parse_length(value: Any, *, allow_zero: bool = False) -> float:
    """Metres of ``"<number> <length unit>"``; positive (or zero when ``allow_zero``)."""
    number, unit = split_quantity(value, "a length", "12 in")
    unit = unit.lower()
    if unit not in LENGTH_UNITS:
        raise ValueError(f"must be a length with unit one of m, cm, mm, um, in, ft, like '12 in'; instead received "
                         f"{show(value)}")
    metres = number * LENGTH_UNITS[unit]
    if not math.isfinite(metres) or metres < 0 or (metres == 0 and not allow_zero):
        raise ValueError(f"must be a finite {'non-negative' if allow_zero else 'positive'} length; "
                         f"instead received {show(value)}")
    return metres


def parse_angle(value: Any) -> float:
    """Radians of ``"<number> deg"`` (or ``°``) or ``"<number> rad"``."""
    number, unit = split_quantity(value, "an angle", "80 deg")
    unit = unit.lower()
    if unit not in ANGLE_UNITS:
        raise ValueError(f"must be an angle with unit deg or rad, like '80 deg'; instead received {show(value)}")
    radians = number if unit == "rad" else math.radians(number)
    if not math.isfinite(radians):
        raise ValueError(f"must be a finite angle; instead received {show(value)}")
    return radians


# a number, then a unit that starts with no digit and may hold spaces ("0.5 N m")
_SCALED = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*([^\d\s.].*?)\s*$")


def parse_scaled(value: Any, what: str, scales: Mapping[str, float], example: str, *, unit_required: bool = False,
                 allow_zero: bool = False, fold_case: bool = False, names: Sequence[str] | None = None) -> float:
    """SI value ``number × scales[unit]`` of ``"<number> <unit>"`` (``what`` a noun, e.g. ``"voltage"``;
    ``example`` shown in the message), or of a bare number already in SI unless ``unit_required``. The unit is
    matched with its spaces collapsed and ``⋅`` read as ``·``, lower-cased first with ``fold_case`` (then the
    keys of ``scales`` are lower case); ``names`` are the units the message lists (default the keys). The result
    is finite and positive (or zero with ``allow_zero``); ValueError saying what was expected otherwise."""
    if not unit_required and isinstance(value, (int, float)) and not isinstance(value, bool):
        result = float(value)
    else:
        match = _SCALED.match(value) if isinstance(value, str) else None
        if match is None:
            raise ValueError(f"must be a {what} with its unit, like {example!r}; instead received {show(value)}")
        unit = match.group(2).lower() if fold_case else match.group(2)
        key = " ".join(unit.replace("⋅", "·").split())
        if key not in scales:
            listed = ", ".join(names if names is not None else scales)
            raise ValueError(f"must be a {what} with unit one of {listed}, like {example!r}; instead received "
                             f"{show(value)}")
        result = float(match.group(1)) * scales[key]
    if not math.isfinite(result) or result < 0 or (result == 0 and not allow_zero):
        raise ValueError(f"must be a finite {'non-negative' if allow_zero else 'positive'} {what}, like "
                         f"{example!r}; instead received {show(value)}")
    return result


def parse_tesla(value: Any) -> float:
    """Tesla of a number or of ``"<number> T"`` / ``"<number> mT"``; positive."""
    return parse_scaled(value, "flux density", TESLA_UNITS, "1.32 T")


def parse_volts(value: Any) -> float:
    """Volts of a number or of ``"<number> V"`` (``mV``, ``kV``); positive."""
    return parse_scaled(value, "voltage", VOLT_UNITS, "24 V")


def parse_watts(value: Any) -> float:
    """Watts of a number or of ``"<number> W"`` (``mW``, ``kW``); positive."""
    return parse_scaled(value, "power", WATT_UNITS, "100 W")


def _shortest(guess: float, target: float, back) -> str | None:
    """The shortest decimal ``text`` of ``guess`` with ``back(float(text)) == target`` exactly, or None."""
    for digits in range(1, 18):
        text = repr(float(f"{guess:.{digits}g}")).removesuffix(".0")
        if back(float(text)) == target:
            return text
    return None


def length_text(metres: float, units: tuple[str, ...] = ("in", "mm", "m")) -> str:
    """``metres`` as the shortest exact string in the first of ``units`` that has one (``"12 in"``)."""
    for unit in units:
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


def volts_text(volts: float) -> str:
    """``volts`` as an exact string ``"24 V"``."""
    return f"{_shortest(volts, volts, float)} V"


def watts_text(watts: float) -> str:
    """``watts`` as an exact string ``"100 W"``."""
    return f"{_shortest(watts, watts, float)} W"
