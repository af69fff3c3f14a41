"""Choosing damping and dwell from the motor's own wells.

The rotational stiffness of a stepper state is the Hessian of the energy at the rest pose its coils hold the
rotor in, ``K = −∂τ/∂ε`` (central differences of the model's torque, symmetrised): the equilibrium reached from the
geometric state (:func:`spherestep.statics.equilibrium`) — a fraction of a degree away on the air-core model,
degrees on the iron-cored one, whose detent moves the wells (at the geometric states themselves its Hessian can
be indefinite). Sampled states whose descent does not end at a strict minimum are left out. With the softest stiffness ``k`` (the 10th percentile over
sample states of the smallest eigenvalue: a soft well left overdamped would creep into place too slowly) and the rotor's inertia ``I``, the slowest well oscillates at
``ω = √(k/I)``; viscous damping ``b = 2ζ√(kI)`` gives damping ratio ``ζ`` on that mode. Every mode then
decays at least as fast as ``e^{−λt}`` with ``λ = ζω`` for ``ζ < 1`` (stiffer modes, less damped, share the
envelope ``e^{−bt/2I}``) and ``λ = ω(ζ − √(ζ² − 1))`` for ``ζ ≥ 1``; the dwell ``8/λ`` leaves below 0.3 % of
a step (``(1 + 8)e⁻⁸`` in the critical case) before the next one. The time step resolves the stiffest
well (90th percentile of the largest eigenvalue, ``ω_max``): ``dt = 0.25/ω_max``, at most dwell/50; the
fourth-order integrator then changes settled orientations by less than 0.01° (the demo plan at 26 ms against 10 ms).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..errors import bad_value
from ..motor import coil_currents
from ..statics import equilibrium, finite_difference_hessian
from .rotor import Integrator, Rotor
from .._fast.threads import single_blas_thread

FD_STEP = 1e-4  # rad, central differences of the torque
DECAY = 8.0  # dwell in units of the slowest decay time
SOFT_QUANTILE = 0.1  # which of the sampled wells' softest stiffness sets the damping
IRON_DWELL = 4.0  # an iron relay step's dwell, in units of tune's (which covers the well, not the transit)


@dataclass(frozen=True)
class Tuning:
    """``rotor`` (with the chosen damping), ``dwell`` (s), softest ``stiffness`` (N·m/rad) and ``omega`` (rad/s),
    and the integration time step ``dt`` (s)."""

    rotor: Rotor
    dwell: float
    stiffness: float
    omega: float
    dt: float

    def released(self, model, R: np.ndarray, currents: np.ndarray, trap=None) -> np.ndarray:
        """Where this rotor, released at rest at ``R`` under ``currents``, is at the end of one ``dwell`` at step
        ``dt`` (:class:`~.rotor.Integrator`). ``trap`` ``(R_min, radius, bound)``: on a model with compiled
        terms the integration stops once the rotor is trapped in that well —
        :func:`spherestep._fast.settle.settle`: within ``radius`` of ``R_min`` with ``½ I|ω|² + E(R) − E(R_min) ≤
        bound``; damping and friction only take energy away, so it stays there (the iron planner's settling check,
        :mod:`spherestep.commutation.iron_planner`)."""
        steps = max(1, int(round(self.dwell / self.dt)))
        packed = model.packed_terms(currents) if trap is not None else None
        if packed is None:
            return Integrator(model, self.rotor, self.dt).run(np.array(R, dtype=float), np.zeros(3), currents,
                                                              self.dwell, record_every=steps)[0]
        from .._fast.settle import settle
        from .rotor import YOSHIDA

        R_min, radius, bound = trap
        rotor = self.rotor
        return settle(*packed[:2], np.array(R, dtype=float), *packed[2:7], rotor.inertia, rotor.damping,
                      rotor.friction, self.dt, steps, np.array(YOSHIDA), np.ascontiguousarray(R_min), radius,
                      bound)[0]


def stiffness(model, R: np.ndarray, currents: np.ndarray) -> np.ndarray:
    """Eigenvalues (ascending) of the symmetrised ``−∂τ/∂ε`` at ``R`` under ``currents``
    (:func:`spherestep.statics.finite_difference_hessian`, step 1e-4 rad)."""
    return np.linalg.eigvalsh(finite_difference_hessian(model, R, currents, FD_STEP))


@single_blas_thread
def tune(design, model, zeta: float = 1.0, samples: int = 40, seed: int = 0) -> Tuning:
    """Damping and dwell for ``design`` under the torque ``model`` (see the module docstring)."""
    zeta = checks.positive(zeta, "zeta", "a positive damping ratio")
    states = design.states()
    rng = np.random.default_rng(seed)
    picks = rng.choice(len(states), size=min(samples, len(states)), replace=False)
    currents = np.array([coil_currents(states.coils(int(i)), len(design.stator)) for i in picks])
    rest = equilibrium(model, states.rotations[picks], currents)
    eig = np.array([stiffness(model, rest.rotation[i], currents[i]) for i in np.flatnonzero(rest.is_minimum)])
    if len(eig) == 0:
        raise bad_value("model", "a torque model with stable wells near the stepper states",
                        "no sampled state's descent ends at a minimum")
    k = float(np.quantile(eig[:, 0], SOFT_QUANTILE))
    if not k > 0:
        raise bad_value("model", "a torque model with stable wells at the stepper states", f"stiffness {k:.3g}")
    base = Rotor.from_design(design)
    omega = math.sqrt(k / base.inertia)
    rotor = Rotor(base.inertia, damping=2.0 * zeta * math.sqrt(k * base.inertia), friction=base.friction)
    rate = zeta * omega if zeta < 1 else omega * (zeta - math.sqrt(zeta * zeta - 1.0))
    dwell = DECAY / rate
    omega_max = math.sqrt(max(float(np.quantile(eig[:, -1], 0.9)), k) / base.inertia)
    return Tuning(rotor, dwell, k, omega, min(0.25 / omega_max, dwell / 50))


def iron_tuning(design, model) -> Tuning:
    """The relay rotor for iron plans (:func:`spherestep.commutation.plan_iron`): :func:`tune`'s damping and time
    step, its dwell × :data:`IRON_DWELL` (its dwell is eight decay times of the softest well; on the iron the
    transit through the detent's flat stretches takes longer: the prototype's misses on the tuned dwell all land
    at four times it)."""
    from dataclasses import replace

    base = tune(design, model)
    return replace(base, dwell=IRON_DWELL * base.dwell)
