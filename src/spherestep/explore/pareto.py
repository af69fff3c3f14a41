"""Choosing designs: the Pareto front of resolution against coil count, and its figure.

A design dominates another when it is no worse in every objective and better in one; the front is the set
no design dominates. The objectives are the median resolution (degrees, smaller is finer), the number of
coils (fewer is cheaper: relays, wiring, power) and, when the sweep measured it, the median holding torque
(N·m, larger holds against larger loads; a design whose torque could not be measured is then not on the
front). Only designs that were measured, fit the coil budget and reach every orientation (``reaches_all``:
every random orientation within one step of a state, and the states linked into one graph) are candidates,
unless ``require_reach_all=False``.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter, ScalarFormatter

from ..errors import bad_value

OBJECTIVES = ("resolution_median_deg", "coils")  # both minimised
TORQUE = "holding_torque_median_Nm"  # maximised, when measured
CAPABILITY = "capability_p5_Nm"  # maximised, when measured: torque available in every direction on 95 % of SO(3)


def pareto_mask(values, maximize=()) -> np.ndarray:
    """Boolean mask of the rows of ``values (n, k)`` that no other row dominates.

    Columns are minimised, except those whose indices are in ``maximize``. Rows with a NaN are never on the
    front. Equal rows do not dominate each other (all are kept). Rows are visited in lexicographic order, in
    which every dominating row comes before the rows it dominates, and each is compared only with the front
    found so far (a dominated row's dominator is dominated by, or is, a front row): ``O(n · front)``.
    """
    v = np.array(values, dtype=float)
    if v.ndim != 2:
        raise bad_value("values", "a 2-D array (rows of objectives)", f"shape {v.shape}")
    v[:, list(maximize)] *= -1
    mask = np.zeros(len(v), dtype=bool)
    rows = np.flatnonzero(~np.isnan(v).any(axis=1))
    order = rows[np.lexsort(v[rows].T[::-1])]
    front = np.zeros((0, v.shape[1]))
    for i in order:
        p = v[i]
        if np.any(np.all(front <= p, axis=1) & np.any(front < p, axis=1)):
            continue
        mask[i] = True
        front = np.vstack([front, p])
    return mask


def eligible(table: pd.DataFrame, budget_coils: int, require_reach_all: bool = True) -> pd.Series:
    """Rows that may be proposed: measured, within ``budget_coils`` and (by default) reaching every orientation."""
    ok = (table["status"] == "ok") & (table["coils"].astype("Float64") <= budget_coils)
    if require_reach_all:
        ok &= table["reaches_all"].astype("boolean")
    return ok.fillna(False).astype(bool)


def objectives(table: pd.DataFrame) -> list[str]:
    """:data:`OBJECTIVES`, and :data:`TORQUE` and :data:`CAPABILITY` when ``table`` has them measured."""
    return list(OBJECTIVES) + [c for c in (TORQUE, CAPABILITY) if c in table.columns and table[c].notna().any()]


def pareto_front(table: pd.DataFrame, budget_coils: int, require_reach_all: bool = True) -> pd.DataFrame:
    """The Pareto set of the eligible designs in ``table`` (see :func:`eligible`) over :func:`objectives`,
    fewest coils first; grid points that build the same motor (equal ``motor`` fingerprint) count once, as the
    first of them."""
    pool = table[eligible(table, budget_coils, require_reach_all)].drop_duplicates("motor")
    columns = objectives(pool)
    values = pool[columns].astype("float64").to_numpy()
    front = pool[pareto_mask(values, maximize=[columns.index(c) for c in (TORQUE, CAPABILITY) if c in columns])]
    return front.sort_values(["coils", "resolution_median_deg", "key"]).reset_index(drop=True)


def _short(row) -> str:
    return f"{row['rotor']}/L{row['rotor_level']} × {row['stator']}/L{row['stator_level']}"


def _scatter(ax, table: pd.DataFrame, column: str) -> None:
    measured = table[(table["status"] == "ok") & table[column].notna()]
    reach = measured["reaches_all"].astype("boolean").fillna(False).astype(bool)
    for rule, marker, face in (("different", "o", None), ("same", "s", "none")):
        noun = "families" if rule == "different" else "family"
        for reaches, colour, text in ((True, "#2c6fbb", "reaches all"), (False, "#9a9a9a", "does not reach all")):
            part = measured[(measured["family_rule"] == rule) & (reach == reaches)]
            if len(part):
                ax.scatter(part["coils"].astype(float), part[column].astype(float), s=22, marker=marker,
                           facecolors=colour if face is None else face, edgecolors=colour, linewidths=0.9,
                           alpha=0.75, label=f"{rule} {noun}, {text} ({len(part)})")


def _log_ticks(ax) -> None:
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(ScalarFormatter())
    ax.yaxis.set_minor_formatter(NullFormatter())
    low, high = ax.get_ylim()
    ax.set_yticks([t for t in (0.5, 1, 2, 3, 5, 7, 10, 15, 20, 30, 50, 70) if low <= t <= high])
    ax.set_ylim(low, high)


def figure_pareto(table: pd.DataFrame, front: pd.DataFrame, budget_coils: int) -> Figure:
    """Median resolution against coils for every measured design, and median holding torque against coils
    when measured; the Pareto set circled and numbered in the order of ``front`` (the design files' order),
    joined by its staircase when resolution and coils are the only objectives.

    Filled markers: rotor and stator from different symmetry families; open squares: the same family. Grey:
    the design does not reach every orientation. Dashed: the coil budget.
    """
    panels = [("resolution_median_deg", "median distance to the nearest stepper state (°)", "Resolution")]
    if TORQUE in objectives(table):
        panels.append((TORQUE, "median holding torque of sampled states (N·m)", "Holding torque"))
    if CAPABILITY in objectives(table):
        panels.append((CAPABILITY, "torque available in every direction on 95 % of SO(3) (N·m)", "Capability"))
    fig = Figure(figsize=(9.0 if len(panels) == 1 else 7.0 * len(panels), 6.0))
    for n, (column, label, title) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), n + 1)
        _scatter(ax, table, column)
        if len(front):
            x = front["coils"].astype(float).to_numpy()
            y = front[column].astype(float).to_numpy()
            if len(panels) == 1:
                ax.step(x, y, where="post", color="#c0392b", lw=1.4, zorder=3)
            ax.scatter(x, y, s=70, facecolors="none", edgecolors="#c0392b", linewidths=1.8, zorder=4,
                       label=f"Pareto set within the budget ({len(front)}, numbered)")
            for rank, (xi, yi) in enumerate(zip(x, y), start=1):  # numbered as the table and the design files
                ax.annotate(str(rank), (xi, yi), xytext=(5, 5), textcoords="offset points", fontsize=8,
                            color="#7b241c")
        ax.axvline(budget_coils + 0.5, color="#555555", ls="--", lw=1.0, label=f"budget: {budget_coils} coils")
        if column == "resolution_median_deg":
            _log_ticks(ax)
        ax.set_xlabel("coils")
        ax.set_ylabel(label)
        ax.set_title(f"{title} against coil count")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    return fig
