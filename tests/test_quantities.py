"""The one reader of a quantity in a table of units (design_file.quantities.parse_scaled), with its rules as
options, as the design files and the builder's specification use it."""

from __future__ import annotations

import math

import pytest

from spherestep.design_file.quantities import VOLT_UNITS, parse_scaled, parse_tesla, parse_volts, parse_watts
from spherestep.synthesis.spec import parse_mass, parse_seconds, parse_torque

TIMES = {"s": 1.0, "ms": 1e-3}


def test_a_quantity_is_its_number_times_its_units_scale():
    assert parse_scaled("2.5 kV", "voltage", VOLT_UNITS, "24 V") == 2500.0
    assert parse_scaled(" 3ms ", "time", TIMES, "0.4 s") == pytest.approx(3e-3, rel=1e-15)
    assert parse_scaled("1e-1  s", "time", TIMES, "0.4 s") == 0.1
    assert parse_torque("500 mN⋅m") == parse_torque("500 mN  m") == pytest.approx(0.5, rel=1e-15)
    assert parse_torque("0.5 N m") == parse_torque("0.5 n M") == parse_torque("0.5 Nm") == 0.5
    assert (parse_seconds("2 min"), parse_mass("250 g")) == (120.0, 0.25)
    assert (parse_tesla("320 mT"), parse_volts("24 V"), parse_watts("1 kW")) == (0.32, 24.0, 1000.0)


def test_the_rules_are_options():
    # a bare number is SI unless the unit is required
    assert parse_scaled(24, "voltage", VOLT_UNITS, "24 V") == parse_volts(24) == 24.0
    with pytest.raises(ValueError, match=r"^must be a voltage with its unit, like '24 V'; instead received 24$"):
        parse_scaled(24, "voltage", VOLT_UNITS, "24 V", unit_required=True)
    with pytest.raises(ValueError, match="with its unit"):
        parse_torque(0.5)
    with pytest.raises(ValueError, match="with its unit"):
        parse_volts("24")  # a string must carry its unit
    # zero only when allowed; negative and infinite never
    assert parse_scaled("0 ms", "time", TIMES, "0.4 s", allow_zero=True) == 0.0
    with pytest.raises(ValueError, match=r"^must be a finite positive time, like '0.4 s'"):
        parse_scaled("0 ms", "time", TIMES, "0.4 s")
    with pytest.raises(ValueError, match="finite non-negative time"):
        parse_scaled("-1 s", "time", TIMES, "0.4 s", allow_zero=True)
    with pytest.raises(ValueError, match="finite positive voltage"):
        parse_volts(math.inf)
    # case matters unless folded: mV is not MV
    with pytest.raises(ValueError, match=r"^must be a voltage with unit one of V, mV, kV, like '24 V'"):
        parse_volts("1 MV")
    with pytest.raises(ValueError, match="with unit one of s, ms"):
        parse_scaled("1 MS", "time", TIMES, "0.4 s")
    assert parse_scaled("1 MS", "time", TIMES, "0.4 s", fold_case=True) == 1e-3
    # the message lists the names given, else the table's keys
    with pytest.raises(ValueError, match=r"^must be a torque with unit one of N m, N·m, Nm, mN m, like '0.5 N m'; "
                                         r"instead received '1 kg'$"):
        parse_torque("1 kg")
    with pytest.raises(ValueError, match="with its unit"):
        parse_scaled(True, "voltage", VOLT_UNITS, "24 V")  # a bool is not a number
