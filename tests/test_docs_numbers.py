"""Every generated block of README and docs/ is what ``scripts/docs_numbers.py`` renders from the stored
measurements (``data/demo_summary.json``, ``data/forces_states.json``, ``data/servo_robust.json``,
``data/iron_compare.json``, the benchmarks' ``data/bench_*.json``), so the docs cannot drift from them; and the stored measurements' cheap numbers are held against the live code (issue 27 §4)."""

import importlib.util
import math
import re
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("docs_numbers", ROOT / "scripts" / "docs_numbers.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


SCRIPT = _script()


@pytest.mark.parametrize("block", SCRIPT.BLOCKS, ids=lambda b: b.name)
def test_every_block_is_its_stored_measurement_rendered(block):
    text = (ROOT / block.path).read_text(encoding="utf-8")
    have = SCRIPT.current(text, block.name)
    assert have is not None, f"{block.path} lost the markers of {block.name}"
    assert not block.missing(), f"{block.missing()} missing"
    assert have == block.text(block.data()), (
        f"{block.path}: the block {block.name} differs from {', '.join(block.sources)}: run "
        "`python scripts/docs_numbers.py` (after `make demo && python scripts/docs_numbers.py demo` for new numbers, "
        "`python scripts/docs_numbers.py bench` for new benchmark runs)")


def test_every_marker_is_registered_and_paired():
    """A marker the generator does not know would be a block nobody rewrites; each pair exactly once, in order."""
    names = {b.name: b.path for b in SCRIPT.BLOCKS}
    seen = set()
    for path in SCRIPT.marked_files():
        rel = str(path.relative_to(ROOT))
        marks = SCRIPT.MARKER.findall(path.read_text(encoding="utf-8"))
        for (name, kind), nxt in zip(marks[::2], marks[1::2] + [("", "")] * (len(marks) % 2)):
            assert names.get(name) == rel, f"{rel}: marker {name!r} is not a block of scripts/docs_numbers.py"
            assert (kind, nxt) == ("start", (name, "end")), f"{rel}: {name} is not a start/end pair"
            assert name not in seen, f"{name} appears twice"
            seen.add(name)
    assert seen == set(names), f"blocks without markers: {sorted(set(names) - seen)}"


def test_the_generator_rewrites_a_stale_block(tmp_path, monkeypatch):
    """Rewriting is what the test above demands: a block with a stale number is put back, the rest untouched."""
    block = next(b for b in SCRIPT.BLOCKS if b.name == "move-servo")
    doc = tmp_path / "docs" / "control.md"
    doc.parent.mkdir()
    good = block.text(SCRIPT.stored("demo"))
    doc.write_text(f"before {re.sub(r'in [0-9.]+ s', 'in 9.99 s', good)} after\n", encoding="utf-8")
    monkeypatch.setattr(SCRIPT, "ROOT", tmp_path)
    monkeypatch.setattr(SCRIPT, "BLOCKS", (block,))
    assert SCRIPT.write() == 1
    assert doc.read_text(encoding="utf-8") == f"before {good} after\n"
    assert SCRIPT.differing() == []


@pytest.mark.parametrize("name", SCRIPT.BENCHES)
def test_every_stored_benchmark_says_when_and_under_what_load(name):
    """A stored benchmark run is its script's (which takes ``--json``) and states its date, load and machine, which
    every table rendered from it repeats; no benchmark runs here."""
    script = ROOT / "benchmarks" / SCRIPT.BENCHES[name][0]
    assert script.exists() and "Record(" in script.read_text(encoding="utf-8"), f"{script.name} stores no --json"
    b = SCRIPT.stored(f"bench-{name}")
    assert b["benchmark"] == name and b["command"].startswith(script.name)
    assert re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", b["measured"]) and len(b["load"]) == 2
    assert b["values"] and "cores" in b["machine"]
    for block in SCRIPT.BLOCKS:
        if f"bench-{name}" in block.sources and not block.inline:
            assert b["measured"] in block.text(block.data()), f"{block.name} does not say when {name} ran"


def test_a_bench_block_follows_its_stored_run(tmp_path, monkeypatch):
    """Drift of a benchmark's stored number reaches its docs: the stored run changed, the block differs."""
    import json

    block = next(b for b in SCRIPT.BLOCKS if b.name == "bench-loop-cost")
    b = SCRIPT.stored("bench-servo_loop")
    b["values"]["law iron"]["law.step (turn)"][0] *= 2
    path = tmp_path / "bench_servo_loop.json"
    path.write_text(json.dumps(b), encoding="utf-8")
    monkeypatch.setitem(SCRIPT.STORES, "bench-servo_loop", path)
    assert f"{block.path}: {block.name}" in SCRIPT.differing()


def test_the_gallery_blocks_read_what_the_package_stores():
    """The gallery's blocks read ``metrics.csv`` as ``gallery.stored_metrics()`` does: same entries, same numbers."""
    from spherestep import gallery

    g, live = SCRIPT.stored("gallery"), gallery.stored_metrics()
    assert list(g) == list(live) == [e.key for e in gallery.entries()]
    for key, m in live.items():
        assert g[key]["states"] == m.states
        assert g[key]["torque_median_N_m"] == pytest.approx(m.torque_median_N_m, rel=1e-9)
        assert g[key]["resolution_median_deg"] == pytest.approx(math.degrees(m.resolution_median_rad), rel=1e-9)


def test_the_stored_demo_agrees_with_the_code(proto, proto_metrics):
    """States exactly; the resolution within its sampling noise (the stored run used seed 0, the fixture seed 7:
    two 20,000-sample medians differ by ~0.01°); the plan's step count; the coil as built."""
    from spherestep.commutation import turn
    from spherestep.magnetics import design_model

    s = SCRIPT.stored("demo")
    assert s["states"] == proto_metrics.states == 101_640
    assert s["resolution_median_deg"] == pytest.approx(math.degrees(proto_metrics.resolution_median_rad), abs=0.03)
    assert s["plan"]["steps"] == len(turn(proto, s["plan"]["axis"], math.radians(s["plan"]["angle_deg"])).steps) - 1 \
        == 73  # the headline's plan length, pinned (issue 27 §5)
    assert s["iron"]["electrics"]["nominal_current_A"] == pytest.approx(design_model(proto).limits.nominal_current,
                                                                        rel=1e-12)
    assert s["torque_model"] == design_model(proto).label
    assert s["drives"]["model"] == design_model(proto).label


def test_the_stored_forces_agree_with_the_code(proto):
    """The stored sample is ``rng(0)``'s 20 states of the live enumeration, with the live coils and polarities;
    two of its rows are recomputed (holding and stepping torques; deterministic, so to 1e-6 relative)."""
    from spherestep.magnetics import state_torques, torque_map

    f = SCRIPT.stored("forces")
    states = proto.states()
    idx = np.sort(np.random.default_rng(SCRIPT.FORCES_SEED).choice(len(states), SCRIPT.FORCES_STATES, replace=False))
    assert [r["state"] for r in f["states"]] == idx.tolist()
    picked = [f["states"][i] for i in (0, 5)]
    live = [r.to_dict(degrees=True) for r in state_torques(proto, torque_map(proto), [r["state"] for r in picked])]
    for want, got in zip(picked, live):
        assert {str(k): v for k, v in got["coils"].items()} == want["coils"]
        for key in ("holding_torque_Nm", "strongest_axis_Nm", "equilibrium_offset_deg", "step_peak_torque_Nm"):
            assert got[key] == pytest.approx(want[key], rel=1e-6, abs=1e-9), key
        assert got["stiffness_Nm_per_rad"] == pytest.approx(want["stiffness_Nm_per_rad"], rel=1e-6)
        assert (got["downhill_steps"], got["steps"]) == (want["downhill_steps"], want["steps"])


def test_the_stored_potential_numbers_agree_with_the_code():
    """docs/potential.md's model constants are the live model's (profiles, band limit, kernel table, cut-off); the
    stored equilibria are a full sample of strict minima."""
    from spherestep.motor import prototype
    from spherestep.potential import MotorPotential

    m = SCRIPT.stored("potential")
    p = MotorPotential(prototype())
    assert m["rotor_kappa"] == pytest.approx(p.rotor_profile.kappa, rel=1e-12)
    assert m["stator_kappa"] == pytest.approx(p.stator_profile.kappa, rel=1e-12)
    assert (m["bandlimit"], m["kernel_intervals"]) == (p.bandlimit, p.kernel.intervals)
    assert m["kernel_errors"] == pytest.approx(list(p.kernel.table_error), rel=1e-6)
    assert m["cutoff_deg"] == pytest.approx(math.degrees(p.rotor_field.cut), abs=1e-9)
    e = m["equilibria"]
    assert e["minima"] == e["states"] == SCRIPT.POTENTIAL_OFFSET_STATES
    assert sum(r["states"] for r in e["rows"] if r["held"] is not None) == e["states"]


def test_the_stored_dynamics_numbers_agree_with_the_code():
    """docs/dynamics.md's inertia is the live rotor's; the tuning is internally consistent: ``b = 2ζ√(kI)`` with
    ζ = 1, ``ω = √(k/I)``, ``dt ≤ dwell/50``."""
    from spherestep.dynamics import Rotor
    from spherestep.motor import prototype

    m = SCRIPT.stored("dynamics")
    inertia = Rotor.from_design(prototype()).inertia
    assert m["inertia_kg_m2"] == pytest.approx(inertia, rel=1e-12)
    for name in ("torque map", "iron model"):
        t = m[name]
        assert t["omega_rad_s"] == pytest.approx(math.sqrt(t["stiffness_Nm_per_rad"] / inertia), rel=1e-9)
        assert t["damping_Nm_s"] == pytest.approx(2 * math.sqrt(t["stiffness_Nm_per_rad"] * inertia), rel=1e-9)
        assert 0 < t["dt_s"] <= t["dwell_s"] / 50 * (1 + 1e-12)


def test_the_stored_explore_sweep_is_the_default_grid():
    """data/explore_default.json is docs/explore.md's command on today's default grid (restricted to the stated
    pairs): every design of that grid has a status, the counts add up, the torques are on the designs' own (iron)
    models, the front is within budget."""
    from spherestep.explore.grid import default_grid

    e = SCRIPT.stored("explore")
    assert e["command"] == f"spherestep explore {' '.join(SCRIPT.EXPLORE_OPTIONS)} --out …"
    grid = default_grid(**SCRIPT.EXPLORE_SUBSET)
    assert e["designs"] == len(grid.points()) == sum(e["status_counts"].values())
    assert e["pairs"] == len(grid.pairs())
    assert e["measured_designs"] == e["status_counts"]["ok"] and e["reach_all"] <= e["measured_designs"]
    assert sum(e["no_states"].values()) == e["status_counts"].get("no_states", 0)
    assert sum(e["too_large"].values()) == e["status_counts"].get("too_large", 0)
    assert sum(e["models"].values()) == e["torques_measured"] and all(m.startswith("iron") for m in e["models"])
    assert e["pareto"] and all(r["coils"] <= 32 for r in e["pareto"])
    assert e["family"]["different"]["designs"] + e["family"]["same"]["designs"] == e["reach_all"]


@pytest.mark.parametrize("name", ["control-notes", "sensing-notes"])
def test_the_stored_notes_say_when_and_under_what_load(name):
    """docs/control.md's and docs/sensing.md's hand-measured numbers are now ``scripts/docs_numbers.py NAME``'s
    stored run: it states its date, load and machine, and the page's source says so; no dated one-off is left
    outside the page's design record."""
    n = SCRIPT.stored(name)
    assert n["mode"] == name and re.fullmatch(r"\d{4}-\d\d-\d\d \d\d:\d\d UTC", n["measured"])
    assert len(n["load"]) == 2 and "cores" in n["machine"] and n["wall_s"] > 0
    page = {"control-notes": "docs/control.md", "sensing-notes": "docs/sensing.md"}[name]
    text = (ROOT / page).read_text(encoding="utf-8")
    body, record = text.split("## Design record (dated experiments, not regenerated)")
    assert "one-off" not in body, f"{page}: a one-off measurement outside the design record"
    assert n["measured"] in text


def test_a_notes_mode_rewrites_only_its_own_blocks(tmp_path, monkeypatch):
    """``control-notes`` stores its measurement and rewrites the blocks rendered from it, not the demo's blocks on
    the same page (the lead regenerates those)."""
    import json

    own = next(b for b in SCRIPT.BLOCKS if b.name == "control-notes-iron-coil")
    other = next(b for b in SCRIPT.BLOCKS if b.name == "move-servo")
    n = SCRIPT.stored("control-notes")
    n["iron_coil"]["resistance_ohm"] += 1.0
    stale_other = other.text(SCRIPT.stored("demo")).replace("in 1.", "in 9.")
    doc = tmp_path / "docs" / "control.md"
    doc.parent.mkdir()
    doc.write_text(f"{own.text(SCRIPT.stored('control-notes'))}\n{stale_other}\n", encoding="utf-8")
    store = tmp_path / "notes.json"
    monkeypatch.setattr(SCRIPT, "ROOT", tmp_path)
    monkeypatch.setitem(SCRIPT.STORES, "control-notes", store)
    monkeypatch.setattr(SCRIPT, "measure_control_notes", lambda: n)
    monkeypatch.setattr(SCRIPT, "BLOCKS", (own, other))
    assert SCRIPT.main(["control-notes"]) == 0
    assert json.loads(store.read_text(encoding="utf-8")) == n
    assert doc.read_text(encoding="utf-8") == f"{own.text(n)}\n{stale_other}\n"


def test_the_stored_control_notes_agree_with_the_code():
    """The iron coil's limits are the live ``design_model``'s; the fastest iron plan is the one the calibration table
    ran (same code, same turn); the weakest plant misses at least one hold, as the robustness table says."""
    from spherestep.magnetics import design_model
    from spherestep.motor import prototype

    n = SCRIPT.stored("control-notes")
    lim = design_model(prototype(), "iron").limits
    c = n["iron_coil"]
    assert c["resistance_ohm"] == pytest.approx(lim.resistance, rel=1e-9)
    assert c["inductance_H"] == pytest.approx(lim.inductance, rel=1e-9)
    assert c["rho"] == pytest.approx(lim.per_unit_power_radius, rel=1e-9)
    fastest = n["turns"]["iron"]["fastest"]["duration_s"]
    assert fastest == pytest.approx(SCRIPT.stored("calibration")["plans"]["fastest"]["duration_s"], abs=1e-3)
    assert n["turns"]["iron"]["bound_s"] < fastest <= 1.5
    missed = [h for h in n["weakest_plant"]["holds"] if not h["plant"]["reachable"]]
    robust = next(r for r in SCRIPT.stored("robust")["rows"] if r["case"] == n["weakest_plant"]["case"]
                  and r["observer"] == "on")
    assert len(missed) >= robust["holds"] - robust["holds_within"]


def test_the_stored_sensing_notes_agree_with_the_code():
    """The placement's candidates are the live ``candidate_positions``; the rows are the stated cases."""
    from spherestep.motor import prototype
    from spherestep.sensing import candidate_positions

    n = SCRIPT.stored("sensing-notes")
    assert n["placement"]["candidates"] == len(candidate_positions(prototype()))
    assert n["global"]["trials"] == SCRIPT.SENSING_GLOBAL_TRIALS and len(n["global"]["rows"]) == 4
    assert [(r["sensors"], r["layout"]) for r in n["accuracy"]][-2:] == [(24, "greedy"), (24, "spread")]
    assert n["iron_accuracy"]["with"]["field_model"] == "rotor + cores"
