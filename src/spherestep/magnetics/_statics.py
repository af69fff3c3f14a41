"""Statics of the magnets' torque map: the map's equilibrium settings and the torques of stepper states.

Equilibria, stiffness, holding torque and the torque along a step are those of :mod:`spherestep.statics`, which
work on any torque model; here they run on the :class:`~._table.TorqueMap` (torque ``T(R, c)`` and its exact
energy ``E(R, c)``, ``T = −∂E/∂θ`` for ``R → exp(θ̂) R``, fixed frame, N·m and J), batched over orientations.

* :func:`equilibrium`: :func:`spherestep.statics.equilibrium` with the map's settings (``gtol`` 1e-9 of
  ``τ_ref = max|τ| Σ_k |c_k|``, steps of at most 2°, 60 iterations).
* :func:`state_torques`: holding and stepping torques of stepper states, one frozen :class:`StateTorque` each.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..errors import bad_value
from ..units import result_dict
from ..statics import Equilibrium, holding_torque, step_torque
from ..statics import equilibrium as descend
from ._table import TorqueMap


def equilibrium(tmap: TorqueMap, R0, currents, *, gtol: float = 1e-9, max_iter: int = 60,
                max_step: float = math.radians(2.0)) -> Equilibrium:
    """The rest orientation of the rotor from ``R0 (K, 3, 3)`` under ``currents (K, N)``:
    :func:`spherestep.statics.equilibrium` with the map's settings (see the module)."""
    return descend(tmap, R0, currents, gtol=gtol, max_iter=max_iter, max_step=max_step)


def state_currents(design, index: int) -> np.ndarray:
    """Currents ``(N,)`` that hold stepper state ``index``: each held pole's coil at the pole's polarity
    (``design.coil_currents(design.states().coils(index))``, the one coils → currents helper)."""
    return design.coil_currents(design.states().coils(int(index)))


@dataclass(frozen=True)
class StateTorque:
    """Holding and stepping torques of one stepper state (N·m; angles in radians, ``*_rad``).

    ``coils``: its coils and their polarities; ``equilibrium_offset_rad``: Park distance of the physical
    equilibrium from the geometric state; ``stiffness_Nm_per_rad``: the stiffness eigenvalues; the holding
    torque (weakest of the 32 axes of :func:`~spherestep.statics.holding_torque`), its ``weakest_axis`` and the
    strongest axis's torque; over the ``steps`` to every state within ``design.max_step``: the largest drive
    torque met along any step, the smallest and the median drive at a step's start and the number of downhill
    steps (all None when the state has no neighbour within a step).
    """

    state: int
    coils: dict[int, int]
    equilibrium_offset_rad: float
    stiffness_Nm_per_rad: tuple[float, ...]
    holding_torque_Nm: float
    weakest_axis: tuple[float, float, float]
    strongest_axis_Nm: float
    steps: int
    step_peak_torque_Nm: float | None = None
    step_start_torque_min_Nm: float | None = None
    step_start_torque_median_Nm: float | None = None
    downhill_steps: int | None = None

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict; ``equilibrium_offset_deg`` in degrees when ``degrees``; tuples as lists
        (:func:`spherestep.units.result_dict`)."""
        return result_dict(self, degrees)


def state_torques(design, tmap: TorqueMap, indices, *, max_angle: float = math.radians(20.0)) -> list[StateTorque]:
    """The :class:`StateTorque` of each stepper state in ``indices`` of ``design``, on the torque map: its coils
    on at their poles' polarities, settled into the physical equilibrium, turned about 32 axes for the holding
    torque (:func:`holding_torque`), and stepped to every state within ``design.max_step`` (next state's coils
    on, along the geodesic between the equilibria, :func:`step_torque`).
    """
    st = design.states()
    idx = np.asarray(indices, dtype=int).reshape(-1)
    if np.any((idx < 0) | (idx >= len(st))):
        raise bad_value("indices", f"stepper-state indices in 0..{len(st) - 1}", idx.tolist())
    c = np.array([state_currents(design, i) for i in idx])
    eq = equilibrium(tmap, st.rotations[idx], c)
    hold = holding_torque(tmap, eq.rotation, c, max_angle=max_angle)
    rows = []
    for n, i in enumerate(idx):
        nb = st.within(st.rotations[i], design.max_step)
        nb = nb[nb != i]
        steps = {}
        if len(nb):
            cb = np.array([state_currents(design, j) for j in nb])
            eqb = equilibrium(tmap, st.rotations[nb], cb)
            s = step_torque(tmap, np.repeat(eq.rotation[n][None], len(nb), axis=0), eqb.rotation, cb)
            steps = dict(step_peak_torque_Nm=float(s.peak.max()), step_start_torque_min_Nm=float(s.start.min()),
                         step_start_torque_median_Nm=float(np.median(s.start)),
                         downhill_steps=int(np.sum(s.least > 0)))
        rows.append(StateTorque(
            state=int(i), coils={int(k): int(v) for k, v in st.coils(int(i)).items()},
            equilibrium_offset_rad=float(so3.distance(eq.rotation[n], st.rotations[i])),
            stiffness_Nm_per_rad=tuple(eq.stiffness[n].tolist()), holding_torque_Nm=float(hold.torque[n]),
            weakest_axis=tuple(hold.weakest[n].tolist()), strongest_axis_Nm=float(hold.per_axis[n].max()),
            steps=int(len(nb)), **steps))
    return rows
