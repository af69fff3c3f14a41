"""The main job on a design (``spherestep demo``): what a builder asks first, measured and written to a folder.

1. the design's stepper states, resolution, range and escape directions (:meth:`MotorDesign.metrics`);
2. its torque models and what they mean: the air-cored coils (the magnets' torque map) and the paper's
   iron-cored coils (:func:`spherestep.magnetics.iron_model`): the torque capability of each over SO(3)
   (:func:`spherestep.control.torque_capability`), and what the iron changes (detent, unpowered holding, where the
   stepper states come to rest, saturation, power: :func:`spherestep.magnetics.iron_summary`);
3. a turn about a tilted axis commutated by the paper's geometric planner (:func:`spherestep.commutation.turn`):
   plan CSV/JSON and figures;
4. the turn driven three ways (:func:`spherestep.dynamics.compare_drives`): the paper's settled relay steps, ramped
   relay steps at the pull-out rate, and the current-controlled servo, with the bang-bang bound, on the air-core
   model; then on the iron-cored model (:func:`iron_drives`): the same relay plan settled and ramped, the relay
   steps as the potential planner finds them there (the detent holds the rotor: few or none move it) and the
   servo, which does turn it;
5. the HTML report with every section, and ``summary.json``.

:data:`DEMO_FILES` names everything written, so a caller can check the folder before the work and count what was
written if the disk fills.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np

from . import plots, so3
from .atomic import write_text

PLAN_FILES = ("plan.csv", "plan.json", "commutation_steps.png", "motor_3d.png", "plan_error.png")
SIMULATION_FILES = ("trajectory.csv", "simulation.png")
IRON_SERVO_TIME = 3.0  # s: the servo's time for the demo turn on the iron-cored model (see iron_drives)
IRON_RELAY_RATES = (2.0, 5.0, 14.0)  # steps/s: the ramped relays tried on iron (a subset of dynamics.ramped.RATES)
DRIVE_FILES = ("drives.json", "servo.png", "capability.png", "iron.png")
DEMO_FILES = PLAN_FILES + SIMULATION_FILES + DRIVE_FILES + ("report.html", "summary.json")
CAPABILITY_SAMPLES = 400


def write_plan_files(design, plan, axis, out: Path) -> None:
    """The plan (CSV, JSON) and its figures (:data:`PLAN_FILES`) into ``out``."""
    plan.to_csv(out / "plan.csv")
    plan.to_json(out / "plan.json")
    plots.save_figure(plots.figure_steps(design, plan, axis), out / "commutation_steps.png")
    plots.save_figure(plots.figure_motor_3d(design, plan.steps[0].achieved), out / "motor_3d.png")
    plots.save_figure(plots.figure_plan_error(plan), out / "plan_error.png")


def simulate_and_write(design, plan, axis, out: Path, model=None, tuning=None):
    """Run ``plan`` on the rotor under ``model`` (default the design's magnets' torque map) with tuned damping,
    dwell and time step; write :data:`SIMULATION_FILES`. Returns ``(simulation, summary dict)``."""
    from .dynamics import simulate, tune
    from .magnetics import torque_map

    model = torque_map(design) if model is None else model
    tuning = tune(design, model) if tuning is None else tuning
    sim = simulate(design, plan, model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    sim.to_csv(out / "trajectory.csv", axis)
    plots.save_figure(plots.figure_simulation(sim, plan, axis, tuning.dwell), out / "simulation.png")
    summary = sim.summary() | {
        "dwell_s": tuning.dwell, "damping_N_m_s": tuning.rotor.damping,
        "final_error_to_target_deg": math.degrees(float(so3.distance(sim.settled[-1], plan.targets[-1])))}
    return sim, summary


def run_demo(design, out: Path, axis, angle_deg: float, *,
             progress: Callable[[str], None] | None = None) -> dict:
    """Do the main job (module docstring) on ``design`` for a turn of ``angle_deg`` degrees about ``axis`` (fixed
    frame) and write :data:`DEMO_FILES` into the folder ``out`` (which must exist and be writable). Returns the
    summary written to ``summary.json`` (angles in degrees, torque in N·m, power in W, time in s)."""
    from .commutation import turn
    from .control import DriveLimits, torque_capability
    from .dynamics import compare_drives, figure_drive
    from .magnetics import iron_model, iron_summary, torque_map
    from .report import Section, capability_figure, servo_figure, write_report

    say = progress or (lambda _: None)
    axis = np.asarray(axis, dtype=float)
    say("enumerating stepper states")
    design.states()
    say("measuring resolution, range and escape directions")
    metrics = design.metrics()
    info = design.summary() | metrics.to_dict(degrees=True)
    say("building the torque models: air-cored and iron-cored coils")
    model, iron = torque_map(design), iron_model(design)
    limits = DriveLimits()
    info["torque_model"] = "TorqueMap (air core)"
    say("mapping the torque capability over SO(3)")
    capability = torque_capability(design, model, limits, samples=CAPABILITY_SAMPLES, seed=0)
    iron_limits = DriveLimits.from_spec(iron.coil, design)  # its winding: resistance, nominal current
    iron_capability = torque_capability(design, iron, iron_limits, samples=CAPABILITY_SAMPLES, seed=0)
    info["capability"] = capability.to_dict()
    info["iron_capability"] = iron_capability.to_dict()
    plots.save_figure(_matplotlib_capability({"air core": capability, "iron core": iron_capability}),
                      out / "capability.png")
    say("measuring what the iron cores change")
    iron_effects = iron_summary(design)
    info["iron"] = iron_effects.to_dict()
    plots.save_figure(iron_effects.figure(design), out / "iron.png")
    say("commutating")
    plan = turn(design, axis, angle_deg)
    write_plan_files(design, plan, axis, out)
    info["plan"] = plan.summary(max_step=design.max_step).to_dict() | {
        "axis": (axis / np.linalg.norm(axis)).tolist(), "angle_deg": angle_deg}
    say("simulating the settled relay steps")
    sim, info["simulation"] = simulate_and_write(design, plan, axis, out, model=model)
    say("driving the turn three ways: settled relays, ramped relays, servo")
    drives = compare_drives(design, axis, math.radians(angle_deg), model, limits=limits)
    info["drives"] = drives.to_dict()
    run = drives.servo_run
    plots.save_figure(figure_drive(run.times, run.tracking_error, run.currents, run.power,
                                   title="servo: the demo's turn"), out / "servo.png")
    say("driving the turn on the iron-cored model: settled and ramped relays, relays planned on it, the servo")
    info["iron_drives"] = iron_drives(design, axis, math.radians(angle_deg), iron, iron_limits)
    write_text(out / "drives.json", json.dumps(info["drives"] | {"iron": info["iron_drives"]}, indent=1))
    say("writing the HTML report")
    sections = (
        Section("capability", "Torque capability over SO(3)",
                note=f"Torque available in every direction with the coils within their limits (±{limits.max_current:g} A,"
                     f" {limits.supply_power:g} W supply), at {capability.radius.size} orientations drawn uniformly on "
                     f"SO(3) (seed 0), on the {type(model).__name__}. Median "
                     f"{np.median(capability.radius):.2f} N·m, 5th percentile "
                     f"{np.percentile(capability.radius, 5):.2f} N·m.",
                figure=capability_figure(capability), height=440),
        Section("iron", "Iron: detent and saturation", html=_iron_table(iron_effects, iron_capability)),
        Section("drives", "The turn driven three ways", html=_drives_table(drives) + _iron_drives_note(
            info["iron_drives"])),
        Section("servo", "Servo run", note="The servo's run of the same turn: tracking error against the "
                "trajectory and the sensor's error, every coil's current, and the power drawn from the supply.",
                figure=servo_figure(run), height=640),
    )
    write_report(out / "report.html", design, metrics, plan, simulation=sim, axis=axis, sections=sections)
    write_text(out / "summary.json", json.dumps(info, indent=1, default=_jsonable))
    return info


def iron_drives(design, axis, angle: float, model, limits, duration: float = IRON_SERVO_TIME) -> dict:
    """The turn driven three ways on the iron-cored ``model`` (``limits`` of the iron coil's winding): the paper's
    geometric plan as settled and as ramped relay steps (:func:`spherestep.dynamics.relay_drives`, damping, dwell
    and time step tuned on the iron's wells; ramped at :data:`IRON_RELAY_RATES`), the relay steps as the potential
    planner finds them on the iron model (how many of its steps move the rotor), and the servo over ``duration`` s
    — a fixed time, because the fastest-turn planner needs torque in every direction all along the path, which the
    detent denies (docs/magnetics.md)."""
    from .commutation import turn
    from .dynamics import drive_turn, relay_drives, tune

    plan = turn(design, axis, math.degrees(angle))
    settled, ramped, _ = relay_drives(design, plan, model, tune(design, model), limits, IRON_RELAY_RATES)
    planned = turn(design, axis, math.degrees(angle), planner="potential", model=model)
    s = planned.summary(max_step=design.max_step).to_dict()
    servo = drive_turn(design, axis, angle, mode="servo", model=model, limits=limits, duration=duration).summary
    keep = ("time_s", "final_error_deg", "max_tracking_error_deg", "peak_power_W", "mean_power_W",
            "peak_current_A", "reachable_fraction")
    return {"settled": settled.to_dict(), "ramped": ramped.to_dict(),
            "potential_plan": {"steps": s["steps"], "moves": s["moves"], "final_error_deg": s["error_final_deg"]},
            "servo": {k: servo[k] for k in keep}}


def iron_drives_lines(d: dict) -> list[str]:
    """The iron-cored turn (:func:`iron_drives`) in three sentences, for the report and the console."""
    st, rp, pp, sv = d["settled"], d["ramped"], d["potential_plan"], d["servo"]
    rates = ", ".join(f"{r:g}" for r, _ in rp["details"]["tried"])
    ramped = (f"ramped relay steps lose a step at every rate tried ({rates} steps/s)" if rp["time_s"] is None else
              f"ramped relay steps arrive in {rp['time_s']:.2f} s at {rp['details']['pull_out_rate_steps_per_s']:.1f}"
              f" steps/s")
    return [f"the paper's relay plan, settled ({st['details']['dwell_s']:.2f} s dwell, damping "
            f"{st['details']['damping_N_m_s_per_rad']:.2f} N·m·s/rad tuned on the iron's wells): "
            f"{st['details']['steps_settled_on_plan']} of {st['details']['steps']} steps settle on the plan, the "
            f"rotor ends {st['final_error_deg']:.1f}° from the turn's end; {ramped}",
            f"relay steps planned on the iron model move the rotor in {pp['moves']} of {pp['steps']} steps (final "
            f"error {pp['final_error_deg']:.1f}°: the detent holds it)",
            f"the servo turns it in {sv['time_s']:.2f} s, final error {sv['final_error_deg']:.4f}°, max tracking "
            f"error {sv['max_tracking_error_deg']:.2f}°, peak power {sv['peak_power_W']:.0f} W, mean "
            f"{sv['mean_power_W']:.1f} W"]


def _iron_drives_note(d: dict) -> str:
    return '<p class="note">On the iron-cored model: ' + "; ".join(iron_drives_lines(d)) + ".</p>"


def _jsonable(value):
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _drives_table(drives) -> str:
    rows = "".join(
        f"<tr><td>{r.mode}</td><td class=num>{r.time:.2f}</td><td class=num>{math.degrees(r.final_error):.3f}</td>"
        f"<td class=num>{math.degrees(r.max_tracking_error):.2f}</td><td class=num>{r.peak_power:.1f}</td>"
        f"<td class=num>{r.mean_power:.1f}</td></tr>" for r in drives.results)
    return ("<table><tr><th>mode</th><th>time (s)</th><th>final error (°)</th><th>max tracking error (°)</th>"
            "<th>peak power (W)</th><th>mean power (W)</th></tr>" + rows + "</table>"
            f'<p class="note">Bang-bang lower bound for the turn on the capability along its path: '
            f"{drives.bound:.2f} s; the servo took {drives.ratio:.2f}× that. Ramped relays at the pull-out rate "
            f"{drives.pull_out_rate:.1f} steps/s.</p>")


def _iron_table(effects, capability) -> str:
    e = effects
    rows = [
        ("pair torque peak, one pole and one coil: air core at nominal / iron detent (coil off) / iron per nominal "
         "current", f"{e.air_peak_Nm:.2f} / {e.detent_peak_Nm:.2f} / {e.linear_peak_Nm:.2f} N·m"),
        ("unpowered: random starts that come to rest at a minimum", f"{e.unpowered_minima} of {e.unpowered_starts}"),
        ("unpowered holding torque, median / least", f"{e.unpowered_holding_median_Nm:.2f} / "
                                                      f"{e.unpowered_holding_min_Nm:.2f} N·m"),
        ("stepper states that stay minima: air / iron", f"{e.air_states_minima} / {e.iron_states_minima} of "
                                                        f"{e.states_sampled}"),
        ("rest orientation from the geometric state: air median / iron median / iron max",
         f"{math.degrees(e.air_offset_median):.2f}° / {math.degrees(e.iron_offset_median):.2f}° / "
         f"{math.degrees(e.iron_offset_max):.2f}°"),
        ("holding torque of the states, median: air / iron", f"{e.air_holding_median_Nm:.2f} / "
                                                             f"{e.iron_holding_median_Nm:.2f} N·m"),
        ("a coil driven against its pole still attracts it", "yes" if e.wrong_polarity_attracts else "no"),
        ("largest mean |B| in the pole face of an energised coil at the sampled states, linear iron (coils on / "
         "off; a pole 4° off axis reaches 2.9 T: docs/magnetics.md), against the knee",
         f"{e.max_core_B_T:.2f} / {e.max_core_B_off_T:.2f} T against {e.knee_T:.2f} T"
         + (" — saturated" if e.saturated else "")),
        ("torque available in every direction (iron), median / 5th percentile",
         f"{np.median(capability.radius):.2f} / {np.percentile(capability.radius, 5):.2f} N·m"),
        ("fraction of SO(3) where the coils can cancel the detent in every direction",
         f"{np.mean(capability.radius > 0):.0%}"),
    ]
    body = "".join(f"<tr><td>{a}</td><td class=num>{b}</td></tr>" for a, b in rows)
    return ('<p class="note">The paper\'s stator has soft-iron cores. Their pull on the rotor magnets (the detent) is '
            "there with every coil off, is the same for both polarities, and moves where the rotor rests. Measured on "
            "the iron model (method-of-moments pair tables, linear iron; docs/magnetics.md).</p>"
            "<table><tr><th>quantity</th><th>value</th></tr>" + body + "</table>")


def _matplotlib_capability(capabilities: dict):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 3.6))
    ax = fig.add_subplot()
    for label, capability in capabilities.items():
        torque = np.sort(capability.radius)
        ax.step(torque, 1.0 - np.arange(len(torque)) / len(torque), where="post", label=label)
    ax.legend()
    ax.set_xlabel("torque available in every direction (N·m)")
    ax.set_ylabel("fraction of SO(3) with at least")
    ax.set_ylim(0, 1.02)
    ax.axvline(0.0, color="k", lw=0.5)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig
