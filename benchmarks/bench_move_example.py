"""The `move --help` example repeated (issue 38 §1): ``spherestep move --axis 1,0.5,2 --angle 360 --emulate`` (the
fastest turn the planner finds within the drive's voltage, back-EMF included; 500 Hz; the emulated coils with
their back-EMF, the host sending its estimate) run as a user runs it, each a fresh process in a temporary folder.

Run: ``.venv/bin/python benchmarks/bench_move_example.py [runs] [--json data/bench_move_example.json]`` (default
20). Prints per run the exit status, the outcome, the max tracking and final errors and the deadlines missed (from
the run's ``move.json``), the wall seconds and the load; then how many exited 0, and the spread.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import Record  # noqa: E402

CLI = "import sys; from spherestep.cli import main; sys.exit(main(sys.argv[1:]))"
EXAMPLE = ["move", "--axis", "1,0.5,2", "--angle", "360", "--emulate"]


def one() -> dict:
    """One run of the example: exit status, the figures its ``move.json`` reports, wall seconds, load."""
    load = os.getloadavg()[0]
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, "-c", CLI, *EXAMPLE, "--out", "m"], cwd=tmp, capture_output=True,
                              text=True)
        wall = time.perf_counter() - start
        summary = Path(tmp, "m", "move.json")
        report = json.loads(summary.read_text()) if summary.is_file() else {}
    row = {"exit": done.returncode, "wall_s": wall, "load": [load, os.getloadavg()[0]]}
    for key in ("max_tracking_error_deg", "final_error_deg"):
        row[key] = report.get(key)
    details = report.get("details", {}) if isinstance(report.get("details"), dict) else {}
    for key in ("outcome", "missed", "slowed", "rate_Hz"):
        row[key] = details.get(key)
    if done.returncode != 0:
        row["last_line"] = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or [""])[-1]
    return row


def main() -> None:
    record = Record("move_example")
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    runs = int(args[0]) if args else 20
    print(f"spherestep {' '.join(EXAMPLE)}: {runs} runs; load at start {os.getloadavg()[0]:.2f} "
          f"({os.cpu_count()} cores)", flush=True)
    rows = []
    for k in range(runs):
        row = one()
        rows.append(row)
        print(f"  run {k + 1:2d}: exit {row['exit']}, {row['outcome']}, max tracking {row['max_tracking_error_deg']}°, "
              f"final {row['final_error_deg']}°, missed {row['missed']}, {row['wall_s']:.0f} s, load "
              f"{row['load'][1]:.2f}" + (f" — {row['last_line']}" if row["exit"] else ""), flush=True)
    ok = sum(r["exit"] == 0 for r in rows)
    track = np.array([r["max_tracking_error_deg"] for r in rows if r["max_tracking_error_deg"] is not None], float)
    final = np.array([r["final_error_deg"] for r in rows if r["final_error_deg"] is not None], float)
    spread = {}
    if len(track):
        spread = {"tracking_median_deg": float(np.median(track)), "tracking_p10_deg": float(np.percentile(track, 10)),
                  "tracking_p90_deg": float(np.percentile(track, 90)), "tracking_worst_deg": float(track.max()),
                  "final_median_deg": float(np.median(final)), "final_worst_deg": float(final.max())}
    print(f"exit 0 in {ok} of {runs}; {spread}; load at end {os.getloadavg()[0]:.2f}")
    record.put("command", "spherestep " + " ".join(EXAMPLE))
    record.put("runs", rows)
    record.put("exit_0", ok)
    record.put("spread", spread)
    record.write()


if __name__ == "__main__":
    main()
