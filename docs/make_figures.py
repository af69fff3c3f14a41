"""Generate the documentation figures into ``docs/figures/`` (PNG, matplotlib's Agg backend).

Usage::

    python docs/make_figures.py            # every figure
    python docs/make_figures.py packings   # only the named ones
    python docs/make_figures.py --list     # the names

Each figure is a function ``(outdir: Path) -> Path`` registered in :data:`FIGURES` with the :func:`figure`
decorator; add new ones the same way. Files are written whole or not at all (temporary file, then rename).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from collections.abc import Callable

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Polygon  # noqa: E402

from spherestep.atomic import atomic_path  # noqa: E402
from spherestep.packing import CONSTRUCTIONS, NAMES, by_name, congruent  # noqa: E402

OUTDIR = Path(__file__).resolve().parent / "figures"
FIGURES: dict[str, Callable[[Path], Path]] = {}


def figure(name: str):
    """Register a figure function under ``name``."""
    def register(func):
        FIGURES[name] = func
        return func
    return register


def save(fig, path: Path, dpi: int = 110) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight", facecolor="white")
        tmp.chmod(0o644)  # mkstemp creates 0600
    plt.close(fig)
    return path


# --- orthographic views of caps ----------------------------------------------------------------------
def view_basis(azimuth_deg: float = 25.0, elevation_deg: float = 20.0) -> np.ndarray:
    """Rows ``(right, up, towards the viewer)`` of an orthographic camera looking at the origin."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    toward = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    right = np.array([-np.sin(az), np.cos(az), 0.0])
    up = np.cross(toward, right)
    return np.array([right, up, toward])


def cap_boundaries(centers: np.ndarray, radii: np.ndarray, samples: int = 96) -> np.ndarray:
    """Points ``(N, samples, 3)`` on each cap's boundary circle ``cos r c + sin r (cos t e1 + sin t e2)``."""
    helper = np.where(np.abs(centers[:, 2:3]) < 0.9, [[0.0, 0.0, 1.0]], [[1.0, 0.0, 0.0]])
    e1 = np.cross(centers, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(centers, e1)
    t = np.linspace(0.0, 2.0 * np.pi, samples)
    ring = np.cos(t)[None, :, None] * e1[:, None, :] + np.sin(t)[None, :, None] * e2[:, None, :]
    return np.cos(radii)[:, None, None] * centers[:, None, :] + np.sin(radii)[:, None, None] * ring


def draw_caps(ax, centers, radii, colour, basis=None, edge="#1f1f1f"):
    """Draw caps on the unit sphere seen from ``basis[2]``: the visible part of each cap filled, its
    boundary drawn on the front hemisphere only (hidden points are pushed radially onto the limb)."""
    basis = view_basis() if basis is None else basis
    ax.add_patch(Circle((0, 0), 1.0, facecolor="#f4f4f4", edgecolor="#808080", lw=0.8, zorder=0))
    pts = cap_boundaries(centers, radii) @ basis.T  # (N, S, 3): x, y, depth
    depth_order = np.argsort(centers @ basis[2])
    for k in depth_order:
        xy, depth = pts[k, :, :2], pts[k, :, 2]
        if np.all(depth < 0):
            continue
        shade = 0.55 + 0.45 * max(0.0, float(centers[k] @ basis[2]))  # darker towards the limb
        face = np.clip(np.array(matplotlib.colors.to_rgb(colour)) * shade + (1 - shade), 0, 1)
        clipped = xy.copy()
        hidden = depth < 0
        clipped[hidden] /= np.linalg.norm(clipped[hidden], axis=1, keepdims=True)
        ax.add_patch(Polygon(clipped, closed=True, facecolor=face, edgecolor="none", zorder=1))
        visible = np.where(hidden[:, None], np.nan, xy)  # NaN breaks the line where the circle goes behind
        ax.plot(visible[:, 0], visible[:, 1], color=edge, lw=0.6, zorder=2)
    ax.add_patch(Circle((0, 0), 1.0, facecolor="none", edgecolor="#606060", lw=0.9, zorder=3))  # the limb
    ax.set_xlim(-1.06, 1.06)
    ax.set_ylim(-1.06, 1.06)
    ax.set_aspect("equal")
    ax.axis("off")


@figure("packings")
def packings(outdir: Path) -> Path:
    """The 3 × 7 base packings (Sec. II-B-3): rows T, O, I; columns the seven Wythoff constructions."""
    family_colour = {"T": "#3b75af", "O": "#d9822b", "I": "#3a923a"}
    family_label = {"T": "tetrahedral (T)", "O": "octahedral (O)", "I": "icosahedral (I)"}
    construction_label = {"P": "P: solid vertex", "Q": "Q: face centre", "R": "R: edge midpoint",
                          "PR": "on side PR", "QR": "on side QR", "PQ": "on side PQ", "PQR": "PQR: incentre"}
    kept = {}  # T packings congruent to another one, for the "≅" notes
    o_family = [by_name(n) for n in NAMES["O"]]
    fig, axes = plt.subplots(3, 7, figsize=(17.5, 8.6))
    for row, family in enumerate(("T", "O", "I")):
        for col, construction in enumerate(CONSTRUCTIONS):
            name = NAMES[family][col]
            p = by_name(name)
            ax = axes[row, col]
            draw_caps(ax, p.centers, p.radii, family_colour[family])
            label = name.replace("tetrahedral-", "tetrahedral-\n") if len(name) > 22 else name
            ax.set_title(f"{label}\n{len(p)} caps, r = {np.degrees(p.radii[0]):.2f}°", fontsize=9.5, pad=3)
            if family == "T":  # note the copies: congruent to an octahedral one or to an earlier T one
                earlier = o_family + [by_name(n) for n in NAMES["T"][:col]]
                twin = next((q.name for q in earlier if congruent(p, q)), None)
                if twin:
                    kept[name] = twin
                    ax.text(0.5, -0.04, f"≅ {twin}", transform=ax.transAxes, ha="center", va="top",
                            fontsize=8.5, style="italic", color="#555555")
            if row == 0:
                ax.text(0.5, 1.32, construction_label[construction], transform=ax.transAxes, ha="center",
                        va="bottom", fontsize=10, weight="bold")
        axes[row, 0].text(-0.16, 0.5, family_label[family], transform=axes[row, 0].transAxes, rotation=90,
                          ha="right", va="center", fontsize=11, weight="bold", color=family_colour[family])
    fig.suptitle("The 21 packings of congruent kissing caps: the primary circle at a corner, on a side or "
                 f"inside the fundamental triangle PQR ({21 - len(kept)} distinct up to rotation)",
                 fontsize=12.5, y=1.0)
    fig.subplots_adjust(wspace=0.08, hspace=0.42)
    return save(fig, outdir / "packings.png")


@figure("potential_well")
def potential_well(outdir: Path) -> Path:
    """Eq. (4) around a stepper state of the prototype with the state's coils energised (Sec. III-B, Fig. 6):
    the energy over rotations exp((a e1 + b e2)^) R_s about two fixed-frame axes normal to the held coils' mean
    direction, and a cut with the torque about e1 (the rotational analogue of Fig. 6's force and potential)."""
    from spherestep import so3
    from spherestep.motor import prototype
    from spherestep.potential import MotorPotential, coil_currents
    from spherestep.statics import equilibrium

    design = prototype()
    states = design.states()
    index = 0
    R_s = states.rotations[index]
    c = coil_currents(design, states.coils(index))
    model = MotorPotential(design)
    eq = equilibrium(model, R_s, c)
    mean = design.stator.centers[[k for _, k in states.held(index)]].sum(axis=0)
    mean /= np.linalg.norm(mean)
    e1 = np.cross(mean, [1.0, 0.0, 0.0] if abs(mean[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(mean, e1)
    span = np.radians(np.linspace(-30.0, 30.0, 241))
    a, b = np.meshgrid(span, span, indexing="xy")
    R = so3.exp(a[..., None] * e1 + b[..., None] * e2) @ R_s
    V = model.energy_pairwise(R, c)
    offset = so3.log(eq.rotation @ R_s.T)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11.5, 4.8), gridspec_kw={"width_ratios": [1.05, 1]})
    shown = left.contourf(np.degrees(a), np.degrees(b), V - eq.energy, levels=24, cmap="viridis")
    left.contour(np.degrees(a), np.degrees(b), V - eq.energy, levels=24, colors="k", linewidths=0.3, alpha=0.5)
    fig.colorbar(shown, ax=left, label="V(R, c) − V(R_eq, c)  (model units)")
    left.plot(0, 0, "w+", ms=11, mew=2, label="geometric state")
    left.plot(*np.degrees([offset @ e1, offset @ e2]), "rx", ms=9, mew=2, label="equilibrium (min of V)")
    left.set_xlabel("rotation about e1 (°)")
    left.set_ylabel("rotation about e2 (°)")
    left.set_aspect("equal")
    left.legend(loc="upper right", fontsize=8, framealpha=0.85)
    left.set_title(f"state {index}: {len(states.held(index))} held pairs, coils {sorted(states.coils(index))}",
                   fontsize=10)
    line = so3.exp(span[:, None] * e1) @ eq.rotation
    E, tau = model.energy_and_torque(line, c)
    right.plot(np.degrees(span), E - eq.energy, color="k", label="energy V − V_eq")
    right.set_xlabel("rotation about e1 from the equilibrium (°)")
    right.set_ylabel("energy (model units)")
    twin = right.twinx()
    twin.plot(np.degrees(span), tau @ e1, color="#c0392b", label="torque τ · e1")
    twin.axhline(0, color="#c0392b", lw=0.5, ls=":")
    twin.set_ylabel("torque about e1 (model units)", color="#c0392b")
    right.set_title("cut through the minimum: the well and its restoring torque", fontsize=10)
    fig.suptitle(f"Eq. (4) for the prototype (von Mises–Fisher profiles, L = {model.bandlimit}); equilibrium "
                 f"{np.degrees(so3.distance(eq.rotation, R_s)):.2f}° from the geometric state", fontsize=11)
    fig.tight_layout()
    return save(fig, outdir / "potential_well.png")


@figure("magnetics_fig6")
def magnetics_fig6(outdir: Path) -> Path:
    """Fig. 6 in simulation (magpylib) and the calibrated potential model against magpylib: the force curve
    and its quartic, the potentials, the pole–coil torque three ways, and torques on 1000 random orientations
    (direct getFT at 8 cells per magnet: about a minute). docs/magnetics.md."""
    from spherestep import magnetics as mg
    from spherestep.motor import prototype

    design = prototype()
    calibration = mg.calibrate(design)
    tmap = mg.torque_map(design)
    comparison = mg.compare_models(design, calibration, tmap, samples=1000, states=300, seed=0)
    return save(mg.figure_comparison(design, calibration, comparison, tmap), outdir / "magnetics_fig6.png")


@figure("commutation_steps")
def commutation_steps(outdir: Path) -> Path:
    """Fig. 10 view: three steps of the demo's 360° turn about (1, 0.5, 2) on the prototype."""
    import math

    from spherestep import plots
    from spherestep.commutation import about_axis, plan_geometric, steps_for
    from spherestep.motor import prototype

    design = prototype()
    axis = np.array([1.0, 0.5, 2.0])
    start = design.states().rotations[int(design.states().nearest(np.eye(3))[1].ravel()[0])]
    plan = plan_geometric(design, about_axis(axis, 2 * math.pi, steps_for(2 * math.pi, 0.35 * design.max_step),
                                             start=start))
    return plots.save_figure(plots.figure_steps(design, plan, axis), outdir / "commutation_steps.png")


@figure("iron_basins")
def iron_basins(outdir: Path) -> Path:
    """Basins of attraction on the prototype's iron model, in the slice of orientations ``exp(a ẑ + b x̂) R̃₀``
    about the first rest pose of the iron plan of 30° about z: with every coil off (the detent alone) and under
    the plan's first mask. Each point is coloured by the minimum the energy's descent from it reaches; crosses
    mark the minima (where they lie in the slice), the circle the rest pose the step starts from."""
    import math

    from spherestep import so3
    from spherestep.commutation import plan_iron, turn_targets
    from spherestep.dynamics import iron_tuning
    from spherestep.magnetics import design_model
    from spherestep.motor import prototype
    from spherestep.statics import descend

    design = prototype()
    own = design_model(design)
    plan = plan_iron(design, turn_targets(design, (0, 0, 1), math.radians(30)), own.model, limits=own.limits,
                     tuning=iron_tuning(design, own.model))
    R0 = plan.steps[0].achieved
    span = np.radians(np.linspace(-12, 12, 61))
    a, b = np.meshgrid(span, span, indexing="xy")
    w = np.stack([b.ravel(), np.zeros(a.size), a.ravel()], axis=1)  # x̂ b + ẑ a
    starts = so3.exp(w) @ R0
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.6))
    masks = (("every coil off: the detent alone", np.zeros(len(design.stator))),
             (f"step 1's mask, coils {sorted(plan.steps[1].coils)}", design.coil_currents(plan.steps[1].coils)))
    for ax, (title, c) in zip(axes, masks):
        ends = descend(own.model, starts.copy(), np.repeat(c[None], len(starts), axis=0))[0]
        labels = np.full(len(ends), -1)
        minima = []
        for i, R in enumerate(ends):
            for k, M in enumerate(minima):
                if so3.distance(R, M) < math.radians(0.1):
                    labels[i] = k
                    break
            else:
                labels[i] = len(minima)
                minima.append(R)
        ax.imshow(labels.reshape(a.shape) % 20, origin="lower", cmap="tab20", interpolation="nearest",
                  extent=[-12, 12, -12, 12], vmin=0, vmax=19)
        for M in minima:
            v = np.degrees(so3.log(M @ R0.T))
            if abs(v[0]) <= 12 and abs(v[2]) <= 12 and abs(v[1]) < 1.0:
                ax.plot(v[0], v[2], "kx", ms=8, mew=2)
        ax.plot(0, 0, "o", mfc="none", mec="k", ms=10, mew=2)
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("turn about x (°)")
        ax.set_ylabel("turn about z (°)")
    fig.suptitle("Basins of the iron model's minima about the prototype's first rest pose (one colour per minimum)",
                 fontsize=10)
    return save(fig, outdir / "iron_basins.png")


@figure("sensing_layout")
def sensing_layout(outdir: Path) -> Path:
    """The prototype's 24 magnetometers (greedy placement) between its coils, and the worst-case bound against
    sensor count. docs/sensing.md."""
    from spherestep import plots, sensing
    from spherestep.motor import prototype

    design = prototype()
    placement = sensing.greedy_placement(design, 24)
    return plots.save_figure(sensing.figure_layout(design, placement), outdir / "sensing_layout.png")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help=f"figures to make (default all): {', '.join(FIGURES)}")
    parser.add_argument("--outdir", type=Path, default=OUTDIR)
    parser.add_argument("--list", action="store_true", help="print the figure names and exit")
    args = parser.parse_args(argv)
    if args.list:
        print("\n".join(FIGURES))
        return 0
    unknown = [n for n in args.names if n not in FIGURES]
    if unknown:
        print(f"make_figures: unknown figure(s) {', '.join(unknown)}; choose from {', '.join(FIGURES)}",
              file=sys.stderr)
        return 2
    for name in args.names or list(FIGURES):
        path = FIGURES[name](args.outdir)
        print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
