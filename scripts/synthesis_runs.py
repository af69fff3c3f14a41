"""Store a finished `spherestep synthesize` run compactly in data/synthesis_normal_runs.json (issue 40 §6, issue 39 §3).

Run: ``python scripts/synthesis_runs.py NAME SPEC --folder DIR [--commit SHA]``, where ``DIR/NAME`` is the search's
``--out`` folder and beside it ``NAME.time`` (``/usr/bin/time -v`` of the command), ``NAME.load`` (lines ``epoch
load1 load5 load15``, sampled during the run), ``NAME.log`` (its console) and ``NAME.info`` (``start … commit …``);
a search interrupted and resumed with ``--resume`` has its earlier segments' files as ``NAME-partK.*`` (their wall
and CPU times are summed; the ladder's wall is theirs plus the last segment's until its finalists stage began).

Kept: every ladder task's layout, kind, core and seconds (from ``DIR/NAME/tasks.jsonl``, the shared rungs' as
:func:`~spherestep.synthesis.schedule.corrected`, rounded to 0.1 ms; their sum is ``sum_seconds``), each stored row's layout, core, stage and
seconds (its chain, as the search records it), the wall and CPU times, the load, the outcome counts, the relay rung's numbers (rows that
reached it, landed the spec's turn, passed the many-turn verdict) and the winner's or closest row; derived with
:mod:`spherestep.synthesis.schedule`: the 16-worker bound, list schedules and the 2-worker efficiency (the tasks'
summed seconds over twice the ladder's wall time), and the bound without the layouts that solved an iron table
(``solving_layouts``: a one-off per part size, cached on disk, so a search on a warm cache has them as ordinary
tasks). Not kept: the Dask logs and the whole results table.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import statistics
from dataclasses import fields
from pathlib import Path

import pandas as pd

from spherestep.synthesis import BUDGETS, Candidate, Ladder, load_spec, schedule
from spherestep.synthesis.run import STORE, TASKS, _solves, cost_estimate

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "data" / "synthesis_normal_runs.json"
FIELDS = [f.name for f in fields(Candidate)]
ROW = ["key", "core", "stage", "status", "reason", "states", "resolution_median_deg", "reaches_all",
       "torque_quantile_Nm", "step_torque_Nm", "relay_steps", "relay_steps_on_plan", "relay_worst_deg",
       "relay_peak_W", "relay_turns_fraction", "change", "params"]


def _time(path: Path) -> dict:
    text = path.read_text()

    def grab(label):
        return re.search(rf"{re.escape(label)}: (.+)", text).group(1).strip()

    h, m, s = ([0] + [float(v) for v in grab("Elapsed (wall clock) time (h:mm:ss or m:ss)").split(":")])[-3:]
    return {"wall_s": round(3600 * h + 60 * m + s, 2), "user_s": float(grab("User time (seconds)")),
            "system_s": float(grab("System time (seconds)")), "exit": int(grab("Exit status"))}


def _stages(log: Path) -> dict:
    """The elapsed seconds at which each stage's first progress line appeared (``stage 2 of 4, finalists: …
    (2756 s)``)."""
    out = {}
    for line in log.read_text().splitlines():
        m = re.match(r"spherestep: stage \d+ of \d+, ([a-z ]+):.*\((\d+) s\)$", line)
        if m and m.group(1) not in out:
            out[m.group(1)] = int(m.group(2))
    return out


def _clean(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if hasattr(value, "item"):
        return _clean(value.item())
    return value


def store_run(name: str, spec_path: str, folder: Path, commit: str | None, budget: str = "normal") -> dict:
    out = folder / name
    table = pd.read_parquet(out / STORE).drop_duplicates("key", keep="last")
    records = schedule.corrected(schedule.read_tasks(out / TASKS), table)
    layouts = list(dict.fromkeys(r["params"] for r in records))
    index = {p: n for n, p in enumerate(layouts)}
    tasks = [[index[r["params"]], r["kind"], r["core"], round(float(r["seconds"]), 4)] for r in records]
    rounded = [dict(params=r["params"], kind=r["kind"], core=r["core"], seconds=t[3]) for r, t in zip(records, tasks)]
    spec = load_spec(spec_path)
    plan = BUDGETS[budget]
    ladder = Ladder(spec, plan.allow_costly, None, plan.costly_neighbourhood)
    cands = [Candidate(**json.loads(p)) for p in layouts]
    order = [p for _, p in sorted(zip((-cost_estimate(c, spec, ladder.may_solve(c)) for c in cands), layouts))]
    answer = out / "synthesis.json"  # absent when the search was stopped before its answer
    result = json.loads(answer.read_text()) if answer.exists() else {"winner": None, "finalists": [], "statement":
                                                                     "stopped during the ladder: no answer"}
    counts = {f"{stage}:{status}": int(n) for (stage, status), n in table.groupby(["stage", "status"]).size().items()}
    relay = table[table["relay_steps"].notna()]
    turns = relay[relay["relay_turns_fraction"].notna()]
    winner = result["winner"]
    named = winner or (result["finalists"][0]["key"] if result["finalists"] else None)  # else the closest finalist
    shown = table[table["key"] == named] if named else table.iloc[0:0]
    if not len(shown):  # stopped before its finalists: the row whose settled plan landed most of its steps
        steps = table["relay_steps_on_plan"].fillna(-1) / table["relay_steps"].fillna(1).clip(lower=1)
        shown = table.loc[[steps.idxmax()]]
    segments = [f.name[:-len(".info")] for f in sorted(folder.glob(f"{name}-part*.info"))] + [name]
    times = [_time(folder / f"{seg}.time") for seg in segments]
    infos = [(folder / f"{seg}.info").read_text() for seg in segments]
    stages = _stages(folder / f"{name}.log")
    last = stages.get("finalists", stages.get("verification"))
    ladder_wall = sum(t["wall_s"] for t in times) if last is None else sum(t["wall_s"] for t in times[:-1]) + last
    loads = [float(line.split()[1]) for seg in segments
             for line in (folder / f"{seg}.load").read_text().splitlines() if line.strip()]
    total = sum(t[3] for t in tasks)
    kinds = {k: round(sum(t[3] for t in tasks if t[1] == k), 4) for k in schedule.KINDS}
    per = schedule.layouts(rounded)
    solving = [n for n, c in enumerate(cands) if _solves(c, spec, ladder.may_solve(c))]
    warm = [r for r in rounded if index[r["params"]] not in solving]
    return {
        "spec": spec_path, "budget": budget, "workers": 2,
        "segments": [{"commit": commit or re.search(r"commit (\S+)", info).group(1),
                      "started": re.search(r"start (\S+)", info).group(1),
                      "ended": re.search(r"end (\S+)", info).group(1), **t} for info, t in zip(infos, times)],
        **{k: round(sum(t[k] for t in times), 2) for k in ("wall_s", "user_s", "system_s")},
        "load": {"samples": len(loads), "min": min(loads), "median": statistics.median(loads), "max": max(loads)},
        "stages_s": stages, "ladder_wall_s": ladder_wall,
        "finished": answer.exists(), "candidates": int(len(table)), "counts": counts, "statement": result["statement"],
        "winner": winner, "finalists": len(result["finalists"]),
        "relay_rung": {"reached": int(len(relay)), "spec_turn_executed": int(relay["relay_executed"].fillna(False).sum()),
                       "many_turns_checked": int(len(turns)),
                       "many_turns_passed": int((turns["relay_turns_fraction"] >= 0.95).sum()),
                       "many_turns_fractions": sorted(round(float(v), 4) for v in turns["relay_turns_fraction"]),
                       "passed": int(((table["stage"] == "relays") & (table["status"] == "ok")).sum())},
        "row": {k: _clean(shown.iloc[0][k]) for k in ROW if k in shown.columns},
        "sum_seconds": round(total, 4), "kind_seconds": kinds,
        "longest_task_s": max(t[3] for t in tasks), "longest_path_s": round(max(v["path"] for v in per.values()), 4),
        "bound_16": round(schedule.bound(rounded, 16), 3),
        "list_16_longest_first": round(schedule.speedup(rounded, 16), 3),
        "list_16_search_order": round(schedule.speedup(rounded, 16, order), 3),
        "solving_layouts": solving, "bound_16_without_solving": round(schedule.bound(warm, 16), 3),
        "longest_path_without_solving_s": round(max(v["path"] for v in schedule.layouts(warm).values()), 4),
        "efficiency_2": round(total / (2 * ladder_wall), 3),
        "fields": FIELDS, "layouts": [[json.loads(p)[f] for f in FIELDS] for p in layouts],
        "order": [index[p] for p in order], "tasks": tasks,
        "rows": [[index[r.params], r.core, r.stage, round(float(r.seconds), 4)] for r in table.itertuples()
                 if r.params in index],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name")
    parser.add_argument("spec")
    parser.add_argument("--folder", required=True, type=Path)
    parser.add_argument("--commit")
    parser.add_argument("--data", type=Path, default=OUT, help="the JSON file the run is stored in")
    args = parser.parse_args()
    runs = json.loads(args.data.read_text()) if args.data.exists() else {}
    runs[args.name] = store_run(args.name, args.spec, args.folder, args.commit)
    text = json.dumps(runs, indent=None, separators=(",", ":"))
    args.data.write_text(text.replace('],[', '],\n[').replace('},"', '},\n"') + "\n")
    r = runs[args.name]
    print(f"{args.name}: {len(r['layouts'])} layouts, {len(r['tasks'])} tasks, Σt {r['sum_seconds']:.1f} s, "
          f"longest path {r['longest_path_s']:.1f} s, bound on 16 {r['bound_16']:.2f}x, list schedule "
          f"{r['list_16_longest_first']:.2f}x (search order {r['list_16_search_order']:.2f}x), 2-worker efficiency "
          f"{r['efficiency_2']}, wall {r['wall_s']:.0f} s, load {r['load']['min']:.1f}-{r['load']['max']:.1f}")


if __name__ == "__main__":
    main()
