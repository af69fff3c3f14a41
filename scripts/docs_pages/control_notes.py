"""docs/control.md's hand-measured notes (``data/docs_control_notes.json``: :func:`measure_control_notes`)."""

from __future__ import annotations

import json
import math
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from .common import _mode, _notes_when, _run_footer, _run_header, _signed, table


NOTES_AXIS = (1.0, 0.5, 2.0)  # the demo's 360° turn, from the stepper state nearest the identity


def measure_control_notes() -> dict:
    """docs/control.md's numbers of today's code outside the demo and the benchmarks: the torque map's capability
    (1000 orientations, seed 0), the iron coil's limits, the demo turn's plans and their servo runs
    (``bench_time_optimal.py --servo --repeat 1``), ``drive_turn``'s wall time, the coupled model's cost per
    orientation and which holds the weakest mismatched plant can reach. ~2–4 min of one core."""
    import numpy as np

    from spherestep import so3
    from spherestep.commutation import turn
    from spherestep.control import bang_bang_time, fastest_turn, plan_trapezoid, torque_capability
    from spherestep.control.allocation import allocate_matrix
    from spherestep.drive import drive_turn
    from spherestep.dynamics import Rotor, simulate_servo
    from spherestep.errors import InputError
    from spherestep.magnetics import design_model, iron_model, torque_map
    from spherestep.magnetics.mismatch import MISMATCH_CASES, scaled_model
    from spherestep.motor import prototype
    from spherestep.sensing import NoisySensor

    run = _run_header("control-notes")
    design = prototype()
    t = time.perf_counter()
    cap = torque_capability(design, torque_map(design), samples=1000, seed=0)
    sv = cap.singular_values
    run["capability"] = {"samples": 1000, "seed": 0, "seconds": time.perf_counter() - t,
                         "percentiles": cap.percentiles(), "at_least_1": cap.fraction_at_least(1.0),
                         "at_least_1_5": cap.fraction_at_least(1.5), "sigma3_median": float(np.median(sv[:, -1])),
                         "condition_median": float(np.median(cap.condition)),
                         "condition_p95": float(np.percentile(cap.condition, 95))}
    iron, air = design_model(design, "iron"), design_model(design, "air")
    lim = iron.limits
    run["iron_coil"] = {"resistance_ohm": lim.resistance, "nominal_current_A": lim.nominal_current,
                        "max_current_A": lim.max_current, "rho": lim.per_unit_power_radius,
                        "inductance_H": lim.inductance, "time_constant_s": lim.time_constant,
                        "air_inductance_H": air.limits.inductance}
    axis = np.array(NOTES_AXIS)
    R0 = turn(design, axis, 2 * math.pi).targets[0]
    inertia = Rotor.from_design(design).inertia
    run["turns"] = {}
    for core, dm in (("iron", iron), ("air", air)):
        row = {"model": dm.label}
        t = time.perf_counter()
        ft = fastest_turn(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits)
        row["fastest"] = {"duration_s": ft.duration, "plan_s": time.perf_counter() - t, "path": ft.path,
                          "margin": ft.margin, "paths_tried": len(ft.candidates)}
        t = time.perf_counter()
        row["bound_s"] = bang_bang_time(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits)
        row["bound_plan_s"] = time.perf_counter() - t
        try:
            trap = plan_trapezoid(dm.model, R0, axis, 2 * math.pi, inertia, dm.limits)
            row["trapezoid"] = {"duration_s": trap.duration}
        except InputError as error:
            trap, row["trapezoid"] = None, {"refused": str(error).splitlines()[0]}
        for name, traj in (("trapezoid", trap), ("fastest", ft.trajectory)):
            if traj is None:
                continue
            t = time.perf_counter()
            r = simulate_servo(design, traj, dm.model, limits=dm.limits, sensor=NoisySensor(math.radians(0.02), rng=0))
            row[name].update({"max_tracking_deg": math.degrees(float(r.tracking_error.max())),
                              "final_deg": math.degrees(float(r.tracking_error[-1])),
                              "peak_power_W": float(r.power.max()), "mean_power_W": float(r.power.mean()),
                              "reachable": float(np.mean(r.reachable)), "wall_s": time.perf_counter() - t})
        run["turns"][core] = row
    t = time.perf_counter()
    d = drive_turn(design, axis, 2 * math.pi, mode="servo", sensor_noise=math.radians(0.02))
    run["move"] = {"wall_s": time.perf_counter() - t, "time_s": d.time, "final_deg": math.degrees(d.final_error)}
    coupled, pairwise = iron_model(design, coupling=True), iron_model(design, coupling=False)
    c = np.zeros(len(design.stator))
    for key, model in (("coupled_cost_s", coupled), ("pairwise_cost_s", pairwise)):
        model.torque(so3.random(1, 99)[0], c)  # compiled and tables built before timing
        ts = []
        for R in so3.random(20, 3):  # each orientation new to the model (no cache can answer)
            t = time.process_time()
            model.torque(R, c)
            ts.append(time.process_time() - t)
        run[key] = statistics.median(ts)
    case = next(m for m in MISMATCH_CASES if m.winding != 1 and m.detent != 1)
    plant, _ = case.build(design)
    flat = scaled_model(pairwise, case.winding, case.detent)
    holds = []
    for i, R in enumerate(so3.random(20, 0)):
        h = {"index": i}
        for name, p in (("plant", plant), ("pairwise", flat)):
            b = p.torque(R, np.zeros(p.coil_count))
            a, _ = allocate_matrix(p.torque_matrix(R), np.zeros(3), lim, bias=b, failed=p.failed)
            h[name] = {"detent_Nm": float(np.linalg.norm(b)), "reachable": bool(a.reachable), "unmet_Nm": float(a.error),
                       "coil_fraction": float(np.max(np.abs(a.currents)) / lim.per_unit_bound),
                       "copper_W": float(lim.copper_power(a.currents))}
        holds.append(h)
    run["weakest_plant"] = {"case": case.name, "holds": holds}
    # along the demo's turn on the design's model: each coil's back-EMF per rad/s and the share of a coil's current
    # that holding the rotor at rest takes, every 1° (the time-optimal planner's constraints)
    n_axis = axis / np.linalg.norm(axis)
    path = [so3.exp(math.radians(a) * n_axis) @ R0 for a in range(360)]
    emf = [float(np.max(np.abs(lim.back_emf(n_axis @ iron.model.torque_matrix(R))))) for R in path]
    hold = []
    for R in path:
        a, _ = allocate_matrix(iron.model.torque_matrix(R), np.zeros(3), lim,
                               bias=iron.model.torque(R, np.zeros(len(design.stator))))
        hold.append(float(np.max(np.abs(a.currents)) / lim.per_unit_bound) if a.reachable else 1.0)
    run["path"] = {"emf_V_per_rad_s": max(emf), "supply_V": lim.supply_voltage, "hold_fraction": hold}
    delta = [float(np.linalg.norm(coupled.torque(R, c) - pairwise.torque(R, c))) for R in so3.random(200, 11)]
    run["coupling_torque_max_Nm"] = max(delta)
    with tempfile.TemporaryDirectory() as folder:  # `spherestep calibrate --emulate`, its defaults (60 holds)
        t = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", "calibrate", "--emulate", "--json", "--out",
                              str(Path(folder) / "calibration.yaml")], check=True, cwd=folder, capture_output=True,
                             text=True)
        wall = time.perf_counter() - t
    cal = json.loads(out.stdout)
    c = cal["calibration"]
    run["emulated_calibration"] = {
        "wall_s": wall, "holds": c["holds"], "plant_error": cal["plant_error"],
        "torque_error_before": cal["torque_error_before"], "torque_error_after": cal["torque_error_after"],
        "scale_detent": c["scale_detent"], "scale_winding": c["scale_winding"], "scale_std": c["scale_std"],
        "max_hold_offset_deg": cal["holds"]["max_hold_offset_deg"], "max_drift_deg_s": cal["holds"]["max_drift_deg_s"]}
    return _run_footer(run)


def notes_capability(n: dict) -> str:
    """docs/control.md: the torque map's capability over SO(3)."""
    c = n["capability"]
    p = c["percentiles"]
    return (f"torque available in every direction min {p['0']:.2f}, 5 % {p['5']:.2f}, median {p['50']:.2f}, 95 % "
            f"{p['95']:.2f}, max {p['100']:.2f} N·m; at least 1 N·m on {100 * c['at_least_1']:.1f} % of SO(3), at least "
            f"1.5 N·m on {100 * c['at_least_1_5']:.1f} %. `σ₃(K)` median {c['sigma3_median']:.2f} N·m per unit current "
            f"(the issue's \"about 1.1\"), condition number median {c['condition_median']:.2f}, 95 % "
            f"{c['condition_p95']:.2f} ({c['samples']} orientations, seed {c['seed']}, {c['seconds']:.1f} s; "
            f"{_notes_when(n)})")


def notes_iron_coil(n: dict) -> str:
    """docs/control.md: the prototype's iron coil as ``DriveLimits``."""
    c = n["iron_coil"]
    eq = "= `V/R`" if abs(c["max_current_A"] - c["nominal_current_A"]) < 1e-9 else f"(`V/R` = {c['max_current_A']:.3f} A)"
    return (f"{c['resistance_ohm']:.1f} Ω, `I_n` = {c['nominal_current_A']:.3f} A {eq}, ρ = {c['rho']:.2f}, and its own "
            f"{c['inductance_H']:.3f} H (`L/R` = {1e3 * c['time_constant_s']:.1f} ms; Wheeler's air-core "
            f"{1e3 * c['air_inductance_H']:.0f} mH for the same winding without the core)")


def notes_fastest_table(n: dict) -> str:
    """docs/control.md: the demo's turn planned each way on both cores, and the servo along each plan."""
    rows = []
    for core, row in n["turns"].items():
        b = row["bound_s"]
        for name, label in (("trapezoid", "trapezoid (`plan_trapezoid`)"), ("fastest", "**time-optimal**")):
            r = row[name]
            if "refused" in r:
                rows.append((core, label, f"refused: {r['refused']}", f"{b:.3f} s", "—", "—", "—", "—"))
                continue
            if name == "fastest":
                label += f" ({r['path']}, margin {r['margin']:g})"
            dur = f"{r['duration_s']:.3f} s"
            lost = r["max_tracking_deg"] > 5
            rows.append((core, label, f"**{dur}**" if name == "fastest" else dur, f"{b:.3f} s", f"{r['duration_s'] / b:.2f}",
                         f"{r['max_tracking_deg']:.{1 if lost else 3}f}°{' (lost)' if lost else ''}", f"{r['final_deg']:.3f}°",
                         f"{r['peak_power_W']:.0f} / {r['mean_power_W']:.1f} W"))
    return table(("core", "planner", "time", "bound (margin 1)", "ratio", "servo: max tracking", "final",
                  "peak / mean power"), rows, f"Measured {n['measured']}, load {n['load'][0]:.1f} → {n['load'][1]:.1f} "
                 f"(`scripts/docs_numbers.py control-notes`; {n['machine']}):")


def notes_fastest_summary(n: dict) -> str:
    """docs/control.md, inline: the iron turn against the 1.5 s target."""
    r, b = n["turns"]["iron"]["fastest"], n["turns"]["iron"]["bound_s"]
    met = "met" if r["duration_s"] <= 1.5 else "**not** met"
    return (f"The iron target of ≤ 1.5 s is {met}: {r['duration_s']:.3f} s, {r['duration_s'] / b:.2f} × the bound "
            f"with the detent, tracked within {r['max_tracking_deg']:.3f}° and ended within {r['final_deg']:.3f}° "
            f"(planned in {r['plan_s']:.1f} s; {_notes_when(n)})")


def notes_move(n: dict) -> str:
    m = n["move"]
    return (f"{m['wall_s']:.0f} s wall time for `drive_turn` in one process, numba's kernels cached (arrival "
            f"{m['time_s']:.2f} s, final error {m['final_deg']:.3f}°; {_notes_when(n)})")


def notes_planning(n: dict) -> str:
    i, a = n["turns"]["iron"], n["turns"]["air"]
    return (f"iron {i['fastest']['plan_s']:.1f} s ({i['fastest']['paths_tried']} paths tried), air "
            f"{a['fastest']['plan_s']:.1f} s ({a['fastest']['paths_tried']}); the bound {i['bound_plan_s']:.1f} s (iron) and "
            f"{a['bound_plan_s']:.1f} s (air) ({_notes_when(n)}, one run each)")


def notes_coupled_cost(n: dict) -> str:
    return (f"the coupled model costs {1e3 * n['coupled_cost_s']:.2f} ms of CPU per orientation against "
            f"{1e3 * n['pairwise_cost_s']:.3f} ms for the pairwise one ({_notes_when(n)})")


def notes_emf(n: dict) -> str:
    p = n["path"]
    return (f"{p['emf_V_per_rad_s']:.1f} V per rad/s against the {p['supply_V']:.0f} V supply, so the coils add little "
            f"torque above ≈ {p['supply_V'] / p['emf_V_per_rad_s']:.0f} rad/s")


def notes_hold_stretch(n: dict) -> str:
    """docs/control.md, inline: the longest stretch of the demo's turn where holding takes more than 80 % of a coil."""
    h = n["path"]["hold_fraction"]
    best, start = (0, 0), None
    for i, f in enumerate([*h, 0.0]):
        if f > 0.8 and start is None:
            start = i
        elif f <= 0.8 and start is not None:
            best, start = max(best, (i - start, start)), None
    length, first = best
    return (f"more than 80 % of a coil's current from {first}° to {first + length - 1}° of the demo's turn (its most, "
            f"{100 * max(h):.0f} %)")


def notes_coupling(n: dict) -> str:
    return f"up to {n['coupling_torque_max_Nm']:.2f} N·m at 200 random orientations"


def notes_weakest_hold(n: dict) -> str:
    """docs/control.md, inline: which holds the weakest mismatched plant can reach at all."""
    holds = n["weakest_plant"]["holds"]
    miss = [h for h in holds if not h["plant"]["reachable"]]
    ok = [h for h in holds if h["plant"]["reachable"]]
    text = ", ".join(f"#{h['index'] + 1} (detent {h['plant']['detent_Nm']:.1f} N·m: {h['plant']['unmet_Nm']:.3f} N·m "
                     f"unmet, {h['pairwise']['unmet_Nm']:.3f} on the pairwise plant)" for h in miss) or "none"
    return (f"orientations the plant cannot hold within the limits at all: {text}; the other {len(ok)} need at most "
            f"{100 * max(h['plant']['coil_fraction'] for h in ok):.0f} % of a coil and "
            f"{max(h['plant']['copper_W'] for h in ok):.0f} W ({_notes_when(n)})")


def notes_emulated_calibration(n: dict) -> str:
    """docs/control.md, inline: ``spherestep calibrate --emulate`` with its defaults."""
    e = n["emulated_calibration"]
    b, a = e["torque_error_before"], e["torque_error_after"]
    sd = e["scale_std"]
    return (f"with the default **{e['holds']} holds** ({_notes_when(n)}, {e['wall_s']:.0f} s) the torque error against "
            f"the plant at 200 held-out orientations and currents falls **{b:.4f} → {a:.4f} ({b / a:.1f}×)**, the "
            f"scales come back as ×{e['scale_detent']:.3f} ± {sd[0]:.3f} (detent) and ×{e['scale_winding']:.3f} ± "
            f"{sd[1]:.3f} (winding); the holds end up to {e['max_hold_offset_deg']:.1f}° from their targets, drifting "
            f"at up to {e['max_drift_deg_s']:.0f}°/s")


def robust_summary(r: dict) -> str:
    """docs/control.md, inline: the robustness table's ranges (``data/servo_robust.json``)."""
    on = [x for x in r["rows"] if x["observer"] == "on"]
    off = {x["case"]: x for x in r["rows"] if x["observer"] == "off"}
    mism = [x for x in on if x["case"] != "exact model"]
    met = sum(x["passed"] for x in mism)
    rng = lambda xs, f="{:.3f}": f"{f.format(min(xs))}–{f.format(max(xs))}"  # noqa: E731
    d_power = [x["mean_power_W"] - off[x["case"]]["mean_power_W"] for x in on]
    missed = "; ".join(f"{x['case']}: {x['holds_within']}/{x['holds']}, worst {x['worst_hold_deg']:.3f}°"
                       for x in on if not x["passed"])
    return (f"every target is met on {met} of the {len(mism)} mismatched plants and on the exact model "
            f"{'' if all(x['passed'] for x in on if x['case'] == 'exact model') else 'not '}(run of {r['measured']}): "
            f"holds worst {rng([x['worst_hold_deg'] for x in on if x['passed']])}° where met"
            + (f" ({missed})" if missed else "") + ", turns end within "
            f"{rng([x['final_error_deg'] for x in on])}° and track within "
            f"{rng([x['max_tracking_error_deg'] for x in on], '{:.2f}')}°, "
            f"{rng([x['mean_power_W'] for x in on], '{:.0f}')} W; the PD law alone misses every mismatched plant's "
            f"holds by {rng([off[x['case']]['worst_hold_deg'] for x in mism], '{:.1f}')}° and ends the turn "
            f"{rng([off[x['case']]['final_error_deg'] for x in mism], '{:.2f}')}° off; the estimate changes the mean "
            f"power by {f'{min(d_power):+.1f}'.replace('-', '−')} to {f'{max(d_power):+.1f}'.replace('-', '−')} W")


def calibration_fastest(run: dict) -> str:
    """docs/control.md, inline: the fastest plan on the mismatched plants (``data/calibration_table.json``)."""
    rows = run["rows"]
    f = [(r["plant"].replace("-", "−"), r["turn"]["fastest"]) for r in rows]
    misses = [(p, t) for p, t in f if t["exact_max_deg"] > 0.2]
    meets = [(p, t) for p, t in f if t["exact_max_deg"] <= 0.2]
    before = [(r["plant"].replace("-", "−"), r["turn"]["margin"]["before_max_deg"]) for r in rows
              if r["turn"]["margin"]["before_max_deg"] > 0.2]
    return (f"on the `MARGIN` plan before calibration {len(before)} of {len(rows)} plants miss 0.2°"
            + (" (" + "; ".join(f"{p} {x:.3f}°" for p, x in before) + ")" if before else "")
            + f"; on the fastest plan ({run['plans']['fastest']['duration_s']:.3f} s) the exact model itself misses 0.2° on "
            f"{len(misses)} of {len(rows)} plants ("
            + "; ".join(f"{p} {t['exact_max_deg']:.3f}°" for p, t in misses) + ") and meets it on "
            + ("; ".join(f"{p} {t['exact_max_deg']:.3f}°" for p, t in meets) or "none")
            + f", where the calibrated servo is within "
            f"{max([abs(t['after_max_deg'] - t['exact_max_deg']) for _, t in meets] or [0]) + 0.0005:.3f}° of it "
            f"(`data/calibration_table.json`, {run['measured']})")


def _truth(plant: str) -> tuple[float, float, float] | None:
    """The (detent, winding, coupling gain) a calibration should find for a plant of the calibration table (None for
    the shells, whose change is a shape, not a scale)."""
    if "shell" in plant:
        return None
    w, d = re.search(r"winding ×([0-9.]+)", plant), re.search(r"detent ×([0-9.]+)", plant)
    return (float(d.group(1)) if d else 1.0, float(w.group(1)) if w else 1.0, 0.0 if plant.startswith("pairwise") else 1.0)


def calibration_coupling(run: dict) -> str:
    """docs/control.md, inline: the coupling's gain fitted both ways and how close the scales come back."""
    rows = {r["plant"]: r for r in run["rows"]}
    cp = next(r for p, r in rows.items() if p.startswith("coupled"))
    pp = next(r for p, r in rows.items() if p.startswith("pairwise"))
    z, rel = [], []
    for p, r in rows.items():
        t = _truth(p)
        if t is None:
            continue
        fit = (r["scale_detent"], r["scale_winding"], r["coupling_gain"])
        sd = (*r["scale_std"], r["coupling_std"])
        z += [abs(f - x) / e for f, x, e in zip(fit, t, sd)]
        rel += [abs(f - x) / x for f, x in zip(fit, t) if x]
    return (f"the coupled plant calibrated from the pairwise model comes back at ×{cp['coupling_gain']:.4f} ± "
            f"{cp['coupling_std']:.4f} and the pairwise plant from the coupled model at ×{pp['coupling_gain']:.4f} ± "
            f"{pp['coupling_std']:.4f}; the scales and the gain of every plant whose truth is a scale come back within "
            f"{max(z):.1f}σ of it (within {100 * max(rel):.2f} %)")


def calibration_shell(run: dict) -> str:
    ratios = [r["ratio"] for r in run["rows"] if "shell" in r["plant"]]
    return f"{min(ratios):.0f}–{max(ratios):.0f}×"


def iron_capability_least(s: dict) -> str:
    return f"{_signed(s['capability']['available_torque_N_m']['0'], 2)} N·m"


def servo_drag(s: dict) -> str:
    """docs/control.md, inline: the relay simulation's damping at one turn per second (the air core's and iron's)."""
    a = _mode(s["drives_other"], "settled")["details"]["damping_N_m_s_per_rad"]
    i = _mode(s["drives"], "settled")["details"]["damping_N_m_s_per_rad"]
    return f"{2 * math.pi * a:.1f} N·m of drag on the air core ({2 * math.pi * i:.0f} N·m with the iron's damping)"


def relay_sweep(s: dict) -> str:
    """docs/control.md, inline: the ramped rates the demo tried on the air-core map, and which lost a step."""
    m = _mode(s["drives_other"], "ramped")
    tried = sorted(m["details"]["tried"], key=lambda t: t["rate_steps_per_s"])
    lost = [f"{t['rate_steps_per_s']:.3g}" for t in tried if t["lost_a_step"]]
    kept = [f"{t['rate_steps_per_s']:.3g}" for t in tried if not t["lost_a_step"]]
    return (f"on the demo's plan on the air-core map (the stored demo run) the cruise rates {', '.join(kept)} steps/s "
            f"kept every step and {', '.join(lost)} steps/s lost one; the pull-out rate is "
            f"{m['details']['pull_out_rate_steps_per_s']:.1f} steps/s")
