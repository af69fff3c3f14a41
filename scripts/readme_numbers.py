"""The README's prototype table, generated from one run of the demo, so the numbers it quotes cannot drift.

    make demo                                   # spherestep-out/summary.json
    python scripts/readme_numbers.py            # data/demo_summary.json and the README's table from it

``tests/test_readme_numbers.py`` renders the stored ``data/demo_summary.json`` again and compares it with the
README's table (text between the ``demo-numbers`` markers), and holds the numbers that are cheap to measure
(states, resolution, the plan) against the live code.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STORED = ROOT / "data" / "demo_summary.json"
README = ROOT / "README.md"
START, END = "<!-- demo-numbers:start -->", "<!-- demo-numbers:end -->"
DROP = ("escape_violation_states", "escape_violation_states_note", "files", "held_pairs_histogram")


def _mode(drives: dict, name: str) -> dict:
    return next(m for m in drives["modes"] if m["mode"] == name)


def _time(m: dict) -> str:
    return f"**{m['time_s']:.2f} s**" if m["time_s"] is not None else "never arrives"


def render(s: dict) -> str:
    """The markdown table of the prototype's numbers from a demo ``summary.json`` (degrees, N·m, W, s)."""
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
    return f"{START}\n| quantity | value |\n|---|---|\n{body}\n{END}"


def stored() -> dict:
    return json.loads(STORED.read_text(encoding="utf-8"))


def readme_block(text: str) -> str:
    """The README's generated table, markers included."""
    i, j = text.index(START), text.index(END) + len(END)
    return text[i:j]


def main(argv: list[str]) -> int:
    source = Path(argv[0]) if argv else ROOT / "spherestep-out" / "summary.json"
    summary = {k: v for k, v in json.loads(source.read_text(encoding="utf-8")).items() if k not in DROP}
    if isinstance(summary.get("escape_violations"), list):  # the states themselves: their count is the number
        summary["escape_violations"] = len(summary["escape_violations"])
    STORED.write_text(json.dumps(summary, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")
    text = README.read_text(encoding="utf-8")
    README.write_text(text.replace(readme_block(text), render(summary)), encoding="utf-8")
    print(f"wrote {STORED.relative_to(ROOT)} and the README's table from {source}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
