"""The many-turn verdict: a design "steps on relays" only if it executes a stated set of turns (issue 39 §2).

The set: the spec's turn (when there is one) and ``count`` (default 20) turns about random axes (uniform on the
sphere) by random angles uniform in 15–360°, both senses, drawn from ``seed``. Each turn starts at the stepper state
nearest the identity and is planned by the design's relay planner (:func:`relay_planner`: the iron-aware planner,
:func:`spherestep.commutation.plan_iron`, on an iron-cored design; the geometric one on air) and run on the
simulated rotor (:func:`spherestep.dynamics.simulate`, the planner's tuning: :func:`relay_tuning`) under the
``plant`` (default the planning model itself). A turn is *executed* when

* no step is ``blocked``,
* every step lands within ``tolerance`` (0.5°) of its planned equilibrium, and
* the plan follows the requested rotation: every planned orientation within ``path_tol`` (default one
  ``max_step`` of the design) of its target, the last one included.

The verdict reports the fraction executed, the worst landing and, for the first turn that failed, the step
that missed. Cost: one plan and one simulation per turn (a minute for the prototype's 21 turns on this machine).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from .turn import choose_model, relay_planner, relay_tuning

COUNT = 20
SEED = 0
ANGLES = (math.radians(15.0), math.radians(360.0))
REQUIRED = 0.95  # the fraction of turns a design that "steps on relays" executes
def verdict_turns(count: int = COUNT, seed: int = SEED, spec_turn=None) -> list[tuple[np.ndarray, float]]:
    """``(axis, angle)`` pairs: ``spec_turn`` (``(axis, angle)``, if given) first, then ``count`` random turns
    (module docstring)."""
    count = checks.count(count, "count", 0, 10_000, expected="a whole number of random turns")
    rng = np.random.default_rng(seed)
    out = [] if spec_turn is None else [(checks.axis(spec_turn[0], "spec_turn.axis"), float(spec_turn[1]))]
    for _ in range(count):
        axis = rng.normal(size=3)
        angle = rng.uniform(*ANGLES) * rng.choice((-1.0, 1.0))
        out.append((axis / np.linalg.norm(axis), float(angle)))
    return out


@dataclass(frozen=True)
class TurnOutcome:
    """One turn of the verdict: ``axis``, ``angle`` (rad), ``steps``, ``landed`` (steps within the tolerance),
    ``worst`` (the worst landing, rad), ``first_miss`` (the first step that missed, or −1) and ``first_error`` (its
    landing error, rad), ``blocked`` steps, ``path`` (the plan's largest distance from its target, rad), ``end``
    (where the simulated rotor ended, from the turn's end, rad), ``executed``."""

    axis: tuple[float, float, float]
    angle: float
    steps: int
    landed: int
    worst: float
    first_miss: int
    first_error: float
    blocked: int
    path: float
    end: float
    executed: bool

    def to_dict(self) -> dict:
        return {"axis": [round(x, 6) for x in self.axis], "angle_deg": math.degrees(self.angle), "steps": self.steps,
                "landed": self.landed, "worst_landing_deg": math.degrees(self.worst), "first_miss": self.first_miss,
                "first_miss_deg": math.degrees(self.first_error), "blocked": self.blocked,
                "path_deg": math.degrees(self.path), "end_deg": math.degrees(self.end), "executed": self.executed}


@dataclass(frozen=True)
class Verdict:
    """The many-turn verdict (module docstring): ``outcomes`` of the turns run (fewer than ``turns`` when it
    stopped early: those not run count as failed), the ``planner``, ``tolerance`` and ``path_tol``
    (rad), the ``required`` fraction and the time per 90° of the executed turns (``seconds_per_90``, s: steps ×
    dwell, per 90° turned; ``nan`` when none executed)."""

    outcomes: tuple[TurnOutcome, ...]
    turns: int
    planner: str
    tolerance: float
    path_tol: float
    required: float
    dwell: float
    seconds_per_90: float

    @property
    def fraction(self) -> float:
        """Fraction of the turns executed."""
        return sum(o.executed for o in self.outcomes) / max(1, self.turns)

    @property
    def worst(self) -> float:
        """The worst landing over every turn (rad)."""
        return max((o.worst for o in self.outcomes), default=0.0)

    @property
    def steps(self) -> bool:
        """Whether the design steps on relays: at least ``required`` of the turns executed."""
        return self.fraction >= self.required - 1e-12

    def failure(self) -> str:
        """One line naming the first failed turn and its step ("" when every turn executed)."""
        for n, o in enumerate(self.outcomes):
            if not o.executed:
                what = (f"step {o.first_miss} landed {math.degrees(o.first_error):.2f}° off its planned equilibrium"
                        if o.first_miss >= 0 else f"{o.blocked} steps blocked" if o.blocked else
                        f"the plan strays {math.degrees(o.path):.1f}° from the requested rotation")
                return (f"turn {n} ({math.degrees(o.angle):.0f}° about ({', '.join(f'{x:.2f}' for x in o.axis)})): "
                        f"{what}")
        return ""

    def line(self) -> str:
        """One line for people."""
        executed = sum(o.executed for o in self.outcomes)
        text = (f"{executed} of {self.turns} turns executed ({100 * self.fraction:.0f} %, {self.planner} "
                f"planner), worst landing {math.degrees(self.worst):.2f}°")
        if math.isfinite(self.seconds_per_90):
            text += f", {self.seconds_per_90:.3g} s per 90°"
        if len(self.outcomes) < self.turns:
            text += f" (stopped after {len(self.outcomes)}: {self.required:.0%} out of reach)"
        return text + (f"; first failure: {self.failure()}" if self.failure() else "")

    def to_dict(self) -> dict:
        return {"planner": self.planner, "turns": self.turns, "turns_run": len(self.outcomes), "executed": sum(o.executed for o in self.outcomes),
                "fraction": self.fraction, "steps_on_relays": self.steps, "required": self.required,
                "worst_landing_deg": math.degrees(self.worst), "tolerance_deg": math.degrees(self.tolerance),
                "path_tol_deg": math.degrees(self.path_tol), "dwell_s": self.dwell,
                "seconds_per_90": self.seconds_per_90 if math.isfinite(self.seconds_per_90) else None,
                "first_failure": self.failure(), "outcomes": [o.to_dict() for o in self.outcomes]}


def run_turn(design, plan, plant, tuning, axis, angle: float, tolerance: float, path_tol: float) -> TurnOutcome:
    """Simulate ``plan`` on ``plant`` with ``tuning`` and judge it (module docstring)."""
    from ..dynamics import simulate

    sim = simulate(design, plan, plant, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt,
                   record_every=10_000, tolerance=tolerance)
    errors = np.asarray(sim.step_errors[1:], dtype=float)
    missed = np.flatnonzero(errors > tolerance)
    blocked = len(plan.failures)
    path = float(plan.errors.max())
    executed = not len(missed) and not blocked and path <= path_tol
    end = float(so3.distance(sim.settled[-1], plan.targets[-1]))
    return TurnOutcome(tuple(float(x) for x in axis), float(angle), len(errors), int(len(errors) - len(missed)),
                       float(errors.max()) if len(errors) else 0.0, int(missed[0]) + 1 if len(missed) else -1,
                       float(errors[missed[0]]) if len(missed) else 0.0, blocked, path, end, bool(executed))


def many_turns(design, model=None, *, planner: str = "auto", plant=None, count: int = COUNT, seed: int = SEED,
               spec_turn=None, tolerance: float = math.radians(0.5), path_tol: float | None = None,
               required: float = REQUIRED, stop_early: bool = False, plan_plants=(), plant_tol: float | None = None,
               progress=None) -> Verdict:
    """The many-turn verdict of ``design`` (module docstring). ``model``: the planning model (default the design's
    own, :func:`spherestep.magnetics.design_model`; a DesignModel or a torque model); ``plant``: the model the plans
    run on (default ``model``'s); ``spec_turn``: ``(axis, angle_rad)`` added first; ``stop_early``: stop once
    ``required`` can no longer be reached (the remaining turns are not run and the verdict counts them failed);
    ``plan_plants``, ``plant_tol``: the iron planner's ``plants`` (plans that hold on those models too) and how
    near the planned minimum theirs must lie."""
    from ..commutation import turn

    chosen = choose_model(design, model)
    planner = relay_planner(design, planner, chosen.model)
    plant = chosen.model if plant is None else plant
    tolerance = checks.positive(tolerance, "tolerance", "a positive angle in radians")
    path_tol = design.max_step if path_tol is None else checks.positive(path_tol, "path_tol", "a positive angle")
    required = checks.fraction(required, "required", expected="a fraction in (0, 1]") if required != 1 else 1.0
    tuning = relay_tuning(design, chosen.model, planner)
    turns = verdict_turns(count, seed, spec_turn)
    outcomes, failed = [], 0
    for n, (axis, angle) in enumerate(turns):
        if progress is not None:
            progress(f"turn {n + 1} of {len(turns)}: {math.degrees(angle):.0f}°")
        plan = turn(design, axis, angle, planner=planner, model=chosen.model, limits=chosen.limits, tuning=tuning,
                    plants=plan_plants, plant_tol=plant_tol)
        outcome = run_turn(design, plan, plant, tuning, axis, angle, tolerance, path_tol)
        outcomes.append(outcome)
        failed += not outcome.executed
        if stop_early and failed > (1 - required) * len(turns) + 1e-9:
            break
    done = [o for o in outcomes if o.executed]
    turned = sum(abs(o.angle) for o in done)
    per_90 = tuning.dwell * sum(o.steps for o in done) / (turned / (math.pi / 2)) if done else math.nan
    return Verdict(tuple(outcomes), len(turns), planner, tolerance, path_tol, required, float(tuning.dwell),
                   float(per_90))
