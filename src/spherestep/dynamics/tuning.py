"""Choosing damping and dwell from the motor's own wells.

The rotational stiffness of a stepper state is the Hessian of the energy there, ``K = −∂τ/∂ε`` (central
differences of the model's torque, symmetrised). With the softest stiffness ``k`` (median over sample
states of the smallest eigenvalue) and the rotor's inertia ``I``, the slowest well oscillates at
``ω = √(k/I)``; viscous damping ``b = 2ζ√(kI)`` gives damping ratio ``ζ`` on that mode, and a dwell of
``5/(ζω)`` lets its envelope decay by ``e⁻⁵`` (below 1 %) before the next step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..errors import bad_value
from .rotor import Rotor
from .simulate import currents_of

FD_STEP = 1e-4  # rad, central differences of the torque


@dataclass(frozen=True)
class Tuning:
    """``rotor`` (with the chosen damping), ``dwell`` (s), softest ``stiffness`` (N·m/rad) and ``omega`` (rad/s)."""

    rotor: Rotor
    dwell: float
    stiffness: float
    omega: float


def stiffness(model, R: np.ndarray, currents: np.ndarray) -> np.ndarray:
    """Eigenvalues (ascending) of the symmetrised ``−∂τ/∂ε`` at ``R`` under ``currents``."""
    J = np.stack([-(model.torque(so3.exp(FD_STEP * e) @ R[None], currents[None])
                    - model.torque(so3.exp(-FD_STEP * e) @ R[None], currents[None]))[0] / (2 * FD_STEP)
                  for e in np.eye(3)], axis=1)
    return np.linalg.eigvalsh(0.5 * (J + J.T))


def tune(design, model, zeta: float = 1.0, samples: int = 20, seed: int = 0) -> Tuning:
    """Damping and dwell for ``design`` under the torque ``model`` (see the module docstring)."""
    if not (math.isfinite(zeta) and zeta > 0):
        raise bad_value("zeta", "a positive damping ratio", zeta)
    states = design.states()
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(states), size=min(samples, len(states)), replace=False)
    softest = [stiffness(model, states.rotations[i], currents_of(states.coils(int(i)), len(design.stator)))[0]
               for i in picks]
    k = float(np.median(softest))
    if not k > 0:
        raise bad_value("model", "a torque model with stable wells at the stepper states", f"stiffness {k:.3g}")
    base = Rotor.from_design(design)
    omega = math.sqrt(k / base.inertia)
    rotor = Rotor(base.inertia, damping=2.0 * zeta * math.sqrt(k * base.inertia), friction=base.friction)
    return Tuning(rotor, 5.0 / (zeta * omega), k, omega)
