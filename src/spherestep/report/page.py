"""The report's page: sections, tables and the one self-contained HTML file (plotly.js inline)."""

from __future__ import annotations

import datetime as _dt
import html
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import plotly.io as pio
import plotly.offline

from .. import __version__, checks
from ..atomic import write_text
from ..errors import bad_value
from ..fig10 import plane_basis
from .figures import (FONT, _infer_axis, _turn_angles, commutation_figure, energy_figure, motor_figure,
                      resolution_distances, resolution_figure, trajectory_figure)

CONFIG = {"displaylogo": False, "responsive": True}

CSS = """
body { font-family: FONT_FAMILY; margin: 0 auto; max-width: 1180px; padding: 0 18px 40px; color: #222; }
h1 { font-size: 1.6em; margin: 18px 0 4px; } h2 { font-size: 1.25em; margin-top: 30px;
  border-bottom: 1px solid #ddd; padding-bottom: 3px; }
p.note, p.meta { color: #555; font-size: 0.92em; } nav a { margin-right: 14px; }
table { border-collapse: collapse; font-size: 0.9em; margin: 8px 0; }
th, td { border: 1px solid #ddd; padding: 3px 8px; text-align: left; vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; } th { background: #f3f3f3; }
tr:nth-child(even) td { background: #fafafa; } tr.current td { background: #fff3c4; }
tr.blocked td { color: #a01010; }
.tables { display: flex; flex-wrap: wrap; gap: 28px; }
.scroll { max-height: 420px; overflow-y: auto; border: 1px solid #eee; }
.scroll table { margin: 0; } .scroll th { position: sticky; top: 0; }
""".replace("FONT_FAMILY", FONT)

# highlight the plan table's row of the step shown by the commutation slider
ROW_SCRIPT = """
<script type="text/javascript">
window.addEventListener("load", function () {
  var gd = document.getElementById("commutation");
  if (!gd || !gd.on) { return; }
  gd.on("plotly_animatingframe", function (event) {
    var old = document.querySelector("tr.current");
    if (old) { old.classList.remove("current"); }
    var row = document.getElementById("step-" + event.name);
    if (row) { row.classList.add("current"); }
  });
});
</script>
"""


def _table(rows, header=None, numeric=()) -> str:
    out = ["<table>"]
    if header:
        out.append("<tr>" + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>")
    for row in rows:
        cells = (f'<td{" class=num" if c in numeric else ""}>{html.escape(str(v))}</td>' for c, v in enumerate(row))
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</table>")
    return "".join(out)


def _fmt(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "yes" if value else "no"
    if isinstance(value, (float, np.floating)):
        return f"{value:.6g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(_fmt(v) for v in value) or "none"
    return str(value)


def _div(fig, div_id: str, height: int) -> str:
    return pio.to_html(fig, include_plotlyjs=False, full_html=False, div_id=div_id, config=CONFIG,
                       auto_play=False, default_height=f"{height}px", validate=False)


def design_tables(design, metrics) -> str:
    """HTML: the design's dimensions, its two packings side by side, and its metrics (degrees for angles)."""
    s = design.summary()
    dims = [
        ("name", s["name"]), ("rotor poles", s["rotor_poles"]), ("stator coils", s["coils"]),
        ("failed coils", _fmt(s["failed_coils"])),
        ("stator axis", _fmt([round(float(a), 4) for a in design.stator_axis])),
        ("stator cap half-angle", f"{s['cap_half_angle_deg']:.2f}°"),
        ("sphere diameter", f"{s['sphere_diameter_mm']:.2f} mm"),
        ("magnet diameter × length", f"{s['magnet_mm'][0]:.2f} × {s['magnet_mm'][1]:.2f} mm"),
        ("coil diameter × length", f"{s['coil_mm'][0]:.2f} × {s['coil_mm'][1]:.2f} mm"),
        ("air gap", f"{s['air_gap_mm']:.3f} mm"),
        ("magnet face, angular radius", f"{math.degrees(design.magnet_angle):.3f}°"),
        ("coil face, angular radius", f"{math.degrees(design.coil_angle):.3f}°"),
        ("state tolerance", f"{s['state_tol_deg']:.3f}°"),
        ("max step (coil + magnet face)", f"{s['max_step_deg']:.3f}°"),
    ]
    rotor, stator = design.rotor.summary(), design.stator.summary()
    labels = [("name", "packing"), ("family", "symmetry family"), ("caps", "caps"),
              ("radius_min_deg", "cap radius min (°)"), ("radius_max_deg", "cap radius max (°)"),
              ("radius_ratio", "radius ratio"), ("density", "density (covered fraction)"),
              ("min_separation_deg", "min centre separation (°)"), ("symmetry_order", "symmetry rotations"),
              ("inertia_isotropy", "inertia isotropy (max/min)")]
    packing_rows = [(label, _fmt(rotor[key]), _fmt(stator[key])) for key, label in labels]
    m = metrics.to_dict(degrees=True)
    rows = [("stepper states", m["states"])]
    if m["states"]:
        hist = m["held_pairs_histogram"]
        rows += [
            ("resolution median / 95% / max", f"{m['resolution_median_deg']:.3f}° / {m['resolution_p95_deg']:.3f}° / "
                                              f"{m['resolution_max_deg']:.3f}°"),
            ("random orientations sampled", m["samples"]),
            ("range: orientations within one step of a state", f"{100 * m['range_fraction']:.2f}%"),
            ("state graph components (states one step apart linked)", m["state_graph_components"]),
            ("reaches all of SO(3)", _fmt(m["reaches_all"])),
            ("states with a 45° cone of no escape", "not checked" if m["escape_violations"] is None
             else f"{len(m['escape_violations'])} of {m['states']}"),
            ("states by held pairs", ", ".join(f"{n} pairs: {c}" for n, c in enumerate(hist) if c) or "none"),
        ]
    return ('<div class="tables"><div><h3>Dimensions</h3>' + _table(dims, ("quantity", "value")) +
            "</div><div><h3>Packings</h3>" + _table(packing_rows, ("", "rotor (magnets)", "stator (coils)"), (1, 2)) +
            "</div><div><h3>Design metrics</h3>" + _table(rows, ("metric", "value"), (1,)) + "</div></div>")


def plan_table(plan, axis) -> str:
    """HTML table of the plan: one row per step (angles in degrees)."""
    basis = plane_basis(axis)
    start = plan.steps[0].achieved
    targets = _turn_angles(plan.targets, start, basis)
    turned = _turn_angles(plan.achieved, start, basis)
    header = ("step", "status", "target turn (°)", "turned (°)", "error (°)", "coils (polarity)",
              "held (pole→coil)", "next pole", "enable mask", "polarity mask")
    rows = []
    for s in plan.steps:
        enable, polarity = s.masks(plan.channel_map)
        cells = (s.index, s.status, f"{targets[s.index]:.2f}", f"{turned[s.index]:.2f}", f"{math.degrees(s.error):.2f}",
                 " ".join(f"{k}:{v:+d}" for k, v in sorted(s.coils.items())),
                 " ".join(f"{j}→{k}" for j, k in s.held), "" if s.next_pole is None else s.next_pole,
                 hex(enable), hex(polarity))
        cls = ' class="blocked"' if s.status.startswith("blocked") else ""
        rows.append(f'<tr id="step-{s.index}"{cls}>' + "".join(
            f'<td{" class=num" if c in (0, 2, 3, 4) else ""}>{html.escape(str(v))}</td>' for c, v in enumerate(cells))
            + "</tr>")
    return ('<div class="scroll"><table><tr>' + "".join(f"<th>{html.escape(h)}</th>" for h in header) + "</tr>" +
            "".join(rows) + "</table></div>")


@dataclass(frozen=True)
class Section:
    """A section of the page: ``anchor`` (HTML id), ``heading``, ``note`` (HTML above the figure), ``figure``
    (a plotly figure or figure dict, or None) and its ``height`` in pixels, and ``html`` below it."""

    anchor: str
    heading: str
    note: str = ""
    figure: object = None
    height: int = 460
    html: str = ""

    def body(self) -> str:
        figure = _div(self.figure, self.anchor, self.height) if self.figure is not None else ""
        return (f'<p class="note">{self.note}</p>' if self.note else "") + figure + self.html


def build_report(design, metrics=None, plan=None, simulation=None, energy_map=None, axis=None, *,
                 samples: int = 20_000, seed=0, title: str | None = None, sections: tuple[Section, ...] = (),
                 progress: Callable[[str], None] | None = None) -> tuple[str, dict]:
    """The report's HTML text and a summary of its contents (see :func:`write_report`)."""
    say = progress or (lambda _: None)
    if metrics is None:
        say("measuring resolution, range and escape directions")
        metrics = design.metrics(samples=samples, seed=seed)
    samples = metrics.samples
    if axis is not None:
        axis = checks.axis(axis)
    elif plan is not None:
        axis = _infer_axis(plan.targets)
    elif simulation is not None:
        axis = _infer_axis(simulation.planned)
    title = title or f"spherestep report: {design.name}"
    sections_html: list[tuple[str, str, str]] = []  # (anchor, heading, body)
    say("drawing the motor")
    sections_html.append(("motor", "Motor in 3-D",
                     '<p class="note">Drag to turn, scroll to zoom, hover for pole and coil numbers. Red discs: '
                     "magnets with the north pole facing out (+1); blue: south out (−1). Grey rings: the stator "
                     "coils' faces, just outside the rotor."
                     + (" Rotor at the plan's first state." if plan is not None else "") + "</p>" +
                     _div(motor_figure(design, plan.steps[0].achieved if plan is not None else None), "motor3d", 600)))
    sections_html.append(("design", "Design, packings and metrics", design_tables(design, metrics)))
    if metrics.states:
        say("measuring the resolution histogram")
        dist = resolution_distances(design, samples, seed)
        sections_html.append(("resolution", "Resolution",
                         f'<p class="note">Park distance D(R, R̃) = θ(RᵀR̃) from {samples} orientations drawn '
                         f"uniformly on SO(3) (seed {seed}) to the nearest of the {metrics.states} stepper states. "
                         "A state is in reach when it lies within one max step.</p>" +
                         _div(resolution_figure(design, dist), "resolution", 360)))
    frames = 0
    summary = {}
    if plan is not None:
        say("animating the commutation")
        numbers = plan.summary().to_dict()
        fig = commutation_figure(design, plan, axis)
        frames = len(fig["frames"])
        thinned = (f" The animation shows {frames} evenly spaced steps of {len(plan.steps)}."
                   if frames < len(plan.steps) else "")
        axis_text = ", ".join(f"{a:.3f}" for a in axis)
        sections_html.append(("commutation", "Commutation",
                         f"<p><b>{numbers['steps']} steps</b> about the axis ({axis_text}) (fixed frame), planner "
                         f"{html.escape(plan.planner)}: {numbers['moves']} moves, {numbers['holds']} holds, "
                         f"{numbers['blocked']} blocked; error median {numbers['error_median_deg']:.2f}°, max "
                         f"{numbers['error_max_deg']:.2f}°, final {numbers['error_final_deg']:.2f}°.</p>"
                         '<p class="note">Left, the Fig. 10 view: everything projected on the plane normal to the '
                         "rotation axis (axis out of the page). Grey outlines: stator coils, tinted when energised "
                         "(red +1, blue −1, coil number inside); small filled outlines: the rotor poles they hold "
                         "(red north out, blue south out); hatched: the next pole to be attracted; black line: a "
                         "marker fixed in the rotor, dotted: where it started. Right, the same step in 3-D: poles as "
                         "dots, held poles outlined, the next pole as a diamond, energised coils as coloured rings, "
                         "the axis dashed. Move the slider or press ▶." + thinned + "</p>" +
                         _div(fig, "commutation", 620) + "<h3>Plan</h3>" + plan_table(plan, axis) + ROW_SCRIPT))
        summary["plan_steps"] = numbers["steps"]
    if simulation is not None:
        say("plotting the simulated run")
        executed = "every step settled" if simulation.executed else \
            f"{len(simulation.missed_steps)} steps missed"
        sections_html.append(("simulation", "Simulated run",
                         f'<p class="note">{len(simulation.times)} samples over {simulation.times[-1]:.2f} s; '
                         f"{executed} (within {math.degrees(simulation.tolerance):.2f}° of the planned state). "
                         "Rotation angles are read from the rotor marker about the commutation axis.</p>" +
                         _div(trajectory_figure(simulation, axis, plan.targets if plan is not None else None),
                              "trajectory", 520)))
    if energy_map is not None:
        say("plotting the energy map")
        sections_html.append(("energy", "Energy map", _div(energy_figure(energy_map), "energy", 460)))
    for extra in sections:
        if not isinstance(extra, Section):
            raise bad_value("sections", "spherestep.report.Section values", type(extra).__name__)
        sections_html.append((extra.anchor, extra.heading, extra.body()))
    say("writing the page")
    nav = " ".join(f'<a href="#section-{a}">{html.escape(h)}</a>' for a, h, _ in sections_html)
    stamp = _dt.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z")
    body = "".join(f'<section id="section-{a}"><h2>{html.escape(h)}</h2>{b}</section>' for a, h, b in sections_html)
    page = (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f'<meta name="viewport" content="width=device-width, initial-scale=1">'
            f"<title>{html.escape(title)}</title><style>{CSS}</style>"
            f'<script type="text/javascript">{plotly.offline.get_plotlyjs()}</script></head><body>'
            f"<h1>{html.escape(title)}</h1>"
            f'<p class="meta">spherestep {__version__}, {stamp}. Rotor {html.escape(design.rotor.label)} '
            f"({len(design.rotor)} magnets), stator {html.escape(design.stator.label)} ({len(design.stator)} coils). "
            "Angles in degrees; after Chirikjian &amp; Stein (1999).</p>"
            f"<nav>{nav}</nav>{body}</body></html>\n")
    summary = {"title": title, "sections": [a for a, _, _ in sections_html], "frames": frames} | summary
    return page, summary


def write_report(path, design, metrics=None, plan=None, simulation=None, energy_map=None, axis=None, *,
                 samples: int = 20_000, seed=0, title: str | None = None, sections: tuple[Section, ...] = (),
                 progress: Callable[[str], None] | None = None) -> dict:
    """Write the HTML report on ``design`` to ``path``, atomically; returns a summary of what was written.

    ``metrics``: as returned by :meth:`MotorDesign.metrics` (computed with ``samples`` and ``seed`` when
    None; the resolution histogram redraws the same ``seed``). ``plan``: a :class:`~spherestep.commutation.Plan`
    to tabulate and animate; ``simulation``: a :class:`~spherestep.dynamics.Simulation` of it; ``energy_map``:
    see :func:`energy_figure`; ``axis``: the rotation axis of the Fig. 10 view (default: the plan's);
    ``sections``: further :class:`Section` values (capability map, servo run, iron, sensors …) appended in order.
    ``progress`` is called with a short description of each stage.
    Returns ``{"path", "bytes", "title", "sections", "frames", "plan_steps"?}``.
    """
    page, summary = build_report(design, metrics, plan, simulation, energy_map, axis, samples=samples, seed=seed,
                                 title=title, sections=sections, progress=progress)
    written = write_text(path, page)
    return {"path": str(written), "bytes": written.stat().st_size} | summary
