"""How the ladder is cut into Dask tasks (issue 40 §6): per layout, one task for the shared rungs and one per core
and rung after them, so a long layout's work spreads over workers.

For a candidate layout ``c``:

* ``shared`` — :func:`shared_rungs`: geometry and the stepper states (rungs 1–2, shared by the cores; the states
  are enumerated once), and an iron table solve if the layout needs one; its result, the rows and the built
  designs, stays on the worker that made it;
* per core still climbing, ``capability`` — :func:`core_rung`: rung 3 on that core's design;
* per core, for relay specs, ``relays`` — :func:`relay_part`: the relay rung (:func:`~.ladder.relay_rung`), run
  beside the capability rung rather than after it (it needs only the design and its states). Its result is kept
  only when the capability rung passes the row, so every row is the one the whole ladder in one task gives; the
  price is a relay rung run for a row the capability rung then prunes (relay specs prune there only on
  ``torque.step``).

The critical path of a layout is ``shared + max(capability, relays)`` over its cores instead of
``shared + Σ cores (capability + relays)``; the dependents are submitted ahead of any shared rung
(:data:`AHEAD`), so a layout's rungs start as soon as its states are known. :func:`merge` assembles the rows; each
row's ``seconds`` is its own chain (the shared rungs, its capability and its relay rung), :func:`merge` also
returns the layout's summed task seconds for the ETA.
"""

from __future__ import annotations

import time

AHEAD = 1e18  # priority added to a layout's per-core tasks: above every shared rung's (run.cost_estimate < 1e16)


def shared_rungs(runner, candidate):
    """Rungs 1–2 of ``candidate`` (:func:`~.ladder.climb` through the states): ``(rows, designs)``, the designs
    of the cores still climbing (their stepper states found). An iron design still climbing whose tables are not
    stored has them solved here, once (cached on disk, :mod:`spherestep.magnetics`), rather than by its capability
    and relay tasks side by side, each the same minutes; the rows' seconds count the solve."""
    from .ladder import climb, iron_is_stored

    start = time.perf_counter()
    rows, designs = climb(candidate, runner.spec, runner.may_solve(candidate), runner.baseline, through="states")
    iron = designs.get("iron")
    if iron is not None and not iron_is_stored(iron):
        from .. import magnetics

        try:
            magnetics.design_model(iron)
        except Exception:  # noqa: BLE001 (the capability rung meets the same error and records it)
            pass
        took = time.perf_counter() - start
        for row in rows:
            row["seconds"] = took
    return rows, designs


def _row_of(part, core: str) -> tuple[dict, object]:
    rows, designs = part
    row = next(r for r in rows if r["core"] == core)
    return dict(row), designs.get(core)


def core_rung(part, runner, candidate, core: str) -> tuple[dict, float]:
    """``core``'s row after the capability rung (unchanged if the shared rungs stopped it) and this task's seconds."""
    from .ladder import capability_rung

    start = time.perf_counter()
    row, design = _row_of(part, core)
    if row.get("status") is None:
        capability_rung(candidate, row, design, runner.spec)
    took = time.perf_counter() - start
    row["seconds"] = float(row["seconds"]) + took
    return row, took


def relay_part(part, runner, candidate, core: str) -> tuple[dict | None, float]:
    """The relay rung's changes to ``core``'s row (None if the shared rungs stopped it) and this task's seconds."""
    from .ladder import relay_rung

    start = time.perf_counter()
    row, design = _row_of(part, core)
    if row.get("status") is not None:
        return None, time.perf_counter() - start
    before = dict(row)
    relay_rung(candidate, row, runner.spec, design)
    changes = {k: v for k, v in row.items() if k != "seconds" and (k not in before or before[k] != v)}
    return changes, time.perf_counter() - start


def submit(client, runner, candidate, priority: float, retries: int = 2) -> list:
    """Submit ``candidate``'s tasks (module docstring); returns the futures :func:`merge` reads, the shared
    rungs' first."""
    cores = runner.spec.cores
    part = client.submit(shared_rungs, runner, candidate, pure=False, retries=retries, priority=priority)
    ahead = dict(pure=False, retries=retries, priority=priority + AHEAD)
    futures = [part] + [client.submit(core_rung, part, runner, candidate, core, **ahead) for core in cores]
    if runner.spec.relays:
        futures += [client.submit(relay_part, part, runner, candidate, core, **ahead) for core in cores]
    return futures


def timings(spec, candidate, results: list) -> list[dict]:
    """One record per task of ``candidate`` from its per-core results (as :func:`merge` reads them): ``kind``
    (``shared``, ``capability`` or ``relays``), ``core`` (None for the shared rungs) and ``seconds`` inside the
    task; the shared rungs' seconds are a core row's less its own task's (the row carries both)."""
    import json
    from dataclasses import asdict

    cores = list(spec.cores)
    rungs, relays = results[:len(cores)], results[len(cores):]
    params = json.dumps(asdict(candidate), sort_keys=True)
    shared = min(float(row["seconds"]) - took for row, took in rungs)
    out = [{"params": params, "kind": "shared", "core": None, "seconds": shared}]
    out += [{"params": params, "kind": "capability", "core": core, "seconds": float(took)}
            for core, (_, took) in zip(cores, rungs)]
    out += [{"params": params, "kind": "relays", "core": core, "seconds": float(took)}
            for core, (_, took) in zip(cores, relays)]
    return out


def merge(spec, results: list) -> tuple[list[dict], float]:
    """The rows of one layout from its per-core results (:func:`submit`'s futures but the first, in order) and the
    summed seconds of its tasks (the shared rungs counted once)."""
    cores = len(spec.cores)
    rungs, relays = results[:cores], results[cores:]
    rows, total = [], 0.0
    shared = min(float(row["seconds"]) - took for row, took in rungs)
    for k, (row, took) in enumerate(rungs):
        row = dict(row)  # the results stay as the tasks returned them (timings reads them too)
        total += took
        if relays:
            changes, relay_took = relays[k]
            total += relay_took
            if changes is not None and row.get("status") == "ok":
                row.update(changes)
                row["seconds"] = float(row["seconds"]) + relay_took
        rows.append(row)
    return rows, total + shared
