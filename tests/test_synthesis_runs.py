"""The stored `normal` searches (data/synthesis_normal_runs.json, scripts/synthesis_runs.py; issue 40 §6, issue 39
§3): what is stored agrees with itself — the task times sum to the stored Σt, every layout has its shared rungs and
one task per core and rung, the bound and the list schedules are what :mod:`spherestep.synthesis.schedule` gives
on those times, the relay rung's counts agree — and the row the answer names is what the ladder gives again."""

import json
from pathlib import Path

import pytest

from spherestep.synthesis import Candidate, Ladder, load_spec, schedule

ROOT = Path(__file__).resolve().parents[1]
RUNS = json.loads((ROOT / "data" / "synthesis_normal_runs.json").read_text())


def _records(run):
    layouts = [json.dumps(dict(zip(run["fields"], values)), sort_keys=True) for values in run["layouts"]]
    return layouts, [dict(params=layouts[n], kind=kind, core=core, seconds=t) for n, kind, core, t in run["tasks"]]


@pytest.mark.parametrize("name", sorted(RUNS))
def test_the_stored_run_agrees_with_itself(name):
    run = RUNS[name]
    spec = load_spec(ROOT / run["spec"])
    layouts, records = _records(run)
    assert sum(r["seconds"] for r in records) == pytest.approx(run["sum_seconds"], abs=1e-6)
    for kind, seconds in run["kind_seconds"].items():
        assert sum(r["seconds"] for r in records if r["kind"] == kind) == pytest.approx(seconds, abs=1e-6)
    per = schedule.layouts(records)
    parts = len(spec.cores) * (2 if spec.relays else 1)
    assert len(per) == len(layouts) and all(len(v["parts"]) == parts for v in per.values())
    assert sum(r["kind"] == "shared" for r in records) == len(layouts)
    assert max(v["path"] for v in per.values()) == pytest.approx(run["longest_path_s"], abs=1e-3)
    assert schedule.bound(records, 16) == pytest.approx(run["bound_16"], abs=1e-3)
    assert schedule.speedup(records, 16) == pytest.approx(run["list_16_longest_first"], abs=1e-3)
    warm = [r for r in records if layouts.index(r["params"]) not in set(run["solving_layouts"])]
    assert schedule.bound(warm, 16) == pytest.approx(run["bound_16_without_solving"], abs=1e-3)
    order = [layouts[n] for n in run["order"]]
    assert schedule.speedup(records, 16, order) == pytest.approx(run["list_16_search_order"], abs=1e-3)
    # every stored row is a logged layout's (a layout's rows all come from its tasks; a failed one has a row only)
    assert sum(run["counts"].values()) == run["candidates"]
    failed = run["counts"].get("cluster:failed", 0)
    assert len(layouts) * len(spec.cores) + failed == run["candidates"]
    # each stored row's seconds (its chain, from the results store) is its layout's shared task, its capability
    # task and, where the relay rung's result was merged (stage "relays"), its relay task (from the task log)
    own = {(r["params"], r["kind"], r["core"]): r["seconds"] for r in records}
    assert len(run["rows"]) == len(layouts) * len(spec.cores)
    for n, core, stage, seconds in run["rows"]:
        p = layouts[n]
        chain = own[(p, "shared", None)] + own[(p, "capability", core)]
        chain += own.get((p, "relays", core), 0.0) if stage == "relays" else 0.0
        assert seconds == pytest.approx(chain, abs=1e-3)
    relay = run["relay_rung"]
    assert relay["many_turns_checked"] == len(relay["many_turns_fractions"]) <= relay["spec_turn_executed"] \
        <= relay["reached"]
    assert relay["many_turns_passed"] == sum(f >= 0.95 for f in relay["many_turns_fractions"])
    assert relay["passed"] <= relay["many_turns_passed"]
    assert run["efficiency_2"] == pytest.approx(run["sum_seconds"] / (2 * run["ladder_wall_s"]), abs=1e-3)
    assert run["ladder_wall_s"] <= run["wall_s"] and run["load"]["min"] <= run["load"]["median"] <= run["load"]["max"]


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(RUNS))
def test_the_stored_row_is_what_the_ladder_gives_again(name):
    """The row the run's answer names (the winner's, else the closest relay row), climbed again in this process."""
    run = RUNS[name]
    spec = load_spec(ROOT / run["spec"])
    row = run["row"]
    c = Candidate(**json.loads(row["params"]))
    assert c.key(spec.digest, row["core"]) == row["key"]
    again = next(r for r in Ladder(spec, False, None, True)(c) if r["core"] == row["core"])
    for k in ("stage", "status", "states", "reaches_all", "relay_steps", "relay_steps_on_plan"):
        assert again.get(k) == row[k], k
    for k in ("resolution_median_deg", "relay_worst_deg", "relay_turns_fraction"):
        if row.get(k) is not None:
            assert again[k] == pytest.approx(row[k], rel=1e-6, abs=1e-9), k
