"""The firmware's coil constants for one design: the header ``spherestep_config.h`` the Teensy sketch includes.

HELLO (protocol 2) reports the supply, the coils' resistance and inductance and the current limit from the
firmware's ``LIMITS`` and loop constants, and the host refuses a device that differs from the design's
:class:`~spherestep.electrics.DriveLimits` by more than 2 % (``DriveInfo.check_drive``). So the constants are
written from the design rather than by hand: ``LIMITS`` is :meth:`CurrentLimits.from_drive` of the design's drive
(max current, duty 0.95, supply power, the nominal current as the continuous rating, 60 s thermal time,
resistance, trip at 1.25×), and the loop's supply (V), inductance (H) and relay-mode current (mA) are the drive's.
The header also names the design and its fingerprint, and the coil count the sketch checks at compile time.
"""

from __future__ import annotations

from ..electrics import DriveLimits, milliamperes
from .limits import CurrentLimits

HEADER = "spherestep_config.h"


def _number(x: float) -> str:
    """A C++ double literal that reads back to ``x`` exactly (Python's shortest round-trip repr)."""
    text = repr(float(x))
    return text if any(c in text for c in ".en") else text + ".0"


def sketch_config(drive: DriveLimits, *, coils: int, design: str, fingerprint: str) -> str:
    """The text of ``spherestep_config.h`` for a design of ``coils`` coils driven within ``drive`` (module
    docstring); ``design`` and ``fingerprint`` (``MotorDesign.fingerprint``) are recorded in its comments."""
    lim = CurrentLimits.from_drive(drive)
    limits = ", ".join(_number(v) for v in (lim.max_current, lim.max_duty, lim.max_power, lim.continuous_current,
                                             lim.thermal_time, lim.resistance, lim.trip_ratio))
    return "\n".join((
        f"// {HEADER}: the coils the host's design drives, written by `spherestep export` (do not edit; re-export).",
        f"// design: {design}",
        f"// fingerprint: {fingerprint}",
        f"// winding {drive.resistance:.2f} ohm, {drive.inductance * 1e3:.1f} mH, {drive.nominal_current:.4f} A nominal "
        f"on {drive.supply_voltage:g} V, {drive.supply_power:g} W supply",
        "#pragma once",
        "#include \"drive.h\"",
        "",
        "namespace spherestep_config {",
        f"const uint8_t COILS = {int(coils)};",
        "// max current A, max duty, supply power W, continuous current A, thermal time s, resistance ohm, trip ratio",
        f"const spherestep::Limits LIMITS = {{{limits}}};",
        f"const double SUPPLY_V = {_number(drive.supply_voltage)};",
        f"const double INDUCTANCE_H = {_number(drive.inductance)};",
        f"const int32_t NOMINAL_MA = {round(milliamperes(drive.nominal_current))};",
        "}  // namespace spherestep_config",
        "",
    ))
