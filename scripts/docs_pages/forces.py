"""docs/magnetics.md's forces at the stepper states (``data/forces_states.json``: ``spherestep forces``)."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
from .common import FORCES_SEED, FORCES_STATES, ROOT, _signed, table


def _coils(r: dict) -> str:
    return " ".join(f"{k}{'+' if s > 0 else '−'}" for k, s in r["coils"].items())


def forces_table(f: dict) -> str:
    """docs/magnetics.md: the state torques ``spherestep forces --states 20 --core air`` prints."""
    rows = []
    for r in f["states"]:
        peak = f"{r['step_peak_torque_Nm']:.3f}" if r["step_peak_torque_Nm"] is not None else "—"
        rows.append((r["state"], _coils(r), f"{r['equilibrium_offset_deg']:.2f}",
                     " / ".join(f"{k:.2f}" for k in r["stiffness_Nm_per_rad"]), f"{r['holding_torque_Nm']:.3f}",
                     f"{r['strongest_axis_Nm']:.3f}", f"{r['downhill_steps'] or 0}/{r['steps']}", peak))
    return table(("state", "coils", "offset °", "stiffness N·m/rad", "holding N·m", "strongest axis N·m",
                  "downhill/steps", "peak step N·m"), rows)


def forces_summary(f: dict) -> str:
    rows = f["states"]
    hold = [r["holding_torque_Nm"] for r in rows]
    strong = [r["strongest_axis_Nm"] for r in rows]
    return (f"holding torque {min(hold):.2f}–{max(hold):.2f} N·m (median {statistics.median(hold):.2f}); about the "
            f"strongest axis {min(strong):.1f}–{max(strong):.1f} N·m")


def forces_soft(f: dict) -> str:
    """The states whose softest stiffness is under 0.5 N·m/rad (two coils, the turn about their bisector)."""
    soft = [r for r in f["states"] if r["stiffness_Nm_per_rad"][0] < 0.5]
    k0 = [r["stiffness_Nm_per_rad"][0] for r in soft]
    k12 = [k for r in soft for k in r["stiffness_Nm_per_rad"][1:]]
    hold = [r["holding_torque_Nm"] for r in soft]
    return (f"{min(k0):.2f}–{max(k0):.2f} N·m/rad against {min(k12):.1f}–{max(k12):.1f} about the other axes, and "
            f"the holding torque {min(hold):.2f}–{max(hold):.2f} N·m")


def forces_steps(f: dict) -> str:
    rows = [r for r in f["states"] if r["steps"]]
    down, steps = sum(r["downhill_steps"] or 0 for r in rows), sum(r["steps"] for r in rows)
    start = [r["step_start_torque_median_Nm"] for r in rows]
    low = min(r["step_start_torque_min_Nm"] for r in rows)
    peak = [r["step_peak_torque_Nm"] for r in rows]
    return (f"Steps: {down} of {steps} steps run downhill all the way along the geodesic; drive at a step's start "
            f"median {statistics.median(start):.2f} N·m over the states (some long steps start slightly uphill, down "
            f"to {_signed(low, 2)} N·m), largest drive met along a step {min(peak):.2f}–{max(peak):.2f} N·m")


def measure_forces() -> dict:
    """``spherestep forces --states 20 --seed 0 --core air --json`` on the prototype, its state rows kept."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-c", "from spherestep.cli import main; main()", "forces", "--states", str(FORCES_STATES), "--seed",
               str(FORCES_SEED), "--core", "air", "--json", "--out", tmp]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})
    info = json.loads(out.stdout)
    return {"command": f"spherestep forces --states {FORCES_STATES} --seed {FORCES_SEED} --core air --json",
            "design": info["design"], "states": info["states"]}
