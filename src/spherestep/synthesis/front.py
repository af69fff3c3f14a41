"""The search's Pareto set and finalists (issue 29 §2): the objectives a spec leaves free (:func:`objectives`), the
front over every measured candidate (:func:`pareto`, by :func:`spherestep.explore.pareto_mask`), the finalists
taken from it in the spec's order of preference (:func:`choose_finalists`) and the :class:`Finalist` each becomes
once verified. The runner is :mod:`.run`, the answer's prose :mod:`.answer`.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from .ladder import GRADES, N42


def objectives(spec) -> list[tuple[str, bool]]:
    """The Pareto objectives, ``(column, maximise)``: what the spec leaves free — magnet mass, coils, drive power,
    resolution, torque in every direction (servo) or step torque (relays), the turn's time estimate (with a speed),
    the change from the baseline (with one)."""
    out = [("magnet_mass_kg", False), ("coils", False), ("power_W", False), ("resolution_median_deg", False)]
    if spec.servo:
        out.append(("torque_quantile_Nm", True))
        if spec.speed is not None:
            out.append(("time_estimate_s", False))
    if spec.relays and spec.torque.step is not None:
        out.append(("step_torque_Nm", True))
    if spec.baseline is not None:
        out.append(("change", False))
    return out


PREFER = {"mass": ("magnet_mass_kg", False), "power": ("power_W", False), "time": ("time_estimate_s", False),
          "precision": ("resolution_median_deg", False), "torque": ("torque_quantile_Nm", True),
          "coils": ("coils", False), "change": ("change", False)}


def pareto(table, spec):
    """The feasible rows (status ``ok``) that no other feasible row dominates on :func:`objectives`, each motor
    once, in the order of the spec's ``prefer``."""
    from ..explore import pareto_mask

    ok = table[table["status"] == "ok"].copy()
    if "motor" in ok and ok["motor"].notna().any():
        ok = ok.drop_duplicates("motor")
    cols = objectives(spec)
    values = ok[[c for c, _ in cols]].astype("float64").to_numpy()
    values = np.where(np.isnan(values), np.inf, values)  # an objective not measured never wins
    front = ok[pareto_mask(values, maximize=[n for n, (_, mx) in enumerate(cols) if mx])]
    return sort_preferred(front, spec)


def sort_preferred(frame, spec):
    column, maximise = PREFER[spec.prefer]
    if column not in frame:
        column, maximise = "magnet_mass_kg", False
    return frame.sort_values([column, "coils", "key"], ascending=[not maximise, True, True]).reset_index(drop=True)


def choose_finalists(front, spec, count: int):
    """Up to ``count`` rows of the front: the preferred best first, then the best in each other objective, then the
    rest in preferred order."""
    if len(front) <= count:
        return front
    picks = [0]
    for column, maximise in objectives(spec):
        series = front[column].astype("float64")
        if series.notna().any():
            picks.append(int(series.idxmax() if maximise else series.idxmin()))
    picks += list(range(len(front)))
    seen = list(dict.fromkeys(picks))[:count]
    return front.loc[sorted(seen)].reset_index(drop=True)


@dataclass(frozen=True)
class Finalist:
    """A finalist: its ``row`` of the search (a dict), its design file ``path`` and ``verification``."""

    row: dict
    path: str
    verification: object

    def to_dict(self) -> dict:
        return {"key": self.row["key"], "layout": _layout(self.row), "design_file": self.path,
                "search": {k: _json(v) for k, v in self.row.items() if k not in ("params",)},
                "verification": self.verification.to_dict()}


def _json(v):
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return None if not math.isfinite(float(v)) else float(v)
    if v is None or isinstance(v, (str, bool, int)):
        return v
    try:
        import pandas as pd

        if pd.isna(v):
            return None
    except (TypeError, ValueError):
        pass
    return str(v)


def _missing(v) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def _layout(row) -> str:
    gap = row.get("gap_scale") or 1.0
    params = json.loads(row["params"]) if row.get("params") else {}
    grade, wound = float(params.get("remanence", N42)), int(params.get("wound_for", 0))
    return (f"{row['rotor']}/L{row['rotor_level']} × {row['stator']}/L{row['stator_level']}, cap "
            f"{row['cap_deg']:g}°, ball {row['sphere_diameter_mm']:.4g} mm, {row['core']}"
            + (f", air gap ×{gap:g}" if gap != 1.0 else "")
            + (f", {GRADES.get(grade, 'magnets')} {grade:g} T" if grade != N42 else "")
            + (f", rewound for {wound} coils on" if wound else ""))
