"""Design metrics: how finely and how far the motor moves (Sec. II-B-3, III-A).

* ``resolution_*``: Park distance from uniformly random orientations to the nearest stepper state.
* ``range_fraction``: the fraction of random orientations with a state within one step (``max_step``);
  with ``state_graph_components == 1`` (states linked when one step apart) and a fraction of 1, every
  orientation is reachable: unbounded rotation about any axis.
* ``escape_violations``: states from which some direction has no next state, i.e. the axes of the steps
  to neighbouring states (relative rotations ``R_aᵀ R_b``, body frame) leave a cone of half-angle 45°
  empty: the largest empty cone is found exactly from the convex hull of the step axes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..units import result_dict

ESCAPE_CONE = math.radians(45.0)


def rotor_symmetries(design) -> np.ndarray:
    """Rotations ``g`` of the rotor's packing that also keep every pole's polarity (``(G, 3, 3)``)."""
    from ..packing import symmetry_rotations

    rotor = design.rotor
    group = symmetry_rotations(rotor)
    keep = []
    for g in group:
        _, image = rotor.tree.query(rotor.centers @ g.T)
        keep.append(np.array_equal(design.polarity[image], design.polarity))
    return group[np.array(keep, dtype=bool)]


def orbit_representatives(rotations: np.ndarray, group: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Group states ``R`` into orbits ``{R g}``: the representative ``R g*`` with ``g* = argmax tr(R g)``.

    Returns ``(rep_index (K,), unique representative indices)``, where ``rep_index[i]`` is the index of the
    state that represents state ``i``'s orbit (the first state whose representative coincides).
    """
    traces = np.einsum("kij,gji->kg", rotations, group)
    best = group[np.argmax(traces, axis=1)]
    reps = rotations @ best
    keys = np.round(reps.reshape(len(reps), -1), 6)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    return first[inverse.ravel()], np.unique(first)


def largest_empty_cone(axes: np.ndarray) -> float:
    """Half-angle (rad) of the largest cone about any direction that contains none of ``axes (P, 3)``.

    With the origin inside the convex hull of the unit axes, the largest empty cap is the circumcircle of
    a hull facet: ``acos(−b)`` for facet plane ``n·x + b = 0``. Otherwise a whole hemisphere is empty (≥ 90°).
    """
    from scipy.spatial import ConvexHull, QhullError

    if len(axes) < 4:
        return math.pi
    try:
        hull = ConvexHull(axes)
    except QhullError:
        return math.pi
    offsets = hull.equations[:, 3]
    if np.any(offsets >= 0):
        return math.pi / 2 + float(np.arcsin(np.clip(offsets.max(), 0.0, 1.0)))
    return float(np.arccos(np.clip(-offsets, -1.0, 1.0)).max())


def escape_violations(design, states, cone: float = ESCAPE_CONE) -> np.ndarray:
    """Indices of states from which some direction has no next state within ``max_step`` (see module).

    The answer is the same for every state of an orbit ``{R g}`` under the rotor's symmetries (steps
    from ``R g`` are the steps from ``R`` with axes turned by ``gᵀ``), so it is computed once per orbit.
    """
    if len(states) == 0:
        return np.zeros(0, dtype=np.int64)
    rep_of, reps = orbit_representatives(states.rotations, rotor_symmetries(design))
    bad = np.zeros(len(states), dtype=bool)
    for r in reps:
        near = states.within(states.rotations[r], design.max_step)
        near = near[near != r]
        axes, _ = so3.axis_angle(states.rotations[r].T @ states.rotations[near]) if len(near) else (np.zeros((0, 3)), None)
        bad[r] = largest_empty_cone(axes) > cone
    return np.flatnonzero(bad[rep_of])


@dataclass(frozen=True)
class Coverage:
    """How finely and how far a set of ``states`` (orientations: a design's stepper states, or the equilibria the
    rotor really rests in, :class:`spherestep.commutation.EquilibriumMetrics`) covers SO(3), from ``samples``
    random orientations: the distance to the nearest state (``resolution_*``), the share within ``max_step_rad``
    (``range_fraction``), the components of the graph of states within ``max_step_rad`` of each other, and
    whether every orientation is reached (``reaches_all``). Angles in radians, named ``*_rad``; :meth:`to_dict`
    gives a JSON-ready dict with the angles in degrees (``*_deg``) or radians (``*_rad``)."""

    states: int
    samples: int
    max_step_rad: float
    resolution_median_rad: float
    resolution_p95_rad: float
    resolution_max_rad: float
    range_fraction: float
    state_graph_components: int
    reaches_all: bool

    def to_dict(self, degrees: bool = True) -> dict:
        """The metrics as a dict: ``*_rad`` fields become ``*_deg`` in degrees when ``degrees``; tuples lists
        (:func:`spherestep.units.result_dict`)."""
        return result_dict(self, degrees)


@dataclass(frozen=True)
class DesignMetrics(Coverage):
    """How finely and how far a design moves (see the module docstring): its stepper states' :class:`Coverage`,
    the histogram of held pairs per state and the escape check (``escape_violations`` None when skipped)."""

    held_pairs_histogram: tuple[int, ...]
    escape_violations: tuple[int, ...] | None


@dataclass(frozen=True)
class CoilFailure:
    """The design with one ``coil`` failed (no escape check): its states, range, state-graph components,
    whether it still reaches all of SO(3), and its median resolution (rad)."""

    coil: int
    states: int
    range_fraction: float
    state_graph_components: int
    reaches_all: bool
    resolution_median_rad: float

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict, the resolution in degrees (``resolution_median_deg``) when ``degrees``."""
        return result_dict(self, degrees)


def design_metrics(design, samples: int = 20_000, seed: int = 0, escape: bool = True) -> DesignMetrics:
    """The :class:`DesignMetrics` of ``design`` from ``samples`` random orientations (``seed``);
    ``escape=False`` skips the escape-direction check (the slowest part)."""
    states = design.states()
    rng = np.random.default_rng(seed)
    if len(states) == 0:
        return DesignMetrics(states=0, samples=samples, max_step_rad=design.max_step, resolution_median_rad=math.inf,
                             resolution_p95_rad=math.inf, resolution_max_rad=math.inf, range_fraction=0.0,
                             state_graph_components=0, reaches_all=False, held_pairs_histogram=(),
                             escape_violations=() if escape else None)
    dist, _ = states.nearest(so3.random(samples, rng))
    dist = dist[:, 0]
    components = states.components(design.max_step)
    return DesignMetrics(
        states=len(states), samples=samples, max_step_rad=design.max_step,
        resolution_median_rad=float(np.median(dist)),
        resolution_p95_rad=float(np.quantile(dist, 0.95)),
        resolution_max_rad=float(dist.max()),
        range_fraction=float(np.mean(dist <= design.max_step)),
        state_graph_components=int(components),
        reaches_all=bool(np.all(dist <= design.max_step) and components == 1),
        held_pairs_histogram=tuple(np.bincount(states.counts).tolist()),
        escape_violations=tuple(escape_violations(design, states).tolist()) if escape else None,
    )


def single_coil_failures(design, samples: int = 5000, seed: int = 0) -> list[CoilFailure]:
    """For each working coil, the :class:`CoilFailure` of the design with that coil failed (no escape check).
    The fraction with ``reaches_all`` is how often all of SO(3) stays reachable after one coil fails."""
    rows = []
    for k in design.active_coils:
        m = design_metrics(design.without_coils([int(k)]), samples=samples, seed=seed, escape=False)
        rows.append(CoilFailure(coil=int(k), states=m.states, range_fraction=m.range_fraction,
                                state_graph_components=m.state_graph_components, reaches_all=m.reaches_all,
                                resolution_median_rad=m.resolution_median_rad))
    return rows
