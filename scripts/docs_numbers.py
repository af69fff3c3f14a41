"""Every generated number in README and docs/ from stored measurement files, so the docs cannot drift (issue 27 §4).

A generated block is the text between ``<!-- NAME:start -->`` and ``<!-- NAME:end -->`` in a markdown file; each
NAME is registered in :data:`BLOCKS` with its file, the stored measurement it is rendered from and the renderer.
Blocks on their own lines hold tables; inline blocks hold a sentence's numbers. The stored measurements
(``data/``) are written by the commands below, never by hand:

    make demo && python scripts/docs_numbers.py demo     # data/demo_summary.json from spherestep-out/summary.json
    python scripts/docs_numbers.py forces                # data/forces_states.json: `spherestep forces`, 20 states
    python scripts/docs_numbers.py robust [BENCH.json]   # data/servo_robust.json: benchmarks/bench_servo_robust.py
    python scripts/docs_numbers.py iron                  # data/iron_compare.json: scripts/iron_compare.py
    python scripts/docs_numbers.py all                   # demo + forces (the end-of-session run)
    python scripts/docs_numbers.py                       # rewrite every block from the stored files
    python scripts/docs_numbers.py --check               # list the blocks that differ, exit 1 if any

Each command that stores a measurement then rewrites every block. ``tests/test_docs_numbers.py`` renders every
block again from the stored files and compares it with the docs (and holds the cheap stored numbers against the
live code).
"""

from __future__ import annotations

import datetime
import json
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
}
# the demo summary's keys not stored: file lists and per-state lists (their counts are the numbers)
DROP = ("escape_violation_states", "escape_violation_states_note", "files")
FORCES_STATES, FORCES_SEED = 20, 0
MARKER = re.compile(r"<!-- ([a-z0-9-]+):(start|end) -->")


def stored(name: str) -> dict | list:
    return json.loads(STORES[name].read_text(encoding="utf-8"))


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


# ------------------------------------------------------------------------------------------------------ blocks

@dataclass(frozen=True)
class Block:
    """One generated block: ``name`` its marker, ``path`` the file, ``source`` the stored measurement."""

    name: str
    path: str
    source: str
    render: Callable[[dict], str]
    inline: bool = False

    def text(self, data) -> str:
        body = self.render(data)
        sep = "" if self.inline else "\n"
        return f"<!-- {self.name}:start -->{sep}{body}{sep}<!-- {self.name}:end -->"


BLOCKS = (
    Block("demo-numbers", "README.md", "demo", readme_table),
    Block("drives-table", "docs/control.md", "demo", drives_table),
    Block("move-servo", "docs/control.md", "demo", move_servo, inline=True),
    Block("robust-table", "docs/control.md", "robust", robust_table),
    Block("run-frames", "docs/errors.md", "demo", run_frames, inline=True),
    Block("motor-metrics", "docs/motor.md", "demo", motor_metrics, inline=True),
    Block("motor-states", "docs/motor.md", "demo", motor_states, inline=True),
    Block("motor-violations", "docs/motor.md", "demo", motor_violations, inline=True),
    Block("iron-table", "docs/magnetics.md", "demo", iron_table),
    Block("iron-drives", "docs/magnetics.md", "demo", iron_drives, inline=True),
    Block("forces-table", "docs/magnetics.md", "forces", forces_table),
    Block("forces-summary", "docs/magnetics.md", "forces", forces_summary, inline=True),
    Block("forces-soft", "docs/magnetics.md", "forces", forces_soft, inline=True),
    Block("forces-steps", "docs/magnetics.md", "forces", forces_steps, inline=True),
    Block("iron-compare", "docs/magnetics.md", "iron", iron_compare_table),
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
        if not STORES[b.source].exists():
            bad.append(f"{b.name}: {STORES[b.source].relative_to(ROOT)} missing")
            continue
        data = cache.setdefault(b.source, stored(b.source))
        have = current((ROOT / b.path).read_text(encoding="utf-8"), b.name)
        if have != b.text(data):
            bad.append(f"{b.path}: {b.name}" + (" (markers missing)" if have is None else ""))
    return bad


def write() -> int:
    """Rewrite every block from the stored measurements; the number of blocks changed."""
    cache: dict = {}
    changed = 0
    for b in BLOCKS:
        if not STORES[b.source].exists():
            print(f"skipped {b.name}: {STORES[b.source].relative_to(ROOT)} missing")
            continue
        path = ROOT / b.path
        text = path.read_text(encoding="utf-8")
        have = current(text, b.name)
        if have is None:
            print(f"skipped {b.name}: no markers in {b.path}")
            continue
        new = b.text(cache.setdefault(b.source, stored(b.source)))
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
    if cmd not in ("demo", "forces", "robust", "iron", "all", "write"):
        print(f"unknown command {cmd!r}: demo [SUMMARY], forces, robust [BENCH.json], iron, all [SUMMARY], --check",
              file=sys.stderr)
        return 2
    print(f"{write()} blocks rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
