"""Every generated number in README and docs/ from stored measurement files, so the docs cannot drift (issue 27 §4).

A generated block is the text between ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` in a markdown file; each
NAME is registered in :data:`BLOCKS` with its file, the stored measurement it is rendered from and the renderer.
Blocks on their own lines hold tables; inline blocks hold a sentence's numbers. The stored measurements
(``data/``) are written by the commands below, never by hand:

    make demo && python scripts/docs_numbers.py demo     # data/demo_summary.json from spherestep-out/summary.json
    python scripts/docs_numbers.py forces                # data/forces_states.json: `spherestep forces`, 20 states
    python scripts/docs_numbers.py robust [BENCH.json]   # data/servo_robust.json: benchmarks/bench_servo_robust.py
    python scripts/docs_numbers.py iron                  # data/iron_compare.json: scripts/iron_compare.py
    python scripts/docs_numbers.py calibration           # data/calibration_table.json: bench_calibration.py
                                                         # (~10 min quiet)
    python scripts/docs_numbers.py bench [NAME ...]      # data/bench_NAME.json: every benchmark of BENCHES (or
                                                         # those named) run one after another: ~15 min quiet,
                                                         # ~40 min at load 10 (bench_motor's 812-pole rotor)
    python scripts/docs_numbers.py potential             # data/potential_numbers.json: the prototype's energy
                                                         # model (measure_potential, ~1 min)
    python scripts/docs_numbers.py dynamics              # data/dynamics_tune.json: dynamics.tune (~30 s)
    python scripts/docs_numbers.py explore [FOLDER]      # data/explore_default.json: docs/explore.md's default
                                                         # sweep (spherestep explore --budget-coils 32 --workers 2,
                                                         # ~15-40 min), or the summary of a finished FOLDER
                                                         # (these three rewrite only their own page's blocks)
    python scripts/docs_numbers.py all                   # demo + forces (the end-of-session run; not bench)
    python scripts/docs_numbers.py                       # rewrite every block from the stored files
    python scripts/docs_numbers.py --check               # list the blocks that differ, exit 1 if any

``bench`` is a separate step (minutes of both cores): run it on a quiet machine, alone; each stored benchmark
records its date, command, machine and the load average at its start and end, and every table it feeds states
them. The gallery's blocks read ``src/spherestep/data/gallery/metrics.csv`` (``scripts/gallery_metrics.py``).
Each command that stores a measurement then rewrites every block. ``tests/test_docs_numbers.py`` renders every
block again from the stored files and compares it with the docs (and holds the cheap stored numbers against the
live code).
"""

from __future__ import annotations

import csv
import datetime
import json
import math
import os
import re
import statistics
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from collections.abc import Callable

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
STORES = {
    "demo": DATA / "demo_summary.json",
    "forces": DATA / "forces_states.json",
    "robust": DATA / "servo_robust.json",
    "iron": DATA / "iron_compare.json",
    "calibration": DATA / "calibration_table.json",  # benchmarks/bench_calibration.py --json
    "gallery": ROOT / "src" / "spherestep" / "data" / "gallery" / "metrics.csv",  # scripts/gallery_metrics.py
    "explore": DATA / "explore_default.json",  # docs_numbers.py explore: spherestep explore, docs/explore.md's sweep
    "potential": DATA / "potential_numbers.json",  # docs_numbers.py potential (measure_potential)
    "dynamics": DATA / "dynamics_tune.json",  # docs_numbers.py dynamics (measure_dynamics)
}
# the demo summary's keys not stored: file lists and per-state lists (their counts are the numbers)
DROP = ("escape_violation_states", "escape_violation_states_note", "files")
FORCES_STATES, FORCES_SEED = 20, 0
MARKER = re.compile(r"<!-- ([a-z0-9-]+):(start|end) -->")


def stored(name: str) -> dict | list:
    """A stored measurement: JSON, or a CSV as ``{first column: {column: value}}``."""
    path = STORES[name]
    if path.suffix == ".csv":
        with path.open(encoding="utf-8", newline="") as f:
            return {row[next(iter(row))]: {k: _num(v) for k, v in row.items()} for row in csv.DictReader(f)}
    return json.loads(path.read_text(encoding="utf-8"))


def _store(name: str, value) -> None:
    STORES[name].write_text(json.dumps(value, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    print(f"stored {STORES[name].relative_to(ROOT)}")


# ---------------------------------------------------------------------------------------------------- the demo

def _signed(x: float, digits: int) -> str:
    """``x`` with the typographic minus the docs use."""
    return f"{x:.{digits}f}".replace("-", "−")


def _mode(drives: dict, name: str) -> dict:
    return next(m for m in drives["modes"] if m["mode"] == name)


def _time(m: dict) -> str:
    return f"**{m['time_s']:.2f} s**" if m["time_s"] is not None else "never arrives"


def readme_table(s: dict) -> str:
    """The README's table of the prototype's numbers (degrees, N·m, W, s)."""
    cap, cap_air = s["capability"]["available_torque_N_m"], s["capability_other"]["available_torque_N_m"]
    frac = s["capability"]["fraction_at_least"]
    d, a = s["drives"], s["drives_other"]
    iron_servo, air_servo = _mode(d, "servo"), _mode(a, "servo")
    iron_settled, iron_ramped = _mode(d, "settled"), _mode(d, "ramped")
    air_settled, air_ramped = _mode(a, "settled"), _mode(a, "ramped")
    iron, plan, sim, pp, rob = s["iron"], s["plan"], s["simulation"], s["potential_plan"], s["robustness"]
    e = iron["electrics"]
    settled = iron_settled["details"]
    rows = [
        ("rotor poles / coils", f"{s['rotor_poles']} / {s['coils']} (cap {s['cap_half_angle_deg']:.0f}° about −z)"),
        ("the coil as built (the design's own: `magnetics.design_model`)",
         f"{e['core']} core, {e['turns']:,} turns, {e['resistance_ohm']:.0f} Ω, {e['nominal_current_A']:.3f} A "
         f"nominal ({e['ampere_turns']:.0f} A-turns, {e['power_W']:.1f} W); {e['supply_V']:.0f} V / "
         f"{e['supply_W']:.0f} W supply"),
        ("stepper states (≥ 2 poles within 1° of coils)", f"{s['states']:,}"),
        (f"resolution: median / 95 % / max distance to the nearest state ({s['samples']:,} random orientations)",
         f"{s['resolution_median_deg']:.2f}° / {s['resolution_p95_deg']:.2f}° / {s['resolution_max_deg']:.2f}°"),
        ("max step (two coils; coil face + magnet face)", f"{s['max_step_deg']:.2f}°"),
        ("orientations within one step of a state; state graph",
         f"{100 * s['range_fraction']:.0f} %; {s['state_graph_components']} component"
         + (" — **all of SO(3) is reachable**" if s["reaches_all"] else "")),
        ("states with a 45° cone of directions and no next state",
         f"{s['escape_violations']:,} ({100 * s['escape_violations'] / s['states']:.0f} %) (`docs/motor.md`)"),
        (f"360° about ({', '.join(f'{x:.3f}' for x in plan['axis'])}): the paper's geometric plan",
         f"{plan['steps']} steps, tracking error median {plan['error_median_deg']:.2f}°, max "
         f"{plan['error_max_deg']:.2f}°, final {plan['error_final_deg']:.2f}°"),
        ("torque available in every direction over SO(3), 400 orientations: iron (the design's own) / air core "
         "(same winding)",
         f"median {cap['50']:.2f} / {cap_air['50']:.2f} N·m, 5th percentile {cap['5']:.2f} / {cap_air['5']:.2f} "
         f"N·m; iron: least {cap['0']:.2f} N·m (the detent exceeds what the coils can cancel there), at least "
         f"1 N·m on {100 * frac['1_N_m']:.1f} % of SO(3)"),
        ("iron, one pole and one coil (NGSolve 3-D FEM table below 21°; `docs/magnetics.md`)",
         f"detent (coil off) peak {-iron['detent_peak_Nm']:.2f} N·m at {iron['detent_peak_angle_deg']:.0f}°; the "
         f"winding through the iron {-iron['linear_peak_Nm']:.2f} N·m per nominal current; air core "
         f"{-iron['air_peak_Nm']:.2f} N·m"),
        ("iron, the whole motor unpowered / the stepper states powered",
         f"{iron['unpowered_minima']} of {iron['unpowered_starts']} random starts come to rest, holding "
         f"{iron['unpowered_holding_median_Nm']:.1f} N·m (median); the states' rest poses move "
         f"{iron['iron_offset_median_deg']:.1f}° (median, up to {iron['iron_offset_max_deg']:.0f}°) from the "
         f"geometric states, holding {iron['iron_holding_median_Nm']:.1f} N·m (air core "
         f"{iron['air_holding_median_Nm']:.2f} N·m); the pole face reaches {iron['max_core_B_T']:.1f} T in the linear "
         f"solve, above the {iron['knee_T']:.1f} T knee"),
        (f"the turn driven three ways on the {d['model']} model (`drives.json`)",
         f"settled relay steps: {settled['steps_settled_on_plan']} of {settled['steps']} settle on the plan, "
         f"{_time(iron_settled)}, ends {iron_settled['final_error_deg']:.1f}° off; ramped relays: {_time(iron_ramped)}; "
         f"relay steps planned on the iron model move the rotor in {pp['moves']} of {pp['steps']}; servo (fastest "
         f"turn with the detent, 0.02° sensor noise) {_time(iron_servo)}, final error "
         f"{iron_servo['final_error_deg']:.3f}°, max tracking error {iron_servo['max_tracking_error_deg']:.2f}°, "
         f"peak {iron_servo['peak_power_W']:.0f} W, mean {iron_servo['mean_power_W']:.0f} W; bang-bang bound "
         f"{d['bang_bang_bound_s']:.2f} s"),
        (f"the same on the {a['model']} model", f"settled relay steps {_time(air_settled)} (simulated rotor time), "
         f"final {air_settled['final_error_deg']:.3f}°; ramped relays {_time(air_ramped)}; servo {_time(air_servo)}, "
         f"final error {air_servo['final_error_deg']:.3f}°, max tracking error "
         f"{air_servo['max_tracking_error_deg']:.2f}°, mean {air_servo['mean_power_W']:.0f} W; bang-bang bound "
         f"{a['bang_bang_bound_s']:.2f} s"),
        ("the paper's relay plan simulated on the air-core map", f"{sim['steps']} steps, executed: "
         f"{'yes' if sim['executed'] else 'no'} (settled within 0.5° of the plan: median "
         f"{sim['settled_error_median_deg']:.2f}°, max {sim['settled_error_max_deg']:.2f}°)"),
    ]
    if rob:
        rows.append((f"the servo on a motor that differs from its model by {rob['case']} (the worst case of "
                     "`docs/control.md`'s table)",
                     f"holds {rob['holds_within']} of {rob['holds']} random orientations within 0.05° (worst "
                     f"{rob['worst_hold_deg']:.3f}°); the turn final error {rob['final_error_deg']:.3f}°, max "
                     f"tracking error {rob['max_tracking_error_deg']:.2f}°, mean {rob['mean_power_W']:.0f} W"))
    body = "\n".join(f"| {k} | {v} |" for k, v in rows)
    return f"| quantity | value |\n|---|---|\n{body}"


def _relay_label(m: dict) -> str:
    det = m["details"]
    if m["mode"] == "settled":
        return (f"settled relays ({det['steps']} steps, dwell {det['dwell_s']:.2f} s, damping "
                f"{det['damping_N_m_s_per_rad']:.2f} N·m·s/rad)")
    if m["mode"] == "ramped":
        rate = det["pull_out_rate_steps_per_s"]
        return (f"ramped relays, pull-out rate {rate:.1f} steps/s" if rate > 0
                else "ramped relays, " + ", ".join(f"{t['rate_steps_per_s']:g}" for t in det["tried"]) + " steps/s")
    return f"**servo** ({det['trajectory']} turn, {det['sensor_noise_deg']:g}° sensor noise)"


def drives_table(s: dict) -> str:
    """docs/control.md: the demo's turn driven three ways on both models (``drives.json`` of the demo)."""
    lines = ["| model | mode | time | final error | max tracking error | peak power | mean power |",
             "|---|---|---|---|---|---|---|"]
    for drives in (s["drives_other"], s["drives"]):
        for m in drives["modes"]:
            servo = m["mode"] == "servo"
            time = f"{m['time_s']:.2f} s" if m["time_s"] is not None else f"never arrives: {m['arrival_note']}"
            final = f"{m['final_error_deg']:.3f}°" if m["final_error_deg"] < 1 else f"{m['final_error_deg']:.1f}°"
            if servo:
                time, final = f"**{time}**", f"**{final}**"
            lines.append(f"| {drives['model'].split()[0]} | {_relay_label(m)} | {time} | {final} | "
                         f"{m['max_tracking_error_deg']:.{2 if servo else 1}f}° | {m['peak_power_W']:.0f} W | "
                         f"{m['mean_power_W']:.1f} W |")
    a, d = s["drives_other"], s["drives"]
    bounds = "; ".join(
        f"{x['model'].split()[0]} {x['bang_bang_bound_s']:.3f} s (the servo takes {x['servo_over_bound']:.2f}× it)" for x in (a, d))
    lines += ["", f"Models: {a['model']} and {d['model']}. Bang-bang lower bound: {bounds}."]
    return "\n".join(lines)


def move_servo(s: dict) -> str:
    """docs/control.md, the fastest turn: what ``move --fastest --mode servo`` (the demo's servo) reports."""
    m = _mode(s["drives"], "servo")
    return (f"arrives in {m['time_s']:.2f} s, final error {m['final_error_deg']:.3f}°, max tracking "
            f"{m['max_tracking_error_deg']:.2f}°")


def demo_servo_power(s: dict) -> str:
    """docs/control.md: the demo's servo turn on both models, supply power and tracking."""
    i, a = _mode(s["drives"], "servo"), _mode(s["drives_other"], "servo")
    return (f"peaks of **{i['peak_power_W']:.0f} W iron and {a['peak_power_W']:.0f} W air**, mean "
            f"{i['mean_power_W']:.0f} / {a['mean_power_W']:.0f} W, tracked within {i['max_tracking_error_deg']:.2f}° / "
            f"{a['max_tracking_error_deg']:.2f}°")


def run_frames(s: dict) -> str:
    """docs/errors.md: what ``run`` says of the demo's plan."""
    return f"{s['plan']['steps'] + 1} frames (the start and {s['plan']['steps']} steps)"


def motor_metrics(s: dict) -> str:
    """docs/motor.md: the prototype's metrics."""
    return (f"Prototype ({s['samples']:,} samples): resolution median {s['resolution_median_deg']:.2f}°, 95 % "
            f"{s['resolution_p95_deg']:.2f}°, max {s['resolution_max_deg']:.2f}°; max step {s['max_step_deg']:.2f}°; "
            f"range {100 * s['range_fraction']:.0f} %")


def motor_states(s: dict) -> str:
    """docs/motor.md: the states and how many pole–coil pairs hold each (the demo's histogram)."""
    words = {2: "two pairs", 3: "three", 4: "four", 5: "five", 6: "six"}
    held = [f"{n:,} by {words.get(k, str(k))}" for k, n in enumerate(s["held_pairs_histogram"]) if n]
    held[0] = held[0].replace(" by ", " held by ", 1)
    return f"{s['states']:,} states at {s['state_tol_deg']:g}° ({', '.join(held)})"


def motor_violations(s: dict) -> str:
    return (f"{s['escape_violations']:,} of the {s['states']:,} states "
            f"({100 * s['escape_violations'] / s['states']:.0f} %)")


def iron_table(s: dict) -> str:
    """docs/magnetics.md, "What the iron changes": ``iron_summary`` and the capability as the demo measured them."""
    i, cap, air = s["iron"], s["capability"], s["capability_other"]
    e = i["electrics"]
    t, ta = cap["available_torque_N_m"], air["available_torque_N_m"]
    wrong = ", ".join(f"{a:.0f}°" for a in i["wrong_polarity_angles_deg"])
    wrong_t = ", ".join(f"{v:+.2f}".replace("-", "−") for v in i["wrong_polarity_torque_Nm"])
    rows = [
        ("peak pull-in torque, one pole, coil +1", f"{-i['air_peak_Nm']:.2f} N·m (`coil_ampere_turns`)",
         f"{-i['detent_peak_Nm']:.2f} N·m detent alone (at {i['detent_peak_angle_deg']:.0f}°); "
         f"{-i['linear_peak_Nm']:.2f} N·m from the coil ({e['ampere_turns']:.0f} A-turns)"),
        ("rotor with every coil off", "no torque: rests anywhere",
         f"holds: {i['unpowered_minima']} of {i['unpowered_starts']} random starts settle in a minimum; holding "
         f"torque median {i['unpowered_holding_median_Nm']:.1f} N·m, least {i['unpowered_holding_min_Nm']:.1f} N·m"),
        (f"stepper states ({i['states_sampled']} sampled) that are minima", f"{i['air_states_minima']}",
         f"{i['iron_states_minima']}"),
        ("distance of the rest pose from the geometric state", f"median {i['air_offset_median_deg']:.2f}°",
         f"median {i['iron_offset_median_deg']:.1f}°, up to {i['iron_offset_max_deg']:.0f}°"),
        ("holding torque of the states (median)", f"{i['air_holding_median_Nm']:.2f} N·m",
         f"{i['iron_holding_median_Nm']:.1f} N·m"),
        (f"coil driven *against* its pole (p c = −1), pair torque at {wrong}", "repels",
         f"{wrong_t} N·m: " + ("pulls in" if i["wrong_polarity_attracts"] else
                               f"still repels out to {i['wrong_polarity_angles_deg'][-1]:.0f}°")),
        ("flux density, mean over the pole's 2-mm face layer (linear iron, moment method)", "—",
         f"{i['max_core_B_off_T']:.1f} T with a pole on the axis, coil off; up to {i['max_core_B_T']:.1f} T at the "
         f"rest poses, where poles sit degrees off the axes (the rim over the pole's edge); the knee of 1010 steel is {i['knee_T']:.1f} T"),
        ("power per coil at nominal current", "—",
         f"{e['power_W']:.1f} W ({e['resistance_ohm']:.0f} Ω, {e['nominal_current_A']:.2f} A); {e['coils_on']} coils "
         f"{e['coils_on'] * e['power_W']:.0f} W of the {e['supply_W']:.0f} W supply"),
        (f"torque available in every direction ({cap['samples']} orientations, coils within their limits)",
         f"median {ta['50']:.2f} N·m, 5th percentile {ta['5']:.2f} N·m",
         f"median {t['50']:.1f} N·m, 5th percentile {t['5']:.1f} N·m; ≥ 0.5 N·m on "
         f"{100 * cap['fraction_at_least']['0.5_N_m']:.0f} % of SO(3); worst sampled {_signed(t['0'], 1)} N·m"),
    ]
    body = "\n".join(f"| {a} | {b} | {c} |" for a, b, c in rows)
    return f"| | air core | iron core (pot, μr 1000, linear) |\n|---|---|---|\n{body}"


def iron_drives(s: dict) -> str:
    """docs/magnetics.md: the demo's turn on the iron model, in words."""
    d = s["drives"]
    settled, ramped, servo = _mode(d, "settled"), _mode(d, "ramped"), _mode(d, "servo")
    st, rt, sv = settled["details"], ramped["details"], servo["details"]
    air_pull = s["drives_other"]["pull_out_rate_steps_per_s"]
    pp = s["potential_plan"]
    rates = ", ".join(f"{t['rate_steps_per_s']:g}" for t in rt["tried"])
    lost = all(t["lost_a_step"] for t in rt["tried"])
    return (
        f"damping {st['damping_N_m_s_per_rad']:.2f} N·m·s/rad, dwell {st['dwell_s']:.2f} s): "
        f"**{st['steps_settled_on_plan']} of the {st['steps']} steps settle within {st['plan_tolerance_deg']:g}° of "
        f"their planned states, and the rotor ends {settled['final_error_deg']:.1f}° from the turn's end**. "
        f"*Ramped relay steps* at {rates} steps/s (the air core's pull-out rate is {air_pull:.1f}): "
        + ("**a step is lost at every rate**" if lost else f"pull-out rate {rt['pull_out_rate_steps_per_s']:.1f}")
        + ". *Relay steps planned on the iron model*: the potential planner, choosing each relay activation (≤ 4 coils "
        "at nominal current, polarity switched) by the equilibrium it leads to on the iron model, finds activations "
        f"that move the rotor in only **{pp['moves']} of its {pp['steps']} steps; the plan ends "
        f"{pp['final_error_deg']:.1f}° from the target**"
        + (" — the detent of all the cores holds the rotor where four coils cannot pull it out"
           if pp["final_error_deg"] > 10 else "")
        + ". The servo (all coils, continuous currents, the bias `b(R) = τ(R, 0)` allocated against; "
        f"the {sv['trajectory']} turn, {sv['sensor_noise_deg']:g}° sensor noise) turns it in "
        f"**{servo['time_s']:.2f} s** (bang-bang bound {d['bang_bang_bound_s']:.2f} s), final error "
        f"{servo['final_error_deg']:.3f}°, max tracking error {servo['max_tracking_error_deg']:.2f}°, peak "
        f"{servo['peak_power_W']:.0f} W, mean {servo['mean_power_W']:.1f} W")


def iron_meaning(s: dict) -> str:
    """docs/magnetics.md, "What this means": the demo's iron numbers in its sentence."""
    i = s["iron"]
    ratio = s["capability"]["available_torque_N_m"]["50"] / s["capability_other"]["available_torque_N_m"]["50"]
    polarity = ("a reversed coil still pulls the pole in" if i["wrong_polarity_attracts"] else
                f"a reversed coil repels out to {i['wrong_polarity_angles_deg'][-1]:.0f}°")
    return (f"(median {i['iron_offset_median_deg']:.1f}°) away from the geometric state the commutation assumes: the "
            "Sec. III-A tolerance is not met, and stepping has to be planned on the iron model — where most relay "
            "activations no longer move the rotor at all. Polarity switching does what the paper assumes near the "
            f"axis ({polarity}). Current control with every coil works: the iron gives {ratio:.1f}× the air core's "
            "median torque capability")


# ------------------------------------------------------------------------------------------------------ forces

def _coils(r: dict) -> str:
    return " ".join(f"{k}{'+' if s > 0 else '−'}" for k, s in r["coils"].items())


def forces_table(f: dict) -> str:
    """docs/magnetics.md: the state torques ``spherestep forces --states 20 --core air`` prints."""
    lines = ["| state | coils | offset ° | stiffness N·m/rad | holding N·m | strongest axis N·m | downhill/steps "
             "| peak step N·m |", "|---|---|---|---|---|---|---|---|"]
    for r in f["states"]:
        peak = f"{r['step_peak_torque_Nm']:.3f}" if r["step_peak_torque_Nm"] is not None else "—"
        lines.append(f"| {r['state']} | {_coils(r)} | {r['equilibrium_offset_deg']:.2f} | "
                     + " / ".join(f"{k:.2f}" for k in r["stiffness_Nm_per_rad"])
                     + f" | {r['holding_torque_Nm']:.3f} | {r['strongest_axis_Nm']:.3f} | "
                     f"{r['downhill_steps'] or 0}/{r['steps']} | {peak} |")
    return "\n".join(lines)


def forces_summary(f: dict) -> str:
    rows = f["states"]
    hold = [r["holding_torque_Nm"] for r in rows]
    strong = [r["strongest_axis_Nm"] for r in rows]
    return (f"holding torque {min(hold):.2f}–{max(hold):.2f} N·m (median {statistics.median(hold):.2f}); about the "
            f"strongest axis {min(strong):.1f}–{max(strong):.1f} N·m")


def forces_soft(f: dict) -> str:
    """The states whose softest stiffness is under 0.5 N·m/rad (two coils, the turn about their bisector)."""
    soft = [r for r in f["states"] if r["stiffness_Nm_per_rad"][0] < 0.5]
    k0 = [r["stiffness_Nm_per_rad"][0] for r in soft]
    k12 = [k for r in soft for k in r["stiffness_Nm_per_rad"][1:]]
    hold = [r["holding_torque_Nm"] for r in soft]
    return (f"{min(k0):.2f}–{max(k0):.2f} N·m/rad against {min(k12):.1f}–{max(k12):.1f} about the other axes, and "
            f"the holding torque {min(hold):.2f}–{max(hold):.2f} N·m")


def forces_steps(f: dict) -> str:
    rows = [r for r in f["states"] if r["steps"]]
    down, steps = sum(r["downhill_steps"] or 0 for r in rows), sum(r["steps"] for r in rows)
    start = [r["step_start_torque_median_Nm"] for r in rows]
    low = min(r["step_start_torque_min_Nm"] for r in rows)
    peak = [r["step_peak_torque_Nm"] for r in rows]
    return (f"Steps: {down} of {steps} steps run downhill all the way along the geodesic; drive at a step's start "
            f"median {statistics.median(start):.2f} N·m over the states (some long steps start slightly uphill, down "
            f"to {_signed(low, 2)} N·m), largest drive met along a step {min(peak):.2f}–{max(peak):.2f} N·m")


def measure_forces() -> dict:
    """``spherestep forces --states 20 --seed 0 --core air --json`` on the prototype, its state rows kept."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-c", "from spherestep.cli import main; main()", "forces", "--states", str(FORCES_STATES), "--seed",
               str(FORCES_SEED), "--core", "air", "--json", "--out", tmp]
        out = subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})
    info = json.loads(out.stdout)
    return {"command": f"spherestep forces --states {FORCES_STATES} --seed {FORCES_SEED} --core air --json",
            "design": info["design"], "states": info["states"]}


# -------------------------------------------------------------------------------------------------- benchmarks

def robust_table(stored_run: dict) -> str:
    """docs/control.md: benchmarks/bench_servo_robust.py's table, the observer off → on per case."""
    rows = stored_run["rows"]
    turn = {r["turn_time_s"] for r in rows}
    note = f"{stored_run['note']}; " if stored_run.get("note") else ""
    lines = [f"Measured {stored_run['measured']} ({note}the planned turn is "
             + " / ".join(f"{x:.3f}" for x in sorted(turn)) + " s):", "","| plant (controller: the design's iron model) | holds within 0.05° (worst) off → **on** | turn final "
             "error off → **on** | max tracking off → **on** | mean power off → on | reachable on | targets met |",
             "|---|---|---|---|---|---|---|"]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    for case in cases:
        by = {r["observer"]: r for r in rows if r["case"] == case}
        off, on = by["off"], by["on"]
        lines.append(
            f"| {case} | {off['holds_within']}/{off['holds']} ({off['worst_hold_deg']:.3f}°) → "
            f"**{on['holds_within']}/{on['holds']} ({on['worst_hold_deg']:.3f}°)** | {off['final_error_deg']:.3f}° → "
            f"**{on['final_error_deg']:.4f}°** | {off['max_tracking_error_deg']:.2f}° → "
            f"**{on['max_tracking_error_deg']:.3f}°** | {off['mean_power_W']:.1f} → {on['mean_power_W']:.1f} W | "
            f"{on['reachable_fraction']:.3f} | {'yes' if on['passed'] else '**no**'} |")
    return "\n".join(lines)


def calibration_table(run: dict) -> str:
    """docs/control.md: benchmarks/bench_calibration.py's table, per plant the torque error and the turn on each
    plan before calibration, after and on the exact model."""
    plans = run["plans"]
    head = ("| plant (controller: the design's coupled model unless said) | holds (collected in) | torque error before "
            "→ after (ratio) | scales fitted (detent, winding; coupling) ± σ |"
            + "".join(f" {'fastest' if k == 'fastest' else '`MARGIN`'} plan ({plans[k]['duration_s']:.2f} s): before "
                      "→ **after** (exact) |" for k in plans))
    lines = [f"Measured {run['measured']}, load {run['load'][0]:.1f} → {run['load_after'][0]:.1f} "
             f"(`benchmarks/bench_calibration.py --json data/calibration_table.json`):", "", head,
             "|" + "---|" * (4 + len(plans))]
    for r in run["rows"]:
        sd = r["scale_std"]
        gain = "" if r["coupling_gain"] is None else f"; {r['coupling_gain']:.4f} ± {r['coupling_std']:.4f}"
        cells = "".join(f" {r['turn'][k]['before_max_deg']:.3f}° → **{r['turn'][k]['after_max_deg']:.3f}°** "
                        f"({r['turn'][k]['exact_max_deg']:.3f}°) |" for k in plans if k in r["turn"])
        lines.append(f"| {r['plant'].replace('-', '−')} | {r['holds']} ({r['collect_s']:.0f} s) | "
                     f"{r['torque_error_before']:.4f} → {r['torque_error_after']:.4f} ({r['ratio']:.0f}×) | "
                     f"{r['scale_detent']:.4f} ± {sd[0]:.4f}, {r['scale_winding']:.4f} ± {sd[1]:.4f}{gain} |" + cells)
    return "\n".join(lines)


def calibration_summary(run: dict) -> str:
    """docs/control.md, inline: the range of the error drop and of the calibrated servo's tracking on the MARGIN plan."""
    rows = run["rows"]
    ratios = [r["ratio"] for r in rows]
    after = [r["turn"]["margin"]["after_max_deg"] for r in rows]
    gap = max(abs(r["turn"]["margin"]["after_max_deg"] - r["turn"]["margin"]["exact_max_deg"]) for r in rows)
    return (f"the torque error drops {min(ratios):.0f}–{max(ratios):.0f}× (≥ 5×), and on the `MARGIN` plan the "
            f"calibrated servo tracks within {min(after):.3f}–{max(after):.3f}° (≤ 0.2°), equal to the exact model's "
            f"to {max(gap, 0.0005):.3f}°")


# ------------------------------------------------------------------------------------------- the iron models

IRON_ROWS = (("unpowered: minima of 12 starts", "{unpowered_minima:d}"),
             ("unpowered: median holding torque (N·m)", "{unpowered_holding_median_Nm:.2f}"),
             ("stepper states: minima of 12", "{state_minima:d}"),
             ("stepper states: rest from the geometric state, median / max (°)",
              "{state_offset_median_deg:.2f} / {state_offset_max_deg:.2f}"),
             ("stepper states: median holding torque (N·m)", "{state_holding_median_Nm:.2f}"),
             ("capability, 400 orientations: median / 5th percentile (N·m)",
              "{capability_median_Nm:.2f} / {capability_p5_Nm:.2f}"),
             ("servo turn 360° about (1, 0.5, 2): time (s)", "{servo_time_s:.2f}"),
             ("servo turn: final / max tracking error (°)", "{servo_final_deg:.3f} / {servo_tracking_deg:.2f}"),
             ("servo turn: mean power (W)", "{servo_mean_W:.1f}"))


def iron_compare_table(rows: dict) -> str:
    """docs/magnetics.md: ``scripts/iron_compare.py``'s pairwise and coupled models side by side."""
    a, b = rows["pairwise"], rows["coupled"]
    lines = [f"| the prototype, iron-cored | {a['model']} | {b['model']} |", "|---|---|---|"]
    lines += [f"| {label} | {fmt.format(**a)} | {fmt.format(**b)} |" for label, fmt in IRON_ROWS]
    return "\n".join(lines)


# ------------------------------------------------------------------------------------------ stored benchmarks

# each benchmark's command (in benchmarks/) and its store, data/bench_NAME.json: ``docs_numbers.py bench [NAME...]``
BENCHES = {
    "servo_loop": ("bench_servo_loop.py",),
    "hardware": ("bench_hardware.py",),
    "iron": ("bench_iron.py",),
    "packing": ("bench_packing.py",),
    "motor": ("bench_motor.py", "--levels", "1", "2", "3"),
    "harmonics": ("bench_harmonics.py",),
    "potential": ("bench_potential.py",),
    "dynamics": ("bench_dynamics.py",),
    "planners": ("bench_planners.py",),
    "control": ("bench_control.py", "--quick"),
    "sensing": ("bench_sensing.py", "--docs"),
}
STORES.update({f"bench-{name}": DATA / f"bench_{name}.json" for name in BENCHES})


def _when(b: dict) -> str:
    """When and under what load a stored benchmark ran: ``2026-11-26 00:18 UTC, load 5.5–7.1``."""
    lo, hi = sorted(b["load"])
    load = f"{lo:.1f}" if f"{lo:.1f}" == f"{hi:.1f}" else f"{lo:.1f}–{hi:.1f}"
    return f"{b['measured']}, load {load}"


def _us(x: float) -> str:
    return f"{x:.0f}" if x >= 10 else f"{x:.1f}"


def _range(values, fmt: str = "{:.2f}", sep: str = "–") -> str:
    lo, hi = min(values), max(values)
    a, b = fmt.format(lo), fmt.format(hi)
    return a if a == b else f"{a}{sep}{b}"


LAW_ROWS = (("estimate (observer predict + correct)", "estimate"),
            ("feedback (trajectory + geometric PD)", "feedback"),
            ("`K(R)` and bias, one evaluation (`ModelCache`, compiled: `spherestep._fast.linear`)", "K(R) and bias"),
            ("allocation, warm-started (compiled Newton: `spherestep._fast.allocation`)", "allocation"),
            ("the supply box + allocation (the law's)", "supply box + allocation"),
            ("out of reach: closest reachable torque (compiled bisection \\| Clarabel)", "closest reachable"),
            ("`ServoLaw.step` on a 20° turn", "law.step (turn)"),
            ("`ServoLaw.step`, `K(R)` every period (the fast turn's worst case)", "law.step, K each"))


def loop_cost_table(b: dict) -> str:
    """docs/hardware.md: the law's cost per period by part, now | before (``bench_servo_loop.py``)."""
    v = b["values"]
    air, iron = v["law air"], v["law iron"]
    lines = [f"Measured {_when(b)} (`benchmarks/bench_servo_loop.py`; {b['machine']}); CPU µs, now \\| before issue "
             "27 (the reference paths in the same run):", "",
             "| part of one period | air-core map, µs | iron model (pairwise), µs |", "|---|---|---|"]
    for label, key in LAW_ROWS:
        if key == "law.step (turn)":
            label += (f" (`K(R)` re-evaluated in {air['K evaluations'][0]} / {iron['K evaluations'][0]} of "
                      f"{air['K evaluations'][1]} periods)")
        lines.append(f"| {label} | {_us(air[key][0])} \\| {_us(air[key][1])} | {_us(iron[key][0])} \\| "
                     f"{_us(iron[key][1])} |")
    mag = _us(v["magnetometer update"])
    lines.append(f"| + magnetometer update (the Hall tracker, 8 magnetometers) | {mag} | {mag} |")
    return "\n".join(lines)


def _simulate(b: dict) -> list[dict]:
    return [r for k, r in b["values"].items() if k.startswith("simulate ")]


def loop_simulate(b: dict) -> str:
    """docs/hardware.md: ``simulate_servo``'s cost per 1 kHz period and the emulated motor's tick."""
    sims = _simulate(b)
    now, before = [r["now"] / 1e3 for r in sims], [r["before"] / 1e3 for r in sims]
    emu = [r for k, r in b["values"].items() if k.startswith("emulator ")]
    return (f"`simulate_servo` at 1 kHz: {_range(now)} ms per period, "
            f"{_range([1 / t for t in now], '{:.1f}')}× real time (before: {_range(before)} ms); the emulated motor's "
            f"tick: {_range([r['device step'] for r in emu], '{:.0f}')} µs a device step with the coils and rotor, "
            f"{_range([r['magnetometer read'] for r in emu], '{:.0f}')} µs a magnetometer read ({_when(b)})")


def hardware_cycle(b: dict) -> str:
    """docs/hardware.md: the host's whole cycle against the emulated motor over the pty (``bench_hardware.py``)."""
    rows = {r["case"]: r for r in b["values"]["sessions"] if r["how"] == "pty" and r["rate asked Hz"] == 500}
    hold, turn = rows["hold"], rows["turn"]
    return (f"{hold['cpu mean ms']:.2f} ms (hold) to {turn['cpu mean ms']:.2f} ms (the 360° turn in 2.4 s) of CPU on "
            f"the air-core map, against a 2 ms period, at {hold['rate Hz']:.0f} / {turn['rate Hz']:.0f} Hz with "
            f"{hold['missed']} / {turn['missed']} deadlines missed (`bench_hardware.py --servo`, {_when(b)})")


def control_speed_table(b: dict) -> str:
    """docs/control.md, Speed: ``bench_control.py --quick`` (allocation, closed loop, holds, capability)."""
    v = b["values"]
    a, cpu, loop = v["allocation us"], v["allocation cpu us"], v["closed loop"]
    rows = [
        ("allocation, 29 coils, dual Newton (exact)",
         f"{a['newton']:.0f} µs wall, **{cpu['newton']:.0f} µs CPU** per call ({_thin(round(1e6 / a['newton']))}/s); "
         f"`pinv(K)t` without limits {a['pinv']:.0f} µs wall, {cpu['pinv']:.0f} µs CPU; Clarabel on the same QP "
         f"{a['clarabel'] / 1e3:.2f} ms ({a['clarabel'] / a['newton']:.0f}×), {cpu['clarabel'] / 1e3:.2f} ms CPU; "
         f"currents agree to {v['newton vs clarabel']:.1e}"),
        ("out-of-reach allocation (Clarabel SOCP + Newton)", _us_or_ms(a["out of reach"])),
        ("relay allocation (exhaustive, ≤ 4 coils)", _us_or_ms(a["relay"])),
        ("closed loop at 1 kHz, hold (`dynamics.hold`, magnets' torque map)",
         f"{loop['x real time']:.2f}× real time ({loop['ms per period']:.2f} ms per control period; one `K(R)` "
         f"{loop['K(R) ms']:.2f} ms, one torque evaluation {loop['torque ms']:.2f} ms of the torque map)"),
        ("holding 5 random orientations, 0.02° noise",
         "largest error over the last 0.15 s of 0.3 s: " + ", ".join(f"{w:.4f}°" for w in loop["hold worst deg"])),
        ("capability map, 1000 orientations", f"{v['capability 1000 s']:.1f} s"),
    ]
    body = "\n".join(f"| {k} | {x} |" for k, x in rows)
    return f"Measured {_when(b)} (`{b['command']}`; {b['machine']}):\n\n| what | measured |\n|---|---|\n{body}"


def control_loop_table(b: dict) -> str:
    """docs/control.md: ``simulate_servo`` per period and the law alone (``bench_servo_loop.py``)."""
    v = b["values"]
    lines = [f"Measured {_when(b)} ({b['machine']}); \"before\" is the same run through the reference paths "
             "(the models' own methods, the NumPy Newton and Clarabel):", "",
             "| model | hold | 20° turn | `ServoLaw.step` | the law with K and bias every period |",
             "|---|---|---|---|---|"]
    for name, label in (("air", "air core (`magnetics.torque_map`)"), ("iron", "iron (`magnetics.iron_model`, pairwise)")):
        hold, turn, law = v[f"simulate {name} hold"], v[f"simulate {name} turn"], v[f"law {name}"]
        lines.append(f"| {label} | {hold['now'] / 1e3:.2f} ms (before {hold['before'] / 1e3:.2f}) | "
                     f"{turn['now'] / 1e3:.2f} ms (before {turn['before'] / 1e3:.2f}) | "
                     f"**{law['law.step (turn)'][0] / 1e3:.3f} ms** (before {law['law.step (turn)'][1] / 1e3:.2f}) | "
                     f"{law['law.step, K each'][0] / 1e3:.3f} ms (before {law['law.step, K each'][1] / 1e3:.2f}) |")
    return "\n".join(lines)


def loop_law(b: dict) -> str:
    """docs/control.md, the robust servo's cost: the law's step and the supply box (``bench_servo_loop.py``)."""
    v = b["values"]
    air, iron = v["law air"], v["law iron"]
    every = _range([iron["law.step, K each"][0], air["law.step, K each"][0]], "{:.0f}")
    return (f"`law.step` iron {iron['law.step (turn)'][0]:.1f} µs, air {air['law.step (turn)'][0]:.1f} µs ({every} µs "
            f"when `K` is re-evaluated every period); the supply box + allocation "
            f"{iron['supply box + allocation'][0]:.1f} µs against {iron['allocation'][0]:.1f} µs for the symmetric "
            f"box alone (`bench_servo_loop.py`, {_when(b)})")


def loop_evaluations(b: dict) -> str:
    """docs/control.md: how often the law re-evaluates ``K(R̂)`` on the 20° turn."""
    n, periods = b["values"]["law iron"]["K evaluations"]
    return f"{n} times in {periods} periods"


def iron_bench_table(b: dict) -> str:
    """docs/magnetics.md: the pairwise and the coupled model's costs side by side (``bench_iron.py``)."""
    m = b["values"]["model"]
    pair = m["E+tau pairwise us"]
    rows = {r["model"].split()[0]: r for r in m["rows"]}
    p, c = rows["pairwise"], rows["coupled"]
    lines = [f"Measured {_when(b)} (`benchmarks/bench_iron.py`; {b['machine']}; the design's own model: "
             f"{m['label']}):", "", "| what | measured | ratio to pairwise |", "|---|---|---|",
             f"| E + τ, one orientation, pairwise (compiled zonal sums, 29 cores × 92 poles) | {pair:.0f} µs | 1 |",
             f"| E + τ, one orientation, coupled, NumPy sums | {m['E+tau coupled numpy us'] / 1e3:.1f} ms | "
             f"{m['E+tau coupled numpy us'] / pair:.0f} × |",
             f"| E + τ, one orientation, coupled, tables (the model's call) | {m['E+tau coupled tables us']:.0f} µs | "
             f"1/{pair / m['E+tau coupled tables us']:.0f} |",
             f"| E + τ, one orientation, coupled, tables (the compiled call the integrator makes) | "
             f"{m['E+tau coupled packed us']:.1f} µs | 1/{pair / m['E+tau coupled packed us']:.0f} |",
             f"| coupled tables, cold build (of which `G` on its grid) | {m['tables cold build s']:.1f} s "
             f"({m['coupling grid s']:.1f} s) | |",
             f"| dynamics at the tuned step ({p['dt ms']:.2f} / {c['dt ms']:.2f} ms), pairwise | "
             f"{p['x real time']:.1f} × real time | |",
             f"| dynamics at the tuned step, coupled (tables) | {c['x real time']:.0f} × real time | "
             f"{c['x real time'] / p['x real time']:.0f} × pairwise |",
             f"| capability map, 400 orientations, pairwise / coupled | {p['capability s']:.1f} s / "
             f"{c['capability s']:.1f} s | |"]
    return "\n".join(lines)


def iron_mom_table(b: dict) -> str:
    """docs/magnetics.md: the moment method's and the FEM's costs (``bench_iron.py`` without ``--no-mom``)."""
    m = b["values"]["mom"]
    lines = [f"Measured {_when(b)} (`benchmarks/bench_iron.py`; the FEM rows: medians of `data/iron_fem.csv`):", "",
             "| what | time | ratio |", "|---|---|---|",
             f"| MoM: factorise one core (level {m['level']}, {m['cells']} cells; `demag_tensor` + LU) | "
             f"{m['factorise s']:.1f} s | |",
             f"| MoM: pair table, per angle (detent + linear) | {m['per angle s']:.2f} s | |",
             f"| iron map (pairwise): 1000 orientations (compiled spline sums, detent over all 29 cores) | "
             f"{m['iron map 1000 ms']:.0f} ms | {m['iron map 1000 ms'] / m['air map 1000 ms']:.2f} × air map |",
             f"| iron map (pairwise): one orientation | {m['iron map one us']:.0f} µs | "
             f"{m['iron map one us'] / m['air map one us']:.2f} × air map |"]
    if "fem solve s" in m:
        lines += [f"| FEM (NGSolve): mesh one angle, median of the stored runs | {m['fem mesh s']:.0f} s | |",
                  f"| FEM (NGSolve): one solve (order 2, sparse Cholesky), median of the stored runs | "
                  f"{m['fem solve s']:.0f} s | {m['fem solve s'] / m['per angle s']:.0f} × a MoM angle |"]
    return "\n".join(lines)


def _times(x: float) -> str:
    """A ratio with about three significant figures: 3,766 / 91 / 2.4."""
    return f"{x:,.0f}" if x >= 10 else f"{x:.1f}"


def _script(b: dict) -> str:
    return f"`{b['command']}`, {_when(b)}"


def performance_table(bs: dict) -> str:
    """README, Performance: one row per benchmark figure, each with its run's date and load."""
    g = {k.removeprefix("bench-"): v for k, v in bs.items()}
    pk, mo, ha, po = g["packing"]["values"], g["motor"]["values"], g["harmonics"]["values"], g["potential"]["values"]
    dy, pl, hw, co = g["dynamics"]["values"], g["planners"]["values"], g["hardware"]["values"], g["control"]["values"]
    lo, se = g["servo_loop"]["values"], g["sensing"]["values"]
    sec = pk["seconds"]
    lv = {r["poles"]: r for r in mo["levels"]}
    proto, finer = lv[min(lv)], sorted(lv)[1:]
    leg = next(r for r in ha["rows"] if r["task"].startswith("P^l matrix, l=64") and "recurrence" in r["baseline"])
    batch, single = po["batch us per orientation"], po["single us"]
    pair29 = batch["energy, pairwise (exact), 29 coils"]
    quad = batch["quadrature (5 orientations, scaled), 29 coils"]
    fast = [batch[f"{t}, 29 coils"] for t in ("energy, fast", "energy + torque, fast", "E, τ, Hessian, fast",
                                                "K(R), fast")]
    vs = po["batch vs exact"]
    speedups = [vs[f"{t}, 29 coils"] for t in ("energy, fast", "energy + torque, fast", "E, τ, Hessian, fast",
                                                "K(R), fast")]
    dyn = {k: dy[k] for k in ("potential", "magnets' torque map", "iron model")}
    rates = hw["relay frames per second"]
    alloc, cpu = co["allocation us"], co["allocation cpu us"]
    sims = _simulate(g["servo_loop"])
    law = lo["law iron"]
    sessions = [r for r in hw["sessions"] if r["rate asked Hz"] == 500]
    pty = {r["case"]: r for r in sessions if r["how"] == "pty"}
    lock = {r["case"]: r for r in sessions if r["how"] == "lockstep"}
    off, drills = hw["faults all off"]
    track = se["timing us"]["track: 1 Gauss–Newton step (update)"]
    acc = se["accuracy"]
    rows = [
        (f"refine the truncated icosahedron to ≥ 10,000 caps ({pk['refined caps']:,})", f"{sec['refine']:.2f} s",
         g["packing"]),
        (f"`validate()` / `min_separation()` on {pk['refined caps']:,} caps (KD-tree)",
         f"{1e3 * sec['validate']:.0f} ms / {1e3 * sec['min_separation']:.1f} ms", g["packing"]),
        (f"min separation, brute-force N² vs KD-tree, {pk['brute caps']:,} caps",
         f"{sec['brute'] / sec['kd']:.1f}× slower", g["packing"]),
        (f"stepper states of the prototype ({proto['states']:,})",
         f"{proto['enumerate s']:.2f} s; dense dot products instead of the voxel lookup: "
         f"{mo['baseline']['dense s']:.1f} s ({mo['baseline']['dense s'] / mo['baseline']['voxel s']:.1f}×)",
         g["motor"]),
        ("stepper states with finer rotors (same stator)",
         "; ".join(f"{r} poles (tol {lv[r]['tol deg']:.2f}°): {lv[r]['states']:,} states in "
                   f"{lv[r]['enumerate s']:.0f} s" for r in finer) + " — they grow with the square of the poles",
         g["motor"]),
        ("geometric planner", f"{proto['plan steps per s']:,.0f} steps/s (prototype), "
         f"{lv[max(lv)]['plan steps per s']:,.0f} steps/s with the {max(lv)}-pole rotor", g["motor"]),
        ("potential planner, prototype (compiled descent)",
         f"{po['planner steps per s']['fast']:,.0f} steps/s over one turn (`bench_potential.py`), "
         f"{pl['potential']['steps per s']:,.0f} (`bench_planners.py`, {pl['potential']['trials']} turns); exact forms "
         f"{po['planner steps per s']['exact']:,.0f}", g["potential"]),
        (f"geometric vs potential planner, {pl['geometric']['trials']} full turns",
         f"tracking error median {pl['geometric']['median error deg']:.2f}° vs {pl['potential']['median error deg']:.2f}°, "
         f"worst {pl['geometric']['worst error deg']:.1f}° vs {pl['potential']['worst error deg']:.1f}°, final "
         f"{pl['geometric']['final error deg']:.2f}° vs {pl['potential']['final error deg']:.2f}°", g["planners"]),
        ("rotor dynamics at the tuned time step (4th order), compiled integrator: potential model / magnets' torque "
         "map / iron model (pairwise)",
         " / ".join(f"{_times(r['x real time'])}× real time ({r['dt ms']:.1f} ms)" for r in dyn.values())
         + "; NumPy `Rotor.step`: " + " / ".join(f"{_times(r['numpy x real time'])}×" for r in dyn.values())
         + "; at 5 ms: " + " / ".join(f"{_times(r['dt 5 ms x real time'])}×" for r in dyn.values()), g["dynamics"]),
        ("generalized Legendre matrix P^l, l = 64, 1000 angles",
         f"{1e3 * leg['s']:.0f} ms; {leg['baseline s'] / leg['s']:.0f}× faster than the element-wise recurrence",
         g["harmonics"]),
        ("motor energy, 1000 orientations, 29 coils: pairwise / harmonic form",
         f"{pair29:.0f} ms / {batch['energy, harmonic (exact), 29 coils']:.0f} ms; {quad / pair29:.0f}× / "
         f"{quad / batch['energy, harmonic (exact), 29 coils']:.0f}× faster than quadrature", g["potential"]),
        ("fast path (rotor function at the coils, ducc0), 1000 orientations, 29 coils: energy / energy + torque / "
         "E, τ, Hessian / `K(R)`",
         " / ".join(f"{x:.1f}" for x in fast) + f" µs per orientation: {_range(speedups, '{:.0f}')}× faster than "
         f"the pairwise form; ducc0's synthesis of the energy alone "
         f"{batch['ducc0 synthesis of F (anchor), 29 coils']:.2f} µs (the anchor)", g["potential"]),
        ("one orientation per call, 4 coils: energy + torque / torque",
         f"{single['single call energy + torque, fast, 4 coils']:.0f} µs / "
         f"{single['single call torque, fast, 4 coils']:.0f} µs (the compiled call alone "
         f"{single['single call energy + torque, the compiled call alone, 4 coils']:.0f} µs); pairwise form "
         f"{single['single call energy + torque, pairwise, 4 coils']:.0f} µs", g["potential"]),
        ("equilibria of 10⁴ starts, fast path (compiled descent) / exact forms",
         f"{po['equilibria 1e4 s']['fast']:.2f} s / {po['equilibria 1e4 s']['exact']:.1f} s", g["potential"]),
        ("serial protocol 1 over a pseudo-terminal (stop-and-wait)",
         f"{rates['SET round trip over pty']:,.0f} acknowledged SET frames/s, `play()` "
         f"{rates['play() over pty, rate unbounded']:,.0f}/s", g["hardware"]),
        ("least-power current allocation, 29 coils",
         f"{alloc['newton']:.0f} µs per call ({cpu['newton']:.0f} µs CPU); Clarabel on the same QP "
         f"{alloc['clarabel'] / 1e3:.2f} ms, same currents to {co['newton vs clarabel']:.1e}", g["control"]),
        ("torque capability over 1000 orientations (magnets' torque map)", f"{co['capability 1000 s']:.1f} s",
         g["control"]),
        ("servo simulation at 1 kHz control (coil electrics, sensor, plant and law)",
         f"{_range([1e3 / r['now'] for r in sims], '{:.1f}')}× real time; one period of the servo law "
         f"{law['law.step (turn)'][0]:.0f} µs CPU on a turn (iron; `K(R)` and bias {law['K(R) and bias'][0]:.0f} µs "
         f"when re-evaluated, allocation {law['allocation'][0]:.0f} µs; {law['law.step (turn)'][1]:.0f} µs through "
         "the reference paths)", g["servo_loop"]),
        (f"orientation from {acc['sensors']} magnetometers (one Gauss–Newton update on the field table)",
         f"{track:.0f} µs ({1e3 / track:.1f} kHz); {acc['rms deg']:.4f}° RMS, {acc['worst deg']:.4f}° worst over "
         f"{acc['samples']} uniform orientations with coils energised", g["sensing"]),
        ("protocol 2 over a pseudo-terminal against the emulated motor (magnets' torque map), the loop at 500 Hz",
         f"{pty['hold']['cpu mean ms']:.2f}–{pty['turn']['cpu mean ms']:.2f} ms host CPU per 2 ms cycle; hold "
         f"{pty['hold']['error deg']:.3f}° at {pty['hold']['rate Hz']:.0f} Hz ({pty['hold']['missed']} deadlines "
         f"missed), the 360° turn about (1, 0.5, 2) in 2.4 s {pty['turn']['error deg']:.3f}° off at the loop's end "
         f"({pty['turn']['missed']} missed); in lockstep {lock['turn']['rate Hz']:.0f} Hz, {lock['turn']['missed']} "
         f"missed, {lock['turn']['error deg']:.4f}°; {off} of {drills} injected faults end all-off within the 100 ms "
         "watchdog", g["hardware"]),
    ]
    body = "\n".join(f"| {what} | {value} | {_script(b)} |" for what, value, b in rows)
    machines = sorted({b["machine"] for b in bs.values()})
    return f"Machine: {'; '.join(machines)}.\n\n| what | measured | script, when |\n|---|---|---|\n{body}"


SENSING_ROWS = (("magpylib: rotor field at the 24 sensors", "magpylib rotor field (1 call)"),
                ("table: field", "table field"), ("table: field + Jacobian", "table field + Jacobian"),
                ("**update (`track`, 1 Gauss–Newton step)**", "track: 1 Gauss–Newton step (update)"),
                ("`solve`: LM to 1e-10 rad from 0.06°", "solve: LM to 1e-10 rad from 0.06°"))


def _us_or_ms(us: float) -> str:
    return f"{us / 1e3:.1f} ms" if us >= 1000 else f"{us:.0f} µs"


def sensing_timing(b: dict) -> str:
    """docs/sensing.md: time per call of the estimator's pieces (``bench_sensing.py --docs``)."""
    t = b["values"]["timing us"]
    mag = t["magpylib rotor field (1 call)"]
    lines = [f"Measured {_when(b)} (`benchmarks/bench_sensing.py --docs`; {b['machine']}):", "",
             "| call | median | rate | vs one magpylib call |", "|---|---|---|---|"]
    for label, key in SENSING_ROWS:
        bold = "**" if label.startswith("**") else ""
        lines.append(f"| {label} | {bold}{_us_or_ms(t[key])}{bold} | {bold}{_thin(round(1e6 / t[key]))} /s{bold} | "
                     f"{mag / t[key]:.0f}× |".replace("| 1× |", "| 1 |"))
    return "\n".join(lines)


def sensing_rate(b: dict) -> str:
    return f"{1e3 / b['values']['timing us']['track: 1 Gauss–Newton step (update)']:.1f} kHz in Python"


def sensing_magpylib(b: dict) -> str:
    return f"{1e6 / b['values']['timing us']['magpylib rotor field (1 call)']:.0f} Hz"


def sensing_update(b: dict) -> str:
    us = b["values"]["timing us"]["track: 1 Gauss–Newton step (update)"]
    return f"{1e3 / us:.1f} kHz (one Gauss–Newton step, {us:.0f} µs; {b['measured'][:10]})"


def sensing_rms(b: dict) -> str:
    return f"{b['values']['accuracy']['rms deg']:.4f}° RMS"


def sensing_accuracy(b: dict) -> str:
    """docs/sensing.md: the default array's accuracy (``bench_sensing.py --docs``)."""
    a = b["values"]["accuracy"]
    return (f"**{a['rms deg']:.4f}° RMS, {a['worst deg']:.4f}° worst** ({a['samples']} Haar orientations, "
            f"{b['measured'][:10]})")


def sensing_session_update(b: dict) -> str:
    """docs/sensing.md, the emulated path's table: the session's estimator update on iron (8 magnetometers, the cores'
    field modelled), ``bench_servo_loop.py``'s magnetometer update."""
    return (f"{b['values']['magnetometer update']:.0f} µs CPU (`bench_servo_loop.py`, {_when(b)})")


# ----------------------------------------------------------------------------------------------------- gallery

GALLERY_LABELS = {"prototype": "our reading of the paper", "jhu-as-built": "Johns Hopkins",
                  "ncsu-goldberg": "NCSU stator layout"}
GALLERY_TARGET = ("| Kumagai & Hollis SIM (target) | n/a | n/a | n/a | n/a | n/a | n/a | n/a | target: 4 N·m about any axis "
                  "| n/a | n/a | n/a |")


def _num(x: str):
    """A metrics.csv cell: a number, a boolean, or None when empty."""
    if x in ("True", "False"):
        return x == "True"
    if x == "":
        return None
    for kind in (int, float):
        try:
            return kind(x)
        except ValueError:
            pass
    return x


def _thin(n: int) -> str:
    return f"{n:,}".replace(",", " ")


def _nm(x: float) -> str:
    return f"{x:.2f}" if x >= 1 else f"{x:.3f}"


def gallery_table(g: dict) -> str:
    """docs/gallery.md: the stored metrics of every entry (``src/spherestep/data/gallery/metrics.csv``)."""
    lines = ["| design | magnets / coils | core | states | res. median | res. p95 | all SO(3) | escape | torque median "
             "(p5) | detent | magnets | W/coil |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key, r in g.items():
        label = GALLERY_LABELS.get(key)
        name = f"**{key}**" + (f" ({label}, {r['rotor_poles']}/{r['coils']})" if label else "")
        detent = f"{r['bias_torque_max_N_m']:.1f} N·m" if r["bias_torque_max_N_m"] else "0"
        mass = r["magnet_mass_kg"]
        lines.append(
            f"| {name} | {r['rotor_poles']} / {r['coils']} | {r['core']} | {_thin(r['states'])} | "
            f"{r['resolution_median_deg']:.2f}° | {r['resolution_p95_deg']:.2f}° | {'yes' if r['reaches_all'] else 'no'} | "
            f"{100 * r['escape_violations'] / r['states']:.0f} % | {_nm(r['torque_median_N_m'])} "
            f"({_nm(r['torque_p5_N_m'])}) N·m | {detent} | {mass:.2f} kg | "
            f"{r['coil_power_W']:.{1 if r['coil_power_W'] >= 1 else 2}f} |".replace(
                f"{mass:.2f} kg", f"{mass:.3g} kg" if mass < 1 else f"{mass:.2f} kg"))
    lines.append(GALLERY_TARGET)
    return "\n".join(lines)


def gallery_drive_table(g: dict) -> str:
    """docs/gallery.md: each design driven (the servo's fastest turn, the settled relay plan), as stored."""
    lines = ["| design | servo time | final | max track | power | relay plan: executed | steps on plan |",
             "|---|---|---|---|---|---|---|"]
    for key, r in g.items():
        if r["servo_turn_s"] is None:
            servo = "— (planner refused) | — | — | —"
        else:
            servo = (f"{r['servo_turn_s']:.3f} s | {r['servo_final_error_deg']:.1e}° | "
                     f"{r['servo_max_tracking_error_deg']:.2f}° | {r['servo_mean_power_W']:.1f} W")
        lines.append(f"| **{key}** | {servo} | {'yes' if r['relay_executed'] else 'no'} | "
                     f"{r['relay_steps_on_plan']} / {r['relay_steps']} |")
    return "\n".join(lines)


def gallery_asbuilt(g: dict) -> str:
    """docs/gallery.md: the as-built layout against our reading, in numbers."""
    p, j = g["prototype"], g["jhu-as-built"]
    return (f"{_thin(j['states'])} states against {_thin(p['states'])}, resolution median {j['resolution_median_deg']:.2f}° "
            f"against {p['resolution_median_deg']:.2f}°, torque in every direction median "
            f"{_nm(j['torque_median_N_m'])} against {_nm(p['torque_median_N_m'])} N·m and 5th percentile "
            f"{_nm(j['torque_p5_N_m'])} against {_nm(p['torque_p5_N_m'])} N·m")


def gallery_escape(g: dict) -> str:
    p = g["prototype"]
    return f"{100 * p['escape_violations'] / p['states']:.0f} %"


def gallery_gimbal(g: dict) -> str:
    return f"about {1e3 * g['gimbal-40mm']['torque_median_N_m']:.0f} mN·m"


def gallery_servo(g: dict) -> str:
    """docs/gallery.md: the servo's turn on each design, and where the planner refused, its reason."""
    arrived = {k: r for k, r in g.items() if r["servo_turn_s"] is not None}
    refused = {k: r for k, r in g.items() if r["servo_turn_s"] is None}
    out = "; ".join(f"{k} in {r['servo_turn_s']:.2f} s at {r['servo_mean_power_W']:.0f} W (tracked within "
                    f"{r['servo_max_tracking_error_deg']:.2f}°)" for k, r in arrived.items())
    if refused:
        reasons = []
        for k, r in refused.items():
            m = re.search(r"instead received '([^']*)'", r["drive_note"] or "")
            reasons.append(f"{k} ({m.group(1) if m else r['drive_note'] or 'no reason stored'})")
        out += ". The planner refuses the turn for " + "; ".join(reasons)
    return out


def gallery_relay(g: dict) -> str:
    """docs/gallery.md: the settled relay plan on each design, as stored."""
    done = [k for k, r in g.items() if r["relay_executed"]]
    part = ", ".join(f"{k} {r['relay_steps_on_plan']} of {r['relay_steps']}" for k, r in g.items()
                     if not r["relay_executed"])
    return (f"runs the whole turn on {', '.join(done) or 'none of the designs'}; steps settled within 0.5° of the "
            f"plan elsewhere: {part}")


# ----------------------------------------------------------------------------------------------------- explore

# docs/explore.md's published sweep: the default grid restricted to six rotor-stator pairs (the paper's, the old air-core
# front's and both family rules; 72 designs) — the whole default grid (648 designs, iron) takes hours on the shared
# 2-core machine under load; dropping --rotors/--stators here runs it whole
EXPLORE_SUBSET = {"rotors": ("truncated-icosahedron", "rhombicosidodecahedron", "truncated-octahedron"),
                  "stators": ("truncated-cuboctahedron", "truncated-icosahedron", "truncated-cube", "icosidodecahedron")}
EXPLORE_OPTIONS = ("--budget-coils", "32", "--workers", "2", "--rotors", ",".join(EXPLORE_SUBSET["rotors"]),
                   "--stators", ",".join(EXPLORE_SUBSET["stators"]))
EXPLORE_KEEP = ("rotor", "rotor_level", "rotor_poles", "stator", "stator_level", "cap_half_angle_deg", "coils", "states",
                "resolution_median_deg", "resolution_p95_deg", "escape_violations", "holding_torque_median_Nm",
                "capability_median_Nm", "capability_p5_Nm", "family_rule", "rotor_family", "stator_family", "model")
# the paper's pair, as the sweep names it (docs/explore.md compares it with the proposals)
EXPLORE_PROTOTYPE = {"rotor": "truncated-icosahedron", "rotor_level": 1, "stator": "truncated-cuboctahedron",
                     "stator_level": 1, "cap_half_angle_deg": 80.0}


def _records(df) -> list[dict]:
    """Rows as plain JSON values (NaN → None; the counts, floats in a CSV column with gaps, as integers)."""
    counts = ("rotor_level", "rotor_poles", "stator_level", "coils", "states", "escape_violations")
    return [{k: int(v) if k in counts and v is not None else v for k, v in r.items()}
            for r in json.loads(df.to_json(orient="records"))]


def summarise_explore(folder: Path, run: dict) -> dict:
    """The numbers docs/explore.md quotes from a finished sweep folder (``results.csv``, ``pareto.csv``) and how it
    ran (``run``: command, measured, wall_s, load, machine)."""
    import pandas as pd

    t = pd.read_csv(folder / "results.csv")
    front = pd.read_csv(folder / "pareto.csv")
    reason = t["reason"].fillna("")
    status = t["status"]
    ok = t[status == "ok"]
    reach = ok[ok["reaches_all"].astype(bool)]

    def share(df):
        return df["escape_violations"] / df["states"]

    def family(df) -> dict:
        esc = share(df)
        return {"designs": len(df), "resolution_median_deg": float(df["resolution_median_deg"].median()),
                "resolution_best_deg": float(df["resolution_median_deg"].min()),
                "escape_share_median": float(esc.median()), "escape_under_5pct": int((esc < 0.05).sum()),
                "holding_median_Nm": None if df["holding_torque_median_Nm"].isna().all()
                else float(df["holding_torque_median_Nm"].median()),
                "holding_measured": int(df["holding_torque_median_Nm"].notna().sum())}

    over = t[status == "over_budget"]
    proto = t
    for k, v in EXPLORE_PROTOTYPE.items():
        proto = proto[proto[k] == v]
    return {
        **run,
        "designs": len(t),
        "pairs": len(set(zip(t["rotor"], t["stator"]))),
        "status_counts": {k: int(v) for k, v in status.value_counts().items()},
        "no_states": {"few_coils": int(((status == "no_states") & reason.str.contains("coils? in the stator cap")).sum()),
                      "no_alignment": int(((status == "no_states") & reason.str.startswith("no orientation")).sum())},
        "too_large": {"lookup": int(((status == "too_large") & reason.str.contains("lookup grid")).sum()),
                      "candidates": int(((status == "too_large") & reason.str.contains("candidate alignments")).sum()),
                      "poles": int(((status == "too_large") & reason.str.contains("poles, over")).sum())},
        "over_budget": {"designs": len(over), "stators": sorted(set(over["stator"])),
                        "coils": [int(over["coils"].min()), int(over["coils"].max())] if len(over) else []},
        "does_not_fit_reasons": sorted(set(reason[status == "does_not_fit"])),
        "measured_designs": len(ok),
        "torques_measured": int(ok["model"].notna().sum()),
        "models": {k: int(v) for k, v in ok["model"].value_counts().items()},
        "reach_all": len(reach),
        "seconds_inside_designs": float(t["seconds"].fillna(0).sum()),
        "pareto": _records(front[list(EXPLORE_KEEP)]),
        "prototype": _records(proto[list(EXPLORE_KEEP)])[0] if len(proto) else None,
        "family": {"different": family(reach[reach["family_rule"] != "same"]),
                   "same": family(reach[reach["family_rule"] == "same"])},
    }


def run_explore(folder: Path | None) -> None:
    """``spherestep explore`` with docs/explore.md's options into ``folder`` (a fresh temporary one by default),
    timed, the load at its start and end recorded; its summary stored in data/explore_default.json. Given a finished
    ``folder`` whose ``run.json`` says how it ran, only the summary is stored."""
    if folder is not None and (folder / "results.csv").exists():
        run = json.loads((folder / "run.json").read_text(encoding="utf-8")) if (folder / "run.json").exists() else {}
    else:
        folder = folder or Path(tempfile.mkdtemp(prefix="explore-"))
        cmd = [sys.executable, "-c", "from spherestep.cli import main; main()", "explore", *EXPLORE_OPTIONS,
               "--out", str(folder), "--json"]
        load0, start = os.getloadavg()[0], datetime.datetime.now(datetime.UTC)
        print(f"running spherestep explore {' '.join(EXPLORE_OPTIONS)} --out {folder} (load {load0:.1f})", flush=True)
        out = subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})
        wall = (datetime.datetime.now(datetime.UTC) - start).total_seconds()
        info = json.loads(out.stdout)
        run = {"command": f"spherestep explore {' '.join(EXPLORE_OPTIONS)} --out …",
               "measured": start.strftime("%Y-%m-%d %H:%M UTC"), "wall_s": round(wall, 1),
               "load": [round(load0, 1), round(os.getloadavg()[0], 1)], "machine": _machine(),
               "stored_before": info["stored_before"], "evaluated": info["evaluated"]}
        (folder / "run.json").write_text(json.dumps(run, indent=1) + "\n", encoding="utf-8")
    _store("explore", summarise_explore(folder, run))


def _machine() -> str:
    import platform

    import numpy

    return (f"{os.cpu_count()} cores ({platform.machine()}, {platform.system()}), Python {platform.python_version()}, "
            f"NumPy {numpy.__version__}")


def _pack(name: str) -> str:
    return name.replace("-", " ")


def _ex_when(e: dict) -> str:
    lo, hi = sorted(e["load"])
    return f"{e['measured']}, load {lo:.1f}–{hi:.1f}"


def explore_run(e: dict) -> str:
    """docs/explore.md: how the default sweep ran and what became of its designs."""
    c, ns, tl, ob = e["status_counts"], e["no_states"], e["too_large"], e["over_budget"]
    minutes, seconds = divmod(round(e["wall_s"]), 60)
    models = "; ".join(f"{n} on {m}" for m, n in e["models"].items())
    fit = c.get("does_not_fit", 0)
    resumed = (f"; {e['stored_before']} of the {e['designs']} designs had been stored minutes before by an "
               f"interrupted run of the whole grid (same keys: a sweep resumes by key), the other {e['evaluated']} "
               "were evaluated in this run" if e.get("stored_before") else "")
    return (
        f"Measured {_ex_when(e)} with `{e['command']}` under `nice -n 5` ({e['machine']}; other jobs shared the "
        f"two cores): the default grid restricted to {e['pairs']} rotor–stator pairs, {e['designs']} designs — the "
        f"whole grid on the iron model takes hours on this machine under load, so this stated subset is what is "
        f"published (without `--rotors` and `--stators` the same command runs the whole grid). {minutes} min "
        f"{seconds:02d} s wall{resumed}; {e['seconds_inside_designs']:.0f} s inside designs summed over both "
        "workers. The coils are iron-cored (the default `--core iron`), the torques measured on each design's own "
        "model.\n\n"
        f"Of the {e['designs']} designs {e['measured_designs']} were measured; {c.get('no_states', 0)} have no states "
        f"({ns['no_alignment']} with no alignment of two poles on two coils, {ns['few_coils']} with fewer than two "
        f"coils in the cap), {c.get('too_large', 0)} were too large ({tl['lookup']} lookup grids, {tl['candidates']} "
        f"candidate counts, {tl['poles']} rotors over 300 poles), {fit} do not fit and {ob['designs']} are over the "
        "budget"
        + (f" ({', '.join(_pack(s) for s in ob['stators'])} as a stator: {ob['coils'][0]} to {ob['coils'][1]} coils)"
           if ob["designs"] else "") + ". "
        f"Torques were measured on {e['torques_measured']} of the {e['measured_designs']} ({models})"
        + ("" if e["torques_measured"] == e["measured_designs"] else
           "; the others' parts have no stored iron tables (their reason says so)")
        + f". {e['reach_all']} of the {e['measured_designs']} reach every orientation. The Pareto set within 32 coils:")


def explore_pareto_table(e: dict) -> str:
    """docs/explore.md: the default sweep's Pareto set, and the paper's pair beside it."""
    lines = ["| # | rotor | stator | cap | coils | median | 95 % | escape | holding (N·m) | capability p5 (N·m) | "
             "families |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    seen = set()
    for i, r in enumerate(e["pareto"], start=1):
        rotor = f"{_pack(r['rotor'])} L{r['rotor_level']}"
        if rotor not in seen:
            rotor += f" ({r['rotor_poles']})"
            seen.add(rotor.rsplit(" (", 1)[0])
        hold = "—" if r["holding_torque_median_Nm"] is None else f"{r['holding_torque_median_Nm']:.2f}"
        cap = "—" if r["capability_p5_Nm"] is None else _signed(r["capability_p5_Nm"], 2)
        same = " same" if r["family_rule"] == "same" else ""
        lines.append(f"| {i} | {rotor} | {_pack(r['stator'])} L{r['stator_level']} | {r['cap_half_angle_deg']:.0f}° | "
                     f"{r['coils']} | {r['resolution_median_deg']:.2f}° | {r['resolution_p95_deg']:.2f}° | "
                     f"{100 * r['escape_violations'] / r['states']:.0f} % | {hold} | {cap} | "
                     f"{r['rotor_family']}/{r['stator_family']}{same} |")
    return "\n".join(lines)


def explore_prototype(e: dict) -> str:
    """docs/explore.md: the paper's pair as the sweep measured it."""
    p = e["prototype"]
    hold = "not measured" if p["holding_torque_median_Nm"] is None else f"{p['holding_torque_median_Nm']:.2f} N·m"

    def dominates(r) -> bool:
        h, hp = r["holding_torque_median_Nm"], p["holding_torque_median_Nm"]
        torque = h is None or hp is None or h >= hp
        no_worse = r["resolution_median_deg"] <= p["resolution_median_deg"] and r["coils"] <= p["coils"] and torque
        return no_worse and r != p

    by = [(i, r) for i, r in enumerate(e["pareto"], start=1) if dominates(r)]
    if any(r == p for r in e["pareto"]):
        verdict = "it is on the Pareto front"
    elif by:
        i, r = by[-1]
        rh = "" if r["holding_torque_median_Nm"] is None else f", {r['holding_torque_median_Nm']:.2f} N·m"
        verdict = (f"it is dominated by #{i} ({_pack(r['rotor'])} L{r['rotor_level']} × {_pack(r['stator'])} "
                   f"L{r['stator_level']}, {r['cap_half_angle_deg']:.0f}°: {r['coils']} coils, "
                   f"{r['resolution_median_deg']:.2f}°{rh})")
    else:
        verdict = "it is dominated (by a design outside the coil budget or the reach condition)"
    return (f"{p['coils']} coils, {_thin(p['states'])} states, median {p['resolution_median_deg']:.2f}°, 95 % "
            f"{p['resolution_p95_deg']:.2f}°, escape {100 * p['escape_violations'] / p['states']:.0f} %, holding "
            f"torque {hold}: {verdict}")


def explore_measured(e: dict) -> str:
    return f"{e['measured_designs']} measured designs"


def explore_family(e: dict) -> str:
    """docs/explore.md: the family rule on the designs that reach every orientation."""
    d, s = e["family"]["different"], e["family"]["same"]
    same_front = sum(r["family_rule"] == "same" for r in e["pareto"])

    def hold(f):
        return "—" if f["holding_median_Nm"] is None else f"{f['holding_median_Nm']:.2f}"

    return (f"Among the {e['reach_all']} designs that reach every orientation, the {d['designs']} different-family "
            f"ones have a median resolution of {d['resolution_median_deg']:.2f}° (best "
            f"{d['resolution_best_deg']:.2f}°) and the {s['designs']} same-family ones {s['resolution_median_deg']:.2f}° "
            f"(best {s['resolution_best_deg']:.2f}°); the median share of states failing the escape test is "
            f"{100 * d['escape_share_median']:.1f} % and {100 * s['escape_share_median']:.1f} %, and "
            f"{d['escape_under_5pct']} and {s['escape_under_5pct']} designs have fewer than 5 % failing; the median "
            f"holding torque (of the {d['holding_measured']} and {s['holding_measured']} with torques measured) is "
            f"{hold(d)} and {hold(s)} N·m. {same_front} of the {len(e['pareto'])} proposals are same-family pairs")


# --------------------------------------------------------------------------------- the potential and dynamics

POTENTIAL_OFFSET_STATES, POTENTIAL_SEED = 5000, 0


def measure_potential() -> dict:
    """docs/potential.md's numbers of the prototype's energy model: profiles, band limit, kernel table, cut-off, the
    equilibria of ``POTENTIAL_OFFSET_STATES`` random states (seed ``POTENTIAL_SEED``) and the example curve's fit.
    Deterministic; ~1 min."""
    import numpy as np

    from spherestep import so3
    from spherestep.motor import coil_currents, prototype
    from spherestep.potential import MotorPotential, example_force_curve, fit_profile
    from spherestep.statics import equilibrium

    d = prototype()
    p = MotorPotential(d)
    stator_alone = MotorPotential(d, rotor_profile=p.stator_profile).bandlimit
    field = p.rotor_field
    cut = float(field.cut)
    x = np.random.default_rng(POTENTIAL_SEED).normal(size=(20_000, 3))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    inside = float(np.mean(np.sum(x @ field.poles.T > math.cos(cut), axis=1)))
    states = d.states()
    picks = np.sort(np.random.default_rng(POTENTIAL_SEED).choice(len(states), POTENTIAL_OFFSET_STATES, replace=False))
    coils = [states.coils(int(i)) for i in picks]
    c = np.array([coil_currents(k, len(d.stator)) for k in coils])
    geo = states.rotations[picks]
    eq = equilibrium(p, geo, c)
    off = np.degrees(so3.distance(eq.rotation, geo))
    held = np.array([len(k) for k in coils])
    rows = []
    for n in [*sorted(set(held.tolist())), None]:
        sel = off if n is None else off[held == n]
        rows.append({"held": n, "states": int(sel.size), "median": float(np.median(sel)), "mean": float(np.mean(sel)),
                     "p90": float(np.percentile(sel, 90)), "max": float(np.max(sel))})
    fit = fit_profile(*example_force_curve(), 0.1524, p.rotor_profile)
    return {
        "rotor_half_width_deg": math.degrees(p.rotor_profile.half_width), "rotor_kappa": p.rotor_profile.kappa,
        "stator_half_width_deg": math.degrees(p.stator_profile.half_width), "stator_kappa": p.stator_profile.kappa,
        "bandlimit": p.bandlimit, "bandlimit_stator_alone": stator_alone,
        "kernel_intervals": p.kernel.intervals, "kernel_errors": list(p.kernel.table_error),
        "cutoff_deg": math.degrees(cut), "poles": len(field.poles), "poles_inside_mean": inside,
        "equilibria": {"states": POTENTIAL_OFFSET_STATES, "seed": POTENTIAL_SEED,
                       "minima": int(np.sum(eq.is_minimum)), "iterations_max": int(np.max(eq.iterations)),
                       "iterations_mean": float(np.mean(eq.iterations)), "rows": rows,
                       "stiffness_median": [float(v) for v in np.median(eq.stiffness, axis=0)],
                       "stiffness_min": float(np.min(eq.stiffness))},
        "example_fit": {"kappa_s": fit.stator.kappa, "amplitude_s": fit.stator.amplitude},
    }


def potential_profiles(m: dict) -> str:
    return (f"`ρ_r = {m['rotor_half_width_deg']:.3f}°`, `κ_r = {m['rotor_kappa']:.2f}` and "
            f"`ρ_s = {m['stator_half_width_deg']:.3f}°`, `κ_s = {m['stator_kappa']:.2f}`")


def potential_bandlimit(m: dict) -> str:
    return (f"`L = {m['bandlimit']}` for the prototype (the rotor's sharper bump decides; the stator alone needs "
            f"{m['bandlimit_stator_alone']})")


def potential_kernel(m: dict) -> str:
    g, g1, g2 = m["kernel_errors"]
    return f"{m['kernel_intervals']} intervals, errors {g:.1e} (G), {g1:.1e} (G'), {g2:.1e} (G'')"


def potential_cutoff(m: dict) -> str:
    return (f"**{m['cutoff_deg']:.0f}°** for the prototype, so {m['poles_inside_mean']:.0f} of {m['poles']} poles per "
            "point on average")


def potential_offsets(m: dict) -> str:
    """docs/potential.md: equilibria of random states against their geometric states."""
    e = m["equilibria"]
    lines = [f"({e['states']:,} random states of the prototype (seed {e['seed']}), each with its held coils energised "
             f"with the polarity of their poles, started at the state): {e['minima']:,} of {e['states']:,} converge to "
             f"strict minima (Hessian positive definite) in at most {e['iterations_max']} Newton iterations (mean "
             f"{e['iterations_mean']:.1f}). Park distance equilibrium ↔ geometric state:", "",
             "| held pairs | states | median | mean | 90th pct | max |", "|---:|---:|---:|---:|---:|---:|"]
    for r in e["rows"]:
        lines.append(f"| {r['held'] if r['held'] is not None else 'all'} | {r['states']} | {r['median']:.3f}° | "
                     f"{r['mean']:.3f}° | {r['p90']:.3f}° | {r['max']:.3f}° |")
    return "\n".join(lines)


def potential_stiffness(m: dict) -> str:
    e = m["equilibria"]
    return (f"median {', '.join(f'{v:.1f}' for v in e['stiffness_median'])}; smallest over the sample "
            f"{e['stiffness_min']:.2f}")


def potential_fit(m: dict) -> str:
    f = m["example_fit"]
    return (f"`κ_s = {f['kappa_s']:.2f}`, `A_s = {f['amplitude_s']:.3f}` ({100 * abs(f['kappa_s'] / 51.03 - 1):.1f} % "
            f"and {100 * abs(f['amplitude_s'] / 6.0 - 1):.1f} % off: noise)")


def potential_timings(b: dict) -> str:
    """docs/potential.md, Timings: ``bench_potential.py``'s batches of 1000 orientations and its other figures."""
    v = b["values"]
    batch, vs, single = v["batch us per orientation"], v["batch vs exact"], v["single us"]
    lines = [f"Measured {_when(b)} (`benchmarks/bench_potential.py`; {b['machine']}, `OPENBLAS_NUM_THREADS="
             f"{b.get('OPENBLAS_NUM_THREADS', '?')}`). Batches of 1000 random orientations; \"vs ducc0\" is the row's "
             "time over the anchor's (ducc0's `synthesis_general` of `F` alone at the same points, library time "
             "only); \"vs exact\" the matching exact row's time over the row's. The accuracy of each row is the "
             "tests' (Accuracy, above).", "",
             "| task (1000 orientations) | µs per orientation | per second | vs ducc0 | vs exact |",
             "|---|---:|---:|---:|---:|"]
    for task, us in batch.items():
        coils = task.rsplit(", ", 1)[1]
        anchor = batch[f"ducc0 synthesis of F (anchor), {coils}"]
        name = task.replace("K(R)", "`K(R)`").replace("synthesis of F", "synthesis of `F`")
        if ", fast, " in task:
            name = "**" + name.replace(f", {coils}", "") + f"**, {coils}"
        ratio = vs.get(task)
        lines.append(f"| {name} | {_thin(round(us)) if us >= 100 else f'{us:.2f}'} | {_thin(round(1e6 / us))} | "
                     f"{_times(us / anchor)}× | {'' if ratio is None else f'{ratio:.1f}×'} |")
    eq, pl, dy = v["equilibria 1e4 s"], v["planner steps per s"], v["dynamics"]
    lines += ["", "Same script, same run:", "", "| task | fast path | exact forms |", "|---|---:|---:|"]
    for n in (4, 29):
        lines.append(f"| single call, energy + torque, {n} coils | {single[f'single call energy + torque, fast, {n} coils']:.1f} µs "
                     f"(the compiled call alone {single[f'single call energy + torque, the compiled call alone, {n} coils']:.1f} µs) | "
                     f"{single[f'single call energy + torque, pairwise, {n} coils']:.1f} µs (pairwise) |")
        lines.append(f"| single call, torque only, {n} coils | {single[f'single call torque, fast, {n} coils']:.1f} µs | |")
        lines.append(f"| single call, E, τ, Hessian, {n} coils | {single[f'single call E, τ, Hessian, fast, {n} coils']:.1f} µs | |")
    lines += [f"| equilibria of 10⁴ starts (2° off a state, its coils; {100 * eq['converged']:.0f} % converged) | "
              f"**{eq['fast']:.2f} s** | {eq['exact']:.1f} s |",
              f"| potential planner, one 360° turn | {_thin(round(pl['fast']))} steps/s | {_thin(round(pl['exact']))} steps/s |",
              f"| dynamics at the tuned step ({dy['fast']['dt ms']:.1f} ms) | {_thin(round(dy['fast']['x real time']))}× real "
              f"time | {_times(dy['exact']['x real time'])}× real time |"]
    return "\n".join(lines)


def _met(ok: bool) -> str:
    return "met" if ok else "**not reached**"


def potential_targets(bs: dict) -> str:
    """docs/potential.md: issue 17's targets against the stored runs of bench_potential, bench_planners, bench_dynamics."""
    po, pl, dy = bs["bench-potential"], bs["bench-planners"], bs["bench-dynamics"]
    v = po["values"]
    batch, single = v["batch us per orientation"], v["single us"]
    et, k, h = (batch[f"{t}, fast, 29 coils"] for t in ("energy + torque", "K(R)", "E, τ, Hessian"))
    one = single["single call energy + torque, fast, 4 coils"]
    eq, steps, dyn = v["equilibria 1e4 s"], v["planner steps per s"], dy["values"]["potential"]
    lines = [f"`bench_potential.py` {_when(po)}; `bench_planners.py` {_when(pl)}; `bench_dynamics.py` {_when(dy)}:", "",
             "| task | stored runs | target |", "|---|---:|---:|",
             f"| energy + torque, 29 coils, batches of 1000 | {et:.1f} µs per orientation ({_times(et / batch['ducc0 synthesis of F (anchor), 29 coils'])}× "
             f"the anchor; {batch['energy + torque, pairwise (exact), 29 coils'] / et:.0f}× faster than pairwise) | ≤ 5 µs — {_met(et <= 5)} |",
             f"| `K(R)`, 29 coils, batches | {k:.1f} µs → {_thin(int(round(1e6 / k, -3)))} per second | ≥ 10⁵ /s — {_met(1e6 / k >= 1e5)} |",
             f"| E, τ, Hessian, 29 coils, batches | {h:.1f} µs | — |",
             f"| one orientation per call, energy + torque, 4 coils | {one:.1f} µs (the compiled call alone "
             f"{single['single call energy + torque, the compiled call alone, 4 coils']:.1f} µs; pairwise "
             f"{single['single call energy + torque, pairwise, 4 coils']:.0f} µs) | ≤ 30 µs — {_met(one <= 30)} |",
             f"| equilibria of 10⁴ starts | {eq['fast']:.2f} s (exact forms {eq['exact']:.1f} s) | < 1 s — {_met(eq['fast'] < 1)} |",
             f"| potential planner, one 360° turn | {_thin(round(steps['fast']))} steps/s in `bench_potential.py`, "
             f"{_thin(round(pl['values']['potential']['steps per s']))} in `bench_planners.py` (median of "
             f"{pl['values']['potential']['trials']} turns; exact forms {_thin(round(steps['exact']))}) | ≥ 1000 — "
             f"{_met(min(steps['fast'], pl['values']['potential']['steps per s']) >= 1000)} |",
             f"| dynamics at the tuned step ({dyn['dt ms']:.1f} ms) | {_thin(round(dyn['x real time']))}× real time "
             f"(NumPy `Rotor.step` {_thin(round(dyn['numpy x real time']))}×) | ≥ 500× — {_met(dyn['x real time'] >= 500)} |"]
    return "\n".join(lines)


def planners_potential(b: dict) -> str:
    """docs/potential.md: the potential planner over bench_planners.py's turns, as stored."""
    p = b["values"]["potential"]
    return (f"median {p['median error deg']:.2f}°, worst {p['worst error deg']:.2f}°, final {p['final error deg']:.2f}° "
            f"over {p['trials']} turns, {_thin(round(p['steps per s']))} steps/s ({_when(b)})")


def measure_dynamics() -> dict:
    """docs/dynamics.md's numbers: the prototype's inertia and ``dynamics.tune`` on the torque map and the iron
    model (deterministic; ~30 s)."""
    from spherestep.dynamics import Rotor, tune
    from spherestep.magnetics import iron_model, torque_map
    from spherestep.motor import prototype

    d = prototype()
    out = {"inertia_kg_m2": Rotor.from_design(d).inertia}
    for name, model in (("torque map", torque_map(d)), ("iron model", iron_model(d))):
        t = tune(d, model)
        out[name] = {"stiffness_Nm_per_rad": t.stiffness, "omega_rad_s": t.omega,
                     "damping_Nm_s": t.rotor.damping, "dwell_s": t.dwell, "dt_s": t.dt}
    return out


def dynamics_tune(m: dict) -> str:
    """docs/dynamics.md: ``dynamics.tune`` on the prototype."""
    a, i = m["torque map"], m["iron model"]
    return (f"Prototype on the torque map: `k` = {a['stiffness_Nm_per_rad']:.3f} N·m/rad, `ω` = {a['omega_rad_s']:.2f} "
            f"rad/s, `b` = {a['damping_Nm_s']:.3f} N·m·s, dwell {a['dwell_s']:.2f} s, `dt` {1e3 * a['dt_s']:.1f} ms; on the "
            f"iron model: `k` = {i['stiffness_Nm_per_rad']:.1f} N·m/rad, `ω` = {i['omega_rad_s']:.1f} rad/s, `b` = "
            f"{i['damping_Nm_s']:.2f} N·m·s, dwell {i['dwell_s']:.2f} s, `dt` {1e3 * i['dt_s']:.1f} ms")


def dynamics_inertia(m: dict) -> str:
    return f"{m['inertia_kg_m2']:.4f} kg·m²"


def dynamics_speed(b: dict) -> str:
    """docs/dynamics.md, Speed: ``bench_dynamics.py``, each model at its own tuned step."""
    v = b["values"]
    rows = [(v["potential"], "the potential"), (v["magnets' torque map"], "the torque map"),
            (v["iron model"], "the iron model")]
    at = ", ".join(f"{_times(r['x real time'])}× on {name} ({r['dt ms']:.1f} ms)" for r, name in rows)
    numpy = ", ".join(f"{_times(r['numpy x real time'])}×" for r, _ in rows)
    at5 = ", ".join(f"{_times(r['dt 5 ms x real time'])}×" for r, _ in rows)
    return (f"`benchmarks/bench_dynamics.py`, {_when(b)}, each model at its own tuned step: {at}; `Rotor.step` in "
            f"the same run {numpy}; all three at 5 ms: {at5}")


# ------------------------------------------------------------------------------------------------------ blocks

@dataclass(frozen=True)
class Block:
    """One generated block: ``name`` its marker, ``path`` the file, ``source`` the stored measurement (a tuple of
    them: the renderer gets ``{source: stored}``)."""

    name: str
    path: str
    source: str | tuple[str, ...]
    render: Callable[[dict], str]
    inline: bool = False

    @property
    def sources(self) -> tuple[str, ...]:
        return self.source if isinstance(self.source, tuple) else (self.source,)

    def data(self, cache: dict | None = None):
        """What ``render`` takes: the stored measurement, or ``{source: stored}`` for several."""
        cache = {} if cache is None else cache
        got = {s: cache.setdefault(s, stored(s)) for s in self.sources}
        return got if isinstance(self.source, tuple) else got[self.source]

    def missing(self) -> list[str]:
        """The stored files this block needs that do not exist."""
        return [str(STORES[s].relative_to(ROOT)) for s in self.sources if not STORES[s].exists()]

    def text(self, data) -> str:
        body = self.render(data)
        sep = "" if self.inline else "\n"
        return f"<!-- {self.name}:start -->{sep}{body}{sep}<!-- {self.name}:end -->"


BLOCKS = (
    Block("demo-numbers", "README.md", "demo", readme_table),
    Block("drives-table", "docs/control.md", "demo", drives_table),
    Block("move-servo", "docs/control.md", "demo", move_servo, inline=True),
    Block("demo-servo-power", "docs/control.md", "demo", demo_servo_power, inline=True),
    Block("robust-table", "docs/control.md", "robust", robust_table),
    Block("calibration-table", "docs/control.md", "calibration", calibration_table),
    Block("calibration-summary", "docs/control.md", "calibration", calibration_summary, inline=True),
    Block("run-frames", "docs/errors.md", "demo", run_frames, inline=True),
    Block("motor-metrics", "docs/motor.md", "demo", motor_metrics, inline=True),
    Block("motor-states", "docs/motor.md", "demo", motor_states, inline=True),
    Block("motor-violations", "docs/motor.md", "demo", motor_violations, inline=True),
    Block("iron-table", "docs/magnetics.md", "demo", iron_table),
    Block("iron-drives", "docs/magnetics.md", "demo", iron_drives, inline=True),
    Block("iron-meaning", "docs/magnetics.md", "demo", iron_meaning, inline=True),
    Block("forces-table", "docs/magnetics.md", "forces", forces_table),
    Block("forces-summary", "docs/magnetics.md", "forces", forces_summary, inline=True),
    Block("forces-soft", "docs/magnetics.md", "forces", forces_soft, inline=True),
    Block("forces-steps", "docs/magnetics.md", "forces", forces_steps, inline=True),
    Block("iron-compare", "docs/magnetics.md", "iron", iron_compare_table),
    Block("gallery-table", "docs/gallery.md", "gallery", gallery_table),
    Block("gallery-drive-table", "docs/gallery.md", "gallery", gallery_drive_table),
    Block("gallery-asbuilt", "docs/gallery.md", "gallery", gallery_asbuilt, inline=True),
    Block("gallery-escape", "docs/gallery.md", "gallery", gallery_escape, inline=True),
    Block("gallery-gimbal", "docs/gallery.md", "gallery", gallery_gimbal, inline=True),
    Block("gallery-servo", "docs/gallery.md", "gallery", gallery_servo, inline=True),
    Block("gallery-relay", "docs/gallery.md", "gallery", gallery_relay, inline=True),
    Block("bench-sensing-timing", "docs/sensing.md", "bench-sensing", sensing_timing),
    Block("bench-sensing-rate", "docs/sensing.md", "bench-sensing", sensing_rate, inline=True),
    Block("bench-sensing-magpylib", "docs/sensing.md", "bench-sensing", sensing_magpylib, inline=True),
    Block("bench-sensing-update", "docs/sensing.md", "bench-sensing", sensing_update, inline=True),
    Block("bench-sensing-rms", "docs/sensing.md", "bench-sensing", sensing_rms, inline=True),
    Block("bench-sensing-accuracy", "docs/sensing.md", "bench-sensing", sensing_accuracy, inline=True),
    Block("bench-sensing-session-update", "docs/sensing.md", "bench-servo_loop", sensing_session_update, inline=True),
    Block("bench-performance", "README.md", tuple(f"bench-{n}" for n in BENCHES if n != "iron"), performance_table),
    Block("bench-loop-cost", "docs/hardware.md", "bench-servo_loop", loop_cost_table),
    Block("bench-loop-simulate", "docs/hardware.md", "bench-servo_loop", loop_simulate, inline=True),
    Block("bench-hw-cycle", "docs/hardware.md", "bench-hardware", hardware_cycle, inline=True),
    Block("bench-control-speed", "docs/control.md", "bench-control", control_speed_table),
    Block("bench-loop-table", "docs/control.md", "bench-servo_loop", control_loop_table),
    Block("bench-loop-law", "docs/control.md", "bench-servo_loop", loop_law, inline=True),
    Block("bench-loop-evaluations", "docs/control.md", "bench-servo_loop", loop_evaluations, inline=True),
    Block("bench-iron-models", "docs/magnetics.md", "bench-iron", iron_bench_table),
    Block("bench-iron-mom", "docs/magnetics.md", "bench-iron", iron_mom_table),
    Block("potential-profiles", "docs/potential.md", "potential", potential_profiles, inline=True),
    Block("potential-bandlimit", "docs/potential.md", "potential", potential_bandlimit, inline=True),
    Block("potential-kernel", "docs/potential.md", "potential", potential_kernel, inline=True),
    Block("potential-cutoff", "docs/potential.md", "potential", potential_cutoff, inline=True),
    Block("potential-offsets", "docs/potential.md", "potential", potential_offsets),
    Block("potential-stiffness", "docs/potential.md", "potential", potential_stiffness, inline=True),
    Block("potential-fit", "docs/potential.md", "potential", potential_fit, inline=True),
    Block("bench-potential-planner", "docs/potential.md", "bench-planners", planners_potential, inline=True),
    Block("bench-potential-timings", "docs/potential.md", "bench-potential", potential_timings),
    Block("bench-potential-targets", "docs/potential.md", ("bench-potential", "bench-planners", "bench-dynamics"),
          potential_targets),
    Block("dynamics-inertia", "docs/dynamics.md", "dynamics", dynamics_inertia, inline=True),
    Block("dynamics-tune", "docs/dynamics.md", "dynamics", dynamics_tune, inline=True),
    Block("bench-dynamics-speed", "docs/dynamics.md", "bench-dynamics", dynamics_speed, inline=True),
    Block("explore-run", "docs/explore.md", "explore", explore_run),
    Block("explore-pareto", "docs/explore.md", "explore", explore_pareto_table),
    Block("explore-prototype", "docs/explore.md", "explore", explore_prototype, inline=True),
    Block("explore-measured", "docs/explore.md", "explore", explore_measured, inline=True),
    Block("explore-family", "docs/explore.md", "explore", explore_family, inline=True),
)


def current(text: str, name: str) -> str | None:
    """The block ``name`` in ``text``, markers included (None when the file has no such markers)."""
    start, end = f"<!-- {name}:start -->", f"<!-- {name}:end -->"
    if start not in text:
        return None
    i, j = text.index(start), text.index(end) + len(end)
    return text[i:j]


def marked_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def differing() -> list[str]:
    """The blocks whose text in the docs is not what the stored measurements render (or whose markers are gone)."""
    cache: dict = {}
    bad = []
    for b in BLOCKS:
        if b.missing():
            bad.append(f"{b.name}: {', '.join(b.missing())} missing")
            continue
        have = current((ROOT / b.path).read_text(encoding="utf-8"), b.name)
        if have != b.text(b.data(cache)):
            bad.append(f"{b.path}: {b.name}" + (" (markers missing)" if have is None else ""))
    return bad


def write(paths: set[str] | None = None) -> int:
    """Rewrite every block from the stored measurements (only those in the files ``paths`` when given); the number
    of blocks changed."""
    cache: dict = {}
    changed = 0
    for b in BLOCKS:
        if paths is not None and b.path not in paths:
            continue
        if b.missing():
            print(f"skipped {b.name}: {', '.join(b.missing())} missing")
            continue
        path = ROOT / b.path
        text = path.read_text(encoding="utf-8")
        have = current(text, b.name)
        if have is None:
            print(f"skipped {b.name}: no markers in {b.path}")
            continue
        new = b.text(b.data(cache))
        if new != have:
            path.write_text(text.replace(have, new), encoding="utf-8")
            changed += 1
            print(f"rewrote {b.path}: {b.name}")
    return changed


def store_demo(source: Path) -> None:
    summary = {k: v for k, v in json.loads(source.read_text(encoding="utf-8")).items() if k not in DROP}
    if isinstance(summary.get("escape_violations"), list):  # the states themselves: their count is the number
        summary["escape_violations"] = len(summary["escape_violations"])
    _store("demo", summary)


def store_robust(source: Path | None) -> None:
    if source is None:
        source = Path(tempfile.mkstemp(suffix=".json")[1])
        subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_servo_robust.py"), "--json", str(source)],
                       check=True, cwd=ROOT)
    when = datetime.datetime.fromtimestamp(source.stat().st_mtime, datetime.UTC)
    _store("robust", {"measured": when.strftime("%Y-%m-%d %H:%M UTC"), "note": "",
                      "source": "benchmarks/bench_servo_robust.py", "rows": json.loads(source.read_text(encoding="utf-8"))})


def run_bench(name: str) -> None:
    """Run one benchmark of :data:`BENCHES` (alone: one at a time) storing ``data/bench_NAME.json``."""
    script, *options = BENCHES[name]
    print(f"running benchmarks/{script} {' '.join(options)} (load {os.getloadavg()[0]:.1f})", flush=True)
    subprocess.run([sys.executable, str(ROOT / "benchmarks" / script), *options, "--json",
                    str(STORES[f"bench-{name}"])], check=True, cwd=ROOT,
                   env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})


def main(argv: list[str]) -> int:
    args = list(argv)
    if args[:1] == ["--check"]:
        bad = differing()
        for line in bad:
            print(f"differs: {line}")
        return 1 if bad else 0
    cmd = args.pop(0) if args else "write"
    arg = Path(args[0]) if args else None
    if cmd in ("demo", "all"):
        store_demo(arg or ROOT / "spherestep-out" / "summary.json")
    if cmd in ("forces", "all"):
        _store("forces", measure_forces())
    if cmd == "robust":
        store_robust(arg)
    if cmd == "iron":
        subprocess.run([sys.executable, str(ROOT / "scripts" / "iron_compare.py"), "--json", str(STORES["iron"])],
                       check=True, cwd=ROOT)
    if cmd == "calibration":
        subprocess.run([sys.executable, str(ROOT / "benchmarks" / "bench_calibration.py"), "--json",
                        str(STORES["calibration"])], check=True, cwd=ROOT)
    if cmd == "bench":
        names = args or list(BENCHES)
        unknown = [n for n in names if n not in BENCHES]
        if unknown:
            print(f"unknown benchmark {', '.join(unknown)}: one of {', '.join(BENCHES)}", file=sys.stderr)
            return 2
        for name in names:
            run_bench(name)
    own = {"potential": {"docs/potential.md"}, "dynamics": {"docs/dynamics.md"}, "explore": {"docs/explore.md"}}
    if cmd in own:  # these store their own measurement and rewrite only their page's blocks
        if cmd == "potential":
            _store("potential", measure_potential())
        elif cmd == "dynamics":
            _store("dynamics", measure_dynamics())
        else:
            run_explore(arg)
        print(f"{write(own[cmd])} blocks rewritten")
        return 0
    if cmd not in ("demo", "forces", "robust", "iron", "calibration", "bench", "all", "write"):
        print(f"unknown command {cmd!r}: demo [SUMMARY], forces, robust [BENCH.json], iron, calibration, bench [NAME ...], "
              "potential, dynamics, explore [FOLDER], all [SUMMARY], --check", file=sys.stderr)
        return 2
    print(f"{write()} blocks rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
