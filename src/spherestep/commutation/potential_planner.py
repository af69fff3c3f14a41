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
pairs within the design's tolerance at the equilibrium. An activation offered twice stands for its last offer
(so a step keeping the coils is ``"hold"`` only when no candidate state offers them too).

Cost: the inputs are checked once per plan (the model's failed coils at every step); each step's candidates
descend together in one call of :func:`spherestep.statics.equilibrium`'s own descent
(:func:`spherestep.statics.descend`); the bookkeeping around
it — candidate currents, distinct activations, the choice — runs compiled (:mod:`spherestep._fast.relays`) on
NumPy's products ``R1ᵀ R2``, so that Park distances, and their ties, come out bit for bit as
:func:`spherestep.so3.distance`'s.
"""

from __future__ import annotations

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..motor import coil_currents
from .geometric import BLOCKED, DEFAULT_CANDIDATES, start_state
from .plan import Plan, Step
from .trajectory import check_targets
from .._fast.threads import single_blas_thread

DEFAULT_MAX_COILS = 4


def _trim(held: list[tuple[int, int]], design, target, max_coils: int) -> dict[int, int]:
    """The coil → polarity map of ``held`` keeping the ``max_coils`` pairs closest at ``target``."""
    if len(held) > max_coils:
        u, v = design.rotor.centers, design.stator.centers
        closeness = [-(target @ u[j]) @ v[k] for j, k in held]
        held = [held[i] for i in np.argsort(closeness)[:max_coils]]
    return {k: int(design.polarity[j]) for j, k in held}


def _activations(states, design, target, ids: np.ndarray, max_coils: int, ranked: bool = True) -> np.ndarray:
    """The currents ``(len(ids), N)`` of :func:`_trim` applied to each of the states ``ids``, in one pass: every
    held pair ranked within its state by closeness ``−(R u_j)·v_k`` at ``target``, the first ``max_coils`` kept.
    ``ranked=False`` skips the ranking, for states none of which holds more than ``max_coils`` pairs."""
    from .._fast.relays import closest_pairs

    closeness = np.zeros(0)
    if ranked:
        rows = np.concatenate([np.arange(states.offsets[s], states.offsets[s + 1]) for s in ids])
        j, k = states.pairs[rows, 0], states.pairs[rows, 1]
        closeness = -np.einsum("pa,pa->p", design.rotor.centers[j] @ target.T, design.stator.centers[k])
    return closest_pairs(states.offsets, states.pairs, design.polarity, ids, closeness, max_coils,
                         len(design.stator))


@single_blas_thread
def plan_potential(design, targets, model, *, max_coils: int = DEFAULT_MAX_COILS,
                   candidates: int = DEFAULT_CANDIDATES, max_step: float | None = None,
                   start: int | None = None) -> Plan:
    """Commutate ``targets (n+1, 3, 3)`` with the energy ``model`` (a
    :class:`~spherestep.potential.MotorPotential` of ``design``); see the module docstring."""
    from ..statics import as_currents, descend, equilibrium
    from .._fast.relays import angles, best, distinct

    targets = check_targets(targets)
    max_coils = checks.count(max_coils, "max_coils", minimum=2,
                             expected="an integer of at least 2 (two poles fix the rotor)")
    states = design.states()
    if len(states) == 0:
        raise bad_value("design", "a design with stepper states", "none")
    reach = design.max_step if max_step is None else float(max_step)
    N = len(design.stator)
    first = start_state(states, targets[0]) if start is None else int(start)
    coils = _trim(states.held(first), design, states.rotations[first], max_coils)
    current = coil_currents(coils, N)
    here = equilibrium(model, states.rotations[first], current).rotation  # checks the model and N, once
    _, near = states.nearest(targets, k=candidates)
    ranked = bool(states.counts.max() > max_coils)  # some state holds more pairs than may be energised
    rows = [(targets[0], here, coils, "ok")]
    for i in range(1, len(targets)):
        # the states nearest the target, and — so a lagging rotor catches up — the reachable ones nearest it
        around = states.within(here, reach)
        turns = np.swapaxes(states.rotations[around], 1, 2) @ targets[i]  # Park distance: angles of R_sᵀ R_i
        around = around[np.argsort(angles(turns))[:candidates]]
        ids = np.concatenate([near[i], around])
        options = np.concatenate([current[None], _activations(states, design, targets[i], ids, max_coils, ranked)])
        unique = distinct(options)  # the last of each activation
        c = options[unique]
        if model.failed:  # the currents' one check left per step (their count was checked above)
            as_currents(c, model.coil_count, model.failed)
        R, _, _, H, _, converged = descend(model, np.repeat(here[None], len(c), axis=0), c)
        back = np.swapaxes(R, 1, 2)  # R_bᵀ: the equilibria's distances to here and to the target
        b = best(back @ here, back @ targets[i], H, converged, reach)
        if b < 0:
            rows.append((targets[i], here, coils, BLOCKED))
            continue
        status = "hold" if unique[b] == 0 else "ok"
        if status == "ok":
            coils = _trim(states.held(int(ids[unique[b] - 1])), design, targets[i], max_coils)
            current = options[unique[b]]
        here = R[b]
        rows.append((targets[i], here, coils, status))
    return _assemble(design, rows)


def _assemble(design, rows) -> Plan:
    """Build the :class:`Plan` from ``(target, achieved, coils, status)`` rows; a step's ``held`` lists the pairs
    of a pole within ``state_tol`` of an energised coil, by pole, then in the order of ``coils``."""
    u, v = design.rotor.centers, design.stator.centers
    targets, achieved = np.stack([row[0] for row in rows]), np.stack([row[1] for row in rows])
    place = np.full((len(rows), len(v)), -1)  # place[i, k]: coil k's place in step i's coils, −1 if off
    for i, row in enumerate(rows):
        for n, k in enumerate(row[2]):
            place[i, k] = n
    step, coil = np.nonzero(place >= 0)  # the energised coils, step by step
    cos = np.einsum("pam,pa->pm", (achieved @ u.T)[step], v[coil])  # theirs R_i u_j · v_k, (·, M)
    p, j = np.nonzero(cos >= np.cos(design.state_tol))
    order = np.lexsort((place[step[p], coil[p]], j, step[p]))  # by step, pole, place of the coil
    p, j = p[order], j[order]
    pairs, bounds = list(zip(j.tolist(), coil[p].tolist())), np.searchsorted(step[p], np.arange(len(rows) + 1))
    errors = so3.distance(achieved, targets).tolist()
    steps = [Step(index=n, target=target, achieved=here, error=errors[n], coils=dict(coils),
                  held=pairs[bounds[n]:bounds[n + 1]], status=status)
             for n, (target, here, coils, status) in enumerate(rows)]
    for a, b in zip(steps[:-1], steps[1:]):
        # the next pole: the pole nearest a newly energised coil at the next equilibrium, not held now
        mine = {j for j, _ in a.held}
        new = [j for j, _ in b.held if j not in mine]
        a.next_pole = new[0] if new else None
    return Plan(steps=steps, coil_count=len(design.stator), channel_map=design.channel_map,
                design=design.name, planner="potential", design_fingerprint=design.fingerprint)
