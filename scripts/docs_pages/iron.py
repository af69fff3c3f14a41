"""docs/magnetics.md's comparison of the iron models (``data/iron_compare.json``)."""

from __future__ import annotations

from .common import table



IRON_ROWS = (("unpowered: minima of 12 starts", "{unpowered_minima:d}"),
             ("unpowered: median holding torque (N·m)", "{unpowered_holding_median_Nm:.2f}"),
             ("stepper states: minima of 12", "{state_minima:d}"),
             ("stepper states: rest from the geometric state, median / max (°)",
              "{state_offset_median_deg:.2f} / {state_offset_max_deg:.2f}"),
             ("stepper states: median holding torque (N·m)", "{state_holding_median_Nm:.2f}"),
             ("capability, 400 orientations: median / 5th percentile (N·m)",
              "{capability_median_Nm:.2f} / {capability_p5_Nm:.2f}"),
             ("servo turn 360° about (1, 0.5, 2): time (s)", "{servo_time_s:.2f}"),
             ("servo turn: final / max tracking error (°)", "{servo_final_deg:.3f} / {servo_tracking_deg:.2f}"),
             ("servo turn: mean power (W)", "{servo_mean_W:.1f}"))


def iron_compare_table(rows: dict) -> str:
    """docs/magnetics.md: ``scripts/iron_compare.py``'s pairwise and coupled models side by side."""
    a, b = rows["pairwise"], rows["coupled"]
    return table(("the prototype, iron-cored", a["model"], b["model"]),
                 [(label, fmt.format(**a), fmt.format(**b)) for label, fmt in IRON_ROWS])
