"""README's and docs/control.md's, docs/motor.md's and docs/magnetics.md's numbers from the demo's summary
(``data/demo_summary.json``)."""

from __future__ import annotations

from .common import _mode, _signed, table


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
    return table(("quantity", "value"), rows)


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
    rows = []
    for drives in (s["drives_other"], s["drives"]):
        for m in drives["modes"]:
            servo = m["mode"] == "servo"
            time = f"{m['time_s']:.2f} s" if m["time_s"] is not None else f"never arrives: {m['arrival_note']}"
            final = f"{m['final_error_deg']:.3f}°" if m["final_error_deg"] < 1 else f"{m['final_error_deg']:.1f}°"
            if servo:
                time, final = f"**{time}**", f"**{final}**"
            rows.append((drives["model"].split()[0], _relay_label(m), time, final,
                         f"{m['max_tracking_error_deg']:.{2 if servo else 1}f}°", f"{m['peak_power_W']:.0f} W",
                         f"{m['mean_power_W']:.1f} W"))
    a, d = s["drives_other"], s["drives"]
    bounds = "; ".join(
        f"{x['model'].split()[0]} {x['bang_bang_bound_s']:.3f} s (the servo takes {x['servo_over_bound']:.2f}× it)" for x in (a, d))
    return (table(("model", "mode", "time", "final error", "max tracking error", "peak power", "mean power"), rows)
            + f"\n\nModels: {a['model']} and {d['model']}. Bang-bang lower bound: {bounds}.")


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
    return table(("", "air core", "iron core (pot, μr 1000, linear)"), rows)


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
