"""The drive room (issue 24 §2): one result type, its honest JSON, the options it refuses, the fixed-time fallback."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.drive import (DriveResult, ServoDetails, check_options, choose_model, drive_turn, fixed_servo_time,
                              TOLERANCE)
from spherestep.errors import InputError


def _result(time: float, final_error: float) -> DriveResult:
    T = 4
    R = so3.rot([0, 0, 1], 0.1 * np.arange(T))
    details = ServoDetails("fastest", "", 1.0, "ideal", 0.0, 0.0, 0.0, 1.0, 0.2, 1.0)
    return DriveResult("servo", "simulated", "air (magnets' torque map)", np.array([0.0, 0.0, 1.0]), 0.3,
                       np.arange(T) * 0.1, R, R, np.zeros(T), np.zeros((T, 2)), np.full(T, 5.0), time,
                       "" if math.isfinite(time) else "not within 0.05° of the turn's end", final_error, 0.0, 5.0,
                       5.0, TOLERANCE, details)


def test_a_result_never_claims_an_arrival_it_did_not_have():
    never = _result(math.inf, math.radians(0.3))
    d = never.to_dict()
    text = json.dumps(d, allow_nan=False)  # no Infinity, no NaN
    assert d["time_s"] is None and d["arrival_note"] and d["within_tolerance"] is False and "Infinity" not in text
    assert not never.ok and "did not arrive" in never.verdict()
    late = _result(1.0, math.radians(0.3))  # arrived by its own clock, but ends outside the tolerance
    assert not late.ok and "more than the tolerance 0.05°" in late.verdict()
    good = _result(1.0, math.radians(0.01))
    assert good.ok and good.verdict() == "" and good.to_dict()["final_error_deg"] == pytest.approx(0.01)
    assert good.to_dict(degrees=False)["final_error_rad"] == pytest.approx(math.radians(0.01))
    assert good.to_dict()["details"]["trajectory"] == "fastest"


@pytest.mark.parametrize("kwargs, name", [
    ({"mode": "pwm", "backend": "simulated"}, "mode"),
    ({"mode": "servo", "backend": "usb"}, "backend"),
    ({"mode": "settled", "backend": "simulated", "duration": 1.0}, "duration"),
    ({"mode": "servo", "backend": "simulated", "duration": -1.0}, "duration"),
    ({"mode": "servo", "backend": "simulated", "rate": 100.0}, "rate"),
    ({"mode": "servo", "backend": "emulated", "sensor": "imu"}, "sensor"),
    ({"mode": "servo", "backend": "simulated", "sensor": "hall", "sensor_noise": 0.001}, "sensor_noise"),
    ({"mode": "ramped", "backend": "simulated", "sensor_noise": 0.001}, "sensor"),
    ({"mode": "settled", "backend": "port", "port": "/dev/null"}, "mode"),
    ({"mode": "servo", "backend": "port"}, "port"),
    ({"mode": "servo", "backend": "simulated", "port": "/dev/null"}, "port"),
    ({"mode": "servo", "backend": "port", "port": "/dev/null", "firmware": "qemu"}, "firmware"),
    ({"mode": "servo", "backend": "simulated", "hold": 1.0}, "hold"),
    ({"mode": "servo", "backend": "simulated", "end": "park"}, "end"),
    ({"mode": "servo", "backend": "port", "port": "/dev/null", "plant_error": object()}, "plant_error"),
])
def test_options_that_do_not_apply_are_refused_by_name(kwargs, name):
    mode, backend = kwargs.pop("mode"), kwargs.pop("backend")
    with pytest.raises(InputError, match=f"^{name} must be"):
        check_options(mode, backend, **kwargs)


def test_every_mode_is_one_lookup_in_the_registry(proto, monkeypatch):
    """How a turn is driven is one registry (issue 36): each mode names the backends it runs on and has its own
    tolerance; ``drive_turn`` checks the options, prepares the turn and calls exactly the registered runner, with
    the options it was given (a spy in place of the settled relay steps)."""
    from spherestep.drive import BACKENDS, DRIVE_MODES, MODES
    from spherestep.drive.judgement import MODE_TOLERANCE, RELAY_TOLERANCE, SERVO_TOLERANCE

    assert MODES == ("servo", "ramped", "settled") and set(MODE_TOLERANCE) == set(MODES)
    assert {m: tuple(DRIVE_MODES[m].runs) for m in MODES} == {"servo": BACKENDS, "ramped": ("simulated",),
                                                              "settled": ("simulated",)}
    assert MODE_TOLERANCE == {"servo": SERVO_TOLERANCE, "ramped": RELAY_TOLERANCE, "settled": RELAY_TOLERANCE}
    seen = []
    runs = dict(DRIVE_MODES["settled"].runs, simulated=lambda job, o: seen.append((job, o)) or "ran")
    monkeypatch.setitem(DRIVE_MODES, "settled", type(DRIVE_MODES["settled"])("settled", runs))
    from spherestep.magnetics import design_model

    assert drive_turn(proto, [0, 0, 1], 0.3, mode="settled", model=design_model(proto, "air"), rates=(1.0,)) == "ran"
    (job, options), = seen
    assert job.angle == 0.3 and job.tolerance("settled") == RELAY_TOLERANCE and options.rates == (1.0,)


def test_the_fixed_time_keeps_the_demo_turn_and_its_acceleration():
    assert fixed_servo_time(2 * math.pi) == pytest.approx(3.0)
    # the same peak acceleration 4θ/T² for any angle
    for angle in (0.1, math.pi, 4 * math.pi):
        assert 4 * angle / fixed_servo_time(angle) ** 2 == pytest.approx(4 * 2 * math.pi / 9.0)


def test_the_servo_takes_the_fixed_time_where_the_planner_refuses_the_model(proto, monkeypatch):
    """Until the planner turns on every model, a refusal is not a crash: the turn takes the fixed time and the
    result says so."""
    import spherestep.control as control
    from spherestep.dynamics import Rotor
    from spherestep.drive.turn import Turn
    from spherestep.errors import bad_value
    from spherestep.magnetics import design_model

    def refuse(*args, **kwargs):
        raise bad_value("axis", "a turn along which the drive can give torque in every direction", "-1.35 N·m")

    monkeypatch.setattr(control, "plan_turn", refuse)
    job = Turn(proto, [1, 0.5, 2], math.radians(90), choose_model(proto, design_model(proto, "air")))
    traj, kind, note = job.servo_trajectory(job.start, None, Rotor.from_design(proto))
    assert kind == "fixed" and traj.duration == pytest.approx(fixed_servo_time(math.radians(90)))
    assert "refused" in note and "-1.35" in note
    assert so3.distance(traj.end, job.end) < 1e-9


def test_drive_turn_refuses_a_time_below_the_bang_bang_bound(proto):
    from spherestep.magnetics import design_model

    with pytest.raises(InputError, match="^duration must be at least the bang-bang bound"):
        drive_turn(proto, [0, 0, 1], math.radians(10), model=design_model(proto, "air"), duration=1e-3)


def test_a_sessions_kind_is_chosen_in_one_place():
    """``drive.connect.session_kind``: the selector's kind for a servo session (what servo_session builds and what
    calibration's current lag is read by), and its refusals naming the field."""
    from spherestep.drive.connect import KINDS, session_kind

    assert session_kind("/dev/ttyACM0") == "port"
    assert session_kind(emulate=True) == "pty" and session_kind(emulate=True, lockstep=True) == "lockstep"
    assert session_kind(emulate=True, firmware="qemu") == "qemu"
    assert {"port", "pty", "lockstep", "qemu"} <= set(KINDS)
    for kwargs, name in (({}, "port"), ({"port": "/dev/x", "emulate": True}, "port"),
                         ({"port": "/dev/x", "lockstep": True}, "lockstep"),
                         ({"emulate": True, "lockstep": True, "firmware": "qemu"}, "firmware"),
                         ({"emulate": True, "firmware": "c++"}, "firmware")):
        with pytest.raises(InputError, match=f"^{name} must be"):
            session_kind(**kwargs)
