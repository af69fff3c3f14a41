"""The search's answer in words (issue 29 §2): the winner among the verified finalists and the sentence that says
why (:func:`_answer`, the runner's), what changed from the baseline layout (:func:`describe_change`), and the closest candidates
when none passed (:func:`nearest_rows`, :func:`closest_row`).
"""

from __future__ import annotations

import json
import math

from .front import PREFER, Finalist, _json, _layout, _missing
from .ladder import GRADES, N42, baseline_layout


def describe_change(row: dict, base: dict) -> str:
    """What differs between the layout of ``row`` and the baseline layout ``base``, for people."""
    parts = []
    for key, label in (("rotor", "rotor packing"), ("rotor_level", "rotor refinement"), ("stator", "stator packing"),
                       ("stator_level", "stator refinement"), ("core", "core")):
        if row[key] != base[key]:
            parts.append(f"{label} {base[key]} → {row[key]}")
    if not math.isclose(row["cap_deg"], base["cap_deg"]):
        parts.append(f"stator cap {base['cap_deg']:g}° → {row['cap_deg']:g}°")
    if not math.isclose(row["sphere_diameter_mm"], 1e3 * base["sphere_diameter"], rel_tol=1e-9):
        parts.append(f"ball {1e3 * base['sphere_diameter']:.4g} → {row['sphere_diameter_mm']:.4g} mm")
    if (row.get("gap_scale") or 1.0) != 1.0:
        parts.append(f"air gap ×{row['gap_scale']:g} ({row['air_gap_mm']:.3g} mm)")
    params = json.loads(row["params"]) if row.get("params") else {}
    grade = float(params.get("remanence", N42))
    if not math.isclose(grade, base.get("remanence", N42), rel_tol=1e-9):
        was = base.get("remanence", N42)
        parts.append(f"magnets {GRADES.get(was, 'B_r')} {was:g} T → {GRADES.get(grade, 'B_r')} {grade:g} T")
    if params.get("wound_for"):
        at = row.get("ampere_turns")
        parts.append(f"coils rewound to draw the supply's share with {params['wound_for']} on"
                     + (f" ({at:.0f} ampere-turns)" if at is not None and not _missing(at) else ""))
    return ", ".join(parts) or "none (the baseline itself)"


RUNGS = ("geometry", "states", "capability", "relays")


def nearest_rows(table, count: int) -> list[dict]:
    """The ``count`` candidates that came nearest when none passed: the furthest rung reached, then (relays) the
    most steps on the plan, reaching all orientations, the finest resolution, the smallest change from the
    baseline, then the key."""
    if not len(table):
        return []
    frame = table.assign(_rung=table["stage"].map({r: n for n, r in enumerate(RUNGS)}).fillna(-1),
                         _steps=table["relay_steps_on_plan"].astype("Float64").fillna(-1),
                         _reach=table["reaches_all"].astype("boolean").fillna(False).astype(int),
                         _res=table["resolution_median_deg"].astype("Float64").fillna(math.inf),
                         _change=table["change"].astype("Float64").fillna(math.inf))
    frame = frame[frame["status"].isin(["ok", "pruned"])]
    extra = ["_rung", "_steps", "_reach", "_res", "_change"]
    order = frame.sort_values(extra + ["key"], ascending=[False, False, False, True, True, True])
    return [{k: _json(v) for k, v in row.drop(extra).items()} for _, row in order.head(count).iterrows()]


def closest_row(table, spec) -> dict | None:
    """The nearest candidate (:func:`nearest_rows`), or None."""
    rows = nearest_rows(table, 1)
    return rows[0] if rows else None


def _answer(spec, finalists, counts, total, closest=None) -> tuple[Finalist | None, str]:
    """The winner (the preferred finalist meeting every requirement) and the sentence that says why."""
    passing = [f for f in finalists if f.verification.met]
    column, maximise = PREFER[spec.prefer]
    if not passing:
        if not finalists:
            near = ""
            if closest is not None:
                near = f" The closest: {_layout(closest)}, stopped at {closest['stage']}: {closest['reason']}."
            return None, (f"Not found in the budget: none of the {total} candidates passed the cheap rungs "
                          f"({', '.join(f'{k} {v}' for k, v in sorted(counts.items()))}).{near}")
        def closeness(f):
            margins = [c.margin for c in f.verification.checks if c.margin is not None]
            return sum(c.met for c in f.verification.checks), min(margins, default=0.0)

        best = max(finalists, key=closeness)
        missed = [c for c in best.verification.checks if not c.met]
        return None, (f"Not found in the budget: {len(finalists)} finalists passed the cheap rungs but none met every "
                      f"requirement under full simulation; the closest ({_layout(best.row)}) misses "
                      + "; ".join(f"{c.name} (required {c.required}, achieved {c.achieved})" for c in missed) + ".")

    def score(f):
        v = f.row.get(column)
        v = math.inf if v is None else float(v)
        return (-v if maximise else v, f.row["key"])

    winner = min(passing, key=score)
    b = winner.verification.binding
    binding = (f"the binding requirement is {b.name}: required {b.required}, achieved {b.achieved} (margin "
               f"{b.margin:.2f}×)") if b is not None else "no requirement has a graded margin"
    change = ""
    base = baseline_layout(spec)
    if base is not None:
        change = f" Change from the baseline ({spec.baseline}): {describe_change(winner.row, base)}."
    return winner, (f"Winner ({spec.prefer} preferred, of {len(passing)} of {len(finalists)} finalists meeting every "
                    f"requirement): {_layout(winner.row)}; {binding}.{change}")
