"""Figures of the physical model (matplotlib, no GUI backend): the Fig. 6 curve with its fit, and the
comparison of the calibrated potential model with magpylib."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from ._calibration import Calibration, Comparison
from ._table import TorqueMap


def draw_force_curve(ax, calibration: Calibration) -> None:
    """Fig. 6(a): the simulated lateral force (N) against displacement (mm), the fit range and the quartic."""
    c, fit = calibration.curve, calibration.fit
    x = c.displacement
    ax.plot(1e3 * x, c.lateral, "o", ms=2.5, color="#2c6fbb", label="lateral force, magpylib getFT")
    ax.plot(1e3 * x, c.normal, "-", lw=1, color="0.55", label="normal force (+: attraction)")
    xf = np.linspace(0.0, calibration.limit, 200)
    ax.plot(1e3 * xf, fit.force_polynomial(xf), "-", color="#c0392b", lw=1.6, label="4th-order fit (fit range)")
    ax.axvline(1e3 * calibration.limit, color="0.7", lw=0.8, ls=":")
    ax.axhline(0.0, color="0.8", lw=0.6)
    ax.set_xlabel("lateral displacement of the magnet (mm)")
    ax.set_ylabel("force on the magnet (N)")
    ax.legend(fontsize=7.5, loc="upper right")


def figure_force_curve(calibration: Calibration, design_name: str = "design") -> Figure:
    """The curve of :func:`draw_force_curve` on its own (for ``spherestep forces``)."""
    fig = Figure(figsize=(6.4, 4.2))
    ax = fig.add_subplot()
    draw_force_curve(ax, calibration)
    gap = calibration.curve.gap
    ax.set_title(f"{design_name}: one magnet slid under one coil at a {1e3 * gap:.3g} mm gap (simulation)",
                 fontsize=9)
    fig.tight_layout()
    return fig


def figure_comparison(design, calibration: Calibration, comparison: Comparison, tmap: TorqueMap) -> Figure:
    """Four panels: (a) the Fig. 6 curve and fit, (b) the potential from the quartic and from the fitted
    profiles, (c) the pair torque τ(α) by magpylib, by the paper's translational estimate and by the
    calibrated potential, (d) the torques of the comparison sample, potential model against magpylib."""
    fig = Figure(figsize=(11.5, 8.6))
    (a, b), (c, d) = fig.subplots(2, 2)
    draw_force_curve(a, calibration)
    a.set_title("(a) Fig. 6(a) in simulation: force vs displacement", fontsize=10)

    fit, curve = calibration.fit, calibration.curve
    x = np.linspace(0.0, calibration.limit, 200)
    b.plot(1e3 * x, 1e3 * fit.potential_polynomial(x), color="#c0392b", label="−∫ quartic (Fig. 6(b))")
    b.plot(1e3 * x, 1e3 * fit.potential(x), "--", color="#2c6fbb",
           label=f"fitted vMF profiles (κ_s = {fit.stator.kappa:.1f})")
    b.set_xlabel("lateral displacement (mm)")
    b.set_ylabel("potential energy (mJ)")
    b.legend(fontsize=8)
    b.set_title("(b) Fig. 6(b): the potential and the calibrated model", fontsize=10)

    alpha = np.radians(np.linspace(0.0, 30.0, 301))
    r = design.radius
    h = 1e-6
    model_tau = -(fit.potential(r * (alpha + h)) - fit.potential(r * np.abs(alpha - h))) / (2 * h)
    c.plot(np.degrees(alpha), tmap.pair(alpha), color="#2c6fbb", lw=1.8, label="magpylib, pole on the sphere")
    shown = curve.displacement <= r * alpha[-1]
    c.plot(np.degrees(curve.displacement[shown] / r), r * curve.lateral[shown], ":", color="k",
           label="R·F(Rα): translation as rotation")
    c.plot(np.degrees(alpha), model_tau, "--", color="#c0392b", label="calibrated potential model")
    c.axhline(0.0, color="0.8", lw=0.6)
    c.set_xlabel("angle α between pole and coil axis (°)")
    c.set_ylabel("torque on the pole τ(α) (N·m)")
    c.legend(fontsize=8)
    c.set_title("(c) one pole, one coil: torque about the centre", fontsize=10)

    s = comparison.summary()["potential_vs_direct"]
    lim = 1.05 * float(np.max(np.abs(comparison.direct)))
    d.plot(comparison.direct.ravel(), comparison.potential.ravel(), ".", ms=2, alpha=0.5, color="#3a923a")
    d.plot([-lim, lim], [-lim, lim], color="0.5", lw=0.8)
    d.set_xlim(-lim, lim)
    d.set_ylim(-lim, lim)
    d.set_aspect("equal")
    d.set_xlabel(f"magpylib getFT torque component (N·m, {comparison.meshing} cells/magnet)")
    d.set_ylabel("potential-model torque component (N·m)")
    d.set_title(f"(d) {len(comparison.rotations)} random orientations, 2–4 coils: r = {s['correlation']:.3f}, "
                f"rel. error {100 * s['relative_error']:.0f} %", fontsize=10)
    fig.tight_layout()
    return fig

