"""The answer's files (issue 29 §3): every candidate, the Pareto front and its figure, the finalists' required /
achieved tables, the summary, and the HTML report beside the gallery's table.

Files in the output folder, each written whole (:mod:`spherestep.atomic`): ``candidates.csv`` (every row of the
ladder), ``pareto.csv``, ``pareto.png`` (:func:`figure_front`), ``synthesis.json``
(:meth:`SynthesisResult.to_dict`), ``report.html`` (:func:`spherestep.report.write_report` on the winner, or the
closest finalist, with the sections below); ``finalists/NN-<key>.yaml`` and ``verification/`` are written by the
search.
"""

from __future__ import annotations

import base64
import html
import io
import json
import math
from pathlib import Path


from ..atomic import write_text


def figure_front(table, front, spec, winner_key: str | None = None):
    """Two panels over the candidates that passed the cheap rungs (grey: pruned at the capability or relay rung):
    torque against magnet mass and resolution against coils; the Pareto set circled, the winner starred."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(12.0, 4.8), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2)
    measured = table[table["magnet_mass_kg"].notna()]
    ok = measured[measured["status"] == "ok"]
    other = measured[measured["status"] != "ok"]
    torque = "torque_quantile_Nm" if spec.servo else "step_torque_Nm"
    label = (f"torque in every direction on {spec.torque.over_fraction:.0%} of the range (N·m)" if spec.servo
             else "step torque, median of sampled states (N·m)")
    for ax, (x, y, xl, yl) in zip((ax1, ax2), ((("magnet_mass_kg", torque, "magnet mass (kg)", label)),
                                               ("coils", "resolution_median_deg", "coils",
                                                "median resolution (°)"))):
        for part, colour, text in ((other, "#b0b0b0", f"pruned or failed ({len(other)})"),
                                   (ok, "#2c6fbb", f"met the cheap rungs ({len(ok)})")):
            if y in part and part[y].notna().any():
                ax.scatter(part[x].astype(float), part[y].astype(float), s=16, color=colour, alpha=0.7, label=text)
        if len(front) and y in front:
            ax.scatter(front[x].astype(float), front[y].astype(float), s=80, facecolors="none",
                       edgecolors="#c0392b", linewidths=1.6, label=f"Pareto set ({len(front)})")
        if winner_key is not None:
            w = table[table["key"] == winner_key]
            if len(w) and y in w:
                ax.scatter(w[x].astype(float), w[y].astype(float), s=220, marker="*", color="#f1c40f",
                           edgecolors="k", zorder=5, label="winner")
        if y == "torque_quantile_Nm" and spec.torque.every_direction is not None:
            ax.axhline(spec.torque.every_direction, color="#555", ls="--", lw=1, label="required")
        if y == "step_torque_Nm" and spec.torque.step is not None:
            ax.axhline(spec.torque.step, color="#555", ls="--", lw=1, label="required")
        if x == "magnet_mass_kg" and spec.envelope.mass_limit is not None:
            ax.axvline(spec.envelope.mass_limit, color="#555", ls=":", lw=1, label="mass limit")
        if x == "coils":
            ax.axvline(spec.max_coils + 0.5, color="#555", ls=":", lw=1, label="coil limit")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.suptitle(f"synthesis for {spec.name}: {len(table)} candidates")
    return fig


def _png(fig) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _table(rows, header) -> str:
    out = ["<table><tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>"]
    for row in rows:
        out.append("<tr>" + "".join(f"<td>{html.escape(str(v))}</td>" for v in row) + "</tr>")
    return "".join(out) + "</table>"


def _spec_rows(spec) -> list:
    rows = []

    def walk(prefix, value):
        if isinstance(value, dict):
            for k, v in value.items():
                walk(f"{prefix}.{k}" if prefix else k, v)
        elif value is not None:
            rows.append((prefix, value if not isinstance(value, float) else f"{value:.6g}"))

    walk("", spec.to_dict())
    return rows


def gallery_rows() -> list:
    """The gallery's stored metrics as table rows (design, magnets/coils, core, states, resolution, torque)."""
    from ..gallery import stored_metrics

    rows = []
    for key, m in stored_metrics().items():
        rows.append((key, f"{m.rotor_poles}/{m.coils}", m.core, m.states, f"{math.degrees(m.resolution_median_rad):.2f}°",
                     f"{m.torque_median_N_m:.3g} ({m.torque_p5_N_m:.2g})", f"{m.magnet_mass_kg:.3g}"))
    return rows


def write_outputs(result, out, samples: int = 2000, closest=None) -> list[Path]:
    """Write the files of the module docstring into ``out`` (the report's resolution from ``samples``
    orientations; ``closest`` the design file of the closest candidate, reported when there is no finalist);
    returns their paths."""
    from ..motor import MotorDesign
    from ..report import Section, write_report

    out = Path(out)
    spec = result.spec
    written = []
    table = result.table
    written.append(write_text(out / "candidates.csv", table.drop(columns=["params"]).to_csv(index=False)))
    written.append(write_text(out / "pareto.csv", result.front.drop(columns=["params"], errors="ignore")
                              .to_csv(index=False)))
    winner_key = None if result.winner is None else result.winner.row["key"]
    png = _png(figure_front(table, result.front, spec, winner_key))
    path = out / "pareto.png"
    from ..atomic import atomic_path

    with atomic_path(path) as tmp:
        Path(tmp).write_bytes(png)
    written.append(path)
    written.append(write_text(out / "synthesis.json", json.dumps(result.to_dict(), indent=1)))
    shown = result.winner or (result.finalists[0] if result.finalists else None)
    if shown is None and closest is None:
        return written
    design = MotorDesign.load(shown.path if shown is not None else closest)
    sections = [Section("answer", "The answer", html=f"<p><b>{html.escape(result.statement)}</b></p>"),
                Section("spec", "Specification", html=_table(_spec_rows(spec), ("field", "value")))]
    for n, f in enumerate(result.finalists, start=1):
        v = f.verification
        verdict = "meets every requirement" if v.met else "misses " + ", ".join(c.name for c in v.checks if not c.met)
        b = v.binding
        sections.append(Section(f"finalist-{n}", f"Finalist {n}: required / achieved",
                                html=(f"<p>{html.escape(f.row['rotor'])}/L{f.row['rotor_level']} × "
                                      f"{html.escape(f.row['stator'])}/L{f.row['stator_level']}, cap "
                                      f"{f.row['cap_deg']:g}°, ball {f.row['sphere_diameter_mm']:.4g} mm, "
                                      f"{html.escape(f.row['core'])} core — {html.escape(verdict)}"
                                      + (f"; binds: {html.escape(b.name)}" if b is not None else "")
                                      + f". Design file: {html.escape(Path(f.path).name)}; verified from the file "
                                      f"in {v.seconds:.1f} s (seed {v.seed}).</p>"
                                      + _table([(c.name, c.required, c.achieved, "yes" if c.met else "NO",
                                                 "—" if c.margin is None else f"{c.margin:.2f}×")
                                                for c in v.checks],
                                               ("requirement", "required", "achieved", "met", "margin")))))
    img = base64.b64encode(png).decode()
    sections.append(Section("pareto", "Pareto front",
                            html=f'<img alt="Pareto front" style="max-width:100%" src="data:image/png;base64,{img}">'))
    rows = []
    for f in result.finalists:
        num = f.verification.numbers
        tq = num.get("torque_median_Nm")
        rows.append((f"finalist {Path(f.path).name}", f"{num['rotor_poles']}/{num['coils']}", num["core"],
                     num["states"], f"{num['resolution_median_deg']:.2f}°",
                     "—" if tq is None else f"{tq:.3g} ({num.get('torque_quantile_Nm', math.nan):.2g} at "
                     f"{1 - spec.torque.over_fraction:.0%})", f"{num['magnet_mass_kg']:.3g}"))
    sections.append(Section("gallery", "Beside the gallery",
                            note="Gallery rows: stored metrics (torque median and 5th percentile over SO(3)); "
                                 "finalists: the verification's numbers (torque median and the spec's quantile over "
                                 "the spec's range).",
                            html=_table(rows + gallery_rows(), ("design", "magnets/coils", "core", "states",
                                                                "res. median", "torque N·m", "magnets kg"))))
    metrics = design.metrics(samples=samples, seed=0, escape=False)
    summary = write_report(out / "report.html", design, metrics, samples=samples, seed=0,
                           title=f"spherestep synthesis: {spec.name}", sections=tuple(sections))
    written.append(Path(summary["path"]))
    return written
