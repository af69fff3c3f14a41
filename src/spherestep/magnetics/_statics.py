"""Statics on the physical model: equilibria, stiffness, holding torque and the torque along a step.

All on the :class:`~._table.TorqueMap` (torque ``T(R, c)`` and its exact energy ``E(R, c)``, ``T = −∂E/∂θ`` for
``R → exp(θ̂) R``, fixed frame, N·m and J), batched over orientations.

* :func:`equilibrium`: the damped Newton descent of :func:`spherestep.potential.equilibrium` on the map's
  energy and torque, with the stiffness ``H = ∂²E/∂θ²`` by central differences of the torque (step 1e-6
  rad), steps of at most ``max_step``; it stops at ``|T| ≤ gtol · τ_ref`` with
  ``τ_ref = max|τ| Σ_k |c_k|`` (:meth:`TorqueMap.torque_reference`). The stiffness eigenvalues (N·m/rad) are
  returned, all positive at a minimum.
* :func:`holding_torque`: from an equilibrium, turn the rotor by ``θ`` about fixed axes ``ŵ`` (32
  directions: the faces, edges and corners of a cube, and both senses of the stiffness's eigen-axes) up to
  ``max_angle`` and record the restoring torque
  ``−T · ŵ``; its peak along a ray is the constant torque about ``ŵ`` the state resists before the rotor
  is pushed over the ridge, and the smallest peak over the axes is the state's holding torque. A rotor
  pushed by a constant torque may leave along a curved path over a lower pass, so the minimum over straight
  rays is an upper bound of the true escape torque.
* :func:`step_torque`: with the next state's coils energised, the drive ``T · n̂`` along the geodesic from
  the current state's equilibrium to the next one's (``n̂`` the step's axis): the torque at the start, its
  peak, and its smallest value before arrival (positive: the step runs downhill all the way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..errors import bad_value
from ..potential.equilibrium import Equilibrium, torque_hessian
from ..potential.equilibrium import equilibrium as potential_equilibrium
from ._model import as_rotations
from ._table import TorqueMap

FD_STEP = 1e-6  # rad, for the stiffness by central differences of the torque


def cube_axes() -> np.ndarray:
    """26 unit axes: the directions to the faces (6), edges (12) and corners (8) of a cube, ``(26, 3)``."""
    grid = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 3)
    grid = grid[np.any(grid != 0, axis=1)].astype(float)
    return grid / np.linalg.norm(grid, axis=1, keepdims=True)


def stiffness(tmap: TorqueMap, R: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``H = ∂²E/∂θ∂θ = −∂T/∂θ`` (N·m/rad) at ``R (K, 3, 3)`` for currents ``c (K, N)``, symmetrised,
    ``(K, 3, 3)`` (:func:`spherestep.potential.torque_hessian`, step 1e-6 rad)."""
    return torque_hessian(tmap, R, c, FD_STEP)


def equilibrium(tmap: TorqueMap, R0, currents, *, gtol: float = 1e-9, max_iter: int = 60,
                max_step: float = math.radians(2.0)) -> Equilibrium:
    """The rest orientation of the rotor from ``R0 (K, 3, 3)`` under ``currents (K, N)``: the damped Newton
    descent of :func:`spherestep.potential.equilibrium` on the map's energy and torque (see the module)."""
    return potential_equilibrium(tmap, R0, currents, gtol=gtol, max_iter=max_iter, max_step=max_step)


@dataclass(frozen=True)
class Holding:
    """Result of :func:`holding_torque` for ``K`` states: ``per_axis (K, A)`` peak restoring torque (N·m)
    about each of the ``axes (K, A, 3)`` and the angle of the peak ``peak_angle (K, A)`` (rad); ``torque (K,)``
    the smallest over the axes (the holding torque) and ``weakest (K, 3)`` its axis."""

    axes: np.ndarray
    per_axis: np.ndarray
    peak_angle: np.ndarray

    @property
    def torque(self) -> np.ndarray:
        return self.per_axis.min(axis=1)

    @property
    def weakest(self) -> np.ndarray:
        return self.axes[np.arange(len(self.axes)), np.argmin(self.per_axis, axis=1)]


def holding_torque(tmap: TorqueMap, R_eq, currents, *, axes=None, max_angle: float = math.radians(20.0),
                   samples: int = 81) -> Holding:
    """Peak restoring torque ``max_θ −T(exp(θ ŵ) R_eq, c) · ŵ`` for ``θ`` in ``[0, max_angle]`` (``samples``
    points) about each axis ``ŵ``; ``R_eq (K, 3, 3)``, ``currents (K, N)``.

    ``axes``: ``(A, 3)`` for every state, or ``(K, A, 3)`` per state; default :func:`cube_axes` plus both
    senses of the three stiffness eigen-axes of each state (so the softest direction is always tried).
    """
    R, _ = as_rotations(R_eq)
    c = np.broadcast_to(np.asarray(currents, dtype=float), (len(R), len(tmap.coils)))
    if axes is None:
        eig = np.swapaxes(np.linalg.eigh(stiffness(tmap, R, c))[1], 1, 2)  # rows: eigen-axes
        W = np.concatenate([np.broadcast_to(cube_axes(), (len(R), 26, 3)), eig, -eig], axis=1)
    else:
        W = np.asarray(axes, dtype=float)
        if W.ndim == 2:
            W = np.broadcast_to(W, (len(R),) + W.shape)
        if W.ndim != 3 or W.shape[0] != len(R) or W.shape[2] != 3 or np.any(np.linalg.norm(W, axis=2) == 0):
            raise bad_value("axes", f"non-zero axes of shape (A, 3) or ({len(R)}, A, 3)", f"shape {W.shape}")
    W = W / np.linalg.norm(W, axis=2, keepdims=True)
    theta = np.linspace(0.0, max_angle, samples)
    per_axis = np.empty(W.shape[:2])
    peak = np.empty(W.shape[:2])
    for k in range(len(R)):  # one state at a time: A × S orientations share its currents
        turns = so3.exp(W[k][:, None, :] * theta[None, :, None])  # (A, S, 3, 3)
        T = tmap.torque((turns @ R[k]).reshape(-1, 3, 3), c[k]).reshape(W.shape[1], samples, 3)
        restoring = -np.einsum("asi,ai->as", T, W[k])
        per_axis[k] = restoring.max(axis=1)
        peak[k] = theta[np.argmax(restoring, axis=1)]
    return Holding(W, per_axis, peak)


@dataclass(frozen=True)
class StepTorque:
    """Drive torque ``T · n̂`` (N·m) along steps: ``start`` at the first orientation, ``peak`` its maximum,
    ``least`` its minimum before the last 10 % of the path, ``angle`` the step's length (rad)."""

    start: np.ndarray
    peak: np.ndarray
    least: np.ndarray
    angle: np.ndarray


def step_torque(tmap: TorqueMap, R_from, R_to, currents, samples: int = 41) -> StepTorque:
    """Drive torque along geodesics ``R(t) = exp(t ω) R_from``, ``ω = log(R_to R_fromᵀ)``, with the target
    state's ``currents (K, N)`` energised; ``n̂ = ω/|ω|``."""
    Ra, _ = as_rotations(R_from)
    Rb, _ = as_rotations(R_to)
    if Ra.shape != Rb.shape:
        raise bad_value("R_to", f"one rotation per R_from, shape {Ra.shape}", f"shape {Rb.shape}")
    c = np.broadcast_to(np.asarray(currents, dtype=float), (len(Ra), len(tmap.coils)))
    omega = so3.log(Rb @ np.swapaxes(Ra, 1, 2))
    angle = np.linalg.norm(omega, axis=1)
    n = omega / np.maximum(angle, 1e-300)[:, None]
    t = np.linspace(0.0, 1.0, samples)
    path = so3.exp(omega[:, None, :] * t[None, :, None]) @ Ra[:, None]  # (K, S, 3, 3)
    T = tmap.torque(path.reshape(-1, 3, 3), np.repeat(c, samples, axis=0)).reshape(len(Ra), samples, 3)
    drive = np.einsum("ksi,ki->ks", T, n)
    body = t < 0.9
    return StepTorque(drive[:, 0], drive.max(axis=1), drive[:, body].min(axis=1), angle)


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
