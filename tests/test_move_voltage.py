"""A servo time the supply cannot follow (issue 38 §1): the triangle turn of ``--time`` asks, at its speed, a torque
the coils' voltage cannot give against their back-EMF; ``move`` refuses it naming the shortest time it can."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from spherestep.cli import main

pytestmark = pytest.mark.slow  # the iron model and ~150 cone programs per check: 40 s at load 20

AXIS = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])


@pytest.fixture(scope="module")
def turn():
    from spherestep.commutation import turn_targets
    from spherestep.drive.turn import choose_model
    from spherestep.dynamics import Rotor
    from spherestep.motor import prototype

    design = prototype()
    chosen = choose_model(design)
    start = turn_targets(design, AXIS, 2 * math.pi, steps=1)[0]
    return chosen.model, chosen.limits, start, Rotor.from_design(design).inertia


def test_the_help_turn_in_2_4_s_is_short_of_voltage_and_a_ten_fold_supply_is_not(turn):
    """The 360° turn in 2.4 s (peak 5.2 rad/s) asks a torque the coils give at rest but not at its speed on 24 V; the
    same coils on 240 V give it (the shortfall is the back-EMF's, nothing else changed), and at rest nothing is
    short (a turn of 100 s)."""
    from spherestep.control import voltage_shortfall

    model, limits, start, inertia = turn
    short = voltage_shortfall(model, start, AXIS, 2 * math.pi, inertia, 2.4, limits)
    assert short is not None
    s, speed, need, (lo, hi) = short
    assert not lo <= need <= hi and speed > 1.0 and 0 < s < 2 * math.pi
    strong = dataclasses.replace(limits, supply_voltage=10 * limits.supply_voltage)
    assert voltage_shortfall(model, start, AXIS, 2 * math.pi, inertia, 2.4, strong) is None
    assert voltage_shortfall(model, start, AXIS, 2 * math.pi, inertia, 100.0, limits) is None


def test_the_shortest_triangle_time_is_allowed_and_a_shorter_one_is_not(turn):
    """``triangle_time`` brackets the boundary within its tolerance: allowed at the time it names, refused 0.05 s
    sooner (bisection checked against the shortfall itself)."""
    from spherestep.control import triangle_time, voltage_shortfall

    model, limits, start, inertia = turn
    T = triangle_time(model, start, AXIS, 2 * math.pi, inertia, 2.4, limits)
    assert 2.4 < T < 10.0
    assert voltage_shortfall(model, start, AXIS, 2 * math.pi, inertia, T, limits) is None
    assert voltage_shortfall(model, start, AXIS, 2 * math.pi, inertia, T - 0.05, limits) is not None


def test_move_refuses_a_time_the_supply_cannot_follow_in_one_line(capsys, tmp_path):
    """The former --help example: exit 2, one line naming --time and the shortest time, nothing written."""
    code = main(["move", "--axis", "1,0.5,2", "--angle", "360", "--time", "2.4", "--emulate", "--out",
                 str(tmp_path / "m")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "--time" in err and "at least" in err and "back-EMF" in err, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err
    assert not (tmp_path / "m").exists()
