"""``spherestep move`` and ``spherestep capability`` end to end (servo on the magnets' torque map)."""

import csv
import json

import numpy as np
import pytest

from spherestep.cli import main


@pytest.mark.slow
def test_move_servo_writes_trajectory_currents_power_and_plot(tmp_path, capsys):
    assert main(["move", "--axis", "0,0,1", "--angle", "10", "--sensor-noise", "0.02", "--out", str(tmp_path),
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["mode"] == "servo" and summary["final_error_deg"] < 0.05
    assert summary["mean_power_W"] < 100
    rows = list(csv.DictReader((tmp_path / "trajectory.csv").open()))
    q = np.array([[float(r[k]) for k in ("qw", "qx", "qy", "qz")] for r in rows])
    assert np.allclose(np.linalg.norm(q, axis=1), 1, atol=1e-9)
    assert float(rows[-1]["error_deg"]) == pytest.approx(summary["final_error_deg"], abs=1e-5)
    header = (tmp_path / "currents.csv").read_text().splitlines()[0].split(",")
    assert header[0] == "t_s" and len(header) == 30
    power = np.loadtxt(tmp_path / "power.csv", delimiter=",", skiprows=1)
    assert power[:, 1].max() == pytest.approx(summary["peak_power_W"], rel=1e-5)
    assert (tmp_path / "move.png").read_bytes()[:4] == b"\x89PNG"


def test_capability_prints_and_plots(tmp_path, capsys):
    assert main(["capability", "--samples", "30", "--seed", "2", "--out", str(tmp_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    r = summary["available_torque_N_m"]
    assert 0 < r["0"] <= r["50"] <= r["100"]
    assert json.loads((tmp_path / "capability.json").read_text())["samples"] == 30
    assert (tmp_path / "capability.png").read_bytes()[:4] == b"\x89PNG"


def test_move_bad_input_exits_2_with_one_line(tmp_path, capsys):
    base = ["move", "--axis", "0,0,1", "--angle", "10", "--out", str(tmp_path / "x")]
    for extra in (["--mode", "pwm"], ["--time", "1", "--mode", "ramped"], ["--time", "1", "--fastest"],
                  ["--time", "-1"], ["--sensor-noise", "-0.1"]):
        capsys.readouterr()
        assert main(base + extra) == 2
        err = capsys.readouterr().err.strip()
        assert err.startswith("spherestep: error:") and "\n" not in err
    assert main(["move", "--axis", "0,0,0", "--angle", "10"]) == 2
    assert not (tmp_path / "x").exists()
