"""``spherestep forces``: the physical model's Fig. 6 curve with its fit, and holding torques of stepper states."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from ..errors import bad_value
from .app import app
from .common import console, design_from, print_json, usable
from .progress import progress


@app.command()
def forces(
    design_path: Path = typer.Option(None, "--design", help="Design file (YAML/TOML); default the built-in prototype."),
    out: Path = typer.Option(Path("spherestep-out/forces"), "--out", help="Output folder."),
    states: int = typer.Option(8, "--states", help="Number of stepper states to sample for the torque table."),
    seed: int = typer.Option(0, "--seed", help="Seed of the state sample."),
    as_json: bool = typer.Option(False, "--json", help="Print the results as JSON."),
    core: str = typer.Option(None, "--core", help="Coil cores to report: air (the winding alone), or both: also the "
                             "design's coils (its coil section; the prototype's: iron) on iron cores (detent, states, "
                             "polarity, saturation, power; about 20 s for the prototype, minutes for a design or "
                             "coil other than the prototype's). Default: both when the design's coils are iron-cored, "
                             "else air."),
) -> None:
    """Physical forces by magpylib: the Fig. 6 force curve (one magnet slid under one coil, simulated) with its
    4th-order fit (force_curve.csv, force_curve.png), and holding and stepping torques (N·m) of a sample of
    stepper states (forces.json; a table, or --json).

    With --core both also the design's coils with iron cores against the air cores: detent, stepper states,
    polarity, saturation and power (iron.json, iron.png).

    Example: [bold]spherestep forces --out forces --states 10 --core both[/bold]
    """
    import numpy as np
    from rich.table import Table

    from .. import magnetics as mg
    from ..atomic import write_text
    from ..outputs import Outputs, output_folder
    from ..plots import save_figure

    if states < 1 or states > 10_000:
        raise bad_value("--states", "a number of states from 1 to 10000", states)
    if seed < 0:
        raise bad_value("--seed", "a whole number ≥ 0", seed)
    if core not in (None, "air", "both"):
        raise bad_value("--core", "air or both (default: both for an iron-cored design, else air)", core)
    out = output_folder(out, "--out")
    design = usable(design_from(design_path), "--design", design_path)
    core = core or ("both" if design.coil.core == "iron" else "air")
    with progress("enumerating stepper states", enabled=not as_json) as say:
        st = design.states()
        say("simulating the Fig. 6 curve and calibrating")
        cal = mg.calibrate(design)
        tmap = mg.torque_map(design)
        idx = np.sort(np.random.default_rng(seed).choice(len(st), min(states, len(st)), replace=False))
        say("holding and step torques")
        rows = [r.to_dict(degrees=True) for r in mg.state_torques(design, tmap, idx)]
        if core != "air":
            say("iron cores: detent, states, saturation")
            iron = mg.iron_summary(design, states=min(states, 12), seed=seed)
    files = Outputs(out, ("force_curve.csv", "force_curve.png", "forces.json"))
    csv_path = out / "force_curve.csv"
    with files:
        cal.curve.save(csv_path, design.name)
        png_path = save_figure(mg.figure_force_curve(cal, design.name), out / "force_curve.png")
    curve = cal.curve
    peak = int(np.argmin(curve.lateral))
    info = {
        "design": design.name,
        "model": mg.model_summary(design),
        "curve": {"source": "simulation (magpylib getFT), not a measurement", "gap_m": curve.gap,
                  "meshing": curve.meshing, "peak_lateral_force_N": float(-curve.lateral[peak]),
                  "peak_at_m": float(curve.displacement[peak]),
                  "normal_force_aligned_N": float(curve.normal[int(np.argmin(np.abs(curve.displacement)))]),
                  "fit_range_m": [0.0, cal.limit],
                  "fit_coefficients_N_per_m^i": cal.fit.force_polynomial.coef.tolist(),
                  "fitted_stator_profile": {"kappa": cal.fit.stator.kappa, "amplitude": cal.fit.stator.amplitude}},
        "states": rows,
    }
    with files:
        json_path = write_text(out / "forces.json", json.dumps(info, indent=1))
    info["files"] = [str(csv_path), str(png_path), str(json_path)]
    if core != "air":
        info["iron"] = iron.to_dict(degrees=True)
        with Outputs(out, ("iron.json", "iron.png")):
            info["files"].append(str(write_text(out / "iron.json", json.dumps(info["iron"], indent=1))))
            info["files"].append(str(save_figure(iron.figure(design), out / "iron.png")))
    if as_json:
        print_json(info)
        return
    console.print(f"Fig. 6 curve (simulated): peak lateral force {info['curve']['peak_lateral_force_N']:.3f} N at "
                  f"{1e3 * info['curve']['peak_at_m']:.1f} mm; attraction when aligned "
                  f"{info['curve']['normal_force_aligned_N']:.3f} N; quartic fitted on 0–{1e3 * cal.limit:.1f} mm")
    table = Table(title=f"{design.name}: torques at {len(rows)} stepper states (N·m)")
    for col in ("state", "coils", "offset °", "holding", "strongest", "min stiffness N·m/rad",
                "downhill steps", "peak step torque"):
        table.add_column(col, justify="right", no_wrap=True)
    for r in rows:
        table.add_row(str(r["state"]), " ".join(f"{k}{'+' if s > 0 else '−'}" for k, s in r["coils"].items()),
                      f"{r['equilibrium_offset_deg']:.2f}", f"{r['holding_torque_Nm']:.3f}",
                      f"{r['strongest_axis_Nm']:.3f}", f"{r['stiffness_Nm_per_rad'][0]:.3f}",
                      f"{r['downhill_steps'] or 0}/{r['steps']}",
                      f"{r['step_peak_torque_Nm']:.3f}" if r["step_peak_torque_Nm"] is not None else "—")
    console.print(table)
    if "iron" in info:
        d = info["iron"]
        t = Table(title=f"{design.name}: air against iron cores (pole–coil pair, N·m; states: {d['states_sampled']})")
        for col in ("", "air", "iron"):
            t.add_column(col, justify="right")
        t.add_row("peak pull-in torque of a +1 coil", f"{d['air_peak_Nm']:.3f}", f"{d['linear_peak_Nm']:.3f}")
        t.add_row("peak detent (coil off)", "0", f"{d['detent_peak_Nm']:.3f} at {d['detent_peak_angle_deg']:.1f}°")
        t.add_row("rest poses with all coils off", "none (no torque)",
                  f"{d['unpowered_minima']}/{d['unpowered_starts']} starts, holding median "
                  f"{d['unpowered_holding_median_Nm']:.3f}")
        t.add_row("stepper states that are minima", f"{d['air_states_minima']}", f"{d['iron_states_minima']}")
        t.add_row("offset from geometric state, median °", f"{d['air_offset_median_deg']:.2f}",
                  f"{d['iron_offset_median_deg']:.2f} (max {d['iron_offset_max_deg']:.2f})")
        t.add_row("holding torque, median", f"{d['air_holding_median_Nm']:.3f}", f"{d['iron_holding_median_Nm']:.3f}")
        t.add_row("coil against the pole still pulls in", "no", "yes" if d["wrong_polarity_attracts"] else "no")
        t.add_row("pole-face |B|, linear iron (knee)", "—", f"{d['max_core_B_T']:.2f} T ({d['knee_T']:.2f} T)")
        t.add_row("power per coil at nominal current", "—",
                  f"{d['electrics']['power_W']:.1f} W ({d['electrics']['supply_W']:.0f} W supply)")
        console.print(t)
    console.print(f"wrote {len(info['files'])} files to {out}/")

