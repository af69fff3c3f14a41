"""The stepper states on the true landscape: the minima of the design's own energy under each state's coils.

For every geometric stepper state ``s`` (a set of poles on coils, :meth:`spherestep.motor.MotorDesign.states`) its
relay mask — the held coils, each with its pole's polarity, trimmed to the ``max_coils`` closest as the planners
energise them — has a minimum near ``R_s``: the energy's descent from ``R_s`` under that mask
(:func:`spherestep.statics.descend`). Those minima that are strict (Hessian positive definite) are the *equilibrium
states*; :func:`equilibrium_metrics` measures on them what :func:`spherestep.motor.design_metrics` measures on the
geometric states — resolution (Park distance from uniformly random orientations to the nearest state: median,
95 %, max), the fraction of orientations with a state within one ``max_step``, the state graph's components (states
linked when within ``max_step``) — and how far each minimum lies from its geometric state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..motor import Coverage
from .potential_planner import DEFAULT_MAX_COILS, _activations
from .._fast.threads import single_blas_thread

BATCH = 4096  # descents per call
DISTINCT = math.radians(0.01)  # rad: minima closer than this are one


@dataclass(frozen=True)
class EquilibriumMetrics(Coverage):
    """:func:`equilibrium_metrics`' result: the :class:`spherestep.motor.Coverage` of the strict minima (``states``
    the geometric states, resolution, range and graph on the minima), ``minima`` (strict minima among their masks'
    descents), ``distinct`` (those more than :data:`DISTINCT` apart: the detent draws many masks to one minimum),
    and the minima's ``offset_*`` from their geometric states (angles in radians; ``to_dict`` in degrees)."""

    minima: int
    distinct: int
    offset_median_rad: float
    offset_max_rad: float


@single_blas_thread
def equilibrium_states(design, model, max_coils: int = DEFAULT_MAX_COILS) -> tuple[np.ndarray, np.ndarray]:
    """``(rotations (K, 3, 3), minimum (K,))``: for every stepper state the end of the energy's descent from it under
    its trimmed mask, and whether that is a strict minimum (module docstring)."""
    from ..statics import descend

    states = design.states()
    out, strict = np.empty((len(states), 3, 3)), np.zeros(len(states), dtype=bool)
    for lo in range(0, len(states), BATCH):
        ids = np.arange(lo, min(lo + BATCH, len(states)))
        c = _activations(states, design, np.eye(3), ids, len(design.stator), False)  # every held pair
        for n in np.flatnonzero(states.counts[ids] > max_coils):  # trimmed at the state's own pose
            s = int(ids[n])
            c[n] = _activations(states, design, states.rotations[s], np.array([s]), max_coils)[0]
        R, _, _, H, _, converged = descend(model, states.rotations[ids].copy(), c)
        out[ids] = R
        strict[ids] = converged & (np.linalg.eigvalsh(H)[:, 0] > 0)
    return out, strict


def equilibrium_metrics(design, model, *, max_coils: int = DEFAULT_MAX_COILS, samples: int = 20_000,
                        seed: int = 0) -> EquilibriumMetrics:
    """Resolution, range and state graph on the equilibrium states (module docstring), from ``samples`` uniformly
    random orientations drawn from ``seed``."""
    from ..motor import StepperStates

    states = design.states()
    R, strict = equilibrium_states(design, model, max_coils)
    keep = np.flatnonzero(strict)
    minima = StepperStates(R[keep], states.pairs[:0], np.zeros(len(keep) + 1, dtype=np.int64), design.polarity,
                           design.state_tol)
    dist = minima.nearest(so3.random(samples, np.random.default_rng(seed)))[0][:, 0]
    components = minima.components(design.max_step)
    offset = so3.distance(R[keep], states.rotations[keep])
    distinct = minima.components(DISTINCT)
    return EquilibriumMetrics(states=len(states), minima=len(keep), distinct=distinct, samples=samples,
                              max_step_rad=design.max_step, resolution_median_rad=float(np.median(dist)),
                              resolution_p95_rad=float(np.quantile(dist, 0.95)), resolution_max_rad=float(dist.max()),
                              range_fraction=float(np.mean(dist <= design.max_step)), state_graph_components=components,
                              reaches_all=bool(np.all(dist <= design.max_step) and components == 1),
                              offset_median_rad=float(np.median(offset)), offset_max_rad=float(offset.max()))
