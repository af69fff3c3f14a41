"""The servo against a plant it does not know exactly: holds and a turn with plant ≠ the controller's model.

For a :class:`~spherestep.magnetics.mismatch.MismatchCase` (plant and controller model of an iron design):

* *holds*: ``holds`` orientations drawn uniformly on SO(3) (``seed``), each held from rest at the orientation
  itself for ``hold_time`` + ``hold_check`` s by :func:`~spherestep.dynamics.hold`; the hold's error is the
  largest tracking error over the last ``hold_check`` s (the target: within 0.05° after 1 s);
* *the turn*: ``angle`` about ``axis`` (fixed frame) from the stepper state nearest the identity, planned by
  :func:`spherestep.control.plan_turn` on the design's pairwise model (the controller's, or the pairwise one the
  coupled controller's plan is made on: ``plan_turn`` refuses the coupled one within ``MARGIN``) and limits, run
  ``settle`` s beyond its end: final and largest tracking error, mean supply power.

Every run uses a :class:`~spherestep.sensing.NoisySensor` of ``noise`` rad at the control rate (seeded), the
design's drive limits (:func:`~spherestep.magnetics.design_model`) and rotor. ``disturbance_bandwidth`` is passed
to the servo law (``0``: the PD law with feed-forward alone, the "before" column of the table).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from .servo import HOLD_TOLERANCE, hold, simulate_servo

TURN_AXIS = (1.0, 0.5, 2.0)
TURN_ANGLE = 2.0 * math.pi
NOISE = math.radians(0.02)
MAX_TRACKING = math.radians(0.5)
MAX_POWER = 100.0  # W


@dataclass(frozen=True)
class RobustnessRow:
    """One case of the table (radians, seconds, watts inside): ``case`` its name; ``hold_errors`` the holds' errors
    after the settling time; ``turn_time`` the planned turn's duration; ``final_error``, ``max_tracking_error``
    and ``mean_power`` of the turn; ``reachable_fraction`` of its periods; ``disturbance_bandwidth`` rad/s of the
    law (0: off); ``hold_reachable`` whether the *plant* can hold each hold's orientation at all within the limits
    (:func:`plant_can_hold`: a hold it cannot is beyond any controller). :attr:`passed` says whether every target of
    issue 25 §2 was met on the holds the plant can make."""

    case: str
    hold_errors: tuple[float, ...]
    turn_time: float
    final_error: float
    max_tracking_error: float
    mean_power: float
    reachable_fraction: float
    disturbance_bandwidth: float | None
    hold_reachable: tuple[bool, ...] = ()

    @property
    def worst_hold(self) -> float:
        return max(self.hold_errors) if self.hold_errors else 0.0

    @property
    def worst_reachable_hold(self) -> float:
        """The worst error over the holds the plant can make (all, when reachability was not checked)."""
        reach = self.hold_reachable or (True,) * len(self.hold_errors)
        return max((e for e, r in zip(self.hold_errors, reach) if r), default=0.0)

    @property
    def passed(self) -> bool:
        return (self.worst_reachable_hold <= HOLD_TOLERANCE and self.final_error <= HOLD_TOLERANCE
                and self.max_tracking_error <= MAX_TRACKING and self.mean_power <= MAX_POWER)

    def to_dict(self, degrees: bool = True) -> dict:
        unit, f = ("deg", math.degrees) if degrees else ("rad", float)
        return {"case": self.case, f"worst_hold_{unit}": f(self.worst_hold),
                "holds_within": sum(e <= HOLD_TOLERANCE for e in self.hold_errors), "holds": len(self.hold_errors),
                "holds_plant_cannot_make": sum(not r for r in self.hold_reachable),
                "turn_time_s": self.turn_time, f"final_error_{unit}": f(self.final_error),
                f"max_tracking_error_{unit}": f(self.max_tracking_error), "mean_power_W": self.mean_power,
                "reachable_fraction": self.reachable_fraction, "disturbance_bandwidth": self.disturbance_bandwidth,
                "passed": self.passed}


def plant_can_hold(plant, R, limits) -> tuple[bool, float]:
    """``(reachable, unmet N·m)``: whether ``plant`` can hold orientation ``R`` at rest within ``limits`` at all
    (:func:`~spherestep.control.allocation.can_hold` against the plant's own ``K(R)`` and bias)."""
    from ..control.allocation import can_hold

    return can_hold(plant.torque_matrix(R), plant.torque(R, np.zeros(plant.coil_count)), limits, failed=plant.failed)


def hold_errors(design, plant, model, limits, rotor, *, holds: int = 20, seed: int = 0, hold_time: float = 1.0,
                hold_check: float = 0.2, noise: float = NOISE, disturbance_bandwidth: float | None = None
                ) -> tuple[float, ...]:
    """The largest tracking error (rad) over the last ``hold_check`` s of each hold (module docstring)."""
    holds = checks.count(holds, "holds", 0)
    targets = so3.random(holds, seed)
    out = []
    for k, target in enumerate(targets):
        run = hold(design, target, plant, duration=hold_time + hold_check, limits=limits, rotor=rotor,
                   sensor=_sensor(noise, seed + 1 + k), controller_model=model,
                   disturbance_bandwidth=disturbance_bandwidth)
        out.append(float(run.tracking_error[run.times >= hold_time - 1e-9].max()))
    return tuple(out)


def turn_plan(design, model, limits, rotor, *, axis=TURN_AXIS, angle: float = TURN_ANGLE,
              margin: float | None = None):
    """The turn of the module (from the stepper state nearest the identity) planned on ``model`` within ``limits``
    and ``margin`` (default ``plan_turn``'s) for ``rotor``: :func:`spherestep.control.plan_turn`'s trajectory."""
    from ..commutation.turn import turn_targets
    from ..control import plan_turn

    start = turn_targets(design, axis, angle, steps=1)[0]
    return plan_turn(model, start, axis, angle, rotor.inertia, limits, damping=rotor.damping, margin=margin)


def turn_run(design, plant, model, limits, rotor, *, axis=TURN_AXIS, angle: float = TURN_ANGLE, seed: int = 0,
             settle: float = 0.5, noise: float = NOISE, disturbance_bandwidth: float | None = None,
             margin: float | None = None, plan_model=None, trajectory=None):
    """``(trajectory, run)``: the turn of the module planned on ``plan_model`` (default ``model``; within
    ``margin``, default ``plan_turn``'s: :func:`turn_plan`) and driven on ``plant`` with the servo on ``model``;
    ``trajectory``: that plan made already (it is the same for every plant and controller; ~6 s of CPU each)."""
    traj = trajectory if trajectory is not None else turn_plan(
        design, model if plan_model is None else plan_model, limits, rotor, axis=axis, angle=angle, margin=margin)
    run = simulate_servo(design, traj, plant, limits=limits, rotor=rotor, sensor=_sensor(noise, seed),
                         settle=settle, controller_model=model, disturbance_bandwidth=disturbance_bandwidth)
    return traj, run


def robustness_row(design, case, *, holds: int = 20, seed: int = 0, hold_time: float = 1.0, axis=TURN_AXIS,
                   angle: float = TURN_ANGLE, settle: float = 0.5, noise: float = NOISE,
                   disturbance_bandwidth: float | None = None, rotor=None, margin: float | None = None,
                   trajectory=None) -> RobustnessRow:
    """The :class:`RobustnessRow` of ``case`` (a :class:`~spherestep.magnetics.mismatch.MismatchCase`) on
    ``design`` (module docstring); ``margin`` the turn's plan's (default ``plan_turn``'s); ``trajectory`` that
    plan made already (:func:`turn_plan` on the pairwise model)."""
    from ..magnetics import design_model
    from .rotor import Rotor

    plant, model = case.build(design)
    limits = design_model(design).limits
    rotor = Rotor.from_design(design) if rotor is None else rotor
    errors = hold_errors(design, plant, model, limits, rotor, holds=holds, seed=seed, hold_time=hold_time,
                         noise=noise, disturbance_bandwidth=disturbance_bandwidth)
    traj, run = turn_run(design, plant, model, limits, rotor, axis=axis, angle=angle, seed=seed, settle=settle,
                         noise=noise, disturbance_bandwidth=disturbance_bandwidth, margin=margin,
                         plan_model=None if trajectory is not None else design_model(design, coupling=False).model,
                         trajectory=trajectory)
    s = run.summary()
    reach = tuple(plant_can_hold(plant, R, limits)[0] for R in so3.random(holds, seed))
    return RobustnessRow(case.name, errors, float(traj.duration), s.final_error, s.max_tracking_error, s.mean_power,
                         s.reachable_fraction, disturbance_bandwidth, reach)


def _sensor(noise: float, seed: int):
    from ..sensing.sensor import NoisySensor

    return NoisySensor(noise, rng=int(seed))


__all__ = ["MAX_POWER", "MAX_TRACKING", "RobustnessRow", "hold_errors", "robustness_row", "turn_plan", "turn_run"]
