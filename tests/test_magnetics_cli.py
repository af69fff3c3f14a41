"""``spherestep forces``: files, JSON, a design file, bad input."""

import json

import pytest

from spherestep.cli import main
from spherestep.motor import prototype
from spherestep.potential import load_force_curve


@pytest.mark.slow
def test_forces_json_and_files(tmp_path, capsys):
    out = tmp_path / "f"
    assert main(["forces", "--states", "2", "--json", "--out", str(out)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["design"] == "prototype"
    assert info["curve"]["source"].startswith("simulation")
    assert 2.5 < info["curve"]["peak_lateral_force_N"] < 3.2  # N, at ~23 mm
    assert len(info["curve"]["fit_coefficients_N_per_m^i"]) == 5
    assert len(info["states"]) == 2
    assert all(0 < r["holding_torque_Nm"] < 2 for r in info["states"])
    for name in ("force_curve.csv", "force_curve.png", "forces.json"):
        assert (out / name).stat().st_size > 100
    x, F = load_force_curve(out / "force_curve.csv")
    assert len(x) == 121 and F.min() == pytest.approx(-info["curve"]["peak_lateral_force_N"], rel=1e-6)
    assert json.loads((out / "forces.json").read_text())["states"] == info["states"]
    assert info["iron"]["states_sampled"] == 2  # the prototype's coils are iron-cored: reported by default


def test_forces_table_for_people(tmp_path, capsys):
    assert main(["forces", "--states", "1", "--core", "air", "--out", str(tmp_path)]) == 0
    text = capsys.readouterr().out
    assert "peak lateral force" in text and "holding" in text


def test_forces_with_a_design_file(tmp_path, capsys):
    path = prototype().save(tmp_path / "m.yaml")
    assert main(["forces", "--design", str(path), "--states", "1", "--core", "air", "--json", "--out",
                 str(tmp_path / "o")]) == 0
    info = json.loads(capsys.readouterr().out)
    assert len(info["states"]) == 1 and "iron" not in info  # --core air: the air-core report only


@pytest.mark.parametrize("args", [["--states", "0"], ["--design", "/nonexistent/m.yaml"]])
def test_forces_bad_input_exits_2(tmp_path, capsys, args):
    assert main(["forces", *args, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("spherestep: error:") and len(err.strip().splitlines()) == 1
