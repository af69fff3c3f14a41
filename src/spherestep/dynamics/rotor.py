"""The rotor as a rigid ball: inertia, damping, castor friction, and a Lie-group integrator on SO(3).

State: orientation ``R`` (3×3) and angular velocity ``ω`` (rad/s, fixed frame, ``Ṙ = [ω]× R``). The torque
model gives ``τ(R, c)`` (N·m, fixed frame, about the centre) and the energy ``V(R, c)`` (J) with
``τ = −∂V/∂ε`` for ``R → exp([ε]×) R``. The paper's rotor is balanced (``I_xx = I_yy = I_zz``, Sec. IV-A), so
the inertia is the scalar ``I`` (the mean principal moment; :meth:`Rotor.from_design` reports the design's
anisotropy) and the free motion is a uniform rotation.

Integrator (one step of length ``h``). The conservative part is velocity Verlet on the group,
``ω ← ω + h/2 · τ(R)/I``, ``R ← exp(h [ω]×) R``, ``ω ← ω + h/2 · τ(R)/I`` (symplectic and time-reversible
for a bi-invariant metric), composed as Yoshida's fourth-order triple ``V(w₁h) V(w₀h) V(w₁h)`` with
``w₁ = 1/(2 − 2^{1/3})``, ``w₀ = 1 − 2w₁``: the energy error stays bounded and falls as ``h⁴``. It is wrapped
by half steps of the dissipation, solved exactly: viscous ``ω ← ω e^{−b t / I}`` then castor (Coulomb)
friction, which lowers ``|ω|`` by ``f t / I`` and stops the rotor rather than reversing it. Static friction:
a rotor at rest after the first half step of dissipation (its speed within ``f h / 2I``) under a torque no larger
than ``f`` stays where it is for the step (without this rule the splitting let a torque of 0.9 ``f`` creep the
prototype's ×1.3 rotor 0.022°/s at ``h`` = 2 ms: the friction of a detent well's dead band did not hold).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..statics import is_torque_model

_W1 = 1.0 / (2.0 - 2.0 ** (1.0 / 3.0))
YOSHIDA = (_W1, 1.0 - 2.0 * _W1, _W1)  # fourth-order symmetric composition of Verlet steps
SHELL_MASS = 0.6  # kg, a 12-in plastic sphere (Sec. IV-A gives no mass; a thin ABS shell of ~2.5 mm)


@dataclass(frozen=True)
class Rotor:
    """Scalar ``inertia`` (kg·m²), viscous ``damping`` (N·m·s/rad) and castor ``friction`` torque (N·m)."""

    inertia: float
    damping: float = 0.0
    friction: float = 0.0

    def __post_init__(self):
        for name in ("inertia", "damping", "friction"):
            check = checks.positive if name == "inertia" else checks.non_negative
            check(getattr(self, name), name, "a finite non-negative number (inertia positive)")

    @classmethod
    def from_design(cls, design, damping: float = 0.0, friction: float = 0.0, shell_mass: float = SHELL_MASS):
        """The design's rotor: thin shell plus point magnets (:meth:`MotorDesign.inertia`), mean moment."""
        return cls(float(np.trace(design.inertia(shell_mass=shell_mass)) / 3.0), damping, friction)

    def dissipate(self, w: np.ndarray, t: float) -> np.ndarray:
        """Exact flow of damping then friction for time ``t`` on angular velocities ``w (..., 3)``."""
        if self.damping:
            w = w * math.exp(-self.damping * t / self.inertia)
        if self.friction:
            speed = np.linalg.norm(w, axis=-1, keepdims=True)
            slower = np.maximum(speed - self.friction * t / self.inertia, 0.0)
            w = np.where(speed > 0, w * slower / np.where(speed > 0, speed, 1.0), 0.0)
        return w

    def step(self, R: np.ndarray, w: np.ndarray, torque, h: float, tau: np.ndarray | None = None):
        """Advance ``(R (K,3,3), ω (K,3))`` by ``h`` seconds under ``torque(R) -> (K, 3)``; see the module.

        ``tau`` is ``torque(R)`` when already known (the last evaluation of the previous step); returns
        ``(R, ω, τ(R))`` so that each step costs three torque evaluations.
        """
        w = self.dissipate(w, 0.5 * h)
        tau = torque(R) if tau is None else tau
        R0, tau0 = R, tau
        stuck = self.sticks(w, tau) if self.friction else None
        for weight in YOSHIDA:
            w = w + (0.5 * weight * h / self.inertia) * tau
            R = so3.exp(weight * h * w) @ R
            tau = torque(R)
            w = w + (0.5 * weight * h / self.inertia) * tau
        w = self.dissipate(w, 0.5 * h)
        if stuck is not None and np.any(stuck):
            R = np.where(stuck[..., None, None], R0, R)
            w = np.where(stuck[..., None], 0.0, w)
            tau = np.where(stuck[..., None], tau0, tau)
        return R, w, tau

    def sticks(self, w: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """Static friction (module doc): rotors at rest ``ω = 0`` under torques ``|τ| ≤ f`` (boolean ``(...)``)."""
        return (np.linalg.norm(w, axis=-1) == 0.0) & (np.linalg.norm(tau, axis=-1) <= self.friction)

    def kinetic_energy(self, w: np.ndarray) -> np.ndarray:
        """``½ I |ω|²`` (J)."""
        return 0.5 * self.inertia * np.sum(w * w, axis=-1)


class Integrator:
    """Integrates one rotor under ``model`` (``torque``/``energy`` of ``(R, currents)``) with time step ``dt``.

    A :class:`~spherestep.statics.TorqueModel` whose ``packed_terms`` are compiled (the potential, the magnets'
    map, the iron model) runs the same scheme compiled (:func:`spherestep._fast.integrate.integrate`, equal to
    :meth:`Rotor.step` to rounding, ``tests/test_fast_path.py``); any other model (one answering ``None``, or a
    plain object with ``torque`` and ``energy``), or ``compiled=False`` (the reference), runs :meth:`Rotor.step`
    with batched ``(1, 3, 3)`` calls."""

    def __init__(self, model, rotor: Rotor, dt: float, compiled: bool = True):
        dt = checks.positive(dt, "dt", "a positive time step in seconds")
        self.model, self.rotor, self.dt, self.compiled = model, rotor, dt, bool(compiled)

    def run(self, R: np.ndarray, w: np.ndarray, currents: np.ndarray, duration: float, record_every: int = 1):
        """Integrate for ``duration`` s from ``(R, ω)``; returns ``(R, ω, times, Rs, ωs, energies)``, the
        trajectory sampled every ``record_every`` steps (times relative to the start)."""
        steps = max(1, int(round(duration / self.dt)))
        compiled = self.compiled and is_torque_model(self.model)
        packed = self.model.packed_terms(currents) if compiled else None
        if packed is not None:  # the same scheme compiled (spherestep._fast.integrate)
            from .._fast.integrate import integrate

            count = steps // record_every + (steps % record_every != 0)
            Rs, ws = np.empty((count, 3, 3)), np.empty((count, 3))
            rotor = self.rotor
            R, w = integrate(*packed[:2], np.array(R, dtype=float), np.array(w, dtype=float), *packed[2:7],
                             rotor.inertia, rotor.damping, rotor.friction, self.dt, steps, record_every,
                             np.array(YOSHIDA), Rs, ws)
            times = self.dt * np.r_[np.arange(record_every, steps + 1, record_every), steps][:count]
            energy = self.rotor.kinetic_energy(ws) + self.model.energy(Rs, np.broadcast_to(currents, (count, len(currents))))
            return R, w, times, Rs, ws, energy
        torque = lambda Rb: self.model.torque(Rb, currents[None])  # noqa: E731
        R, w = R[None], w[None]
        times, Rs, ws = [], [], []
        tau = None
        for n in range(1, steps + 1):
            R, w, tau = self.rotor.step(R, w, torque, self.dt, tau)
            if n % record_every == 0 or n == steps:
                times.append(n * self.dt)
                Rs.append(R[0])
                ws.append(w[0])
        Rs, ws = np.array(Rs), np.array(ws)
        energy = self.rotor.kinetic_energy(ws) + self.model.energy(Rs, np.broadcast_to(currents, (len(Rs), len(currents))))
        return R[0], w[0], np.array(times), Rs, ws, energy
