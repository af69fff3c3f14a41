"""The potential planner of Sec. III-B.

At each step the planner weighs activations — sets of coils with polarities, at most ``max_coils``
energised at once — by where the rotor would come to rest under them: the minimum of the energy
``V(·, c)`` reached by descending from the previous resting orientation ``R̃_{i−1}``
(:func:`spherestep.statics.equilibrium`). The activation whose equilibrium is nearest the desired
``R_i`` wins. Candidate activations are the coil sets of the stepper states nearest ``R_i`` and of the
states within one step of ``R̃_{i−1}`` nearest ``R_i`` (so a lagging rotor catches up), each trimmed to the
``max_coils`` pairs whose poles sit closest to their coils at ``R_i``, plus the current one (staying). An equilibrium counts only if the descent converged to a strict minimum within ``max_step`` of
``R̃_{i−1}`` (one step's pull, as in the geometric planner). The plan's ``achieved`` orientations are these
equilibria, not the geometric states, so a simulated rotor settles on them; ``held`` lists the pole–coil
pairs within the design's tolerance at the equilibrium.
"""

from __future__ import annotations

import numpy as np

from .. import so3
from ..errors import bad_value
from ..motor import coil_currents
from .geometric import BLOCKED, DEFAULT_CANDIDATES, start_state
from .plan import Plan, Step
from .trajectory import check_targets
from .._threads import single_blas_thread

DEFAULT_MAX_COILS = 4


def _trim(held: list[tuple[int, int]], design, target, max_coils: int) -> dict[int, int]:
    """The coil → polarity map of ``held`` keeping the ``max_coils`` pairs closest at ``target``."""
    if len(held) > max_coils:
        u, v = design.rotor.centers, design.stator.centers
        closeness = [-(target @ u[j]) @ v[k] for j, k in held]
        held = [held[i] for i in np.argsort(closeness)[:max_coils]]
    return {k: int(design.polarity[j]) for j, k in held}


def _activations(states, design, target, ids: np.ndarray, max_coils: int) -> np.ndarray:
    """The currents ``(len(ids), N)`` of :func:`_trim` applied to each of the states ``ids``, in one pass: every
    held pair ranked within its state by closeness ``−(R u_j)·v_k`` at ``target``, the first ``max_coils`` kept."""
    starts = states.offsets[ids]
    counts = states.offsets[ids + 1] - starts
    group = np.repeat(np.arange(len(ids)), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    rows = np.arange(counts.sum()) - first + np.repeat(starts, counts)
    j, k = states.pairs[rows, 0], states.pairs[rows, 1]
    closeness = -np.einsum("pa,pa->p", design.rotor.centers[j] @ target.T, design.stator.centers[k])
    order = np.lexsort((closeness, group))
    keep = order[np.arange(len(order)) - first < max_coils]
    currents = np.zeros((len(ids), len(design.stator)))
    currents[group[keep], k[keep]] = design.polarity[j[keep]]
    return currents


@single_blas_thread
def plan_potential(design, targets, model, *, max_coils: int = DEFAULT_MAX_COILS,
                   candidates: int = DEFAULT_CANDIDATES, max_step: float | None = None,
                   start: int | None = None) -> Plan:
    """Commutate ``targets (n+1, 3, 3)`` with the energy ``model`` (a
    :class:`~spherestep.potential.MotorPotential` of ``design``); see the module docstring."""
    from ..statics import equilibrium

    targets = check_targets(targets)
    if isinstance(max_coils, bool) or not isinstance(max_coils, (int, np.integer)) or max_coils < 2:
        raise bad_value("max_coils", "an integer of at least 2 (two poles fix the rotor)", max_coils)
    states = design.states()
    if len(states) == 0:
        raise bad_value("design", "a design with stepper states", "none")
    reach = design.max_step if max_step is None else float(max_step)
    N = len(design.stator)
    first = start_state(states, targets[0]) if start is None else int(start)
    coils = _trim(states.held(first), design, states.rotations[first], max_coils)
    current = coil_currents(coils, N)
    here = equilibrium(model, states.rotations[first], current).rotation
    _, near = states.nearest(targets, k=candidates)
    rows = [(targets[0], here, coils, "ok")]
    for i in range(1, len(targets)):
        # the states nearest the target, and — so a lagging rotor catches up — the reachable ones nearest it
        around = states.within(here, reach)
        around = around[np.argsort(so3.distance(states.rotations[around], targets[i], trusted=True))[:candidates]]
        ids = np.concatenate([near[i], around])
        options = np.vstack([current[None], _activations(states, design, targets[i], ids, max_coils)])
        unique = list({row.tobytes(): n for n, row in enumerate(options)}.values())  # first of each activation
        eq = equilibrium(model, here, options[unique])
        valid = eq.converged & eq.is_minimum & (so3.distance(eq.rotation, here, trusted=True) <= reach)
        if not valid.any():
            rows.append((targets[i], here, coils, BLOCKED))
            continue
        error = np.where(valid, so3.distance(eq.rotation, targets[i], trusted=True), np.inf)
        best = int(np.argmin(error))
        status = "hold" if unique[best] == 0 else "ok"
        if status == "ok":
            coils = _trim(states.held(int(ids[unique[best] - 1])), design, targets[i], max_coils)
            current = options[unique[best]]
        here = eq.rotation[best]
        rows.append((targets[i], here, coils, status))
    return _assemble(design, rows)


def _assemble(design, rows) -> Plan:
    """Build the :class:`Plan` from ``(target, achieved, coils, status)`` rows."""
    u, v, tol = design.rotor.centers, design.stator.centers, design.state_tol
    steps = []
    for i, (target, achieved, coils, status) in enumerate(rows):
        cos = (achieved @ u.T).T @ v[list(coils)].T if coils else np.zeros((len(u), 0))
        ks = list(coils)
        held = [(int(j), ks[c]) for j, c in zip(*np.nonzero(cos >= np.cos(tol)))]
        steps.append(Step(index=i, target=target, achieved=achieved, error=float(so3.distance(achieved, target)),
                          coils=dict(coils), held=held, status=status))
    for a, b in zip(steps[:-1], steps[1:]):
        # the next pole: the pole nearest a newly energised coil at the next equilibrium, not held now
        mine = {j for j, _ in a.held}
        new = [j for j, _ in b.held if j not in mine]
        a.next_pole = new[0] if new else None
    return Plan(steps=steps, coil_count=len(design.stator), channel_map=design.channel_map,
                design=design.name, planner="potential")
