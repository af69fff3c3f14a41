"""The critical-path bound and list schedules of a search's tasks (:mod:`spherestep.synthesis.schedule`), on
synthetic task trees with known answers."""

import json
import random

import pytest

from spherestep.synthesis import schedule


def _records(seed: int, layouts: int = 40, cores=("air", "iron")):
    rng = random.Random(seed)
    out = []
    for n in range(layouts):
        out.append(dict(params=str(n), kind="shared", core=None, seconds=rng.uniform(0.0, 10.0)))
        for core in cores:
            out.append(dict(params=str(n), kind="capability", core=core, seconds=rng.uniform(0.0, 5.0)))
            out.append(dict(params=str(n), kind="relays", core=core, seconds=rng.expovariate(1 / 8)))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_list_schedule_limits_and_the_bound(seed):
    records = _records(seed)
    per = schedule.layouts(records)
    total = sum(r["seconds"] for r in records)
    longest = max(v["path"] for v in per.values())
    assert sum(v["total"] for v in per.values()) == pytest.approx(total)
    assert schedule.list_schedule(records, 1) == pytest.approx(total)  # one worker: one after another
    assert schedule.list_schedule(records, 10_000) == pytest.approx(longest)  # unbounded: the critical path
    for workers in (2, 4, 16):
        makespan = schedule.list_schedule(records, workers)
        assert makespan >= max(total / workers, longest) - 1e-9  # nothing beats the bound
        # Graham: a greedy list schedule is within Σt/n + the critical path
        assert makespan <= total / workers + longest + 1e-9
        assert schedule.speedup(records, workers) <= schedule.bound(records, workers) + 1e-9


def test_a_dependent_waits_for_its_shared_rungs():
    records = [dict(params="a", kind="shared", core=None, seconds=3.0),
               dict(params="a", kind="relays", core="iron", seconds=2.0),
               dict(params="b", kind="shared", core=None, seconds=1.0),
               dict(params="b", kind="relays", core="iron", seconds=1.0)]
    # two workers: a's shared 0-3 then its relay rung 3-5; b's 0-1, 1-2
    assert schedule.list_schedule(records, 2) == pytest.approx(5.0)
    assert schedule.layouts(records)["a"] == {"shared": 3.0, "parts": [2.0], "path": 5.0, "total": 5.0}
    assert schedule.bound(records, 2) == pytest.approx(7.0 / 5.0)


def test_read_tasks_skips_a_cut_last_line_and_keeps_a_resumed_layouts_last(tmp_path):
    lines = [dict(params="a", kind="shared", core=None, seconds=1.0),
             dict(params="a", kind="shared", core=None, seconds=2.0)]
    path = tmp_path / "tasks.jsonl"
    path.write_text("".join(json.dumps(x) + "\n" for x in lines) + '{"params": "b", "ki')
    assert schedule.read_tasks(path) == [lines[1]]
    path.write_text('{"params": "b", "ki\n' + json.dumps(lines[0]) + "\n")
    with pytest.raises(json.JSONDecodeError):
        schedule.read_tasks(path)


def test_corrected_recomputes_the_shared_seconds_from_the_stored_rows():
    """A row's seconds are its shared rungs', its capability task's and (merged, stage "relays") its relay
    task's: the logged shared seconds of runs before ccd4415 carried the relay task's too, and are recomputed."""
    import pandas as pd

    records = [dict(params="a", kind="shared", core=None, seconds=2.0 + 5.0),  # logged with the relay rung's 5 s
               dict(params="a", kind="capability", core="iron", seconds=1.0),
               dict(params="a", kind="relays", core="iron", seconds=5.0),
               dict(params="b", kind="shared", core=None, seconds=3.0),
               dict(params="b", kind="capability", core="iron", seconds=0.5),
               dict(params="b", kind="relays", core="iron", seconds=4.0)]
    table = pd.DataFrame([dict(params="a", core="iron", stage="relays", seconds=8.0),  # 2 + 1 + 5
                          dict(params="b", core="iron", stage="capability", seconds=3.5)])  # pruned: 3 + 0.5
    fixed = schedule.corrected(records, table)
    assert [r["seconds"] for r in fixed if r["kind"] == "shared"] == [2.0, 3.0]
    assert [r for r in fixed if r["kind"] != "shared"] == [r for r in records if r["kind"] != "shared"]
