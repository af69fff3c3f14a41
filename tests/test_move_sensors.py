"""The servo with the sensing room in the loop (issue 16 §3): ``drive_turn(sensor=...)`` and ``move --sensor``."""

from __future__ import annotations

import json
import math

import pytest

from spherestep.cli import main
from spherestep.drive import drive_turn
from spherestep.errors import InputError
from spherestep.magnetics import design_model


@pytest.mark.slow
def test_servo_with_the_magnetometer_array_in_the_loop(proto):
    move = drive_turn(proto, [1, 0.5, 2], math.radians(20), sensor="hall", model=design_model(proto, "air"))
    s = move.to_dict()
    # the array's estimate stays within a few thousandths of a degree; the turn ends within the servo target
    assert s["details"]["sensor"] == "hall" and s["details"]["sensor_error_max_deg"] < 0.02
    assert s["model"] == "air (magnets' torque map)" and move.ok
    assert s["final_error_deg"] < 0.05 and s["max_tracking_error_deg"] < 0.5


@pytest.mark.slow
def test_servo_with_an_imu_is_worse_than_with_the_array(proto):
    imu = drive_turn(proto, [0, 0, 1], math.radians(10), sensor="imu", model=design_model(proto, "air")).to_dict()
    # an AHRS drifts and is noisy: degrees, not thousandths (docs/sensing.md)
    assert imu["details"]["sensor_error_max_deg"] > 0.05


def test_sensor_choice_is_checked(proto, tmp_path, capsys):
    with pytest.raises(InputError, match="^sensor must be one of ideal, hall, imu"):
        drive_turn(proto, [0, 0, 1], 0.1, sensor="camera")
    with pytest.raises(InputError, match="^sensor_noise must be 0 with the hall and imu sensors"):
        drive_turn(proto, [0, 0, 1], 0.1, sensor="hall", sensor_noise=0.001)
    for args in (["--sensor", "camera"], ["--sensor", "hall", "--sensor-noise", "0.1"],
                 ["--sensor", "hall", "--mode", "ramped"]):
        assert main(["move", "--axis", "0,0,1", "--angle", "5", "--out", str(tmp_path / "m"), *args]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "--sensor" in err
    assert not (tmp_path / "m").exists()


@pytest.mark.slow
def test_move_command_with_the_array(tmp_path, capsys):
    assert main(["move", "--axis", "0,0,1", "--angle", "10", "--sensor", "hall", "--core", "air", "--out",
                 str(tmp_path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["details"]["sensor"] == "hall" and info["final_error_deg"] < 0.05
