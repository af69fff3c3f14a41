"""spherestep.synthesis (issue 29 §1–3): the spec's validation errors, the ladder's rungs, a quick search end to end
on a real Dask cluster (threads on loopback), and every finalist re-measured independently of the search — its
design file loaded fresh, another seed, more orientations — meeting its spec."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.synthesis import (BUDGETS, Candidate, SpecError, candidates, iron_is_stored, load_spec, parse_spec,
                                  range_orientations, synthesize, verify)

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "specs"
GOOD = "spec_version: 1\nenvelope: {ball_diameter: [40 mm, 60 mm]}\n"


# --- §1 the specification ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["camera-gimbal", "robot-wrist", "paper-task", "prototype-relays-iron"])
def test_examples_load(name):
    spec = load_spec(EXAMPLES / f"{name}.yaml")
    assert spec.spec_version == 1 and spec.name
    assert json.loads(json.dumps(spec.to_dict()))  # JSON-ready


def test_units_convert_once():
    spec = load_spec(EXAMPLES / "camera-gimbal.yaml")
    assert spec.envelope.ball_diameter == [0.040, 0.060]
    assert spec.torque.every_direction == pytest.approx(5e-3, rel=1e-12)
    assert spec.speed.turn == pytest.approx(math.pi / 2, rel=1e-12)
    assert spec.speed.within == 0.5
    assert spec.precision.servo_hold == pytest.approx(math.radians(0.1), rel=1e-12)
    assert spec.range.cone == pytest.approx(math.radians(45), rel=1e-12)
    assert spec.supply.voltage == 12.0 and spec.supply.power == 20.0
    assert parse_spec(GOOD + "torque: {every_direction: 250 mN m}").torque.every_direction == pytest.approx(0.25)
    assert parse_spec("spec_version: 1\nenvelope: {ball_diameter: [1 in, 2 in], mass_limit: 300 g}").envelope \
        .mass_limit == pytest.approx(0.3)


@pytest.mark.parametrize("text, field, words", [
    (GOOD + "torque: {every_direction: 1 kg}", "torque.every_direction", "must be a torque with unit one of N m"),
    ("spec_version: 1\nenvelope: {ball_diameter: [10 in]}", "envelope.ball_diameter", "at least 2 items"),
    ("spec_version: 1\nenvelope: {ball_diameter: [12 in, 10 in]}", "envelope", "[smallest, largest]"),
    ("spec_version: 1\nenvelope: {ball_diameter: [10, 12]}", "envelope.ball_diameter[0]", "with its unit"),
    (GOOD + "range: {cone: 40 deg, axs: [0, 0, 1]}", "range.axs", "known here: cone, axis"),
    (GOOD + "range: sphere", "range", "'all' or a mapping"),
    (GOOD + "core: copper", "core", "'air', 'iron' or 'either'"),
    (GOOD + "drive: stepper", "drive", "'servo', 'relays' or 'both'"),
    (GOOD + "torque: {step: 1 N m}", "torque.step", "unless drive is relays or both"),
    (GOOD + "drive: relays\nprecision: {servo_hold: 0.1 deg}", "precision.servo_hold", "unless drive is servo"),
    (GOOD + "prefer: change", "baseline", "with prefer: change"),
    (GOOD + "speed: {turn: 90 deg, within: -1 s}", "speed.within", "finite positive time"),
    (GOOD + "speed: {turn: 90 deg}", "speed.within", "is missing"),
    (GOOD + "max_coils: 1", "max_coils", "greater than or equal to 2"),
    (GOOD + "torque: {every_direction: 1 N m, over_fraction: 1.5}", "torque.over_fraction", "less than or equal"),
    (GOOD + "sensing: {hall_parts: 2}", "sensing.hall_parts", "greater than or equal to 3"),
    (GOOD + "colis: 3", "colis", "not a known key"),
    ("spec_version: 2\nenvelope: {ball_diameter: [10 in, 12 in]}", "spec_version", "must be 1"),
    ("envelope: {ball_diameter: [10 in, 12 in]}", "spec_version", "is missing"),
])
def test_spec_errors_name_the_field(text, field, words):
    with pytest.raises(SpecError) as info:
        parse_spec(text, source="s.yaml")
    assert info.value.field == field
    message = str(info.value)
    assert message.startswith(f"s.yaml: {field} ") and words in message
    assert "\n" not in message


@pytest.mark.parametrize("text, words", [("", "is empty"), ("x: [", "YAML syntax error"), ("- 1\n- 2", "mapping")])
def test_spec_errors_without_a_field(text, words):
    with pytest.raises(SpecError) as info:
        parse_spec(text, source="s.yaml")
    assert info.value.field is None and words in str(info.value)


def test_spec_file_errors(tmp_path):
    with pytest.raises(SpecError, match="does not exist"):
        load_spec(tmp_path / "missing.yaml")
    (tmp_path / "s.toml").write_text('spec_version = 1\n[envelope]\nball_diameter = ["40 mm", "60 mm"]\n')
    assert load_spec(tmp_path / "s.toml").envelope.ball_diameter == [0.04, 0.06]


# --- §2 the ladder -----------------------------------------------------------------------------------------------

def test_range_orientations_stay_in_the_cone():
    spec = load_spec(EXAMPLES / "camera-gimbal.yaml")
    R = range_orientations(spec, 2000, 3)
    a = np.array([0.0, 0.0, 1.0])
    tilt = np.degrees(np.arccos(np.clip((R @ a) @ a, -1, 1)))
    assert tilt.max() <= 45.0 + 1e-9
    # R a is uniform on the cap: the share within half the cap's area is one half (binomial σ ≈ 1.1 %)
    half = math.degrees(math.acos(1 - 0.5 * (1 - math.cos(math.radians(45)))))
    assert abs(np.mean(tilt <= half) - 0.5) < 0.04
    assert np.allclose(R @ np.swapaxes(R, -1, -2), np.eye(3), atol=1e-12)
    assert so3.random(1, np.random.default_rng(0)).shape == (1, 3, 3)


def test_candidates_cover_the_baseline_neighbourhood():
    from spherestep.synthesis.ladder import GRADES, WINDINGS
    from spherestep.synthesis.run import GAP_SCALES, neighbours

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    quick, normal = BUDGETS["quick"], BUDGETS["normal"]
    proto = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, 12 * 0.0254,
                      samples=quick.samples, capability_samples=quick.capability_samples)
    found = candidates(spec, quick)
    assert proto in found and len(found) == 5  # the quick grid's four layouts and the baseline alone
    found = candidates(spec, normal)
    assert len(set(found)) == len(found)
    near = neighbours(proto)
    assert proto not in near and len(near) == (8 - 1 + 3 - 1 + 3 - 1 + 16 - 1 + 16 - 1 + len(GAP_SCALES)
                                               + len(GRADES) - 1 + len(WINDINGS))
    for c in near:  # exactly one choice differs
        diff = [k for k in ("rotor", "rotor_level", "stator", "stator_level", "cap_deg", "gap_scale", "remanence",
                            "wound_for") if getattr(c, k) != getattr(proto, k)]
        assert len(diff) == 1, diff
    scaled = {(c.rotor, c.rotor_level, c.stator, c.stator_level, c.cap_deg, c.gap_scale) for c in found}
    assert ("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 80.0, 1.0) in scaled
    assert ("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, 4.0) in scaled
    parts = {(c.remanence, c.wound_for) for c in found if (c.rotor, c.rotor_level, c.stator, c.stator_level,
                                                             c.cap_deg, c.gap_scale) == scaled_key(proto)}
    assert parts == {(g, 0) for g in GRADES} | {(g, n) for g in GRADES for n in WINDINGS}  # every combination


def scaled_key(c):
    return c.rotor, c.rotor_level, c.stator, c.stator_level, c.cap_deg, c.gap_scale


def test_parts_rewind_and_grade_the_prototype():
    """A candidate's parts: the grade sets the magnets' remanence; a rewound coil draws the supply's share
    ``P / (V n)`` with ``n`` coils on (the thickest wire that does, so more ampere-turns) and the iron model
    reads the stored tables at once; the change from the baseline counts each part once plus a tenth of its log
    ratio."""
    from dataclasses import asdict, replace

    from spherestep.motor.coil import iron_coil
    from spherestep.synthesis.ladder import N42, baseline_layout, build, change_from

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    base = baseline_layout(spec)
    c = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, 12 * 0.0254)
    built = build(c, "iron", spec)
    assert built.remanence == N42 and built.coil.wire_diameter == iron_coil().wire_diameter
    rewound = build(replace(c, remanence=0.25, wound_for=3), "iron", spec)
    el, el0 = rewound.coil_electrics(), built.coil_electrics()
    assert rewound.remanence == 0.25 and rewound.coil.coils_on == 3
    assert 0.99 * 100 / 72 < el.nominal_current <= 100 / 72 and el.ampere_turns > 2 * el0.ampere_turns
    assert iron_is_stored(rewound)
    assert change_from(c, "iron", base) == 0.0
    assert change_from(replace(c, wound_for=4), "iron", base) == 1.0
    assert 2.19 < change_from(replace(c, remanence=0.25, wound_for=3), "iron", base) < 2.2
    assert c.key(spec.digest, "iron") == Candidate(**json.loads(json.dumps(asdict(c)))).key(spec.digest, "iron")
    assert replace(c, remanence=0.25).key(spec.digest, "iron") != c.key(spec.digest, "iron")


def test_iron_affordability_is_the_stored_tables(proto):
    """Iron is affordable where stored tables serve it at once (the prototype's shape, scaled by the law, at any
    ampere-turns; the shape table's magnets) and costly where the moment method must solve (another gap)."""
    from dataclasses import replace

    from spherestep.synthesis.ladder import build

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    c = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 80.0, 12 * 0.0254)
    design = build(c, "iron", spec)
    assert iron_is_stored(design) and iron_is_stored(proto)
    assert not iron_is_stored(replace(design, air_gap=2 * design.air_gap))
    assert iron_is_stored(replace(design, coil=replace(design.coil, supply_voltage=12.0)))  # NI: the law's factor
    assert iron_is_stored(replace(design, magnet_diameter=0.9 * design.magnet_diameter))  # in the shape table
    assert not iron_is_stored(replace(design, magnet_diameter=0.5 * design.magnet_diameter))  # below it


def test_tasks_are_submitted_longest_first_by_their_cost_estimate():
    from spherestep.synthesis.run import SOLVE_COST, Ladder, cost_estimate

    relays, gimbal = load_spec(EXAMPLES / "prototype-relays-iron.yaml"), load_spec(EXAMPLES / "camera-gimbal.yaml")
    ball = 12 * 0.0254
    big = Candidate("truncated-icosidodecahedron", 1, "truncated-cuboctahedron", 1, 80.0, ball)  # 182 poles
    proto = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, ball)  # 92 poles
    small = Candidate("truncated-icosahedron", 0, "truncated-cuboctahedron", 1, 60.0, ball)
    assert cost_estimate(big, relays) > cost_estimate(proto, relays) > cost_estimate(small, relays) > 0
    assert cost_estimate(big, relays) / cost_estimate(proto, relays) == pytest.approx((182 / 92) ** 2)
    assert cost_estimate(proto, relays) == 2 * cost_estimate(proto, gimbal)  # the relay rung
    wide = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, ball, gap_scale=4.0)
    normal = Ladder(relays, False, None, True)  # the normal budget: the baseline's wider gaps solve their iron
    assert normal.may_solve(wide) and not normal.may_solve(proto)
    assert cost_estimate(wide, relays, normal.may_solve(wide)) > SOLVE_COST > cost_estimate(big, relays, True)
    assert cost_estimate(wide, gimbal, True) < SOLVE_COST  # air cores solve nothing


@pytest.mark.slow
def test_the_relay_rung_reuses_the_states_and_gives_the_same_row():
    """The task climbs the cheap rungs and the relay rung on the same design (its states found once): the rows are
    those of the rungs run apart, the relay rung building the design again."""
    from spherestep.synthesis.ladder import climb, evaluate
    from spherestep.synthesis.ladder import relay_rung
    from spherestep.synthesis.run import Ladder

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    c = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 60.0, 12 * 0.0254, samples=400,
                  capability_samples=32)
    rows, designs = climb(c, spec)
    assert set(designs) == {"iron"} and rows[0]["states"] == len(designs["iron"].states())
    together = Ladder(spec, False, None)(c)
    apart = evaluate(c, spec)
    for row in apart:
        if row["status"] == "ok":
            relay_rung(c, row, spec)
    drop = {"seconds", "worker"}
    assert [{k: v for k, v in r.items() if k not in drop} for r in together] == \
        [{k: v for k, v in r.items() if k not in drop} for r in apart]
    assert together[0]["stage"] == "relays" and together[0]["relay_steps"] > 0


@pytest.mark.slow
def test_ferrite_and_a_rewound_coil_make_the_prototype_step_on_iron():
    """Issue 29 §3, with issue 39's iron-aware planner and many-turn verdict: the prototype on iron lands its
    settled relay plan (every step within 0.5°) with two parts changed — 0.2 T ferrite magnets and the coils rewound
    for the supply's share with 4 on — and executes at least 95 % of 20 random turns too; the relay rung keeps the
    worst landing error, the plan's peak power and the fraction of turns executed (2-3 min: 21 plans simulated)."""
    from dataclasses import replace

    from spherestep.synthesis.ladder import baseline_layout
    from spherestep.synthesis.run import Ladder

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    proto = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, 12 * 0.0254, samples=400,
                      capability_samples=32)
    row = Ladder(spec, False, baseline_layout(spec))(replace(proto, remanence=0.2, wound_for=4))[0]
    assert row["status"] == "ok" and row["stage"] == "relays" and row["relay_executed"], row["reason"]
    assert row["relay_steps_on_plan"] == row["relay_steps"] >= 7
    assert row["relay_worst_deg"] < 0.5 and row["relay_peak_W"] <= 100.0 and row["relay_turns_fraction"] >= 0.95
    assert 2.1 < row["change"] < 2.2 and 1500 < row["ampere_turns"] < 1600
    assert row["motor"].endswith("i-0.2T-w4")  # the same layout with other parts is another motor on the front


# --- §2–3 a quick search end to end, and every finalist re-measured --------------------------------------------

@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("synth") / "gimbal"
    result = synthesize(EXAMPLES / "camera-gimbal.yaml", out, budget="quick", threads=True, workers=2, seed=0)
    return result, out


def test_quick_search_end_to_end(quick):
    """(Its time is benchmarks/bench_synthesis.py's to measure, not a test's: measured 271 s at load 14 here.)"""
    result, out = quick
    spec = result.spec
    assert len(result.table) == len(candidates(spec, BUDGETS["quick"])) * len(spec.cores)
    assert set(result.table["status"]) <= {"ok", "pruned", "costly", "failed"}
    assert len(result.finalists) >= 1 and result.winner is not None
    assert result.winner.verification.met
    assert "binding requirement" in result.statement
    for name in ("candidates.csv", "pareto.csv", "pareto.png", "synthesis.json", "report.html"):
        assert (out / name).is_file() and (out / name).stat().st_size > 0
    summary = json.loads((out / "synthesis.json").read_text())
    assert summary["winner"] == result.winner.row["key"]
    page = (out / "report.html").read_text()
    assert "required / achieved" in page and "Beside the gallery" in page and "jhu-as-built" in page
    # the front: no feasible row dominates a front row
    from spherestep.synthesis.front import objectives

    cols = objectives(spec)
    ok = result.table[result.table["status"] == "ok"]
    for _, f in result.front.iterrows():
        for _, r in ok.iterrows():
            better = [(r[c] > f[c]) if mx else (r[c] < f[c]) for c, mx in cols]
            worse = [(r[c] < f[c]) if mx else (r[c] > f[c]) for c, mx in cols]
            assert not (any(better) and not any(worse))


def test_quick_search_resumes_and_is_deterministic(quick):
    result, out = quick
    with pytest.raises(InputError, match="--resume"):
        synthesize(EXAMPLES / "camera-gimbal.yaml", out, budget="quick", threads=True, workers=1)
    again = synthesize(EXAMPLES / "camera-gimbal.yaml", out, budget="quick", threads=True, workers=1, resume=True)
    assert again.statement == result.statement
    cols = ["key", "status", "coils", "states", "resolution_median_deg", "torque_quantile_Nm"]
    assert again.table.sort_values("key")[cols].reset_index(drop=True).equals(
        result.table.sort_values("key")[cols].reset_index(drop=True))


def test_every_finalist_remeasured_independently(quick):
    """Each finalist's design file loaded fresh and verified with another seed and more orientations: the verdict
    of the search holds (a finalist the search found missing a requirement may still miss it), and the winner
    meets every requirement of its spec. The capability, measured again three ways, is held to stated bounds: the
    torque in every direction over 90 % of the spec's range within 10 % of the search's (150 orientations, another
    seed; measured 1.8 % and 5.9 %) and at least 0.9 × the spec's 5 mN·m (the winner: all of it); the capability
    room's own median over all of SO(3) within 15 % of the median over the spec's range (measured 5.4-5.5 %)."""
    from spherestep.control import torque_capability
    from spherestep.motor import MotorDesign

    result, _ = quick
    need = result.spec.torque.every_direction
    for f in result.finalists:
        text = Path(f.path).read_text(encoding="utf-8")
        again = verify(text, result.spec, seed=11, samples=2000, capability_samples=150, holds=2)
        design = MotorDesign.load(f.path)
        assert len(design.stator) == f.row["coils"] and len(design.rotor) == f.row["rotor_poles"]
        if f is result.winner:
            assert again.met, [c for c in again.checks if not c.met]
        cap = torque_capability(design, samples=100, seed=5)  # the capability room's own path, all of SO(3)
        searched, quantile = f.verification.numbers["torque_quantile_Nm"], again.numbers["torque_quantile_Nm"]
        assert quantile == pytest.approx(searched, rel=0.10)
        assert quantile >= (1.0 if f is result.winner else 0.9) * need
        assert cap.percentiles(q=(50,))[50] == pytest.approx(again.numbers["torque_median_Nm"], rel=0.15)
        search = {c.name: c for c in f.verification.checks}
        for c in again.checks:
            assert c.name in search
        turn = [c for c in again.checks if c.name.startswith("servo turn")]
        assert turn and float(turn[0].achieved.split()[0]) == pytest.approx(
            float(search[turn[0].name].achieved.split()[0]), rel=1e-6)  # the turn itself is deterministic


def test_cli_refuses_a_bad_spec(tmp_path):
    from spherestep.cli import main

    bad = tmp_path / "bad.yaml"
    bad.write_text(GOOD + "core: copper\n")
    assert main(["synthesize", str(bad), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()


def test_the_eta_estimates_a_task_as_the_order_does():
    """The ETA's estimate of a ladder task (seconds of one worker) is the submission order's cost model in seconds:
    ∝ (M N)², twice with a relay rung, plus the relay rung's many-turn check, and a table solve's minutes for a
    task that may solve iron (tests/test_synthesis_eta.py tests the ETA itself)."""
    from spherestep.synthesis.eta import ALIGNMENT_SECONDS, SOLVE_SECONDS, relay_rung_seconds
    from spherestep.synthesis.run import cost_estimate, pairs, task_seconds

    relays, gimbal = load_spec(EXAMPLES / "prototype-relays-iron.yaml"), load_spec(EXAMPLES / "camera-gimbal.yaml")
    ball = 12 * 0.0254
    proto = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, ball)
    assert pairs(proto) == 92 * 33  # the stator's caps within 80° (the built design fits 29 coils on them)
    for spec, turns in ((relays, relay_rung_seconds(True)), (gimbal, 0.0)):
        assert task_seconds(proto, spec) == pytest.approx(ALIGNMENT_SECONDS * cost_estimate(proto, spec) + turns)
    assert task_seconds(proto, gimbal) == pytest.approx(ALIGNMENT_SECONDS * (92 * 33) ** 2)  # ~5.5 s
    wide = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, ball, gap_scale=4.0)
    assert task_seconds(wide, relays, True) == pytest.approx(task_seconds(wide, relays) + SOLVE_SECONDS)
    assert task_seconds(wide, gimbal, True) == task_seconds(wide, gimbal)  # air cores solve nothing


def test_a_task_that_fails_on_the_cluster_is_a_row_not_lost(tmp_path):
    """A task whose workers died (Dask's KilledWorker: on one machine, a task over the worker's memory limit; the
    272-pole rotor over 29 coils needed more than 11 GiB) is stored as a failed row that says so, one per core."""
    from types import SimpleNamespace

    from distributed.scheduler import KilledWorker

    from spherestep.synthesis.run import _store, failed_rows

    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    c = Candidate("truncated-icosahedron", 2, "truncated-cuboctahedron", 1, 80.0, 12 * 0.0254)
    rows = failed_rows(c, spec, None, KilledWorker("ladder-1", SimpleNamespace(address="tcp://127.0.0.1:1"), 3))
    assert [r["core"] for r in rows] == list(spec.cores)
    assert all(r["status"] == "failed" and r["stage"] == "cluster" and "memory" in r["reason"] for r in rows)
    store = _store(tmp_path)
    store.append(rows)
    table = store.read()
    assert list(table["key"]) == [c.key(spec.digest, core) for core in spec.cores]
    assert (table["status"] == "failed").all()
