"""Shared by the pages: where the stored measurements live (:data:`STORES`), reading one (:func:`stored`), and the
small formatters several pages use."""

from __future__ import annotations

import csv
import datetime
import json
import os
import statistics
import sys
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parents[2]  # the repository (this file: scripts/docs_pages/common.py)
DATA = ROOT / "data"
STORES = {
    "demo": DATA / "demo_summary.json",
    "forces": DATA / "forces_states.json",
    "robust": DATA / "servo_robust.json",
    "iron": DATA / "iron_compare.json",
    "calibration": DATA / "calibration_table.json",  # benchmarks/bench_calibration.py --json
    "gallery": ROOT / "src" / "spherestep" / "data" / "gallery" / "metrics.csv",  # scripts/gallery_metrics.py
    "explore": DATA / "explore_default.json",  # docs_numbers.py explore: spherestep explore, docs/explore.md's sweep
    "potential": DATA / "potential_numbers.json",  # docs_numbers.py potential (measure_potential)
    "dynamics": DATA / "dynamics_tune.json",  # docs_numbers.py dynamics (measure_dynamics)
    "control-notes": DATA / "docs_control_notes.json",  # docs_numbers.py control-notes (measure_control_notes)
    "sensing-notes": DATA / "docs_sensing_notes.json",  # docs_numbers.py sensing-notes (measure_sensing_notes)
}
FORCES_STATES, FORCES_SEED = 20, 0


def stored(name: str) -> dict | list:
    """A stored measurement: JSON, or a CSV as ``{first column: {column: value}}``."""
    path = STORES[name]
    if path.suffix == ".csv":
        with path.open(encoding="utf-8", newline="") as f:
            return {row[next(iter(row))]: {k: _num(v) for k, v in row.items()} for row in csv.DictReader(f)}
    return json.loads(path.read_text(encoding="utf-8"))


def _signed(x: float, digits: int) -> str:
    """``x`` with the typographic minus the docs use."""
    return f"{x:.{digits}f}".replace("-", "−")


def _mode(drives: dict, name: str) -> dict:
    return next(m for m in drives["modes"] if m["mode"] == name)


def _when(b: dict) -> str:
    """When and under what load a stored benchmark ran: ``2026-11-26 00:18 UTC, load 5.5–7.1``."""
    lo, hi = sorted(b["load"])
    load = f"{lo:.1f}" if f"{lo:.1f}" == f"{hi:.1f}" else f"{lo:.1f}–{hi:.1f}"
    return f"{b['measured']}, load {load}"


def _times(x: float) -> str:
    """A ratio with about three significant figures: 3,766 / 91 / 2.4."""
    return f"{x:,.0f}" if x >= 10 else f"{x:.1f}"


def _num(x: str):
    """A metrics.csv cell: a number, a boolean, or None when empty."""
    if x in ("True", "False"):
        return x == "True"
    if x == "":
        return None
    for kind in (int, float):
        try:
            return kind(x)
        except ValueError:
            pass
    return x


def _thin(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def _machine() -> str:
    import platform

    import numpy

    return (f"{os.cpu_count()} cores ({platform.machine()}, {platform.system()}), Python {platform.python_version()}, "
            f"NumPy {numpy.__version__}")


def _run_header(mode: str) -> dict:
    start = datetime.datetime.now(datetime.UTC)
    return {"mode": mode, "measured": start.strftime("%Y-%m-%d %H:%M UTC"), "load": [round(os.getloadavg()[0], 1)],
            "machine": _machine(), "_t0": time.perf_counter()}


def _run_footer(run: dict) -> dict:
    run["wall_s"] = round(time.perf_counter() - run.pop("_t0"), 1)
    run["load"].append(round(os.getloadavg()[0], 1))
    return run


def _step(run: dict, label: str) -> None:
    """A progress line on stderr: the part just measured and the run's time so far."""
    print(f"{run['mode']}: {label} done ({time.perf_counter() - run['_t0']:.0f} s)", file=sys.stderr, flush=True)


def _cpu(f, repeat: int = 200) -> float:
    """Median CPU seconds of ``f()`` over ``repeat`` calls (after one warm-up call)."""
    f()
    ts = []
    for _ in range(repeat):
        t = time.process_time()
        f()
        ts.append(time.process_time() - t)
    return statistics.median(ts)


def _notes_when(n: dict) -> str:
    lo, hi = n["load"]
    return f"`scripts/docs_numbers.py` {n['mode']}, {n['measured']}, load {lo:.1f} → {hi:.1f}"


def _deg(x: float) -> str:
    """Degrees to four decimals below 0.1°, two above (an error of degrees needs no more)."""
    return f"{x:.4f}" if x < 0.1 else f"{x:.2f}"


def table(head, rows, intro: str | None = None, align: str | None = None) -> str:
    """A Markdown table, the one shape every page's tables take: ``intro`` and a blank line first when given, the
    header row of the column titles ``head``, the rule (``---`` a column; ``align`` one letter a column, ``r`` for
    ``---:``), then a line per row of ``rows`` (each a sequence of cell texts; an empty cell ``""`` is ``| |``, a
    ``None`` cell keeps the two spaces of an empty field, ``|  |``, as the potential timings have always had it)."""
    def line(cells) -> str:
        return "|" + "|".join(" " if c == "" else f" {'' if c is None else c} " for c in cells) + "|"

    rule = "|" + "|".join("---:" if a == "r" else "---" for a in (align or "l" * len(head))) + "|"
    return "\n".join(([intro, ""] if intro is not None else []) + [line(head), rule] + [line(r) for r in rows])
