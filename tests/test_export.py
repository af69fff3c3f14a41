"""Manufacturing exports: the tables against the design, the saddle angles, the STL's bodies, bounds and volume,
and ``spherestep export``."""

import csv
import json
import math
from dataclasses import replace

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from spherestep import packing as pk
from spherestep.cli import main
from spherestep.export import SECTIONS, azimuth_reference, layout_mesh, saddle_angles, write_exports
from spherestep.motor import prototype
from spherestep.sphere import point

MM_PER = {"mm": 1.0, "in": 25.4}


def read_csv(path):
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array(rows[1:], dtype=float)


@pytest.fixture(scope="module")
def design():
    base = prototype()
    return replace(base, failed_coils=(2, 7), channel_map=np.arange(58)[::-1].reshape(29, 2))


@pytest.mark.parametrize("unit", ["mm", "in"])
def test_tables_match_the_design(design, tmp_path, unit):
    written = write_exports(design, tmp_path, unit=unit)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in written) == \
        ["coils.csv", "layout.json", "layout.stl", "magnets.csv", "spherestep_config.h"]
    scale = 1000.0 / MM_PER[unit]  # metres → unit
    R, g = design.radius * scale, design.air_gap * scale

    head, mag = read_csv(tmp_path / "magnets.csv")
    assert head == ["pole", "polarity", "phi_deg", "theta_deg", f"x_{unit}", f"y_{unit}", f"z_{unit}"]
    u = design.rotor.centers
    assert np.array_equal(mag[:, 0], np.arange(92)) and np.array_equal(mag[:, 1], design.polarity)
    assert np.max(np.abs(mag[:, 4:7] - R * u)) < 1e-9
    assert np.max(np.abs(point(np.radians(mag[:, 2]), np.radians(mag[:, 3])) - u)) < 1e-12
    assert np.all((mag[:, 2] >= 0) & (mag[:, 2] < 360))

    head, coil = read_csv(tmp_path / "coils.csv")
    assert head[:4] == ["coil", "enable_channel", "polarity_channel", "failed"] and head[8] == f"x_{unit}"
    v = design.stator.centers
    assert np.array_equal(coil[:, 1:3], design.channel_map)
    assert np.flatnonzero(coil[:, 3]).tolist() == [2, 7]
    assert np.max(np.abs(coil[:, 8:11] - (R + g) * v)) < 1e-9
    assert np.max(np.abs(coil[:, 11:14] - v)) < 1e-15
    assert np.max(np.abs(point(np.radians(coil[:, 4]), np.radians(coil[:, 5])) - v)) < 1e-12
    # the stator axis is −z, so e1 = x, e2 = (−z) × x = −y
    assert np.max(np.abs(coil[:, 6] - np.degrees(np.arccos(-v[:, 2])))) < 1e-9
    azimuth = np.degrees(np.arctan2(-v[:, 1], v[:, 0]))
    assert np.max(np.abs(np.mod(coil[:, 7] - azimuth + 180, 360) - 180)) < 1e-9
    assert np.all((coil[:, 7] >= 0) & (coil[:, 7] < 360))
    assert coil[:, 6].max() <= 80 + 1e-9

    layout = json.loads((tmp_path / "layout.json").read_text())
    assert layout["unit"] == unit and layout["design"] == "prototype"
    assert math.isclose(layout["sphere_radius"], R, rel_tol=1e-15) and math.isclose(layout["air_gap"], g, rel_tol=1e-15)
    assert np.array_equal([[m["x"], m["y"], m["z"]] for m in layout["magnets"]], mag[:, 4:7])
    assert np.array_equal([[c["tilt_deg"], c["azimuth_deg"]] for c in layout["coils"]], coil[:, 6:8])
    assert [c["failed"] for c in layout["coils"]].count(True) == 2


def test_inch_and_millimetre_tables_differ_by_25_4(design, tmp_path):
    write_exports(design, tmp_path / "mm", unit="mm")
    write_exports(design, tmp_path / "in", unit="in")
    mm, inch = read_csv(tmp_path / "mm" / "coils.csv")[1], read_csv(tmp_path / "in" / "coils.csv")[1]
    assert np.max(np.abs(mm[:, 8:11] - 25.4 * inch[:, 8:11])) < 1e-9
    assert np.array_equal(mm[:, :8], inch[:, :8])


def test_saddle_angles_rebuild_the_coil_axes_for_any_stator_axis(design):
    for seed in range(5):
        turn = Rotation.random(random_state=seed).as_matrix()
        turned = replace(design, stator=pk.Packing(design.stator.centers @ turn.T, design.stator.radii),
                         stator_axis=turn @ design.stator_axis)
        a = turned.stator_axis
        e1, e2 = azimuth_reference(a)
        assert abs(e1 @ a) < 1e-15 and abs(np.linalg.norm(e1) - 1) < 1e-15 and np.allclose(e2, np.cross(a, e1))
        tilt, az = np.radians(saddle_angles(turned))
        rebuilt = np.cos(tilt)[:, None] * a + np.sin(tilt)[:, None] * (np.cos(az)[:, None] * e1 + np.sin(az)[:, None] * e2)
        assert np.max(np.abs(rebuilt - turned.stator.centers)) < 1e-12
        assert np.allclose(np.sort(np.degrees(tilt)), np.sort(saddle_angles(design)[0]), atol=1e-9)


def cylinder_bounds(centres, axes, half, radius):
    """Exact bounds of true cylinders: centre ± (h |a_i| + r sqrt(1 − a_i²)) along each axis i."""
    reach = half * np.abs(axes) + radius * np.sqrt(np.clip(1 - axes ** 2, 0, 1))
    return (centres - reach).min(axis=0), (centres + reach).max(axis=0)


@pytest.mark.parametrize("unit", ["mm", "in"])
def test_stl_bodies_bounds_and_volume(design, tmp_path, unit):
    write_exports(design, tmp_path, unit=unit)
    mesh = trimesh.load(tmp_path / "layout.stl")
    assert len(mesh.split(only_watertight=False)) == 92 + 29
    s = 1000.0 / MM_PER[unit]
    R, g = design.radius * s, design.air_gap * s
    rm, lm, rc, lc = (0.5 * design.magnet_diameter * s, design.magnet_length * s, 0.5 * design.coil_diameter * s,
                      design.coil_length * s)
    u, v = design.rotor.centers, design.stator.centers
    lo_m, hi_m = cylinder_bounds((R - lm / 2) * u, u, lm / 2, rm)
    lo_c, hi_c = cylinder_bounds((R + g + lc / 2) * v, v, lc / 2, rc)
    lo, hi = np.minimum(lo_m, lo_c), np.maximum(hi_m, hi_c)
    facet = rc * (1 - math.cos(math.pi / SECTIONS)) + 1e-5 * R  # polygon inside the circle; float32 STL
    assert np.all(mesh.bounds[0] >= lo - 1e-5 * R) and np.all(mesh.bounds[0] <= lo + facet)
    assert np.all(mesh.bounds[1] <= hi + 1e-5 * R) and np.all(mesh.bounds[1] >= hi - facet)
    assert hi[2] < R + 1 and lo[2] < -(R + g + lc) + 1e-9  # coils below, magnets reach the top
    polygon = 0.5 * SECTIONS * math.sin(2 * math.pi / SECTIONS)  # area of a unit-radius 48-gon
    expected = polygon * (92 * rm ** 2 * lm + 29 * rc ** 2 * lc)
    assert math.isclose(mesh.volume, expected, rel_tol=1e-5)


def test_stl_with_the_ball(design):
    mesh = layout_mesh(design, "mm", sphere=True)
    assert len(mesh.split(only_watertight=False)) == 92 + 29 + 1
    R = design.radius * 1000
    assert abs(mesh.bounds[1][2] - R) < 1e-3 * R


def test_export_command(tmp_path, capsys):
    path = tmp_path / "motor.yaml"
    assert main(["design", "new", str(path)]) == 0
    out = tmp_path / "build"
    capsys.readouterr()
    assert main(["export", str(path), "--out", str(out), "--unit", "in", "--sphere"]) == 0
    assert "92 magnets, 29 coils" in capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == ["coils.csv", "layout.json", "layout.stl", "magnets.csv", "spherestep_config.h"]
    assert len(trimesh.load(out / "layout.stl").split(only_watertight=False)) == 122
    head, mag = read_csv(out / "magnets.csv")
    assert head[4] == "x_in" and np.max(np.abs(np.linalg.norm(mag[:, 4:7], axis=1) - 6.0)) < 1e-9
    (tmp_path / "afile").write_text("x")
    for args, words in ((["export", str(path), "--out", str(tmp_path / "o"), "--unit", "cm"], "--unit"),
                        (["export", str(path), "--out", str(tmp_path / "afile")], "a folder"),
                        (["export", str(tmp_path / "none.yaml"), "--out", str(tmp_path / "o")], "must be an existing file")):
        assert main(args) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err and "Traceback" not in err
    assert not (tmp_path / "o").exists() and (tmp_path / "afile").read_text() == "x"
    assert main(["export", "--help"]) == 0
    assert "Example: spherestep export" in capsys.readouterr().out
