"""Equilibria of the energy on SO(3) and their basins (issue 5 §1).

:func:`equilibrium` descends ``V(·, c)`` from a start ``R0`` by a safeguarded Newton method on the rotation group:
at ``R`` the local model is ``V(exp(ω̂) R) ≈ V − τ·ω + ½ ωᵀ H ω`` with the analytic torque ``τ`` and Hessian ``H``
of :class:`~spherestep.potential.MotorPotential` — or, for any other torque model with ``energy``, ``torque``,
``coils`` and ``failed`` (the magnets' :class:`~spherestep.magnetics.TorqueMap`), its torque and the Hessian by
central differences of the torque (:func:`torque_hessian`). The step is ``ω = Σ_i (e_i · τ / |h_i|) e_i`` over the
eigenpairs ``(h_i, e_i)`` of ``H`` (Newton where ``H`` is positive definite; along negative curvature it still
descends, so saddles repel rather than attract), shortened to at most ``max_step`` radians, and then halved
until the Armijo condition ``V(exp(sω̂) R) ≤ V − 10⁻⁴ s τ·ω`` holds (or, once the decrease is at rounding
level, until the torque falls). It stops when ``|τ| ≤ gtol · τ_ref`` with ``τ_ref = 2 max|G'| Σ_k |c_k|``, the
largest torque one pole per coil could feel.

:func:`gradient_flow` follows the steepest-descent flow ``Ṙ = τ̂(R) R`` (fixed-frame angular velocity ``τ``)
with an adaptive Runge–Kutta integrator until the torque is small. The basin of attraction of a minimum is
the set of starts whose gradient flow ends there; :func:`in_basin` applies exactly that test. (The cheaper
test "the energy decreases monotonically along the geodesic ``R0 → R_eq``" is neither necessary nor sufficient
for that and is not used.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .. import so3
from ..errors import bad_value
from . import _checks
from .model import MotorPotential, _cross


@dataclass(frozen=True)
class Equilibrium:
    """Result of :func:`equilibrium`, arrays with the broadcast leading shape of ``R0`` and ``currents``.

    ``rotation`` ``(..., 3, 3)``; ``energy``; ``torque`` (residual, fixed frame, ``(..., 3)``); ``stiffness``: the
    eigenvalues of the Hessian ``∂²V/∂ω²`` at ``rotation``, ascending ``(..., 3)`` (all positive at a strict
    minimum); ``iterations``; ``converged`` (``|τ| ≤ gtol τ_ref`` reached).
    """

    rotation: np.ndarray
    energy: np.ndarray
    torque: np.ndarray
    stiffness: np.ndarray
    iterations: np.ndarray
    converged: np.ndarray

    @property
    def is_minimum(self) -> np.ndarray:
        """Converged with a positive definite Hessian."""
        return self.converged & (self.stiffness[..., 0] > 0)


def torque_scale(model, currents: np.ndarray) -> np.ndarray:
    """The reference for torque tolerances, shape ``currents.shape[:-1]``: ``τ_ref = 2 max|G'| Σ_k |c_k|`` for a
    :class:`MotorPotential` (the largest torque one pole per coil could feel), the model's own
    ``torque_reference(c)`` otherwise."""
    if isinstance(model, MotorPotential):
        return 2.0 * model.kernel.maxima[1] * np.sum(np.abs(currents), axis=-1)
    return model.torque_reference(currents)


def torque_hessian(model, R: np.ndarray, c: np.ndarray, step: float = 1e-6) -> np.ndarray:
    """``H = −∂τ/∂θ`` (symmetrised) at ``R (K, 3, 3)`` under ``c (K, N)`` by central differences of the model's
    torque (turns of ``±step`` rad about the fixed axes), ``(K, 3, 3)``."""
    K = len(R)
    basis = np.eye(3)
    turns = so3.exp(np.concatenate([step * basis, -step * basis]))  # (6, 3, 3)
    Rs = np.einsum("sab,kbc->ksac", turns, R).reshape(-1, 3, 3)
    T = model.torque(Rs, np.repeat(c, 6, axis=0)).reshape(K, 6, 3)
    H = -(T[:, :3] - T[:, 3:]) / (2 * step)  # H[k, j, i] = −∂τ_i/∂θ_j
    return 0.5 * (H + np.swapaxes(H, 1, 2))


def _evaluate(model, R: np.ndarray, c: np.ndarray, order: int) -> tuple[np.ndarray, ...]:
    """Energy, torque (order ≥ 1) and Hessian (order 2) of validated batches."""
    if isinstance(model, MotorPotential):
        return model._pairwise(R, c, order)
    out = [model.energy(R, c)]
    if order >= 1:
        out.append(model.torque(R, c))
    if order >= 2:
        out.append(torque_hessian(model, R, c))
    return tuple(out)


def _prepare(model, R0, currents, name: str = "R0") -> tuple[np.ndarray, np.ndarray, tuple]:
    if not all(hasattr(model, attr) for attr in ("energy", "torque", "coils", "failed")):
        raise bad_value("model", "a MotorPotential or a torque model (energy, torque, coils, failed)",
                        type(model).__name__)
    R0 = _checks.rotations(R0, name)
    c = _checks.currents(currents, len(model.coils), model.failed)
    try:
        lead = np.broadcast_shapes(R0.shape[:-2], c.shape[:-1])
    except ValueError:
        raise bad_value("currents", f"leading axes that broadcast against {name}'s {R0.shape[:-2]}",
                        f"shape {c.shape}") from None
    R = np.broadcast_to(R0, lead + (3, 3)).reshape(-1, 3, 3).copy()
    c = np.broadcast_to(c, lead + (c.shape[-1],)).reshape(-1, c.shape[-1]).copy()
    if not np.all(np.any(c != 0, axis=-1)):
        raise bad_value("currents", "at least one energised coil (with all currents zero every orientation "
                        "is an equilibrium)", "all zeros")
    return R, c, lead


def equilibrium(model: MotorPotential, R0, currents, *, gtol: float = 1e-10, max_iter: int = 100,
                max_step: float = math.radians(5.0)) -> Equilibrium:
    """Descend the energy from ``R0`` to a stationary point (normally the local minimum), batched.

    ``R0`` ``(..., 3, 3)`` and ``currents`` ``(..., N)`` broadcast. ``gtol``: torque tolerance relative to
    ``τ_ref = 2 max|G'| Σ|c_k|``; ``max_step``: longest step (radians), which keeps the descent near the
    steepest-descent path while far from the minimum. See the module docstring for the method.

    >>> from spherestep.motor import prototype
    >>> design = prototype(); states = design.states()
    >>> model = MotorPotential(design)
    >>> from spherestep.potential import coil_currents
    >>> eq = equilibrium(model, states.rotations[0], coil_currents(design, states.coils(0)))
    >>> bool(eq.converged), bool(eq.is_minimum)
    (True, True)
    """
    R, c, lead = _prepare(model, R0, currents)
    gtol = _checks.fraction(gtol, "gtol")
    max_iter = _checks.count(max_iter, "max_iter", minimum=1)
    max_step = _checks.positive(max_step, "max_step")
    tol = gtol * torque_scale(model, c)
    E, tau, H = _evaluate(model, R, c, 2)
    iterations = np.zeros(len(R), dtype=int)
    converged = np.linalg.norm(tau, axis=-1) <= tol
    stalled = np.zeros(len(R), dtype=bool)
    for _ in range(max_iter):
        active = np.flatnonzero(~converged & ~stalled)
        if len(active) == 0:
            break
        Ra, ca, Ea, ta = R[active], c[active], E[active], tau[active]
        omega = _newton_direction(H[active], ta, max_step)
        slope = np.sum(ta * omega, axis=-1)  # −dV/ds at s = 0, positive
        step = np.ones(len(active))
        accepted = np.zeros(len(active), dtype=bool)
        new = [None, None, None, None]
        for _ in range(40):
            todo = np.flatnonzero(~accepted)
            if len(todo) == 0:
                break
            Rt = so3.exp(step[todo, None] * omega[todo]) @ Ra[todo]
            Et, tt, Ht = _evaluate(model, Rt, ca[todo], 2)
            rounding = 1e-13 * np.maximum(np.abs(Ea[todo]), 1.0)
            armijo = Et <= Ea[todo] - 1e-4 * step[todo] * slope[todo]
            flat = (np.abs(Et - Ea[todo]) <= rounding) & \
                (np.linalg.norm(tt, axis=-1) < np.linalg.norm(ta[todo], axis=-1))
            ok = armijo | flat
            for slot, value in enumerate((Rt, Et, tt, Ht)):
                if new[slot] is None:
                    new[slot] = np.zeros((len(active),) + value.shape[1:])
                new[slot][todo[ok]] = value[ok]
            accepted[todo[ok]] = True
            step[todo[~ok]] *= 0.5
        moved = active[accepted]
        R[moved], E[moved], tau[moved], H[moved] = (new[i][accepted] for i in range(4))
        iterations[moved] += 1
        stalled[active[~accepted]] = True
        converged[moved] = np.linalg.norm(tau[moved], axis=-1) <= tol[moved]
    stiffness = np.linalg.eigvalsh(H)
    return Equilibrium(R.reshape(lead + (3, 3)), E.reshape(lead), tau.reshape(lead + (3,)),
                       stiffness.reshape(lead + (3,)), iterations.reshape(lead), converged.reshape(lead))


def _newton_direction(H: np.ndarray, tau: np.ndarray, max_step: float) -> np.ndarray:
    """``ω = Σ_i (e_i·τ/|h_i|) e_i`` (``|h_i|`` floored at ``1e-8 max|h|``), shortened to ``|ω| ≤ max_step``."""
    h, e = np.linalg.eigh(H)
    floor = 1e-8 * np.max(np.abs(h), axis=-1, keepdims=True) + np.finfo(float).tiny
    coeff = np.einsum("kai,ka->ki", e, tau) / np.maximum(np.abs(h), floor)
    omega = np.einsum("kai,ki->ka", e, coeff)
    length = np.linalg.norm(omega, axis=-1, keepdims=True)
    return omega * np.minimum(1.0, max_step / np.maximum(length, np.finfo(float).tiny))


def gradient_flow(model: MotorPotential, R0, currents, *, gtol: float = 1e-6, rtol: float = 1e-7,
                  max_rounds: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Follow ``Ṙ = τ̂(R) R`` (steepest descent of ``V``, ``τ`` the fixed-frame torque) from ``R0`` until rest.

    Integrated with SciPy's RK45 (relative tolerance ``rtol``) on the entries of ``R`` for the whole batch, in
    rounds of ``10/h_max`` (``h_max`` the largest Hessian eigenvalue magnitude at the starts), re-orthonormalised
    between rounds, until every ``|τ| ≤ gtol · τ_ref`` or ``max_rounds`` rounds. Returns ``(rotations, at_rest)``
    with the broadcast leading shape.
    """
    R, c, lead = _prepare(model, R0, currents)
    gtol = _checks.fraction(gtol, "gtol")
    rtol = _checks.fraction(rtol, "rtol")
    max_rounds = _checks.count(max_rounds, "max_rounds", minimum=1)
    tol = gtol * torque_scale(model, c)
    K = len(R)

    def rate(_, y):
        Ry = y.reshape(K, 3, 3)
        tau = _evaluate(model, Ry, c, 1)[1]
        return (_cross(tau[:, None, :], np.swapaxes(Ry, -1, -2))).swapaxes(-1, -2).reshape(-1)  # τ̂ R, column-wise

    H = _evaluate(model, R, c, 2)[2]
    h_max = float(np.max(np.abs(np.linalg.eigvalsh(H))))
    span = 10.0 / max(h_max, np.finfo(float).tiny)
    at_rest = np.linalg.norm(_evaluate(model, R, c, 1)[1], axis=-1) <= tol
    for _ in range(max_rounds):
        if np.all(at_rest):
            break
        sol = solve_ivp(rate, (0.0, span), R.reshape(-1), method="RK45", rtol=rtol, atol=rtol * 1e-2)
        R = _orthonormalise(sol.y[:, -1].reshape(K, 3, 3))
        at_rest = np.linalg.norm(_evaluate(model, R, c, 1)[1], axis=-1) <= tol
    return R.reshape(lead + (3, 3)), at_rest.reshape(lead)


def in_basin(model: MotorPotential, R0, currents, R_eq, *, tol: float = math.radians(0.5),
             gtol: float = 1e-6) -> np.ndarray:
    """Whether the gradient flow from ``R0`` comes to rest within Park distance ``tol`` of ``R_eq``.

    That is membership of ``R0`` in the basin of attraction of the minimum ``R_eq`` (for currents ``currents``)
    under the steepest-descent flow of :func:`gradient_flow`, the over-damped limit of the rotor's dynamics.
    Starts on a basin boundary (the stable manifold of a saddle) flow to the saddle and are reported outside.
    Batched: ``R0``, ``currents`` and ``R_eq`` broadcast over leading axes.
    """
    tol = _checks.positive(tol, "tol")
    R_eq = _checks.rotations(R_eq, "R_eq")
    end, at_rest = gradient_flow(model, R0, currents, gtol=gtol)
    return at_rest & (so3.distance(end, R_eq) <= tol)


def _orthonormalise(R: np.ndarray) -> np.ndarray:
    """The nearest rotation (polar factor) of each nearly orthogonal matrix."""
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt
