"""Figures (matplotlib, no GUI backend): the Fig. 10 view of commutation steps, a 3-D view of the motor,
and a plan's tracking error.

Fig. 10 view (:mod:`spherestep.fig10`, the geometry shared with the HTML report): coils tinted when energised,
held poles filled, the next pole hatched, a line fixed in the rotor.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from .atomic import atomic_path
from .fig10 import POLARITY_COLOUR, cap_outline, fig10_step

def draw_step(ax, design, plan, i: int, axis) -> None:
    """Draw step ``i`` of ``plan`` in the Fig. 10 view about ``axis`` on matplotlib axes ``ax``
    (the geometry of :func:`spherestep.fig10.fig10_step`)."""
    view = fig10_step(design, plan, i, axis, points=64)
    for ring in view.coils:
        ax.add_patch(Polygon(ring, closed=True, facecolor="none", edgecolor="0.35", lw=0.8))
    for sign, rings in view.energised.items():
        for ring in rings:
            ax.add_patch(Polygon(ring, closed=True, facecolor=POLARITY_COLOUR[sign], alpha=0.25, edgecolor="0.35",
                                 lw=0.8))
    for k, xy in view.labels:
        ax.text(*xy, str(k), ha="center", va="center", fontsize=6, color="0.2")
    for sign, rings in view.held.items():
        for ring in rings:
            ax.add_patch(Polygon(ring, closed=True, facecolor=POLARITY_COLOUR[sign], edgecolor="k", lw=0.8))
    for ring in view.next_pole:
        ax.add_patch(Polygon(ring, closed=True, facecolor="white", edgecolor=POLARITY_COLOUR[view.next_polarity],
                             hatch="////", lw=0.8))
    ax.plot(view.marker[:, 0], view.marker[:, 1], color="k", lw=1.2)
    ax.plot(0, 0, marker="o", color="k", ms=3)
    t = np.linspace(0, 2 * np.pi, 128)
    ax.add_patch(Polygon(np.column_stack([np.cos(t), np.sin(t)]), closed=True, fill=False, edgecolor="0.8", lw=0.6))
    ax.set_xlim(-1.25, 1.25)
    ax.set_ylim(-1.25, 1.25)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(f"step {i}: error {np.degrees(plan.steps[i].error):.2f}°", fontsize=9)


def figure_steps(design, plan, axis, steps=None) -> Figure:
    """A row of Fig. 10 panels (default: three consecutive steps from the first move)."""
    if steps is None:
        first = next((s.index for s in plan.steps[1:] if s.status == "ok"), 0)
        steps = [i for i in (first - 1, first, first + 1) if 0 <= i < len(plan.steps)]
    fig = Figure(figsize=(3.2 * len(steps), 3.4))
    for col, i in enumerate(steps):
        draw_step(fig.add_subplot(1, len(steps), col + 1), design, plan, i, axis)
    fig.suptitle(f"{design.name}: commutation about ({', '.join(f'{a:.2f}' for a in np.asarray(axis) / np.linalg.norm(axis))})"
                 " — filled: held poles, hatched: next pole", fontsize=9)
    fig.tight_layout()
    return fig


def figure_motor_3d(design, R=None) -> Figure:
    """3-D view: rotor magnets at orientation ``R`` (red north-out, blue south-out) and stator coils."""
    R = np.eye(3) if R is None else np.asarray(R)
    fig = Figure(figsize=(6, 6))
    ax = fig.add_subplot(projection="3d")
    t = np.linspace(0, np.pi, 25)
    p = np.linspace(0, 2 * np.pi, 49)
    ax.plot_wireframe(np.outer(np.sin(t), np.cos(p)), np.outer(np.sin(t), np.sin(p)),
                      np.outer(np.cos(t), np.ones_like(p)), color="0.85", lw=0.4)
    for j, u in enumerate(design.rotor.centers @ R.T):
        ring = cap_outline(u, design.magnet_angle, 24)
        ax.plot(*ring.T, color=POLARITY_COLOUR[int(design.polarity[j])], lw=1.0)
    scale = 1.0 + design.air_gap / design.radius + 0.02
    for v in design.stator.centers:
        ring = cap_outline(v, design.coil_angle, 32) * scale
        ax.plot(*ring.T, color="0.2", lw=1.6)
    ax.set_box_aspect((1, 1, 1))
    ax.set_axis_off()
    ax.set_title(f"{design.name}: {len(design.rotor)} magnets, {len(design.stator)} coils", fontsize=10)
    return fig


def figure_plan_error(plan) -> Figure:
    """Tracking error (degrees) per step, with holds and blocked steps marked."""
    fig = Figure(figsize=(7, 3))
    ax = fig.add_subplot()
    err = np.degrees(plan.errors)
    ax.plot(err, color="k", lw=1.0, label="error D(R̃ᵢ, Rᵢ)")
    hold = [s.index for s in plan.steps if s.status == "hold"]
    bad = [s.index for s in plan.steps if s.status not in ("ok", "hold")]
    ax.plot(hold, err[hold], "o", ms=3, color="0.6", label="hold")
    if bad:
        ax.plot(bad, err[bad], "x", ms=5, color="#c0392b", label="detour / blocked")
    ax.set_xlabel("step")
    ax.set_ylabel("error (°)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def save_figure(fig: Figure, path: str | Path, dpi: int = 130) -> Path:
    """Write ``fig`` to ``path`` atomically (format from the suffix)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=dpi)
    return path


def figure_closed_loop(run, axis) -> Figure:
    """Desired and true rotation angle about ``axis`` (degrees) per controller step of a closed-loop run,
    missed steps marked."""
    from . import so3

    fig = Figure(figsize=(7, 3.2))
    ax = fig.add_subplot()
    steps = np.arange(len(run.targets))
    true = np.degrees(so3.turned_angle(run.true, axis))
    ax.step(steps, np.degrees(so3.turned_angle(run.targets, axis)), where="post", color="0.6", lw=1.0,
            label="desired Rᵢ")
    ax.plot(steps, true, color="k", lw=1.0, marker=".", ms=3, label="true (simulated)")
    ax.plot(steps[run.missed], true[run.missed], "x", color="#c0392b", ms=5, label="missed step")
    ax.set_xlabel("controller step")
    ax.set_ylabel("rotation about the axis (°)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig


def figure_simulation(sim, plan, axis, dwell: float) -> Figure:
    """Desired, planned and simulated rotation angle about ``axis`` (degrees) against time."""
    from . import so3

    fig = Figure(figsize=(7, 3.2))
    ax = fig.add_subplot()
    steps = np.arange(len(plan.steps)) * dwell
    ax.step(steps, np.degrees(so3.turned_angle(plan.targets, axis)), where="post", color="0.6", lw=1.0,
            label="desired Rᵢ")
    ax.step(steps, np.degrees(so3.turned_angle(plan.achieved, axis)), where="post", color="#2c6fbb", lw=1.0,
            label="planned R̃ᵢ")
    ax.plot(sim.times, np.degrees(so3.turned_angle(sim.orientations, axis)), color="k", lw=1.0, label="simulated")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("rotation about the axis (°)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    return fig
