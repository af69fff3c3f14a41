"""The geometric planner of Sec. III-A.

At each desired orientation ``R_i`` the candidate matchings are the stepper states nearest ``R_i`` (each
a set of at least two rotor poles sitting on coils: the pole–coil pairs with the smallest
``d_jk(i) = cos⁻¹((R_i u_j)·v_k)``). Candidates farther than ``max_step`` (Park) from the previous
achieved state ``R̃_{i−1}`` are dropped; of the rest the one minimising the axis cost
``c = cos⁻¹(n(R̃_{i−1}ᵀ R̃^(m)) · n(R̃_{i−1}ᵀ R_i))`` is chosen, so the step turns the rotor about the axis
the desired motion needs. Two refinements the text leaves open, stated here:

* the rotor stays (status ``"hold"``) while the previous state is still nearer ``R_i`` than every other
  reachable candidate — a step that moves away from the path is never taken to satisfy the axis cost;
* at the last step the nearest reachable candidate is taken (the motion ends; only the pose matters);
* when the rotor lags and no candidate is within reach, it moves to the reachable state nearest ``R_i``
  (status ``"detour: …"``); when no reachable state is nearer ``R_i`` than where it is, it is held and the
  step recorded as ``"blocked: …"``;
* if the rotor lags at the end, up to ten extra steps towards the final target are appended (status
  ``"settle: …"``) until it sits in the state nearest that target.
"""

from __future__ import annotations

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .plan import Plan, Step
from .trajectory import check_targets
from .._fast.threads import single_blas_thread

DEFAULT_CANDIDATES = 8
DETOUR = "detour: the states nearest the target are out of reach; moved to the reachable state nearest it"
SETTLE = "settle: an extra step towards the final target"
MAX_SETTLE_STEPS = 10
BLOCKED = "blocked: no state within one step of the current one is nearer the target"


def _axis(R: np.ndarray) -> np.ndarray:
    axis, _ = so3.axis_angle(R)
    return axis


def start_state(states, R0) -> int:
    """Index of the stepper state nearest ``R0`` (where the rotor rests before the plan)."""
    _, idx = states.nearest(R0)
    return int(idx.ravel()[0])


def next_state(states, current: int, target, candidates: np.ndarray, reach: float, last: bool = False
               ) -> tuple[int, str]:
    """One step of the planner: from state ``current`` towards the desired rotation ``target``.

    ``candidates``: indices of the states nearest ``target``; ``reach``: the largest step; ``last``: the
    final step of the motion (nearest candidate instead of the axis cost). Returns the chosen state and
    the step's status (see the module docstring).
    """
    prev_R = states.rotations[current]
    ok = (so3.distance(prev_R, states.rotations[candidates]) <= reach) & (candidates != current)
    to_target = so3.distance(states.rotations[candidates], target)
    stay_d = float(so3.distance(prev_R, target))
    helps = ok & (to_target < stay_d)
    if not helps.any():
        # none of the nearest candidates helps: take the reachable state nearest the target, if it helps
        around = states.within(prev_R, reach)
        around_d = so3.distance(states.rotations[around], target)
        if len(around) and around_d.min() < stay_d - 1e-12:
            return int(around[np.argmin(around_d)]), ("ok" if ok.any() or last else DETOUR)
        return current, ("hold" if stay_d <= to_target.min() + 1e-12 else BLOCKED)
    if last:
        return int(candidates[np.argmin(np.where(ok, to_target, np.inf))]), "ok"
    want = _axis(prev_R.T @ target)
    have = _axis(prev_R.T @ states.rotations[candidates[helps]])
    cost = np.arccos(np.clip(have @ want, -1.0, 1.0))
    return int(candidates[helps][np.argmin(cost)]), "ok"


def settle(states, current: int, target, reach: float, goal: int) -> list[int]:
    """Extra states (at most :data:`MAX_SETTLE_STEPS`) walking from ``current`` to ``goal``, each the
    reachable state nearest ``target``, while that gets nearer."""
    path = []
    while current != goal and len(path) < MAX_SETTLE_STEPS:
        around = states.within(states.rotations[current], reach)
        around_d = so3.distance(states.rotations[around], target)
        if around_d.min() >= so3.distance(states.rotations[current], target) - 1e-12:
            break
        current = int(around[np.argmin(around_d)])
        path.append(current)
    return path


@single_blas_thread
def plan_geometric(design, targets, *, candidates: int = DEFAULT_CANDIDATES, max_step: float | None = None,
                   start: int | None = None) -> Plan:
    """Commutate ``targets (n+1, 3, 3)`` on ``design`` (a :class:`~spherestep.motor.MotorDesign`).

    ``candidates``: how many nearest states of each ``R_i`` are considered; ``max_step``: reach of one
    step (default the design's); ``start``: index of the state the rotor rests in (default: nearest
    ``R_0``). Returns a :class:`Plan` whose step 0 is the starting state.
    """
    targets = check_targets(targets)
    candidates = checks.count(candidates, "candidates", expected="a positive integer")
    states = design.states()
    if len(states) == 0:
        raise bad_value("design", "a design with stepper states (at least two poles can sit on coils)", "none")
    reach = design.max_step if max_step is None else float(max_step)
    current = start_state(states, targets[0]) if start is None else int(start)
    _, near = states.nearest(targets, k=candidates)  # (n+1, k) candidate states per target
    chosen, status = [current], ["ok"]
    n = len(targets) - 1
    for i in range(1, n + 1):
        current, why = next_state(states, current, targets[i], near[i], reach, last=i == n)
        chosen.append(current)
        status.append(why)
    extra = settle(states, current, targets[-1], reach, int(near[-1, 0]))
    chosen += extra
    status += [SETTLE] * len(extra)
    targets = np.concatenate([targets, np.repeat(targets[-1:], len(extra), axis=0)])
    return _build_plan(design, states, targets, chosen, status, "geometric")


def _build_plan(design, states, targets, chosen, status, planner: str) -> Plan:
    """Assemble the :class:`Plan`: coils, held pairs, errors and the next pole to be attracted."""
    achieved = states.rotations[np.array(chosen)]
    errors = so3.distance(achieved, targets)
    steps = []
    for i, s in enumerate(chosen):
        held = states.held(s)
        next_pole = None
        if i + 1 < len(chosen):
            mine = {j for j, _ in held}
            new = [j for j, _ in states.held(chosen[i + 1]) if j not in mine]
            next_pole = new[0] if new else None
        steps.append(Step(index=i, target=targets[i], achieved=achieved[i], error=float(errors[i]),
                          coils=states.coils(s), held=held, next_pole=next_pole, status=status[i]))
    return Plan(steps=steps, coil_count=len(design.stator), channel_map=design.channel_map,
                design=design.name, planner=planner, design_fingerprint=design.fingerprint)
