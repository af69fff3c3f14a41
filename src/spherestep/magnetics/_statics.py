"""Statics of the magnets' torque map: the map's equilibrium settings and the torques of stepper states.

Equilibria, stiffness, holding torque and the torque along a step are those of :mod:`spherestep.statics`, which
work on any torque model; here they run on the :class:`~._table.TorqueMap` (torque ``T(R, c)`` and its exact
energy ``E(R, c)``, ``T = −∂E/∂θ`` for ``R → exp(θ̂) R``, fixed frame, N·m and J), batched over orientations.

* :func:`equilibrium`: :func:`spherestep.statics.equilibrium` with the map's settings (``gtol`` 1e-9 of
  ``τ_ref = max|τ| Σ_k |c_k|``, steps of at most 2°, 60 iterations).
* :func:`state_torques`: holding and stepping torques of stepper states.
"""

from __future__ import annotations

import math

import numpy as np

from .. import so3
from ..errors import bad_value
from ..statics import Equilibrium, holding_torque, step_torque
from ..statics import equilibrium as descend
from ._table import TorqueMap


def equilibrium(tmap: TorqueMap, R0, currents, *, gtol: float = 1e-9, max_iter: int = 60,
                max_step: float = math.radians(2.0)) -> Equilibrium:
    """The rest orientation of the rotor from ``R0 (K, 3, 3)`` under ``currents (K, N)``:
    :func:`spherestep.statics.equilibrium` with the map's settings (see the module)."""
    return descend(tmap, R0, currents, gtol=gtol, max_iter=max_iter, max_step=max_step)


def state_currents(design, index: int) -> np.ndarray:
    """Currents ``(N,)`` that hold stepper state ``index``: each held pole's coil at the pole's polarity."""
    c = np.zeros(len(design.stator))
    for k, sign in design.states().coils(int(index)).items():
        c[k] = sign
    return c


def state_torques(design, tmap: TorqueMap, indices, *, max_angle: float = math.radians(20.0)) -> list[dict]:
    """Holding and stepping torques of the stepper states ``indices`` of ``design`` (N·m, degrees).

    Per state: its coils, the offset of the physical equilibrium from the geometric state, the stiffness
    eigenvalues, the holding torque (weakest of the 32 axes of :func:`holding_torque`) and its axis, the
    strongest axis, and over the steps to every state within ``design.max_step`` (next state's coils on,
    along the geodesic between the equilibria, :func:`step_torque`): the number of steps, the largest drive
    torque met along any of them and the smallest drive at a step's start.
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
        row = {"state": int(i), "coils": {int(k): int(s) for k, s in st.coils(int(i)).items()},
               "equilibrium_offset_deg": float(np.degrees(so3.distance(eq.rotation[n], st.rotations[i]))),
               "stiffness_Nm_per_rad": eq.stiffness[n].tolist(),
               "holding_torque_Nm": float(hold.torque[n]), "weakest_axis": hold.weakest[n].tolist(),
               "strongest_axis_Nm": float(hold.per_axis[n].max()), "steps": int(len(nb))}
        if len(nb):
            cb = np.array([state_currents(design, j) for j in nb])
            eqb = equilibrium(tmap, st.rotations[nb], cb)
            s = step_torque(tmap, np.repeat(eq.rotation[n][None], len(nb), axis=0), eqb.rotation, cb)
            row |= {"step_peak_torque_Nm": float(s.peak.max()), "step_start_torque_min_Nm": float(s.start.min()),
                    "step_start_torque_median_Nm": float(np.median(s.start)),
                    "downhill_steps": int(np.sum(s.least > 0))}
        rows.append(row)
    return rows
