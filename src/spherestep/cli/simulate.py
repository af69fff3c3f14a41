"""``spherestep simulate``: commutate a rotation and run it on the simulated rotor."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from ..errors import ComputationError, bad_value
from .app import app
from .common import (check_axis, check_core, console, design_from, number, parse_vector, print_json, tolerance_option,
                     usable, write_json)
from .progress import progress
from .motor import ANGLE

PLANNERS = ("geometric", "potential", "iron")


def parse_coils(text: str | None) -> list[int]:
    """``"3,7"`` → ``[3, 7]``; InputError naming ``--failed-coils`` otherwise."""
    if not text:
        return []
    try:
        coils = [int(k) for k in text.split(",")]
    except ValueError:
        raise bad_value("--failed-coils", "comma-separated coil numbers like 3,7", text) from None
    if any(k < 0 for k in coils):
        raise bad_value("--failed-coils", "coil numbers of at least 0", text)
    return coils


def _check_coils(ctx: typer.Context, param: typer.CallbackParam, value):
    if value is not None and not ctx.resilient_parsing:
        try:
            parse_coils(value)
        except ValueError as exc:
            raise typer.BadParameter(str(exc).split(" ", 1)[1]) from None
    return value


def _check_planner(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in ("auto",) + PLANNERS and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be one of auto, {', '.join(PLANNERS)}; instead received {value!r}")
    return value


@app.command()
def simulate(
    axis: str = typer.Option(..., "--axis", callback=check_axis, help="Rotation axis X,Y,Z in the fixed (stator) "
                                                                      "frame."),
    angle: float = typer.Option(..., "--angle", callback=ANGLE, help="Rotation angle in degrees."),
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    planner: str = typer.Option("auto", "--planner", callback=_check_planner,
                                help="auto (iron on an iron-cored design, geometric on air), geometric (Sec. "
                                     "III-A), potential (Sec. III-B) or iron (the minima of the design's own energy); "
                                     "the closed loop re-plans with the geometric rule."),
    steps: int = typer.Option(None, "--steps", callback=number("a whole number of steps, 1 to 10000", 1, 10_000),
                              help="Number of steps (default: 0.35 of a max step each)."),
    noise: float = typer.Option(0.0, "--noise", callback=number("a noise σ in degrees, 0 to 180", 0, 180),
                                help="Closed loop: measurement noise σ in degrees."),
    missed: float = typer.Option(0.0, "--missed", callback=number("a fraction of missed steps, 0 to 0.99", 0, 0.99),
                                 help="Closed loop: fraction of missed steps, 0 to 0.99."),
    failed_coils: str = typer.Option(None, "--failed-coils", callback=_check_coils,
                                     help="Coils that do not work, e.g. 3,7."),
    seed: int = typer.Option(0, "--seed", callback=number("a whole number ≥ 0 (a random seed)", 0, 2 ** 63 - 1),
                             help="Random seed for noise and missed steps (a whole number ≥ 0)."),
    plant_winding: float = typer.Option(1.0, "--plant-winding", callback=number("a scale 0.1 to 10", 0.1, 10),
                                        help="Run on a plant whose winding's torque is this many times the model's."),
    plant_detent: float = typer.Option(1.0, "--plant-detent", callback=number("a scale 0 to 10", 0, 10),
                                       help="Run on a plant whose detent (pairwise and through the cores) is this "
                                            "many times the model's (iron)."),
    turns: int = typer.Option(0, "--turns", callback=number("a whole number of random turns, 0 to 200", 0, 200),
                              help="Open loop: also the many-turn verdict — this turn and TURNS seeded random ones of "
                                   "15-360° (20 is the project's rule), each planned and run as this one; exit 1 "
                                   "unless 95 % execute."),
    core: str = typer.Option(None, "--core", callback=check_core,
                             help="air or iron: override the core the design file states (default: the design's)."),
    tolerance: float = tolerance_option(),
    out: Path = typer.Option(Path("spherestep-out"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Plan a rotation and run it on the rotor under the design's own physical torque model (its coils' core:
    iron for the prototype, with its detent; the magnets' torque map for air; --core overrides), which it names:
    trajectory CSV and a plot of desired vs achieved rotation angle (simulation.png). With --noise or --missed
    the loop is closed: the controller measures the orientation and re-plans from it (closed_loop.csv and
    closed_loop.png). Exit status 1 (after writing the files) when a step settles more than --tolerance (default
    0.5°) off its planned state, or the closed loop ends more than that from the state nearest the turn's end.

    Example: [bold]spherestep simulate --axis 1,0.5,2 --angle 90 --missed 0.1 --noise 0.2 --out sim[/bold]
    """
    closed = bool(noise or missed)
    if closed and turns:
        raise bad_value("--turns", "0 with --noise or --missed (the verdict runs the open-loop plans)", turns)
    if closed and planner == "auto":
        planner = "geometric"
    if closed and planner != "geometric":
        raise bad_value("--planner", "geometric with --noise or --missed (the closed loop re-plans with the "
                        "geometric rule); drop --planner, or --noise and --missed for an open-loop run", planner)
    from ..commutation import turn, turn_targets
    from ..outputs import Outputs, output_folder

    out = output_folder(out, "--out")
    axis_vec = parse_vector(axis, "--axis")
    design = design_from(design_path)
    failed = parse_coils(failed_coils)
    bad = [k for k in failed if k >= len(design.stator)]
    if bad:
        raise bad_value("--failed-coils", f"coil numbers 0..{len(design.stator) - 1}", bad)
    if failed:
        design = design.without_coils(failed)
    design = usable(design, "--design" if not failed else "--design/--failed-coils", design_path)
    targets = turn_targets(design, axis_vec, math.radians(angle), steps)  # checked before the torque map is built
    import numpy as np

    from .. import plots  # matplotlib and magpylib load once the command line is known to be good
    from ..drive import relay_planner, relay_tuning
    from ..drive.judgement import judge, tolerance as judged_within
    from ..dynamics import run_closed_loop
    from ..magnetics import design_model
    from ..magnetics.mismatch import scaled_model
    with progress("building the torque model and tuning the rotor", enabled=not as_json):
        own = design_model(design, core)
        physics = own.model
        if planner == "auto":
            planner = relay_planner(design, planner, physics)
        tuning = relay_tuning(design, physics, planner)
        plant = physics
        if plant_winding != 1.0 or plant_detent != 1.0:
            try:
                plant = scaled_model(physics, winding=plant_winding, detent=plant_detent,  # the whole detent
                                     coupling=plant_detent if getattr(physics, "coupling", None) is not None else 1.0)
            except ValueError as exc:
                raise bad_value("--plant-detent", "1 on an air core (it has no detent)", plant_detent) from exc
    summary = {"design": design.name, "model": own.label, "planner": planner, "failed_coils": failed,
               "damping_N_m_s": tuning.rotor.damping, "dwell_s": tuning.dwell,
               "plant": {"winding": plant_winding, "detent": plant_detent}}
    tol = judged_within(tolerance, "relay")
    where = (f"the {own.label} model" if plant is physics else  # a perturbed plant is named as such
             f"the plant (the {own.label} model with the winding ×{plant_winding:g}, the detent ×{plant_detent:g})")
    names = ("closed_loop.csv", "closed_loop.png") if closed else ("trajectory.csv", "simulation.png")
    files = Outputs(out, names + ("simulation.json",))
    with files:
        if closed:
            with progress(f"running the closed loop on {where}", enabled=not as_json):
                run = run_closed_loop(design, targets, plant, dwell=tuning.dwell, noise=math.radians(noise),
                                      missed=missed, rotor=tuning.rotor, dt=tuning.dt, rng=seed)
            run.to_csv(out / "closed_loop.csv", axis_vec)
            plots.save_figure(plots.figure_closed_loop(run, axis_vec), out / "closed_loop.png")
            judged = judge([run.end_error], tol, f"the closed loop on {where}", label="end",
                           times=[len(run.missed) * run.dwell])
            summary |= {"closed_loop": True, "noise_deg": noise, "missed_fraction": missed,
                        "steps_taken": len(run.missed), "missed_steps": int(run.missed.sum()),
                        "final_error_deg": math.degrees(run.final_error),
                        "end_error_to_goal_state_deg": math.degrees(run.end_error)}
        else:
            with progress(f"planning ({planner})", enabled=not as_json):
                plan = turn(design, axis_vec, math.radians(angle), steps, planner, physics if planner != "geometric"
                            else None, limits=own.limits, tuning=tuning if planner == "iron" else None)
            with progress(f"simulating the plan on {where}", enabled=not as_json):
                from ..demo import simulate_and_write

                sim, result = simulate_and_write(design, plan, axis_vec, out, plant, tuning, tolerance=tol)
            judged = judge(sim.step_errors[1:], tol, f"the plan on {where}", first_index=1,
                           times=tuning.dwell * np.arange(1, len(sim.step_errors)))
            summary |= {"closed_loop": False} | result
            if turns:
                from ..drive import many_turns

                with progress(f"the many-turn verdict: {turns + 1} turns", enabled=not as_json):
                    verdict = many_turns(design, own, planner=planner, plant=plant, count=turns, seed=seed,
                                         spec_turn=(axis_vec, math.radians(angle)))
                summary["many_turns"] = verdict.to_dict()
        summary["judgement"] = judged.to_dict()
        summary["files"] = [str(p) for p in files.paths]
        write_json(out / "simulation.json", summary)
    if as_json:
        print_json(summary)
    verdict = summary.get("many_turns")
    if verdict is not None and not verdict["steps_on_relays"]:
        raise ComputationError(f"the design does not step on relays: {verdict['executed']} of {verdict['turns']} turns "
                               f"executed (at least {100 * verdict['required']:.0f} % needed); first failure: "
                               f"{verdict['first_failure']}; files in {out}/")
    judged.require(f"{out}/")
    if as_json:
        return
    if summary["closed_loop"]:
        console.print(f"closed loop on the {own.label} model: {summary['steps_taken']} steps, {summary['missed_steps']} "
                      f"missed; ended {summary['end_error_to_goal_state_deg']:.2f}° from the state nearest the turn's "
                      f"end ({summary['final_error_deg']:.2f}° from the end itself); wrote {len(files.paths)} files to "
                      f"{out}/")
    else:
        console.print(f"{own.label} model: {summary['steps']} steps; settled within {summary['settled_error_max_deg']:.2f}° of the plan "
                      f"(median {summary['settled_error_median_deg']:.2f}°): "
                      f"{'executed' if summary['executed'] else 'NOT executed'}; wrote {len(files.paths)} files "
                      f"to {out}/")
        if verdict is not None:
            console.print(f"many turns: {verdict['executed']} of {verdict['turns']} executed, worst landing "
                          f"{verdict['worst_landing_deg']:.2f}°")

