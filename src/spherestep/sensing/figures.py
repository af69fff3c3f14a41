"""Figures of the sensing room: the sensor layout in the stator and the worst-case bound against sensor count."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure


def figure_layout(design, placement, count: int | None = None) -> Figure:
    """(a) the rotor sphere, the coils' faces (grey rings) and the first ``count`` sensors of ``placement``
    (numbered in greedy order), seen from below and the side; (b) the worst-case Cramér–Rao standard
    deviation (degrees) against sensor count."""
    k = len(placement.order) if count is None else int(count)
    p = placement.candidates[placement.order[:k]]
    fig = Figure(figsize=(11, 5.2))
    grid = fig.add_gridspec(1, 2, width_ratios=(1.3, 1.0))
    ax = fig.add_subplot(grid[0], projection="3d")
    u, v = np.mgrid[0:2 * np.pi:40j, 0:np.pi:20j]
    r = design.radius
    ax.plot_wireframe(r * np.cos(u) * np.sin(v), r * np.sin(u) * np.sin(v), r * np.cos(v), color="#d0d0d0",
                      linewidth=0.4)
    t = np.linspace(0, 2 * np.pi, 48)
    for c in design.stator.centers:
        e1 = np.cross(c, [0.0, 0.0, 1.0] if abs(c[2]) < 0.9 else [1.0, 0.0, 0.0])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(c, e1)
        ring = (r + design.air_gap) * c + 0.5 * design.coil_diameter * (np.outer(np.cos(t), e1)
                                                                       + np.outer(np.sin(t), e2))
        ax.plot(ring[:, 0], ring[:, 1], ring[:, 2], color="#606060", linewidth=0.8)
    ax.scatter(p[:, 0], p[:, 1], p[:, 2], color="#d62728", s=18, depthshade=False, label=f"{k} magnetometers")
    for i, q in enumerate(p[:12]):
        ax.text(*(q * 1.08), str(i + 1), fontsize=6, color="#d62728")
    ax.view_init(elev=-35, azim=30)
    ax.set_box_aspect((1, 1, 1), zoom=1.45)
    ax.set_axis_off()
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"(a) {design.name}: coils (rings) and sensors, from below", fontsize=9)
    bx = fig.add_subplot(grid[1])
    n = np.arange(2, len(placement.order) + 1)
    bx.semilogy(n, placement.bound_deg()[1:], "o-", color="#1f77b4", markersize=3)
    bx.set_xlabel("sensors (greedy order)")
    bx.set_ylabel("worst-case Cramér–Rao σ (°)")
    bx.grid(True, which="both", alpha=0.3)
    bx.set_title("(b) worst axis, worst orientation over SO(3)", fontsize=9)
    fig.tight_layout()
    return fig
