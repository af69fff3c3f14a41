"""``spherestep packings`` and ``spherestep packing``."""

import csv
import json
import math

import numpy as np
import pytest

from spherestep.cli import main
from spherestep.packing import by_name, refine
from spherestep.sphere import point


def test_table_lists_the_16_distinct_packings(capsys):
    assert main(["packings"]) == 0
    out = capsys.readouterr().out
    assert "16 distinct packings of 21 constructions" in out
    for name in ("truncated-icosahedron", "truncated-cuboctahedron", "tetrahedron", "dodecahedron"):
        assert name in out
    assert "dual-tetrahedron" not in out


def test_json_and_all(capsys):
    assert main(["packings", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["count"] == 16 and data["constructions"] == 21
    ti = next(p for p in data["packings"] if p["name"] == "truncated-icosahedron")
    assert ti["caps"] == 60 and ti["symmetry_order"] == 60 and math.isclose(ti["radius_max_deg"], 11.6407, abs_tol=1e-4)
    assert main(["packings", "--all", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["count"] == 21


def test_packing_export_in_inches(tmp_path, capsys):
    out = tmp_path / "rotor.csv"
    assert main(["packing", "truncated-icosahedron", "--refine", "1", "--radius", "6 in", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    p = refine(by_name("truncated-icosahedron"), levels=1)
    assert len(rows) == 92
    xyz = np.array([[float(r[k]) for k in ("x_in", "y_in", "z_in")] for r in rows])
    assert np.allclose(xyz, 6.0 * p.centers, atol=1e-9)
    angles = np.radians([[float(r["phi_deg"]), float(r["theta_deg"])] for r in rows])
    assert np.allclose(point(angles[:, 0], angles[:, 1]), p.centers, atol=1e-10)
    assert np.allclose([float(r["radius_deg"]) for r in rows], np.degrees(p.radii), atol=1e-9)
    assert main(["packing", "cube", "--target", "20", "--out", str(tmp_path / "c.json")]) == 0
    assert len(json.loads((tmp_path / "c.json").read_text())["caps"]) >= 20


@pytest.mark.parametrize("args", [
    ["packing", "nonsense", "--out", "x.csv"],
    ["packing", "cube", "--out", "x.txt"],
    ["packing", "cube", "--refine", "1", "--target", "10", "--out", "x.csv"],
    ["packing", "cube", "--radius", "3 furlong", "--out", "x.csv"],
    ["packing", "cube", "--refine", "-1", "--out", "x.csv"],
    ["packings", "--bogus"],
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, monkeypatch, args):
    monkeypatch.chdir(tmp_path)
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("spherestep: error:") and "Traceback" not in err
    assert not list(tmp_path.iterdir())
