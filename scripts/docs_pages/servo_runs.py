"""docs/control.md's robustness and calibration tables (``data/servo_robust.json``, ``data/calibration_table.json``)."""

from __future__ import annotations

from .common import table



def robust_table(stored_run: dict) -> str:
    """docs/control.md: benchmarks/bench_servo_robust.py's table, the observer off → on per case."""
    rows = stored_run["rows"]
    turn = {r["turn_time_s"] for r in rows}
    note = f"{stored_run['note']}; " if stored_run.get("note") else ""
    cells = []
    for case in dict.fromkeys(r["case"] for r in rows):
        by = {r["observer"]: r for r in rows if r["case"] == case}
        off, on = by["off"], by["on"]
        cells.append((case, f"{off['holds_within']}/{off['holds']} ({off['worst_hold_deg']:.3f}°) → "
                      f"**{on['holds_within']}/{on['holds']} ({on['worst_hold_deg']:.3f}°)**",
                      f"{off['final_error_deg']:.3f}° → **{on['final_error_deg']:.4f}°**",
                      f"{off['max_tracking_error_deg']:.2f}° → **{on['max_tracking_error_deg']:.3f}°**",
                      f"{off['mean_power_W']:.1f} → {on['mean_power_W']:.1f} W", f"{on['reachable_fraction']:.3f}",
                      "yes" if on["passed"] else "**no**"))
    return table(("plant (controller: the design's iron model)", "holds within 0.05° (worst) off → **on**",
                  "turn final error off → **on**", "max tracking off → **on**", "mean power off → on", "reachable on",
                  "targets met"), cells, f"Measured {stored_run['measured']} ({note}the planned turn is "
                 + " / ".join(f"{x:.3f}" for x in sorted(turn)) + " s):")


def calibration_table(run: dict) -> str:
    """docs/control.md: benchmarks/bench_calibration.py's table, per plant the torque error and the turn on each
    plan before calibration, after and on the exact model."""
    plans = run["plans"]
    head = ("plant (controller: the design's coupled model unless said)", "holds (collected in)",
            "torque error before → after (ratio)", "scales fitted (detent, winding; coupling) ± σ",
            *(f"{'fastest' if k == 'fastest' else '`MARGIN`'} plan ({plans[k]['duration_s']:.2f} s): before → **after** "
              "(exact)" for k in plans))
    rows = []
    for r in run["rows"]:
        sd = r["scale_std"]
        gain = "" if r["coupling_gain"] is None else f"; {r['coupling_gain']:.4f} ± {r['coupling_std']:.4f}"
        rows.append((r["plant"].replace("-", "−"), f"{r['holds']} ({r['collect_s']:.0f} s)",
                     f"{r['torque_error_before']:.4f} → {r['torque_error_after']:.4f} ({r['ratio']:.0f}×)",
                     f"{r['scale_detent']:.4f} ± {sd[0]:.4f}, {r['scale_winding']:.4f} ± {sd[1]:.4f}{gain}",
                     *(f"{r['turn'][k]['before_max_deg']:.3f}° → **{r['turn'][k]['after_max_deg']:.3f}°** "
                       f"({r['turn'][k]['exact_max_deg']:.3f}°)" for k in plans if k in r["turn"])))
    return table(head, rows, f"Measured {run['measured']}, load {run['load'][0]:.1f} → {run['load_after'][0]:.1f} "
                 f"(`benchmarks/bench_calibration.py --json data/calibration_table.json`):")


def calibration_summary(run: dict) -> str:
    """docs/control.md, inline: the range of the error drop and of the calibrated servo's tracking on the MARGIN plan."""
    rows = run["rows"]
    ratios = [r["ratio"] for r in rows]
    after = [r["turn"]["margin"]["after_max_deg"] for r in rows]
    gap = max(abs(r["turn"]["margin"]["after_max_deg"] - r["turn"]["margin"]["exact_max_deg"]) for r in rows)
    return (f"the torque error drops {min(ratios):.0f}–{max(ratios):.0f}× (≥ 5×), and on the `MARGIN` plan the "
            f"calibrated servo tracks within {min(after):.3f}–{max(after):.3f}° (≤ 0.2°), equal to the exact model's "
            f"to {max(gap, 0.0005):.3f}°")
