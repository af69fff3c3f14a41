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
    python scripts/docs_numbers.py control-notes         # data/docs_control_notes.json: docs/control.md's numbers
                                                         # outside the demo and the benchmarks (~3 min)
    python scripts/docs_numbers.py sensing-notes         # data/docs_sensing_notes.json: docs/sensing.md's
                                                         # (~5 min; these two rewrite only their own store's blocks)
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
import time
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
    "control-notes": DATA / "docs_control_notes.json",  # docs_numbers.py control-notes (measure_control_notes)
    "sensing-notes": DATA / "docs_sensing_notes.json",  # docs_numbers.py sensing-notes (measure_sensing_notes)
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


# ------------------------------------------------------------------ the hand-written notes of control.md and sensing.md

NOTES_AXIS = (1.0, 0.5, 2.0)  # the demo's 360° turn, from the stepper state nearest the identity


def _run_header(mode: str) -> dict:
    start = datetime.datetime.now(datetime.UTC)
    return {"mode": mode, "measured": start.strftime("%Y-%m-%d %H:%M UTC"), "load": [round(os.getloadavg()[0], 1)],
            "machine": _machine(), "_t0": time.perf_counter()}


def _run_footer(run: dict) -> dict:
    run["wall_s"] = round(time.perf_counter() - run.pop("_t0"), 1)
    run["load"].append(round(os.getloadavg()[0], 1))
    return run


def _step(run: dict, label: str) -> None:
    """A progress line on stderr: the part just measured and the run's time so far."""
    print(f"{run['mode']}: {label} done ({time.perf_counter() - run['_t0']:.0f} s)", file=sys.stderr, flush=True)


def _cpu(f, repeat: int = 200) -> float:
    """Median CPU seconds of ``f()`` over ``repeat`` calls (after one warm-up call)."""
    f()
    ts = []
    for _ in range(repeat):
        t = time.process_time()
        f()
        ts.append(time.process_time() - t)
    return statistics.median(ts)


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


SENSING_GLOBAL_TRIALS = 10  # per row of the global start (the 2026-11-23 one-off ran 50)


def measure_sensing_notes() -> dict:
    """docs/sensing.md's numbers of today's code outside ``bench_sensing.py --docs``: the field table against
    magpylib, the placement, accuracy against sensor count, the global start (shortened), the model errors, the
    self-calibration, the 2-s tracking run with the IMU and the fusion, the servo's 20° turn with each sensor, and on
    the iron prototype the cores' cost, the estimator's error with and without them and ``accuracy``; the same
    seeds and cases as ``benchmarks/bench_sensing.py`` and ``bench_sensing_iron.py``. ~3–5 min of one core."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_sensing import global_start_rows, loop_rows, one_step_case  # the benchmark's own trials, stored here
    from dataclasses import replace

    import numpy as np
    from scipy.spatial.transform import Rotation

    from spherestep import sensing, so3
    from spherestep.sensing import iron as sensing_iron
    from spherestep.control import Trajectory, plan_turn
    from spherestep.drive import choose_model
    from spherestep.drive.turn import Turn
    from spherestep.dynamics import Rotor, simulate_servo
    from spherestep.magnetics import rotor_collection, torque_map
    from spherestep.motor import prototype

    run = _run_header("sensing-notes")
    design = prototype()
    t = time.perf_counter()
    placement = sensing.greedy_placement(design, 24)
    run["placement"] = {"seconds": time.perf_counter() - t, "candidates": len(placement.candidates)}
    array = placement.array(24)
    R = so3.random(200, 1)
    exact = np.asarray(rotor_collection(design, R).getB(array.positions))
    shell = sensing.fibonacci_directions(20_000)  # the rotor at rest: every orientation's field is on this shell
    run["field_max_mT"] = {f"{1e3 * s:g}": float(1e3 * np.linalg.norm(
        rotor_collection(design).getB(shell * (design.radius + s)), axis=-1).max()) for s in (0.010, 0.008, 0.005, 0.003)}
    run["field_max_mT"]["array"] = float(1e3 * np.linalg.norm(exact, axis=-1).max())
    run["table"] = []
    for n in (4097, 16385, 65537):
        t = time.perf_counter()
        table = sensing.FieldTable.build(design, array.positions, nodes=n)
        build = time.perf_counter() - t
        d = table.field(R) - exact
        run["table"].append({"nodes": n, "max_T": float(np.abs(d).max()), "rms_T": float(np.sqrt(np.mean(d ** 2))),
                             "build_s": build})
    table = sensing.FieldTable.build(design, array.positions)
    # symmetry (bench_sensing.symmetry): magpylib over the 60 copies; the marked rotor's nearest wrong copy
    G = sensing.symmetry_group(design)
    spread = max(float(np.abs(B - B[0]).max()) for B in
                 (sensing.rotor_field(design, array.positions, Rk @ G) for Rk in so3.random(5, 4)))
    marked_table = sensing.FieldTable.build(sensing.marked_design(design), array.positions)
    Gp = sensing.symmetry_group(sensing.marked_design(design), polarity=False)
    d = np.array([np.sqrt(np.sum((marked_table.field(Rk @ Gp[1:]) - marked_table.field(Rk)) ** 2, axis=(1, 2))).min()
                  for Rk in so3.random(300, 5)]) / array.part.effective_noise_T
    run["symmetry"] = {"order": len(G), "smallest_turn_deg": float(np.degrees(so3.angle(G[1:])).min()),
                       "copies_spread_T": spread, "marked_order": len(sensing.symmetry_group(sensing.marked_design(design))),
                       "margin_min": float(d.min()), "margin_p5": float(np.percentile(d, 5)),
                       "margin_median": float(np.median(d))}
    run["marker"] = sensing.marker_effect(design, sensing.marked_design(design), states=2, samples=300).to_dict()
    _, _, est, Ri, c, m, prev = one_step_case(design, array)
    run["one_step_deg"] = math.degrees(so3.distance(est.track(m, prev, c).R, Ri))
    run["solved_deg"] = math.degrees(so3.distance(est.solve(m, prev, c).R, Ri))
    _step(run, "placement, table, one step")
    # accuracy against sensor count (bench_sensing.accuracy_vs_count: seed k, 300 orientations) on the air-core
    # prototype (same winding): on iron every array but the stored one needs its cores' and coils' tables (minutes)
    air = replace(design, coil=replace(design.coil, core="air"))
    cand = placement.candidates
    run["accuracy"] = []
    bounds = placement.bound_deg()
    for k in (3, 4, 6, 8, 12, 16, 24):
        spread = sensing.SensorArray.at(cand[np.linspace(0, len(cand) - 1, k).astype(int)])
        for name, arr in (("greedy", placement.array(k)), ("spread", spread)):
            a = sensing.accuracy(air, arr, samples=300, seed=k)
            run["accuracy"].append({"sensors": k, "layout": name, "rms_deg": math.degrees(a.rms),
                                    "worst_deg": math.degrees(a.worst), "predicted_deg": math.degrees(a.predicted_rms),
                                    "bound_deg": float(bounds[k - 1]) if name == "greedy" else None,
                                    "coil_residual_uT": a.coil_residual_T * 1e6})
    _step(run, "accuracy against sensor count")
    # global start (bench_sensing's, shortened)
    run["global"] = {"trials": SENSING_GLOBAL_TRIALS, "rows": global_start_rows(design, array, SENSING_GLOBAL_TRIALS)}
    _step(run, "global start")
    # model errors (bench_sensing.model_error, 100 orientations)
    rng = np.random.default_rng(7)
    Rm = so3.random(100, rng)
    e1 = sensing.Estimator(table, array.axes, array.part)

    def errors(B, axes=array.axes):
        mm = np.einsum("sji,ksj->ksi", axes, B)
        return np.degrees([so3.distance(e1.solve(mm[k], Rm[k]).R, Rm[k]) for k in range(len(Rm))])

    cases = []
    moved = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    cases.append(("sensor positions off by 0.2 mm RMS per axis", errors(sensing.rotor_field(design, moved, Rm))))
    rotor = rotor_collection(design)
    for child in rotor.children:
        child.polarization = np.asarray(child.polarization) * (1.0 + rng.normal(0.0, 0.01))
    rotor.orientation = Rotation.from_matrix(Rm)
    cases.append(("magnet remanence spread 1 % RMS", errors(np.asarray(rotor.getB(array.positions)))))
    gain = 1.0 + rng.normal(0.0, 0.01, (len(array), 3))
    mm = np.einsum("sji,ksj->ksi", array.axes, sensing.rotor_field(design, array.positions, Rm)) * gain
    cases.append(("sensor gains off by 1 % RMS per axis",
                  np.degrees([so3.distance(e1.solve(mm[k], Rm[k]).R, Rm[k]) for k in range(len(Rm))])))
    run["model_error"] = [{"source": n, "rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max())}
                          for n, e in cases]
    _step(run, "model errors")
    # self-calibration (bench_sensing.calibration: 200 poses, 5 rounds, 100 tests)
    rng = np.random.default_rng(1)
    true_pos = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(array), 3)), rng.normal(0.0, 50e-6, (len(array), 3))
    Rc = so3.random(200, rng)
    mc = sensing.sense(array, sensing.rotor_field(design, true_pos, Rc), rng) * gain + offset
    start = np.stack([e1.solve(mc[k], Rc[k]).R for k in range(len(Rc))])
    t = time.perf_counter()
    cal = sensing.calibrate(design, array, mc, start, rounds=5, cores=False)
    took = time.perf_counter() - t
    e2 = sensing.Estimator(sensing.FieldTable.build(design, cal.array.positions), array.axes, array.part)
    Rt = so3.random(100, rng)
    mt = sensing.sense(array, sensing.rotor_field(design, true_pos, Rt), rng) * gain + offset
    E0 = np.stack([so3.log(e1.solve(mt[k], Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    E1 = np.stack([so3.log(e2.solve(cal.correct(mt[k]), Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    rms = lambda E: math.degrees(float(np.sqrt(np.mean(np.sum(E ** 2, axis=1)))))  # noqa: E731
    run["calibration"] = {"seconds": took, "residual_before_uT": float(cal.residual_T[0] * 1e6),
                          "residual_after_uT": float(cal.residual_T[-1] * 1e6),
                          "position_before_mm": float(1e3 * np.sqrt(np.mean((array.positions - true_pos) ** 2))),
                          "position_after_mm": float(1e3 * np.sqrt(np.mean((cal.array.positions - true_pos) ** 2))),
                          "orientation_before_deg": rms(E0), "orientation_after_deg": rms(E1),
                          "common_deg": math.degrees(float(np.linalg.norm(E1.mean(0)))),
                          "scatter_deg": rms(E1 - E1.mean(0))}
    _step(run, "self-calibration")
    # the 2-s run at 1 kHz (bench_sensing's)
    run["loop"] = loop_rows(design, array)
    _step(run, "2-s tracking run")
    # the servo's 20° turn with each sensor (bench_sensing.servo)
    tmap = torque_map(design)
    R0 = so3.random(1, 4)[0]
    traj = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), acceleration=10.0)
    sensors = {"ideal": sensing.IdealSensor(),
               "hall": sensing.HallSensor(design, array=array, current_error=0.01, seed=1, start=R0),
               "fused": sensing.FusedSensor(design, sensing.HallSensor(design, array=array, current_error=0.01,
                                                                       seed=2), 1e-3, seed=3, start=R0),
               "imu": sensing.ImuSensor(design, 1e-3, seed=4)}
    run["servo"] = {}
    for name, s in sensors.items():
        r = simulate_servo(design, traj, tmap, sensor=s, settle=0.15)
        est_e = so3.distance(r.estimates, r.orientations)
        run["servo"][name] = {"max_tracking_deg": math.degrees(float(r.tracking_error.max())),
                              "final_deg": math.degrees(r.final_error),
                              "estimate_rms_deg": math.degrees(float(np.sqrt(np.mean(est_e ** 2))))}
    _step(run, "servo turns")
    # iron: the stored cores' table read, its cost, the estimator's error (bench_sensing_iron.timing, static_error,
    # in_the_loop) and accuracy() with and without the cores
    iron_array = sensing.default_array(design)
    on = sensing.HallSensor(design, iron_array, seed=2)
    off = sensing.HallSensor(design, iron_array, seed=2, cores=False)
    rng = np.random.default_rng(2)
    Ri = so3.random(1, rng)[0]
    mi = on.readings(Ri, c)
    prev = so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8])) @ Ri
    core = on.core_field
    run["iron_cost_us"] = {k: 1e6 * _cpu(f) for k, f in (
        ("rotor", lambda: on.rotor_table.field_and_jacobian(Ri)), ("cores field", lambda: core.field(Ri)),
        ("cores jacobian", lambda: core.field_and_jacobian(Ri)), ("update without", lambda: off.estimator.track(mi, prev, c)),
        ("update with", lambda: on.estimator.track(mi, prev, c)))}
    run["iron_static"] = {}
    for label, cores in (("with", True), ("without", False)):
        s = sensing.HallSensor(design, iron_array, current_error=0.01, seed=4, cores=cores)
        errs = [so3.distance(s.estimator.solve(s.readings(Rk, c), so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8]))
                                               @ Rk, c).R, Rk) for Rk in so3.random(200, 7)]
        e = np.degrees(errs)
        run["iron_static"][label] = {"rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max())}
    chosen = choose_model(design)
    ax, angle = np.array([1.0, 0.0, 0.0]), math.radians(90.0)
    job = Turn(design, ax, angle, chosen)
    rotor = Rotor.from_design(design)
    plan = plan_turn(chosen.model, job.start, ax, angle, rotor.inertia, chosen.limits, damping=rotor.damping)
    run["iron_loop"] = {"model": chosen.label}
    for name, traj in (("turn", plan), ("hold", Trajectory.hold(job.start))):
        for label, cores in (("with", True), ("without", False)):
            s = sensing.HallSensor(design, current_error=0.01, seed=0, rate=1000.0, start=traj.start, cores=cores)
            t = time.perf_counter()
            r = simulate_servo(design, traj, chosen.model, limits=chosen.limits, rotor=rotor, sensor=s, settle=0.5)
            wall = time.perf_counter() - t
            e = np.degrees(so3.distance(r.estimates, r.orientations))
            run["iron_loop"][f"{name} {label}"] = {
                "rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max()),
                "tracking_deg": math.degrees(float(r.tracking_error.max())),
                "final_deg": float(np.degrees(so3.distance(r.orientations[-1], traj.end))),
                "final_sensor_deg": float(e[-1]), "wall_per_simulated": wall / float(r.times[-1])}
    _step(run, "iron cost, static error, loop")
    # self-calibration on iron (tests/test_sensing_model.py's case with 80 poses): with and without the cores
    arr8 = sensing.default_array(design, 8)
    rng = np.random.default_rng(21)
    true_pos = arr8.positions + rng.normal(0.0, 0.2e-3, arr8.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(arr8), 3)), rng.normal(0.0, 50e-6, (len(arr8), 3))
    Rc = so3.random(80, rng)
    cores8 = sensing_iron.iron_fields(design, arr8.positions)[0]
    mc = sensing.sense(arr8, sensing.rotor_field(design, true_pos, Rc) + cores8.field(Rc), rng) * gain + offset
    start = so3.exp(np.radians(0.5) * rng.normal(size=(len(Rc), 3)) / math.sqrt(3)) @ Rc
    run["iron_calibration"] = {"sensors": 8, "poses": 80, "rounds": 5,
                               "position_before_mm": float(1e3 * np.sqrt(np.mean((arr8.positions - true_pos) ** 2)))}
    for label, cores in (("with", None), ("without", False)):
        cal = sensing.calibrate(design, arr8, mc, start, rounds=5, cores=cores)
        run["iron_calibration"][label] = {
            "residual_mT": float(cal.residual_T[-1] * 1e3), "field_model": cal.field_model,
            "position_after_mm": float(1e3 * np.sqrt(np.mean((cal.array.positions - true_pos) ** 2)))}
    _step(run, "iron self-calibration")
    run["iron_accuracy"] = {}
    for label, cores in (("with", None), ("without", False)):
        a = sensing.accuracy(design, iron_array, samples=200, cores=cores)
        run["iron_accuracy"][label] = {"rms_deg": math.degrees(a.rms), "worst_deg": math.degrees(a.worst),
                                       "field_model": a.field_model}
    return _run_footer(run)


def _notes_when(n: dict) -> str:
    lo, hi = n["load"]
    return f"`scripts/docs_numbers.py` {n['mode']}, {n['measured']}, load {lo:.1f} → {hi:.1f}"


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
    lines = [f"Measured {n['measured']}, load {n['load'][0]:.1f} → {n['load'][1]:.1f} (`scripts/docs_numbers.py "
             f"control-notes`; {n['machine']}):", "",
             "| core | planner | time | bound (margin 1) | ratio | servo: max tracking | final | peak / mean power |",
             "|---|---|---|---|---|---|---|---|"]
    for core, row in n["turns"].items():
        b = row["bound_s"]
        for name, label in (("trapezoid", "trapezoid (`plan_trapezoid`)"), ("fastest", "**time-optimal**")):
            r = row[name]
            if "refused" in r:
                lines.append(f"| {core} | {label} | refused: {r['refused']} | {b:.3f} s | — | — | — | — |")
                continue
            if name == "fastest":
                label += f" ({r['path']}, margin {r['margin']:g})"
            dur = f"{r['duration_s']:.3f} s"
            lost = r["max_tracking_deg"] > 5
            lines.append(f"| {core} | {label} | {f'**{dur}**' if name == 'fastest' else dur} | {b:.3f} s | "
                         f"{r['duration_s'] / b:.2f} | {r['max_tracking_deg']:.{1 if lost else 3}f}°{' (lost)' if lost else ''} | "
                         f"{r['final_deg']:.3f}° | "
                         f"{r['peak_power_W']:.0f} / {r['mean_power_W']:.1f} W |")
    return "\n".join(lines)


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


def _deg(x: float) -> str:
    """Degrees to four decimals below 0.1°, two above (an error of degrees needs no more)."""
    return f"{x:.4f}" if x < 0.1 else f"{x:.2f}"


def _sn_when(n: dict) -> str:
    return f"{_notes_when(n)}; {n['machine']}"


def sensing_notes_run(n: dict) -> str:
    return f"{n['measured']} (load {n['load'][0]:.1f} → {n['load'][1]:.1f}, {n['machine']}; {n['wall_s']:.0f} s)"


def sensing_notes_table(n: dict) -> str:
    lines = ["| nodes | max abs error | RMS error | build |", "|---|---|---|---|"]
    for r in n["table"]:
        b = "**" if r["nodes"] == 16385 else ""
        name = f"{_thin(r['nodes'])} (default)" if r["nodes"] == 16385 else _thin(r["nodes"])
        lines.append(f"| {b}{name}{b} | {b}{r['max_T'] * 1e6:.2g} µT{b} | {b}{r['rms_T'] * 1e6:.2g} µT{b} | "
                     f"{r['build_s']:.2f} s |")
    return "\n".join(lines)


def sensing_notes_onestep(n: dict) -> str:
    return (f"one-step error {n['one_step_deg']:.4f}° against {n['solved_deg']:.4f}° after full convergence, from a "
            f"0.06° start (1 rad/s for 1 ms)")


def sensing_notes_loop_cost(n: dict) -> str:
    return f"{n['loop']['hall']['us_per_sample'] / 1e3:.1f} ms per sample"


def sensing_notes_global(n: dict) -> str:
    g = n["global"]
    lines = [f"{g['trials']} Haar-random orientations per row (shortened from the 50 of the first run), 24 sensors, "
             f"grid 2000; {_sn_when(n)}:", "",
             "| rotor | readings averaged | success (error < 0.05°) | median time | failures |", "|---|---|---|---|---|"]
    for r in g["rows"]:
        fails = ", ".join(f"{x:g}°" for x in r["failures_deg"]) or "—"
        lines.append(f"| {r['rotor']} | {r['averaged']} | {r['success']}/{g['trials']} | {r['median_s']:.2f} s | {fails} |")
    return "\n".join(lines)


def sensing_notes_global_short(n: dict) -> str:
    g = n["global"]
    rows = {(r["rotor"], r["averaged"]): r for r in g["rows"]}
    p, m = rows[("prototype, up to its 60 symmetries", 1)], rows[("marked, exact", 32)]
    return (f"{p['success']}/{g['trials']} (prototype, up to its symmetry), {m['success']}/{g['trials']} (marked rotor "
            f"with 32 averaged readings), ≈ {statistics.median(r['median_s'] for r in g['rows']):.1f} s ({n['measured']})")


def sensing_notes_placement(n: dict) -> str:
    p = n["placement"]
    return f"24 sensors from {p['candidates']} candidates in {p['seconds']:.1f} s ({_notes_when(n)})"


def sensing_notes_accuracy(n: dict) -> str:
    lines = [f"Measured {n['measured']}, load {n['load'][0]:.1f} → {n['load'][1]:.1f} (`scripts/docs_numbers.py "
             "sensing-notes`):", "",
             "| sensors | layout | RMS (°) | worst (°) | Cramér–Rao RMS (°) | worst-case bound (°) | coil residual RMS (µT) |",
             "|---|---|---|---|---|---|---|"]
    for r in n["accuracy"]:
        b = "**" if r["sensors"] == 24 and r["layout"] == "greedy" else ""
        bound = "" if r["bound_deg"] is None else f"{b}{r['bound_deg']:.4f}{b}"
        lines.append(f"| {b}{r['sensors']}{b} | {b}{r['layout']}{b} | {b}{r['rms_deg']:.4f}{b} | {b}{r['worst_deg']:.4f}{b} "
                     f"| {b}{r['predicted_deg']:.4f}{b} | {bound} | {r['coil_residual_uT']:.1f} |")
    return "\n".join(lines)


def _acc(n: dict, k: int, layout: str = "greedy") -> dict:
    return next(r for r in n["accuracy"] if r["sensors"] == k and r["layout"] == layout)


def sensing_notes_few(n: dict) -> str:
    """docs/sensing.md, inline: what the greedy layout buys with few sensors."""
    a3, s3, a12, s12 = _acc(n, 3), _acc(n, 3, "spread"), _acc(n, 12), _acc(n, 12, "spread")
    return (f"3 sensors: worst {a3['worst_deg']:.3f}° against {s3['worst_deg']:.3f}°; 12: {a12['worst_deg']:.3f}° against "
            f"{s12['worst_deg']:.3f}°")


def sensing_notes_model_error(n: dict) -> str:
    lines = ["| error source | RMS (°) | worst (°) |", "|---|---|---|"]
    lines += [f"| {r['source']} | {r['rms_deg']:.3f} | {r['worst_deg']:.3f} |" for r in n["model_error"]]
    return "\n".join(lines)


def sensing_notes_calibration(n: dict) -> str:
    c = n["calibration"]
    return "\n".join([
        f"5 rounds in {c['seconds']:.0f} s; {_sn_when(n)}:", "",
        "| | nominal model | calibrated |", "|---|---|---|",
        f"| residual per channel (µT) | {c['residual_before_uT']:.0f} | {c['residual_after_uT']:.0f} (the noise: 100 µT) |",
        f"| sensor position error RMS per axis (mm) | {c['position_before_mm']:.3f} | {c['position_after_mm']:.3f} |",
        f"| orientation error RMS (°) | {c['orientation_before_deg']:.4f} | {c['orientation_after_deg']:.4f} = a common "
        f"turn of {c['common_deg']:.4f} + scatter {c['scatter_deg']:.4f} |"])


def sensing_notes_common(n: dict) -> str:
    c = n["calibration"]
    return f"{c['common_deg']:.3f}° here"


def sensing_notes_scatter(n: dict) -> str:
    return f"{n['calibration']['scatter_deg']:.4f}°"


def sensing_notes_imu(n: dict) -> str:
    lo = n["loop"]
    names = (("hall", "magnetometer array, 1 Gauss–Newton step per sample"), ("imu", "IMU alone (MEKF: gyro, gravity, field)"),
             ("fused", "**fused: gyro + array (MEKF)**"))
    lines = [f"{_sn_when(n)}:", "", "| sensor | RMS (°) | worst (°) | time per sample (µs, incl. simulation) |",
             "|---|---|---|---|"]
    for k, label in names:
        r = lo[k]
        lines.append(f"| {label} | {_deg(r['rms_deg'])} | {_deg(r['worst_deg'])} | {r['us_per_sample']:.0f} |")
    return "\n".join(lines)


def sensing_notes_servo(n: dict) -> str:
    names = (("ideal", "ideal"), ("hall", "**array (24 × TMAG5273A2, 1 % current error)**"),
             ("fused", "fused (gyro + array)"), ("imu", "IMU alone"))
    lines = [f"{_sn_when(n)}:", "", "| sensor | max tracking error (°) | final error (°) | estimate error RMS (°) |",
             "|---|---|---|---|"]
    for k, label in names:
        r = n["servo"][k]
        lines.append(f"| {label} | {_deg(r['max_tracking_deg'])} | {_deg(r['final_deg'])} | {_deg(r['estimate_rms_deg'])} |")
    return "\n".join(lines)


def sensing_notes_iron_cost(n: dict) -> str:
    c, s, lo = n["iron_cost_us"], n["iron_static"], n["iron_loop"]
    rate = lambda us: _thin(int(round(1e6 / us, -2)))  # noqa: E731
    w, wo = lo["turn with"], lo["turn without"]
    hw, hwo = lo["hold with"], lo["hold without"]
    return "\n".join([
        f"CPU medians of 200 calls; {_sn_when(n)}:", "",
        "| call | median | rate |", "|---|---|---|",
        f"| rotor table: field + Jacobian | {c['rotor']:.0f} µs | {rate(c['rotor'])} /s |",
        f"| cores: field / field + Jacobian (compiled B-spline, 92 poles × 24 sensors) | {c['cores field']:.0f} / "
        f"{c['cores jacobian']:.0f} µs | {rate(c['cores field'])} / {rate(c['cores jacobian'])} /s |",
        f"| update without the cores (`track`, one Gauss–Newton step) | {c['update without']:.0f} µs | "
        f"{rate(c['update without'])} /s |",
        f"| **update with the cores** | **{c['update with']:.0f} µs** | **{rate(c['update with'])} /s** |", "",
        "| estimation error, iron prototype (24 × TMAG5273A2, 0.1 mT noise, 4 coils at ±1, 1 % current error) | cores "
        "modelled (default) | cores ignored (`cores=False`) |", "|---|---|---|",
        f"| 200 Haar orientations, LM from 0.06° off: RMS / worst | **{s['with']['rms_deg']:.4f}° / "
        f"{s['with']['worst_deg']:.4f}°** | {s['without']['rms_deg']:.2f}° / {s['without']['worst_deg']:.2f}° |",
        f"| in the loop, 90° turn about x (the drive's fastest turn on the iron model, 1 kHz, 0.5 s settle): sensor RMS "
        f"/ worst | **{w['rms_deg']:.4f}° / {w['worst_deg']:.4f}°** | {wo['rms_deg']:.2f}° / {wo['worst_deg']:.2f}° |",
        f"| same turn: tracking max / final | {w['tracking_deg']:.3f}° / {w['final_deg']:.4f}° | "
        f"{wo['tracking_deg']:.2f}° / {wo['final_deg']:.2f}° |",
        f"| in the loop, hold at the turn's start (0.5 s): sensor RMS / final | **{hw['rms_deg']:.4f}°** / "
        f"{hw['final_sensor_deg']:.4f}° | {hwo['rms_deg']:.2f}° / {hwo['final_sensor_deg']:.2f}° |",
        f"| wall time per simulated second (turn, hold) | {w['wall_per_simulated']:.1f}, {hw['wall_per_simulated']:.1f} | "
        f"{wo['wall_per_simulated']:.1f}, {hwo['wall_per_simulated']:.1f} |"])


def sensing_notes_iron_accuracy(n: dict) -> str:
    a = n["iron_accuracy"]
    return (f"**{a['with']['rms_deg']:.4f}° RMS, {a['with']['worst_deg']:.4f}° worst** with the cores modelled "
            f"(`field_model` `\"{a['with']['field_model']}\"`), {a['without']['rms_deg']:.2f}° / "
            f"{a['without']['worst_deg']:.2f}° ignoring them ({n['measured']})")


def sensing_notes_iron_calibration(n: dict) -> str:
    c = n["iron_calibration"]
    w, wo = c["with"], c["without"]
    return (f"{c['sensors']} sensors, {c['poses']} poses, {c['rounds']} rounds, the errors of "
            f"`tests/test_sensing_model.py`; {n['measured']}: with the cores (`\"{w['field_model']}\"`) the residual "
            f"falls to {w['residual_mT']:.3f} mT (noise 0.100) and the positions come back from "
            f"{c['position_before_mm']:.3f} to {w['position_after_mm']:.3f} mm RMS; ignoring the cores (`cores=False`) the "
            f"residual stays at {wo['residual_mT']:.1f} mT and the positions wander to {wo['position_after_mm']:.1f} mm")


def sensing_notes_iron_bias(n: dict) -> str:
    w = n["iron_static"]["without"]
    return f"**{w['rms_deg']:.2f}° RMS ({w['worst_deg']:.1f}° worst)**"


def sensing_notes_iron_margin(n: dict) -> str:
    return f"{0.05 / n['iron_loop']['turn with']['rms_deg']:.0f}× margin"


def sensing_notes_field(n: dict) -> str:
    """docs/sensing.md, inline: the largest rotor field on the sensor shell at each standoff, and at the array."""
    f = n["field_max_mT"]
    return (f"**{f['10']:.0f} mT** (|B| at 20 000 directions with the rotor at rest, which covers every orientation; "
            f"{f['8']:.0f} mT at 8 mm, {f['5']:.0f} mT at 5 mm, {f['3']:.0f} mT at 3 mm; {f['array']:.0f} mT at the chosen 24 "
            f"sensors over 200 orientations)")


def sensing_notes_symmetry(n: dict) -> str:
    y = n["symmetry"]
    return f"**{y['copies_spread_T']:.1e} T**"


def sensing_notes_marker(n: dict) -> str:
    y = n["symmetry"]
    return f"{y['margin_min']:.1f} (min), {y['margin_p5']:.1f} (5th percentile), {y['margin_median']:.1f} (median)"


def sensing_notes_marker_cost(n: dict) -> str:
    """docs/sensing.md: ``marker_effect`` on the torque map (2 random states each, 300 random drives)."""
    m = n["marker"]
    pair = lambda xs: ", ".join(f"{x:.3f}" for x in xs)  # noqa: E731
    change = [100 * (a / b - 1) for a, b in zip(m["holding_marker_after_Nm"], m["holding_marker_before_Nm"])]
    other = max(abs(a - b) for a, b in zip(m["holding_other_after_Nm"], m["holding_other_before_Nm"]))
    return "\n".join([
        f"{_sn_when(n)}:", "", "| | before | after |", "|---|---|---|",
        f"| share of stepper states that hold the marked pole | — | {100 * m['states_holding_marker']:.1f} % |",
        f"| holding torque, states holding the marked pole (N·m) | {pair(m['holding_marker_before_Nm'])} | "
        f"{pair(m['holding_marker_after_Nm'])} ({_signed(min(change), 0)} to {_signed(max(change), 0)} %) |",
        f"| holding torque, other states (N·m) | {pair(m['holding_other_before_Nm'])} | {pair(m['holding_other_after_Nm'])} "
        f"(changed by at most {other:.1g} N·m) |",
        f"| net dipole of the rotor (A·m²) | {m['dipole_before_Am2']:.0e} | {m['dipole_after_Am2']:.1f} (an Earth-field "
        f"torque of at most {m['dipole_after_Am2'] * 65e-6:.0e} N·m in 65 µT) |",
        f"| RMS torque change, 300 random orientations × random drives (±1 on 40 % of coils) | | "
        f"{100 * m['torque_change_rms']:.0f} % of the RMS torque |"])


def sensing_notes_pub(key: str) -> Callable[[dict], str]:
    """docs/sensing.md: one cell of the table beside the published numbers."""
    def render(n: dict) -> str:
        if key == "3":
            a = _acc(n, 3)
            return f"{a['rms_deg']:.3f}° RMS, {a['worst_deg']:.3f}° worst"
        if key == "positions":
            return f"{n['model_error'][0]['rms_deg']:.3f}° RMS"
        if key == "calibrated":
            c = n["calibration"]
            return f"{c['orientation_after_deg']:.3f}° RMS ({c['scatter_deg']:.3f}° after one reference pose)"
        if key == "fused":
            return f"{n['loop']['fused']['rms_deg']:.4f}° RMS"
        return f"{n['loop']['imu']['rms_deg']:.1f}° RMS"
    return render


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
    Block("control-notes-iron-coil", "docs/control.md", "control-notes", notes_iron_coil, inline=True),
    Block("control-notes-capability", "docs/control.md", "control-notes", notes_capability, inline=True),
    Block("control-notes-fastest", "docs/control.md", "control-notes", notes_fastest_table),
    Block("control-notes-fastest-summary", "docs/control.md", "control-notes", notes_fastest_summary, inline=True),
    Block("control-notes-move", "docs/control.md", "control-notes", notes_move, inline=True),
    Block("control-notes-planning", "docs/control.md", "control-notes", notes_planning, inline=True),
    Block("control-notes-coupled-cost", "docs/control.md", "control-notes", notes_coupled_cost, inline=True),
    Block("control-notes-emf", "docs/control.md", "control-notes", notes_emf, inline=True),
    Block("control-notes-hold-stretch", "docs/control.md", "control-notes", notes_hold_stretch, inline=True),
    Block("control-notes-coupling", "docs/control.md", "control-notes", notes_coupling, inline=True),
    Block("control-notes-weakest-hold", "docs/control.md", "control-notes", notes_weakest_hold, inline=True),
    Block("control-notes-emulated-calibration", "docs/control.md", "control-notes", notes_emulated_calibration,
          inline=True),
    Block("robust-summary", "docs/control.md", "robust", robust_summary, inline=True),
    Block("calibration-fastest", "docs/control.md", "calibration", calibration_fastest, inline=True),
    Block("servo-drag", "docs/control.md", "demo", servo_drag, inline=True),
    Block("relay-sweep", "docs/control.md", "demo", relay_sweep, inline=True),
    Block("calibration-coupling", "docs/control.md", "calibration", calibration_coupling, inline=True),
    Block("calibration-shell", "docs/control.md", "calibration", calibration_shell, inline=True),
    Block("iron-capability-least", "docs/control.md", "demo", iron_capability_least, inline=True),
    Block("sensing-notes-run", "docs/sensing.md", "sensing-notes", sensing_notes_run, inline=True),
    Block("sensing-notes-table", "docs/sensing.md", "sensing-notes", sensing_notes_table),
    Block("sensing-notes-onestep", "docs/sensing.md", "sensing-notes", sensing_notes_onestep, inline=True),
    Block("sensing-notes-loop-cost", "docs/sensing.md", "sensing-notes", sensing_notes_loop_cost, inline=True),
    Block("sensing-notes-global", "docs/sensing.md", "sensing-notes", sensing_notes_global),
    Block("sensing-notes-global-short", "docs/sensing.md", "sensing-notes", sensing_notes_global_short, inline=True),
    Block("sensing-notes-placement", "docs/sensing.md", "sensing-notes", sensing_notes_placement, inline=True),
    Block("sensing-notes-accuracy", "docs/sensing.md", "sensing-notes", sensing_notes_accuracy),
    Block("sensing-notes-few", "docs/sensing.md", "sensing-notes", sensing_notes_few, inline=True),
    Block("sensing-notes-model-error", "docs/sensing.md", "sensing-notes", sensing_notes_model_error),
    Block("sensing-notes-calibration", "docs/sensing.md", "sensing-notes", sensing_notes_calibration),
    Block("sensing-notes-common", "docs/sensing.md", "sensing-notes", sensing_notes_common, inline=True),
    Block("sensing-notes-scatter", "docs/sensing.md", "sensing-notes", sensing_notes_scatter, inline=True),
    Block("sensing-notes-imu", "docs/sensing.md", "sensing-notes", sensing_notes_imu),
    Block("sensing-notes-servo", "docs/sensing.md", "sensing-notes", sensing_notes_servo),
    Block("sensing-notes-iron-cost", "docs/sensing.md", "sensing-notes", sensing_notes_iron_cost),
    Block("sensing-notes-iron-calibration", "docs/sensing.md", "sensing-notes", sensing_notes_iron_calibration,
          inline=True),
    Block("sensing-notes-field", "docs/sensing.md", "sensing-notes", sensing_notes_field, inline=True),
    Block("sensing-notes-symmetry", "docs/sensing.md", "sensing-notes", sensing_notes_symmetry, inline=True),
    Block("sensing-notes-marker", "docs/sensing.md", "sensing-notes", sensing_notes_marker, inline=True),
    Block("sensing-notes-marker-cost", "docs/sensing.md", "sensing-notes", sensing_notes_marker_cost),
    Block("sensing-notes-iron-bias", "docs/sensing.md", "sensing-notes", sensing_notes_iron_bias, inline=True),
    Block("sensing-notes-iron-margin", "docs/sensing.md", "sensing-notes", sensing_notes_iron_margin, inline=True),
    Block("sensing-notes-iron-accuracy", "docs/sensing.md", "sensing-notes", sensing_notes_iron_accuracy, inline=True),
    *(Block(f"sensing-notes-pub-{k}", "docs/sensing.md", "sensing-notes", sensing_notes_pub(k), inline=True)
      for k in ("3", "positions", "calibrated", "fused", "imu")),
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


def write(paths: set[str] | None = None, sources: set[str] | None = None) -> int:
    """Rewrite every block from the stored measurements (only those in the files ``paths``, or rendered from the
    stores ``sources``, when given); the number of blocks changed."""
    cache: dict = {}
    changed = 0
    for b in BLOCKS:
        if paths is not None and b.path not in paths:
            continue
        if sources is not None and not set(b.sources) & sources:
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
    if cmd in ("control-notes", "sensing-notes"):  # pages shared with other stores: only this store's blocks
        _store(cmd, measure_control_notes() if cmd == "control-notes" else measure_sensing_notes())
        print(f"{write(sources={cmd})} blocks rewritten")
        return 0
    if cmd not in ("demo", "forces", "robust", "iron", "calibration", "bench", "all", "write"):
        print(f"unknown command {cmd!r}: demo [SUMMARY], forces, robust [BENCH.json], iron, calibration, bench [NAME ...], "
              "potential, dynamics, explore [FOLDER], control-notes, sensing-notes, all [SUMMARY], --check", file=sys.stderr)
        return 2
    print(f"{write()} blocks rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
