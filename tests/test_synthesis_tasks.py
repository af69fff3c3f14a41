"""The ladder cut into tasks (issue 40 §6, :mod:`spherestep.synthesis.tasks`): the shared rungs, then per core the
capability and the relay rung side by side, give exactly the rows of the whole ladder in one task."""

import json
from dataclasses import asdict
from pathlib import Path

import pytest

from spherestep.synthesis import Candidate, load_spec
from spherestep.synthesis import tasks
from spherestep.synthesis.run import Ladder

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "specs"
DROP = {"seconds", "worker"}


def _split(runner, c):
    """The tasks of ``c`` run in this process, in the order the cluster may run them (dependents after the
    shared rungs, the relay rung before the capability rung)."""
    part = tasks.shared_rungs(runner, c)
    cores = runner.spec.cores
    relays = [tasks.relay_part(part, runner, c, core) for core in cores] if runner.spec.relays else []
    return tasks.merge(runner.spec, [tasks.core_rung(part, runner, c, core) for core in cores] + relays)


def _plain(rows):
    return [{k: v for k, v in r.items() if k not in DROP} for r in rows]


@pytest.mark.slow
@pytest.mark.parametrize("spec_name, c", [
    ("prototype-relays-iron.yaml", Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 60.0,
                                             12 * 0.0254, samples=400, capability_samples=32)),
    ("paper-task.yaml", Candidate("truncated-icosahedron", 0, "truncated-cuboctahedron", 0, 80.0, 0.3,
                                  samples=200, capability_samples=16)),
    ("camera-gimbal.yaml", Candidate("icosidodecahedron", 0, "truncated-octahedron", 0, 60.0, 0.060, samples=100,
                                     capability_samples=8)),
])
def test_the_split_gives_the_rows_of_one_task(spec_name, c):
    spec = load_spec(EXAMPLES / spec_name)
    runner = Ladder(spec, False, None)
    together = runner(c)
    rows, total = _split(runner, c)
    assert _plain(rows) == _plain(together)
    assert [r["core"] for r in rows] == list(spec.cores)
    # each row's seconds is its own chain: the shared rungs and its own rungs, within the layout's summed tasks
    assert all(0 < r["seconds"] <= total + 1e-9 for r in rows)


def test_merge_keeps_the_relay_rung_only_for_rows_the_capability_rung_passes():
    spec = load_spec(EXAMPLES / "paper-task.yaml")  # relays, both cores
    assert spec.relays and list(spec.cores) == ["air", "iron"]
    ok = {"core": "air", "status": "ok", "stage": "capability", "seconds": 3.0}
    pruned = {"core": "iron", "status": "pruned", "stage": "capability", "reason": "step torque", "seconds": 4.0}
    relay = {"stage": "relays", "status": "pruned", "reason": "settled relay plan: 0 of 7", "relay_steps": 7}
    rows, total = tasks.merge(spec, [(dict(ok), 1.0), (dict(pruned), 2.0), (relay, 5.0), (dict(relay), 6.0)])
    assert rows[0] == ok | relay | {"seconds": 8.0}  # the shared 2 s, its capability 1 s, its relay rung 5 s
    assert rows[1] == pruned  # the capability rung's prune stands; its relay rung's work is dropped
    assert total == pytest.approx(2.0 + 1.0 + 2.0 + 5.0 + 6.0)


def test_timings_name_each_task_and_sum_to_the_merged_total():
    spec = load_spec(EXAMPLES / "paper-task.yaml")
    c = Candidate("truncated-icosahedron", 0, "truncated-cuboctahedron", 0, 80.0, 0.3)
    ok = {"core": "air", "status": "ok", "stage": "capability", "seconds": 3.0}
    pruned = {"core": "iron", "status": "pruned", "stage": "capability", "seconds": 4.0}
    results = [(dict(ok), 1.0), (dict(pruned), 2.0), ({}, 5.0), ({}, 6.0)]
    timed = tasks.timings(spec, c, results)
    _, total = tasks.merge(spec, results)
    assert [(t["kind"], t["core"], t["seconds"]) for t in timed] == [
        ("shared", None, 2.0), ("capability", "air", 1.0), ("capability", "iron", 2.0), ("relays", "air", 5.0),
        ("relays", "iron", 6.0)]
    assert sum(t["seconds"] for t in timed) == pytest.approx(total)
    assert {t["params"] for t in timed} == {json.dumps(asdict(c), sort_keys=True)}


def test_merge_leaves_the_results_as_the_tasks_returned_them():
    """The search logs the timings after merging: merging must not add the relay rung's seconds to the row the
    shared rungs' seconds are read from (a one-core relay spec, whose row passes the capability rung)."""
    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    assert spec.relays and list(spec.cores) == ["iron"]
    c = Candidate("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, 0.3048)
    results = [({"core": "iron", "status": "ok", "stage": "capability", "seconds": 3.0}, 1.0),
               ({"stage": "relays", "status": "pruned", "relay_steps": 7}, 5.0)]
    rows, total = tasks.merge(spec, results)
    assert rows[0]["seconds"] == 8.0 and results[0][0]["seconds"] == 3.0 and total == pytest.approx(8.0)
    assert [t["seconds"] for t in tasks.timings(spec, c, results)] == [2.0, 1.0, 5.0]


def test_the_shared_task_solves_an_iron_table_once_for_both_rungs(monkeypatch):
    """A layout whose iron tables are not stored has them solved by its shared task (its capability and relay
    tasks then read them from the disk cache instead of solving them side by side); one whose tables are stored
    does not. The solve is a stand-in here (a real one takes minutes)."""
    import time as clock

    from spherestep import magnetics

    calls = []

    def solve(design, *args, **kwargs):
        calls.append(design)
        clock.sleep(0.05)

    monkeypatch.setattr(magnetics, "design_model", solve)
    spec = load_spec(EXAMPLES / "prototype-relays-iron.yaml")
    runner = Ladder(spec, False, None, True)  # the normal budget's: the baseline's wider gaps may solve
    base = dict(rotor="truncated-icosahedron", rotor_level=0, stator="truncated-cuboctahedron", stator_level=0,
                cap_deg=60.0, sphere_diameter=0.3048, samples=100, capability_samples=8)
    rows, designs = tasks.shared_rungs(runner, Candidate(**base, gap_scale=2.0))
    assert rows[0].get("status") is None and calls == [designs["iron"]]
    assert rows[0]["seconds"] >= 0.05
    tasks.shared_rungs(runner, Candidate(**base))  # the prototype's gap: the stored tables, scaled
    assert len(calls) == 1
