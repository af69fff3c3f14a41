"""A turn about a fixed axis, planned: the targets from the stepper state nearest the identity, and the plan.

``turn_targets(design, axis, angle, steps)`` is ``about_axis(axis, angle, n, start=R̃₀)`` (``angle`` in radians) with
``R̃₀`` the stepper state nearest the identity and, by default, ``n`` the fewest equal steps no longer than
:data:`STEP_FRACTION` of the design's max step (finer steps land more reliably); :func:`turn` commutates them
with the geometric (Sec. III-A) or the potential (Sec. III-B) planner. This is what ``spherestep plan``,
``demo``, ``report`` and ``simulate`` run.
"""

from __future__ import annotations

import math

import numpy as np

from .. import checks
from ..errors import bad_value
from .geometric import plan_geometric
from .plan import Plan
from .trajectory import about_axis, steps_for

STEP_FRACTION = 0.35  # default desired step, as a fraction of the max step
MAX_ANGLE = 200.0 * math.pi  # rad: a hundred turns
MAX_STEPS = 100_000
PLANNERS = ("geometric", "potential", "iron")


def check_turn(axis, angle, steps) -> np.ndarray:
    """``axis`` as a unit 3-vector (:func:`spherestep.checks.axis`) after checking ``axis``, ``angle`` (rad) and
    ``steps``; InputError naming them."""
    vec = checks.axis(axis, "axis")
    if isinstance(angle, bool) or not isinstance(angle, (int, float, np.integer, np.floating)) \
            or not math.isfinite(angle) or angle == 0 or abs(angle) > MAX_ANGLE:
        raise bad_value("angle", f"a finite non-zero angle in radians, at most {MAX_ANGLE:.6g} (a hundred turns) in "
                        "size", angle)
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer))
                              or not 1 <= steps <= MAX_STEPS):
        raise bad_value("steps", f"a whole number of steps 1..{MAX_STEPS}, or None for the default", steps)
    return vec


def turn_targets(design, axis, angle: float, steps: int | None = None) -> np.ndarray:
    """``(n+1, 3, 3)`` desired orientations turning ``angle`` rad about the fixed-frame ``axis`` from the
    stepper state nearest the identity (module docstring); ``steps`` equal steps, default ``STEP_FRACTION`` of
    a max step each."""
    from ..motor import MotorDesign

    if not isinstance(design, MotorDesign):
        raise bad_value("design", "a MotorDesign (spherestep.motor.prototype() or MotorDesign.load(FILE))",
                        type(design).__name__)
    vec = check_turn(axis, angle, steps)
    states = design.states()
    if len(states) == 0:
        raise bad_value("design", "a design with stepper states (see `spherestep design validate`)", "none")
    start = states.rotations[int(states.nearest(np.eye(3))[1].ravel()[0])]
    angle = float(angle)
    n = steps if steps is not None else steps_for(abs(angle), STEP_FRACTION * design.max_step)
    return about_axis(vec, angle, int(n), start=start)


def turn(design, axis, angle: float, steps: int | None = None, planner: str = "geometric",
         model=None, *, limits=None, tuning=None, plants=(), plant_tol: float | None = None, thermal=None,
         rate: float | None = None) -> Plan:
    """Plan a turn of ``angle`` rad about ``axis`` (see :func:`turn_targets`) with ``planner``:
    ``"geometric"`` (:func:`plan_geometric`), ``"potential"`` (:func:`plan_potential` on ``model``, default
    the design's :class:`~spherestep.potential.MotorPotential`) or ``"iron"`` (:func:`plan_iron` on ``model``
    with its ``limits`` and the relay rotor ``tuning``, both required — the design's own model
    (:func:`spherestep.magnetics.design_model`) and :func:`spherestep.dynamics.iron_tuning` live above this room;
    :func:`spherestep.drive.relay_plan` supplies them —, the ``plants`` it must also hold on, within
    ``plant_tol``, and the coils' ``thermal`` limits at the streaming ``rate``).

    >>> import math
    >>> import spherestep as ss
    >>> plan = ss.commutation.turn(ss.motor.prototype(), (0, 0, 1), math.radians(30), steps=4)
    >>> len(plan.steps)
    5
    """
    if planner not in PLANNERS:
        raise bad_value("planner", f"one of {', '.join(PLANNERS)}", planner)
    if plants and planner != "iron":
        raise bad_value("plants", "given only with planner='iron'", f"{len(plants)} plants")
    if (thermal is not None or rate is not None) and planner != "iron":
        raise bad_value("thermal" if thermal is not None else "rate", "given only with planner='iron'", planner)
    targets = turn_targets(design, axis, angle, steps)
    if planner == "iron":
        from .iron_planner import plan_iron

        if model is None:
            raise bad_value("model", "the torque model the iron planner plans on with planner='iron' (the design's "
                            "own: spherestep.magnetics.design_model(design).model; spherestep.drive.relay_plan "
                            "supplies it)", model)
        if tuning is None:
            raise bad_value("tuning", "the relay rotor each step must settle on with planner='iron' "
                            "(spherestep.dynamics.iron_tuning(design, model); spherestep.drive.relay_plan supplies "
                            "it)", tuning)
        return plan_iron(design, targets, model, limits=limits, tuning=tuning, plants=plants, plant_tol=plant_tol,
                         thermal=thermal, rate=rate)
    if planner == "potential":
        from ..potential import MotorPotential
        from .potential_planner import plan_potential

        return plan_potential(design, targets, MotorPotential(design) if model is None else model)
    return plan_geometric(design, targets)
