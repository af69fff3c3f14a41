"""The end of a hardware move is a state (issue 38 §3): ``end="hold"`` (the default) is judged where the servo
holds the rotor and reports the predicted unpowered rest without judging it; ``end="park"`` parks in the detent
well the model predicts, and the rotor stays there with the coils off, judged against that well. Lockstep (the
simulated clock) on the emulated motor: deterministic, whatever the machine's load."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.cli import main
from spherestep.drive.hardware import drive_on_hardware, park_pose
from spherestep.drive.turn import Turn, choose_model

AXIS = (1.0, 0.5, 2.0)


def emulated(design, angle_deg, time, end, model=None):
    job = Turn(design, AXIS, math.radians(angle_deg), choose_model(design, model), math.radians(0.05))
    return drive_on_hardware(job, duration=time, port=None, emulate=True, rate=200.0, lockstep=True,
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
    turn_end = so3.exp(math.radians(90) * np.asarray(AXIS) / np.linalg.norm(AXIS)) @ r.targets[0]
    assert d.rest_offset == pytest.approx(float(so3.distance(well, turn_end)))
    assert d.rest_offset > math.radians(1)  # a real move into a well, not the turn's end itself
    # with every coil off (the rows after the loop's) the rotor stays within 0.05° of the predicted well
    off = r.orientations[cycles:]
    assert len(off) >= 3 and np.all(r.currents[cycles:] == 0)
    assert np.degrees(so3.distance(off, well)).max() < 0.05
    # the final error is where it rests, against the predicted well: within the tolerance, so the move is ok
    assert r.final_error <= math.radians(0.05) and r.ok, r.verdict()


@pytest.mark.slow
def test_hold_is_judged_where_the_servo_holds_and_the_release_is_reported_not_judged():
    """The default end: the servo holds the turn's end; the final error is the hold's last row; the predicted
    unpowered rest (off a detent well the rotor falls) is reported and does not fail the run; no rows after."""
    from spherestep.motor import prototype
    from spherestep.statics import equilibrium

    design = prototype()
    model = choose_model(design).model
    r = emulated(design, 90, 1.5, "hold")
    d = r.details
    assert d.outcome == "done" and d.end == "hold" and d.hold == 0.5 and d.at_rest is None, r.to_dict()
    assert len(r.times) == d.cycles and np.all(np.diff(r.times) > 0)
    assert r.final_error == pytest.approx(float(so3.distance(r.orientations[-1], r.targets[-1])), abs=1e-12)
    assert r.final_error == d.held_error and r.ok == (r.final_error <= r.tolerance)
    assert r.ok, r.verdict()
    # the reported rest: the model's unpowered minimum from the last row, farther from the target than the
    # tolerance here (so a judgement of the release would have failed the run)
    rest = park_pose(model, r.orientations[-1])
    eq = equilibrium(model, rest, np.zeros(len(design.stator)))
    assert bool(eq.is_minimum)
    assert d.rest_offset == pytest.approx(float(so3.distance(rest, r.targets[-1])), abs=1e-9)
    assert d.rest_offset > r.tolerance
    # the emulated rotor after the coils went off (0.15 s): it moved, toward the well, and it is said
    assert d.drift_after_off is not None and d.drift_after_off > 0


def test_park_pose_without_a_detent_is_where_the_rotor_is():
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype

    R = so3.exp(np.array([0.1, -0.2, 0.3]))
    assert np.array_equal(park_pose(torque_map(prototype()), R), R)


@pytest.mark.parametrize("argv, word", [
    (["--end", "park"], "--end"),  # the simulated servo's coils never go off
    (["--end", "rest", "--emulate"], "hold or park"),
    (["--hold", "1"], "--hold"),  # likewise
    (["--hold", "0", "--emulate"], "--hold"),
])
def test_move_refuses_a_bad_end_with_one_line_and_exit_2(argv, word, capsys, tmp_path):
    code = main(["move", "--axis", "1,0.5,2", "--angle", "10", "--out", str(tmp_path / "m"), *argv])
    err = capsys.readouterr().err.strip()
    assert code == 2 and word in err and "Traceback" not in err, err
    assert not (tmp_path / "m").exists()
