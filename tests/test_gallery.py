"""The gallery (issue 29 §4): every design file loads and is the construction it claims, the stored metrics are
re-measured independently of the gallery's code path, and ``spherestep gallery`` runs."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spherestep import gallery
from spherestep import packing as pk
from spherestep.cli import main
from spherestep.control import torque_capability
from spherestep.errors import InputError
from spherestep.magnetics import design_model
from spherestep.motor import MotorDesign

ROOT = Path(__file__).resolve().parent.parent
COUNTS = {"prototype": (92, 29), "jhu-as-built": (80, 16), "ncsu-goldberg": (48, 46),
          "dodecahedral-hobby": (32, 12), "gimbal-40mm": (60, 24)}


def _same_points(a, b, tol=1e-12) -> bool:
    """Whether two sets of unit vectors are equal (each point of one within ``tol`` of a point of the other)."""
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)
    return len(a) == len(b) and d.min(axis=1).max() < tol and d.min(axis=0).max() < tol


@pytest.fixture(scope="module")
def designs():
    return {e.key: e.design() for e in gallery.entries()}


def test_every_design_file_loads_validates_and_has_its_counts(designs):
    assert [e.key for e in gallery.entries()] == list(COUNTS)  # our prototype reading first
    for e in gallery.entries():
        d = designs[e.key]
        assert (len(d.rotor), len(d.stator)) == COUNTS[e.key], e.key
        assert MotorDesign.load(e.path).name == d.name == e.key
        assert e.source and e.assumptions and (e.key == "gimbal-40mm" or e.reported)
    assert main(["design", "validate", str(gallery.entry("jhu-as-built").path)]) == 0
    with pytest.raises(InputError, match="entry must be one of prototype"):
        gallery.entry("nope")


def test_the_files_are_what_their_script_writes():
    done = subprocess.run([sys.executable, str(ROOT / "scripts" / "gallery_designs.py"), "--check"],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr


def test_jhu_as_built_is_our_reading_without_the_twelve_pentagon_poles(designs):
    d, full = designs["jhu-as-built"], pk.named("truncated-icosahedron", 1)
    keep = full.radii > np.sort(full.radii)[11] + 1e-9  # drop the 12 smallest caps: the pentagonal holes
    assert np.sort(full.radii)[11] < np.sort(full.radii)[12] - 1e-3
    assert _same_points(d.rotor.centers, full.centers[keep])
    assert d.polarity.tolist() == [1] * 60 + [-1] * 20
    assert abs(d.polarity @ d.rotor.centers).max() < 1e-12  # no net dipole
    # the stator: the truncated cuboctahedron's caps within 60° of -z, two rings of 8 about the four-fold axis
    tc = pk.named("truncated-cuboctahedron", 0)
    polar = np.degrees(np.arccos(-tc.centers[:, 2]))
    assert _same_points(d.stator.centers, tc.centers[polar < 60])
    assert sorted(np.round(np.degrees(np.arccos(-d.stator.centers[:, 2])), 3)) == [34.316] * 8 + [58.611] * 8
    # same magnets, coils and gap as the prototype: the iron model is the stored FEM table (no solve)
    assert "FEM table" in design_model(d).label and "FEM table" in design_model(designs["ncsu-goldberg"]).label


def test_ncsu_stator_is_a_five_fold_hemisphere_of_the_92_cap_packing(designs):
    d = designs["ncsu-goldberg"]
    full = pk.named("truncated-icosahedron", 1)
    assert sorted(np.unique(np.round(np.degrees(full.radii), 3), return_counts=True)[1]) == [12, 20, 60]
    a = d.stator_axis
    assert np.degrees(np.arccos(np.clip(d.stator.centers @ a, -1, 1))).max() < 80.2
    outside = np.degrees(np.arccos(np.clip(full.centers @ a, -1, 1)))
    assert (outside < 90).sum() == 46 and (outside > 99.8).sum() == 46
    # invariant under a fifth of a turn about the axis
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    turn = np.eye(3) + math.sin(0.4 * math.pi) * k + (1 - math.cos(0.4 * math.pi)) * k @ k
    assert _same_points(d.stator.centers @ turn.T, d.stator.centers, tol=1e-9)


def test_stored_metrics_cover_every_entry_and_round_trip():
    stored = gallery.stored_metrics()
    assert list(stored) == [e.key for e in gallery.entries()] and gallery.METRICS_FILE.endswith(".csv")
    again = gallery.parse_metrics(gallery.metrics_csv(stored.values()))
    for key, m in stored.items():
        assert again[key].states == m.states
        assert math.isclose(again[key].resolution_median_rad, m.resolution_median_rad, rel_tol=1e-9)
        assert again[key].relay_executed == m.relay_executed and again[key].drive_note == m.drive_note
        # the drive: a settled relay plan for every design; a fastest servo turn, or None with the planner's reason
        assert m.relay_steps > 0 and 0 <= m.relay_steps_on_plan <= m.relay_steps
        assert m.relay_executed == (m.relay_steps_on_plan == m.relay_steps)
        assert math.isclose(m.relay_landed_fraction, m.relay_steps_on_plan / m.relay_steps, rel_tol=1e-9)
        if m.servo_turn_s is None:
            assert "planner refused" in m.drive_note and m.servo_mean_power_W is None, key
        else:
            assert 0 < m.servo_turn_s < 10 and m.servo_final_error_rad < math.radians(0.5), key
            assert m.servo_max_tracking_error_rad >= m.servo_final_error_rad and m.servo_mean_power_W > 0
    proto = stored["prototype"]
    assert proto.states == 101_640 and round(math.degrees(proto.resolution_median_rad), 2) == 3.52
    assert all(m.reaches_all for m in stored.values())
    assert math.isclose(proto.magnet_mass_kg, 92 * 7500 * math.pi * 0.0127 ** 2 * 0.0127, rel_tol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("key", list(COUNTS))
def test_stored_metrics_re_measured_independently(designs, key):
    """Another seed and fewer samples, straight through the motor and control rooms: states exactly, the
    resolution within sampling noise (5000 samples: ~1 %), the median torque within 15 % (200 samples)."""
    m = gallery.stored_metrics()[key]
    d = designs[key]
    again = d.metrics(samples=5000, seed=7, escape=False)
    assert again.states == m.states
    assert again.reaches_all == m.reaches_all
    assert math.isclose(again.resolution_median_rad, m.resolution_median_rad, rel_tol=0.02)
    assert math.isclose(again.resolution_p95_rad, m.resolution_p95_rad, rel_tol=0.04)
    cap = torque_capability(d, samples=200, seed=7)
    assert math.isclose(float(np.median(cap.radius)), m.torque_median_N_m, rel_tol=0.15)
    assert (m.core, m.coils, m.rotor_poles) == (d.coil.core, len(d.stator), len(d.rotor))


def test_stored_servo_turn_re_measured_through_the_drive_room(designs):
    """The air-cored gimbal's fastest 360° turn about (1, 0.5, 2), straight through spherestep.drive (about 8 s):
    the run is deterministic (ideal sensor), so the arrival time within 2 % (a few of its 1-ms control periods),
    the mean power within 2 %, the final error within 0.5° as stored; and the planned time is the control room's
    own (``control.plan_turn``), below the arrival."""
    from spherestep.control import plan_turn
    from spherestep.drive import drive_turn
    from spherestep.dynamics import Rotor

    m = gallery.stored_metrics()["gimbal-40mm"]
    d = designs["gimbal-40mm"]
    run = drive_turn(d, (1, 0.5, 2), 2 * math.pi, mode="servo")
    assert run.details.trajectory == "fastest" and run.ok
    assert math.isclose(run.time, m.servo_turn_s, rel_tol=0.02)
    assert math.isclose(run.mean_power, m.servo_mean_power_W, rel_tol=0.02)
    assert run.final_error < math.radians(0.5) and m.servo_final_error_rad < math.radians(0.5)
    assert math.isclose(run.max_tracking_error, m.servo_max_tracking_error_rad, rel_tol=0.1)
    own, rotor = design_model(d), Rotor.from_design(d)
    start = run.orientations[0]
    plan = plan_turn(own.model, start, run.axis, 2 * math.pi, rotor.inertia, own.limits, damping=rotor.damping)
    assert math.isclose(plan.duration, run.details.motion_time, rel_tol=1e-6) and plan.duration < m.servo_turn_s


def test_measure_gives_the_metrics_and_leaves_out_the_drive_on_request():
    m = gallery.measure(gallery.entry("dodecahedral-hobby"), samples=2000, capability_samples=50, escape=False,
                        drive=False)
    assert m.states == 1440 and m.escape_violations is None and m.core == "air"
    d = m.to_dict()
    assert "resolution_median_deg" in d and d["servo_turn_s"] is None and d["relay_executed"] is None
    assert d["drive_note"] == "servo: not measured; relay: not measured"
    with pytest.raises(InputError, match="samples"):
        gallery.measure(gallery.entry("gimbal-40mm"), samples=0)


def test_cli_json_table_and_out(tmp_path, capsys):
    assert main(["gallery", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert [r["key"] for r in data["entries"]] == list(COUNTS)
    assert data["entries"][1]["metrics"]["rotor_poles"] == 80 and data["entries"][1]["metrics"]["coils"] == 16
    assert data["entries"][1]["metrics"]["servo_turn_s"] is None and "planner" in data["entries"][1]["metrics"][
        "drive_note"] and data["entries"][4]["metrics"]["servo_final_error_deg"] < 0.5
    target = data["targets"][0]
    assert target["key"] == "kumagai-hollis-sim" and target["metrics"] is None
    assert "4 N·m" in target["requirements"]["torque"] and "300 rpm" in target["requirements"]["speed"]
    assert main(["gallery", "--out", str(tmp_path / "g")]) == 0
    out = capsys.readouterr().out
    assert "jhu-as-built" in out and "kumagai-hollis-sim" in out and "n/a" in out
    assert "38/38" in out and "drive: the servo's fastest 360° turn" in " ".join(out.split())  # the drive column
    assert len(MotorDesign.load(tmp_path / "g" / "jhu-as-built.yaml").rotor) == 80
    assert gallery.parse_metrics((tmp_path / "g" / "metrics.csv").read_text())["gimbal-40mm"].states == 25_200


@pytest.mark.parametrize("argv, words", [
    (["gallery", "--samples", "5"], "--samples must be a whole number of orientations"),
    (["gallery", "--samples", "many"], "--samples"),
    (["gallery", "--bogus"], "No such option"),
])
def test_cli_bad_options_exit_2_with_one_line(argv, words, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("spherestep: error:") and words in err and "\n" not in err


def test_cli_out_under_a_file_exits_2(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    assert main(["gallery", "--out", str(tmp_path / "f" / "g")]) == 2
    assert capsys.readouterr().err.startswith("spherestep: error: --out")
