"""The end of a hardware move is a state (issue 38 §3): ``end="park"`` parks in the detent well the model
predicts, and the rotor stays there with the coils off; ``end="hold"`` on an air-cored motor rests where it was
held; the final error is where the rotor rests, and a move that ends elsewhere says so. Lockstep (the simulated
clock) on the emulated motor: deterministic, whatever the machine's load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.cli import main
from spherestep.drive.hardware import drive_on_hardware, park_pose
from spherestep.drive.turn import choose_model

AXIS = (1.0, 0.5, 2.0)


def emulated(design, angle_deg, time, end, model=None):
    return drive_on_hardware(design, AXIS, math.radians(angle_deg), choose_model(design, model), duration=time,
                             port=None, emulate=True, rate=200.0, tolerance=math.radians(0.05), lockstep=True,
                             watchdog_ms=100, max_late=0.05, end=end)


@pytest.mark.slow
def test_park_ends_in_the_predicted_detent_well_and_stays_there_with_the_coils_off():
    from spherestep.motor import prototype
    from spherestep.statics import equilibrium

    design = prototype()
    r = emulated(design, 90, 1.5, "park")
    d, cycles = r.details, r.details.cycles
    assert d.outcome == "done" and d.end == "park" and d.at_rest, r.to_dict()
    well = r.targets[-1]  # the loop's last target: the well it parked in
    # the well is the design model's unpowered minimum: at rest there at zero current (independent check: a
    # descent from it does not move, and its stiffness is positive definite)
    eq = equilibrium(choose_model(design).model, well, np.zeros(len(design.stator)))
    assert bool(eq.is_minimum) and math.degrees(float(so3.distance(eq.rotation, well))) < 1e-3
    assert d.park_offset == pytest.approx(float(so3.distance(well, so3.exp(math.radians(90) * np.asarray(AXIS) /
                                                                           np.linalg.norm(AXIS)) @ r.targets[0])))
    # with every coil off (the rows after the loop's) the rotor stays within 0.05° of the predicted well
    off = r.orientations[cycles:]
    assert len(off) >= 3 and np.all(r.currents[cycles:] == 0)
    assert np.degrees(so3.distance(off, well)).max() < 0.05
    # the final error is where it rests, against the turn's end: the well's offset, so the move is judged by it
    assert r.final_error == pytest.approx(d.park_offset, abs=math.radians(0.05))
    assert not r.ok and "parked in the well predicted" in r.verdict()


@pytest.mark.slow
def test_hold_on_an_air_cored_motor_is_judged_where_the_rotor_is_after_the_coils_go_off():
    """No detent: with the coils off the emulated rotor coasts on the speed the hold left it (its damping alone
    slows it), so it has not come to rest where it was held, and the move says so; the final error is its last
    look, in the last row; park is the same pose as hold there."""
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype

    design = prototype()
    air = torque_map(design)
    r = emulated(design, 360, 2.4, "hold", model=air)
    d, cycles = r.details, r.details.cycles
    assert d.outcome == "done" and d.held_error < math.radians(0.05), r.to_dict()
    assert len(r.times) > cycles and np.all(np.diff(r.times) > 0) and np.all(r.currents[cycles:] == 0)
    assert r.final_error == pytest.approx(float(so3.distance(r.orientations[-1], r.targets[-1])), abs=1e-12)
    steps = np.degrees(so3.distance(r.orientations[-1], r.orientations[-2]))
    if d.at_rest:  # stood still: two intervals in a row within 0.01°
        assert steps <= 0.01 and r.ok == (r.final_error <= r.tolerance)
    else:
        assert steps > 0.01 and not r.ok and "coasting at" in r.verdict()
    assert np.array_equal(park_pose(air, r.targets[-1]), r.targets[-1])


@pytest.mark.parametrize("argv, word", [
    (["--end", "park"], "--end"),  # the simulated servo's coils never go off
    (["--end", "rest", "--emulate"], "hold or park"),
])
def test_move_refuses_a_bad_end_with_one_line_and_exit_2(argv, word, capsys, tmp_path):
    code = main(["move", "--axis", "1,0.5,2", "--angle", "10", "--out", str(tmp_path / "m"), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and word in err and "Traceback" not in err, err
    assert not (tmp_path / "m").exists()
