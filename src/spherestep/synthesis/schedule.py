"""What a search's measured task times allow on more workers (issue 40 §6): the critical-path bound and greedy
list schedules of the ladder's tasks (:mod:`.tasks`), from the records a search logs (``OUT/tasks.jsonl``, one per
task: ``params`` naming the layout, ``kind`` ``shared``/``capability``/``relays``, ``core``, ``seconds``).

A layout's tasks form a small tree: its shared rungs, then its per-core tasks side by side. Its **critical path**
is ``shared + max(per-core tasks)``. On ``n`` workers the wall time is at least ``max(Σt / n, max path)``, so the
speed-up over one worker is at most the **bound** ``Σt / max(Σt / n, max path)``. A **list schedule** replays the
tasks on ``n`` workers as a Dask scheduler would: each free worker takes the ready task of highest priority
(a layout's per-core tasks, once its shared rungs are done, before any shared rungs; among the shared rungs the
layout that comes first in the given order), so its speed-up ``Σt / makespan`` is one an order achieves.
"""

from __future__ import annotations

import heapq
import json
import math
from collections import defaultdict
from pathlib import Path

KINDS = ("shared", "capability", "relays")


def read_tasks(path) -> list[dict]:
    """The task records of a search's log ``path`` (JSON lines; a last line cut short by an interrupt is
    skipped, and a layout logged twice — a resumed search — keeps its last records)."""
    records, lines = [], Path(path).read_text(encoding="utf-8").splitlines()
    for n, line in enumerate(lines):
        try:
            records.append(json.loads(line))
        except json.JSONDecodeError:
            if n != len(lines) - 1:
                raise
    last = {}
    for r in records:
        last.setdefault(r["params"], {})[(r["kind"], r["core"])] = r
    return [r for layout in last.values() for r in layout.values()]


def corrected(records: list[dict], table) -> list[dict]:
    """``records`` with each layout's shared-rung seconds recomputed from its stored rows: a row's ``seconds`` is
    the shared rungs', its capability task's and, when the relay rung's result was merged (its ``stage`` is
    ``relays``), its relay task's. (Runs before ccd4415 logged the shared seconds after the merge had added the
    relay rung's to the row they are read from.)"""
    own = {(r["params"], r["kind"], r["core"]): float(r["seconds"]) for r in records}
    shared: dict[str, float] = {}
    for row in table.itertuples():
        if (row.params, "shared", None) not in own:
            continue
        rest = own[(row.params, "capability", row.core)] + (own.get((row.params, "relays", row.core), 0.0)
                                                            if row.stage == "relays" else 0.0)
        shared[row.params] = min(shared.get(row.params, math.inf), float(row.seconds) - rest)
    return [dict(r, seconds=shared.get(r["params"], r["seconds"])) if r["kind"] == "shared" else r for r in records]


def layouts(records: list[dict]) -> dict[str, dict]:
    """Per layout (its ``params``): ``shared`` seconds, ``parts`` the per-core tasks' seconds, ``path`` its
    critical path and ``total`` its summed task seconds."""
    out: dict[str, dict] = defaultdict(lambda: {"shared": 0.0, "parts": []})
    for r in records:
        if r["kind"] not in KINDS:
            raise ValueError(f"task kind {r['kind']!r}, not one of {', '.join(KINDS)}")
        if r["kind"] == "shared":
            out[r["params"]]["shared"] = float(r["seconds"])
        else:
            out[r["params"]]["parts"].append(float(r["seconds"]))
    for layout in out.values():
        layout["path"] = layout["shared"] + max(layout["parts"], default=0.0)
        layout["total"] = layout["shared"] + sum(layout["parts"])
    return dict(out)


def bound(records: list[dict], workers: int = 16) -> float:
    """``Σt / max(Σt / workers, max critical path)``: the most ``workers`` can speed the tasks up."""
    per = layouts(records).values()
    total = sum(v["total"] for v in per)
    return total / max(total / workers, max(v["path"] for v in per))


def list_schedule(records: list[dict], workers: int = 16, order: list[str] | None = None) -> float:
    """The makespan (s) of the tasks on ``workers`` (module docstring), the layouts' shared rungs in ``order``
    (their ``params``; default longest critical path first)."""
    per = layouts(records)
    if order is None:
        order = sorted(per, key=lambda p: (-per[p]["path"], p))
    rank = {p: n for n, p in enumerate(order)}
    ready = [(1, rank[p], 0, per[p]["shared"], p) for p in per]  # (class: 0 per-core, 1 shared; rank; ...)
    heapq.heapify(ready)
    free = [0.0] * workers  # when each worker is next free
    running: list = []  # (finish time, params) of shared rungs whose dependents are not yet released
    clock, end = 0.0, 0.0
    while ready or running:
        if not ready:  # nothing to start until a shared rung finishes
            clock = max(clock, running[0][0])
        while running and running[0][0] <= clock:
            _, p = heapq.heappop(running)
            for k, t in enumerate(per[p]["parts"]):
                heapq.heappush(ready, (0, rank[p], k, t, p))
        if not ready:
            continue
        w = min(range(workers), key=free.__getitem__)
        start = max(free[w], clock)
        if running and running[0][0] < start:  # a shared rung finishes first: its dependents may come first
            clock = running[0][0]
            continue
        kind, _, _, t, p = heapq.heappop(ready)
        free[w] = start + t
        clock, end = start, max(end, start + t)
        if kind == 1:
            heapq.heappush(running, (start + t, p))
    return end


def speedup(records: list[dict], workers: int = 16, order: list[str] | None = None) -> float:
    """``Σt`` over :func:`list_schedule`'s makespan."""
    total = sum(v["total"] for v in layouts(records).values())
    return total / list_schedule(records, workers, order)
