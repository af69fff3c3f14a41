"""Statics on any torque model: the :class:`TorqueModel` protocol, equilibria and their basins, stiffness.

The protocol
------------
Every physical or phenomenological model of the motor — the potential of Sec. III-B
(:class:`~spherestep.potential.MotorPotential`), the magnets' torque map (:class:`~spherestep.magnetics.TorqueMap`),
the iron-cored stator — answers the same five questions about the rotor at orientation ``R`` (``(..., 3, 3)``,
body → fixed, acting on column vectors) with coil currents ``c`` (``(..., N)``, per unit of the coil's nominal
current, ``+1`` attracting a north-out pole; zero on failed coils):

* ``energy(R, c)`` ``(...)`` in J;
* ``torque(R, c)`` ``(..., 3)`` in N·m about the sphere's centre, fixed frame: ``τ = −∂E/∂θ`` for a small turn
  ``R → exp(θ̂) R``;
* ``torque_matrix(R, c=None)`` ``(..., 3, N)``: ``∂τ/∂c_k``, the torque per unit current of each coil (for a
  model linear in the currents it does not depend on ``c``, and ``τ = τ(R, 0) + K(R) c``);
* ``hessian(R, c)`` ``(..., 3, 3)``: ``H = ∂²E/∂θ² = −∂τ/∂θ`` (symmetrised), N·m/rad, the stiffness at rest;
* ``torque_reference(c)`` ``(...)``: a torque scale (N·m) for tolerances.

plus ``coil_count`` and ``failed`` (indices of coils that carry no current), and two declarations of what the
model offers, so that no caller probes it:

* ``has_bias``: ``True`` when the model has torque at zero current (a detent or bias, as iron cores give:
  ``torque(R, 0) ≠ 0``), ``False`` when ``torque(R, 0) ≡ 0`` (the air-core map, the potential);
* ``packed_terms(c)``: the model's energy as compiled zonal terms (a :class:`spherestep._fast.Packed`, built by
  :func:`spherestep.rotor_field.pack_terms`) for currents ``c (..., N)``, or ``None``: the compiled descent and
  integrator run on it, any model answering ``None`` takes the NumPy path;
* ``affine_in_currents``: ``True`` when those packed terms' coefficients are affine in each coil's own current
  (``C(c) = C(0) + Σ_k c_k ∂C/∂c_k``, the same parameters and signs at every ``c``): the servo law's cache then
  evaluates ``K(R)`` and the bias in one compiled call from ``C(0)`` and ``C(1) − C(0)``
  (:class:`spherestep.control.ModelCache`); ``False`` (the default) for a model without packed terms;
* ``winding_currents(c)``: the currents as the windings' torque sees them, so that ``τ(R, c) = τ(R, 0) +
  K(R) winding_currents(c)`` with ``K = torque_matrix(R)`` at zero current: ``c`` itself (the default) for a
  linear winding, bent for a saturating one (:class:`~spherestep.magnetics.percoil.PerCoil`'s ``knee``). The
  emulated motor applies it to the mean current of each rotor step.

:class:`TorqueModelBase` supplies what a model need not write itself: the combined ``evaluate`` (energy, torque
and Hessian in one call), the Hessian by central differences of the torque, ``torque_matrix`` by central
differences in the currents, the current check, and the cautious declarations ``has_bias = True``,
``packed_terms(c) = None``, ``affine_in_currents = False`` and ``winding_currents(c) = c``.

Equilibria
----------
:func:`equilibrium` descends ``E(·, c)`` from ``R0`` by a safeguarded Newton method on the rotation group: at ``R``
the local model is ``E(exp(ω̂) R) ≈ E − τ·ω + ½ ωᵀ H ω``. The step is ``ω = Σ_i (e_i·τ/|h_i|) e_i`` over the
eigenpairs ``(h_i, e_i)`` of ``H`` (Newton where ``H`` is positive definite; along negative curvature it still
descends, so saddles repel rather than attract), shortened to at most ``max_step`` radians, then halved until the
Armijo condition ``E(exp(sω̂) R) ≤ E − 10⁻⁴ s τ·ω`` holds (or, once the decrease is at rounding level, until the
torque falls). It stops when ``|τ| ≤ gtol · torque_reference(c)``. For a model whose energy is a sum of compiled
zonal terms (``packed_terms``) the same iteration runs compiled, row by row (:func:`spherestep._fast.descent.descend`).
:func:`descend` is that descent on inputs already checked, for loops that check once (the potential planner).

:func:`gradient_flow` follows the steepest-descent flow ``Ṙ = τ̂(R) R`` with an adaptive Runge–Kutta integrator
until the torque is small. The basin of attraction of a minimum is the set of starts whose gradient flow ends
there; :func:`in_basin` applies exactly that test.

Holding and stepping
--------------------
:func:`holding_torque`: from an equilibrium, turn the rotor by ``θ`` about fixed axes ``ŵ`` (the faces, edges and
corners of a cube, and both senses of the stiffness's eigen-axes) up to ``max_angle`` and record the restoring
torque ``−τ · ŵ``; its peak along a ray is the constant torque about ``ŵ`` the state resists before the rotor is
pushed over the ridge, and the smallest peak over the axes is the holding torque (an upper bound of the true
escape torque: a rotor pushed by a constant torque may leave along a curved path over a lower pass).
:func:`step_torque`: with the next state's coils energised, the drive ``τ · n̂`` along the geodesic between the
two equilibria: at the start, its peak, and its smallest value before arrival (positive: downhill all the way).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from . import checks, so3
from ._fast import Packed
from ._fast.threads import single_blas_thread
from .errors import bad_value

HESSIAN_STEP = 1e-6  # rad, central differences of the torque
CURRENT_STEP = 1e-3  # per unit current, central differences in the currents (exact for quadratic models)
GTOL, MAX_ITER, MAX_STEP = 1e-10, 100, math.radians(5.0)  # equilibrium's defaults (gtol, max_iter, max_step)


@runtime_checkable
class TorqueModel(Protocol):
    """What every torque model of the motor provides (see the module docstring for units and conventions)."""

    coil_count: int
    failed: tuple[int, ...]
    has_bias: bool
    affine_in_currents: bool

    def energy(self, R, currents) -> np.ndarray: ...

    def torque(self, R, currents) -> np.ndarray: ...

    def torque_matrix(self, R, currents=None) -> np.ndarray: ...

    def hessian(self, R, currents) -> np.ndarray: ...

    def torque_reference(self, currents) -> np.ndarray: ...

    def evaluate(self, R, currents, order: int) -> tuple[np.ndarray, ...]: ...

    def packed_terms(self, currents) -> Packed | None: ...

    def winding_currents(self, currents) -> np.ndarray: ...


def as_currents(currents, coil_count: int, failed: tuple[int, ...] = (), name: str = "currents") -> np.ndarray:
    """The one input contract for coil currents (:func:`spherestep.checks.currents`)."""
    return checks.currents(currents, coil_count, failed, name)


class TorqueModelBase:
    """Defaults for a :class:`TorqueModel`: a subclass sets ``coil_count`` and ``failed`` and writes ``energy``,
    ``torque`` and ``torque_reference``; it overrides ``torque_matrix``, ``hessian`` or ``evaluate`` where it
    has something better than the central differences below, ``has_bias`` (default ``True``: a model that does
    not say otherwise may have torque at zero current) and ``packed_terms`` (default ``None``: no compiled
    form)."""

    coil_count: int
    failed: tuple[int, ...]
    has_bias: bool = True
    affine_in_currents: bool = False

    def packed_terms(self, currents) -> Packed | None:
        """The energy as compiled zonal terms for ``currents (..., N)``; ``None``: this model has none."""
        return None

    def winding_currents(self, currents) -> np.ndarray:
        """The currents as the windings' torque sees them (module docstring): ``currents`` (linear windings)."""
        return currents

    def as_currents(self, currents, name: str = "currents") -> np.ndarray:
        """``currents`` checked against this model (:func:`as_currents`)."""
        return as_currents(currents, self.coil_count, self.failed, name)

    def evaluate(self, R, currents, order: int) -> tuple[np.ndarray, ...]:
        """``(E,)``, ``(E, τ)`` or ``(E, τ, H)`` for ``order`` 0, 1 or 2."""
        out = [self.energy(R, currents)]
        if order >= 1:
            out.append(self.torque(R, currents))
        if order >= 2:
            out.append(self.hessian(R, currents))
        return tuple(out)

    def hessian(self, R, currents) -> np.ndarray:
        """``H = −∂τ/∂θ`` by central differences of the torque (:func:`finite_difference_hessian`)."""
        return finite_difference_hessian(self, R, currents)

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``∂τ/∂c_k`` by central differences of ``±CURRENT_STEP`` in each live coil's current (exact for
        torques at most quadratic in the currents), ``(..., 3, N)``; zero columns for failed coils."""
        R = so3.as_rotations(R)
        N = self.coil_count
        c = np.zeros(R.shape[:-2] + (N,)) if currents is None else self.as_currents(currents)
        lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
        Rf = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
        cf = np.broadcast_to(c, lead + (N,)).reshape(-1, N)
        live = np.setdiff1d(np.arange(N), self.failed)
        shift = np.zeros((2 * len(live), N))
        shift[np.arange(len(live)), live] = CURRENT_STEP
        shift[len(live) + np.arange(len(live)), live] = -CURRENT_STEP
        T = self.torque(np.repeat(Rf, len(shift), axis=0), (cf[:, None, :] + shift[None]).reshape(-1, N))
        T = T.reshape(len(Rf), 2, len(live), 3)
        K = np.zeros((len(Rf), 3, N))
        K[:, :, live] = np.swapaxes((T[:, 0] - T[:, 1]) / (2 * CURRENT_STEP), -1, -2)
        return K.reshape(lead + (3, N))


def finite_difference_hessian(model: TorqueModel, R, currents, step: float = HESSIAN_STEP) -> np.ndarray:
    """``H = −∂τ/∂θ`` (symmetrised, N·m/rad) at ``R (..., 3, 3)`` under ``currents (..., N)`` by central
    differences of the model's torque over turns of ``±step`` rad about the fixed axes, ``(..., 3, 3)``."""
    R = so3.as_rotations(R)
    c = np.asarray(currents, dtype=float)
    lead = np.broadcast_shapes(R.shape[:-2], c.shape[:-1])
    Rf = np.broadcast_to(R, lead + (3, 3)).reshape(-1, 3, 3)
    cf = np.broadcast_to(c, lead + c.shape[-1:]).reshape(-1, c.shape[-1])
    K = len(Rf)
    turns = so3.exp(np.concatenate([step * np.eye(3), -step * np.eye(3)]))  # (6, 3, 3)
    Rs = np.einsum("sab,kbc->ksac", turns, Rf).reshape(-1, 3, 3)
    T = np.asarray(model.torque(Rs, np.repeat(cf, 6, axis=0))).reshape(K, 6, 3)
    H = -(T[:, :3] - T[:, 3:]) / (2 * step)  # H[k, j, i] = −∂τ_i/∂θ_j
    return (0.5 * (H + np.swapaxes(H, 1, 2))).reshape(lead + (3, 3))


def stiffness(model: TorqueModel, R, currents) -> np.ndarray:
    """Eigenvalues (ascending, N·m/rad) of the model's Hessian at ``R`` under ``currents``, ``(..., 3)``."""
    return np.linalg.eigvalsh(model.hessian(R, currents))


@dataclass(frozen=True)
class Equilibrium:
    """Result of :func:`equilibrium`, arrays with the broadcast leading shape of ``R0`` and ``currents``.

    ``rotation`` ``(..., 3, 3)``; ``energy`` (J); ``torque`` (residual, N·m, fixed frame, ``(..., 3)``);
    ``stiffness``: the eigenvalues of the Hessian ``∂²E/∂ω²`` at ``rotation`` (N·m/rad), ascending ``(..., 3)``
    (all positive at a strict minimum); ``iterations``; ``converged`` (``|τ| ≤ gtol τ_ref`` reached).
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


_MODEL_TYPES: set[type] = set()  # types that passed the protocol check (a runtime Protocol check costs ~0.1 ms)


def is_torque_model(model) -> bool:
    """Whether ``model`` is a :class:`TorqueModel` (answers the protocol and declares ``has_bias``,
    ``affine_in_currents`` and ``packed_terms``); the check, ~0.1 ms, runs once per type."""
    if type(model) in _MODEL_TYPES:
        return True
    if isinstance(model, TorqueModel):
        _MODEL_TYPES.add(type(model))
        return True
    return False


def _prepare(model, R0, currents, name: str = "R0") -> tuple[np.ndarray, np.ndarray, tuple]:
    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel: MotorPotential, TorqueMap, …)",
                        type(model).__name__)
    R0 = so3.as_rotations(R0, name)
    c = as_currents(currents, model.coil_count, model.failed)
    try:
        lead = np.broadcast_shapes(R0.shape[:-2], c.shape[:-1])
    except ValueError:
        raise bad_value("currents", f"leading axes that broadcast against {name}'s {R0.shape[:-2]}",
                        f"shape {c.shape}") from None
    R = np.broadcast_to(R0, lead + (3, 3)).reshape(-1, 3, 3).copy()
    c = np.broadcast_to(c, lead + (c.shape[-1],)).reshape(-1, c.shape[-1]).copy()
    return R, c, lead


@single_blas_thread
def equilibrium(model: TorqueModel, R0, currents, *, gtol: float = GTOL, max_iter: int = MAX_ITER,
                max_step: float = MAX_STEP, compiled: bool = True) -> Equilibrium:
    """Descend the energy from ``R0`` to a stationary point (normally the local minimum), batched.

    ``R0`` ``(..., 3, 3)`` and ``currents`` ``(..., N)`` broadcast. ``gtol``: torque tolerance relative to
    ``model.torque_reference(currents)``; ``max_step``: longest step (radians), which keeps the descent near the
    steepest-descent path while far from the minimum. See the module docstring for the method. A model with
    ``packed_terms`` (the potential, the magnets' map, the iron model) descends in one compiled call
    (:func:`spherestep._fast.descent.descend`, the same iteration row by row); ``compiled=False`` runs the NumPy
    reference.

    >>> from spherestep.motor import prototype
    >>> from spherestep.potential import MotorPotential, coil_currents
    >>> design = prototype(); states = design.states()
    >>> eq = equilibrium(MotorPotential(design), states.rotations[0], coil_currents(design, states.coils(0)))
    >>> bool(eq.converged), bool(eq.is_minimum)
    (True, True)
    """
    R, c, lead = _prepare(model, R0, currents)
    gtol = checks.fraction(gtol, "gtol", expected="a number in (0, 1)")
    return _result(*descend(model, R, c, gtol=gtol, max_iter=checks.count(max_iter, "max_iter"),
                            max_step=checks.positive(max_step, "max_step"), compiled=compiled), lead)


def descend(model: TorqueModel, R: np.ndarray, c: np.ndarray, *, gtol: float = GTOL, max_iter: int = MAX_ITER,
            max_step: float = MAX_STEP, compiled: bool = True) -> tuple[np.ndarray, ...]:
    """:func:`equilibrium`'s descent without its checks, for loops that check their inputs once: ``model`` a
    :class:`TorqueModel`, ``R (B, 3, 3)`` proper rotations (overwritten), ``c (B, N)`` currents that passed
    :func:`as_currents`, valid options. Returns the end points' ``(R, E, τ, H, iterations, converged)``, flat
    (``(B, 3, 3)``, ``(B,)``, ``(B, 3)``, ``(B, 3, 3)``, ``(B,)``, ``(B,)``). Unchecked input gives undefined
    results: call :func:`equilibrium` otherwise."""
    scale = np.asarray(model.torque_reference(c), dtype=float)
    if (scale <= 0).any():  # nothing energised and no detent: every orientation is at rest
        scale = np.where(scale > 0, scale, np.finfo(float).tiny)
    tol = gtol * scale
    packed = _packed(model, c) if compiled else None
    if packed is not None:  # the same descent compiled (spherestep._fast.descent)
        from ._fast.descent import descend as compiled_descend

        n = len(R)
        out = (np.empty((n, 3, 3)), np.empty(n), np.empty((n, 3)), np.empty((n, 3, 3)), np.zeros(n, dtype=np.int64),
               np.zeros(n, dtype=bool))
        compiled_descend(*packed[:2], R, *packed[2:], _filled(tol, (n,)), max_iter, max_step, *out)
        return out
    E, tau, H = model.evaluate(R, c, 2)
    iterations = np.zeros(len(R), dtype=int)
    converged = np.linalg.norm(tau, axis=-1) <= tol
    stalled = np.zeros(len(R), dtype=bool)
    for _ in range(max_iter):
        active = np.flatnonzero(~converged & ~stalled)
        if len(active) == 0:
            break
        Ra, ca, Ea, ta = R[active], c[active], E[active], tau[active]
        omega = _newton_direction(H[active], ta, max_step)
        slope = np.sum(ta * omega, axis=-1)  # −dE/ds at s = 0, positive
        step = np.ones(len(active))
        accepted = np.zeros(len(active), dtype=bool)
        new = [None, None, None, None]
        for _ in range(40):
            todo = np.flatnonzero(~accepted)
            if len(todo) == 0:
                break
            Rt = so3.exp(step[todo, None] * omega[todo]) @ Ra[todo]
            Et, tt, Ht = model.evaluate(Rt, ca[todo], 2)
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
    return R, E, tau, H, iterations, converged


def _packed(model: TorqueModel, c: np.ndarray) -> Packed | None:
    """The model's :meth:`~TorqueModel.packed_terms` for the currents ``c (B, N)``, its currents ``C`` and constant
    filled to ``(B, T, N)`` and ``(B,)`` as the compiled descent takes them, or ``None``."""
    packed = model.packed_terms(c)
    if packed is None:
        return None
    return packed._replace(C=_filled(packed.C, (len(c),) + packed.C.shape[-2:]),
                           constant=_filled(packed.constant, (len(c),)))


def _filled(x, shape: tuple) -> np.ndarray:
    """``x`` broadcast to ``shape`` as a C-contiguous float array, without copying one that already is."""
    x = np.asarray(x, dtype=float)
    return np.ascontiguousarray(x if x.shape == shape else np.broadcast_to(x, shape))


def _result(R, E, tau, H, iterations, converged, lead) -> Equilibrium:
    eig = np.linalg.eigvalsh(H)
    return Equilibrium(R.reshape(lead + (3, 3)), E.reshape(lead), tau.reshape(lead + (3,)),
                       eig.reshape(lead + (3,)), iterations.reshape(lead), converged.reshape(lead))


def _newton_direction(H: np.ndarray, tau: np.ndarray, max_step: float) -> np.ndarray:
    """``ω = Σ_i (e_i·τ/|h_i|) e_i`` (``|h_i|`` floored at ``1e-8 max|h|``), shortened to ``|ω| ≤ max_step``."""
    h, e = np.linalg.eigh(H)
    floor = 1e-8 * np.max(np.abs(h), axis=-1, keepdims=True) + np.finfo(float).tiny
    coeff = np.einsum("kai,ka->ki", e, tau) / np.maximum(np.abs(h), floor)
    omega = np.einsum("kai,ki->ka", e, coeff)
    length = np.linalg.norm(omega, axis=-1, keepdims=True)
    return omega * np.minimum(1.0, max_step / np.maximum(length, np.finfo(float).tiny))


@single_blas_thread
def gradient_flow(model: TorqueModel, R0, currents, *, gtol: float = 1e-6, rtol: float = 1e-7,
                  max_rounds: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Follow ``Ṙ = τ̂(R) R`` (steepest descent of ``E``, ``τ`` the fixed-frame torque) from ``R0`` until rest.

    Integrated with SciPy's RK45 (relative tolerance ``rtol``) on the entries of ``R`` for the whole batch, in
    rounds of ``10/h_max`` (``h_max`` the largest Hessian eigenvalue magnitude at the starts), re-orthonormalised
    between rounds, until every ``|τ| ≤ gtol · torque_reference`` or ``max_rounds`` rounds. Returns
    ``(rotations, at_rest)`` with the broadcast leading shape.
    """
    from scipy.integrate import solve_ivp

    R, c, lead = _prepare(model, R0, currents)
    gtol = checks.fraction(gtol, "gtol", expected="a number in (0, 1)")
    rtol = checks.fraction(rtol, "rtol", expected="a number in (0, 1)")
    max_rounds = checks.count(max_rounds, "max_rounds")
    tol = gtol * np.asarray(model.torque_reference(c), dtype=float)
    K = len(R)

    def rate(_, y):
        Ry = y.reshape(K, 3, 3)
        tau = model.evaluate(_orthonormalise(Ry), c, 1)[1]  # the integrator's stages drift off the group
        return np.einsum("kab,kbc->kac", so3.skew(tau), Ry).reshape(-1)

    H = model.evaluate(R, c, 2)[2]
    h_max = float(np.max(np.abs(np.linalg.eigvalsh(H))))
    span = 10.0 / max(h_max, np.finfo(float).tiny)
    at_rest = np.linalg.norm(model.evaluate(R, c, 1)[1], axis=-1) <= tol
    for _ in range(max_rounds):
        if np.all(at_rest):
            break
        sol = solve_ivp(rate, (0.0, span), R.reshape(-1), method="RK45", rtol=rtol, atol=rtol * 1e-2)
        R = _orthonormalise(sol.y[:, -1].reshape(K, 3, 3))
        at_rest = np.linalg.norm(model.evaluate(R, c, 1)[1], axis=-1) <= tol
    return R.reshape(lead + (3, 3)), at_rest.reshape(lead)


def in_basin(model: TorqueModel, R0, currents, R_eq, *, tol: float = math.radians(0.5),
             gtol: float = 1e-6) -> np.ndarray:
    """Whether the gradient flow from ``R0`` comes to rest within Park distance ``tol`` of ``R_eq``.

    That is membership of ``R0`` in the basin of attraction of the minimum ``R_eq`` (for currents ``currents``)
    under the steepest-descent flow of :func:`gradient_flow`, the over-damped limit of the rotor's dynamics.
    Starts on a basin boundary (the stable manifold of a saddle) flow to the saddle and are reported outside.
    Batched: ``R0``, ``currents`` and ``R_eq`` broadcast over leading axes.
    """
    tol = checks.positive(tol, "tol")
    R_eq = so3.as_rotations(R_eq, "R_eq")
    end, at_rest = gradient_flow(model, R0, currents, gtol=gtol)
    return at_rest & (so3.distance(end, R_eq) <= tol)


def _orthonormalise(R: np.ndarray) -> np.ndarray:
    """The nearest rotation (polar factor) of each nearly orthogonal matrix."""
    U, _, Vt = np.linalg.svd(R)
    return U @ Vt


def cube_axes() -> np.ndarray:
    """26 unit axes: the directions to the faces (6), edges (12) and corners (8) of a cube, ``(26, 3)``."""
    grid = np.stack(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1], indexing="ij"), -1).reshape(-1, 3)
    grid = grid[np.any(grid != 0, axis=1)].astype(float)
    return grid / np.linalg.norm(grid, axis=1, keepdims=True)


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


def holding_torque(model: TorqueModel, R_eq, currents, *, axes=None, max_angle: float = math.radians(20.0),
                   samples: int = 81, stride: int = 1) -> Holding:
    """Peak restoring torque ``max_θ −T(exp(θ ŵ) R_eq, c) · ŵ`` for ``θ`` in ``[0, max_angle]`` (``samples``
    points) about each axis ``ŵ``; ``R_eq (K, 3, 3)``, ``currents (K, N)``.

    ``axes``: ``(A, 3)`` for every state, or ``(K, A, 3)`` per state; default :func:`cube_axes` plus both
    senses of the three stiffness eigen-axes of each state (so the softest direction is always tried).
    ``stride`` > 1: every ``stride``-th point of the grid (and the last), then the grid's points within ``stride``
    of each axis's two highest coarse local maxima — the grid's maximum wherever it lies within one coarse
    interval of one of them (~``5/stride`` of the torque evaluations); 1: every point.
    """
    stride = checks.count(stride, "stride", 1, max(1, samples - 1), expected="a whole number of grid points")
    R = so3.as_rotations(R_eq, "R_eq").reshape(-1, 3, 3)
    c = np.broadcast_to(as_currents(currents, model.coil_count, model.failed), (len(R), model.coil_count))
    if axes is None:
        eig = np.swapaxes(np.linalg.eigh(model.hessian(R, c))[1], 1, 2)  # rows: eigen-axes
        W = np.concatenate([np.broadcast_to(cube_axes(), (len(R), 26, 3)), eig, -eig], axis=1)
    else:
        W = np.asarray(axes, dtype=float)
        if W.ndim == 2:
            W = np.broadcast_to(W, (len(R),) + W.shape)
        if W.ndim != 3 or W.shape[0] != len(R) or W.shape[2] != 3 or np.any(np.linalg.norm(W, axis=2) == 0):
            raise bad_value("axes", f"non-zero axes of shape (A, 3) or ({len(R)}, A, 3)", f"shape {W.shape}")
    W = W / np.linalg.norm(W, axis=2, keepdims=True)
    theta = np.linspace(0.0, max_angle, samples)
    coarse = np.unique(np.r_[np.arange(0, samples, stride), samples - 1])
    near = np.r_[-np.arange(1, stride), np.arange(1, stride)]  # the fine points beside a coarse peak (none at 1)
    per_axis = np.empty(W.shape[:2])
    peak = np.empty(W.shape[:2])
    for k in range(len(R)):  # one state at a time: A × S orientations share its currents
        idx = np.broadcast_to(coarse, (W.shape[1], len(coarse)))
        restoring = _restoring(model, R[k], c[k], W[k], theta[idx])
        if stride > 1:
            fine = np.clip(coarse[_two_peaks(restoring)][:, :, None] + near, 0, samples - 1).reshape(len(idx), -1)
            idx = np.concatenate([idx, fine], axis=1)
            restoring = np.concatenate([restoring, _restoring(model, R[k], c[k], W[k], theta[fine])], axis=1)
        best = np.argmax(restoring, axis=1)
        per_axis[k] = restoring[np.arange(len(best)), best]
        peak[k] = theta[idx[np.arange(len(best)), best]]
    return Holding(W, per_axis, peak)


def _two_peaks(y) -> np.ndarray:
    """``(A, 2)`` column indices of each row's two highest local maxima of ``y (A, S)`` (the highest twice when
    there is one)."""
    pad = np.pad(y, ((0, 0), (1, 1)), constant_values=-np.inf)
    peaks = np.where((y >= pad[:, :-2]) & (y >= pad[:, 2:]), y, -np.inf)
    top = np.argsort(-peaks, axis=1, kind="stable")[:, :2]
    return np.where(np.isfinite(np.take_along_axis(peaks, top, axis=1)), top, top[:, :1])


def _restoring(model: TorqueModel, R, c, W, theta) -> np.ndarray:
    """``−T(exp(θ ŵ_a) R, c) · ŵ_a`` for the angles ``theta (A, S)`` about the unit axes ``W (A, 3)``."""
    turns = so3.exp(W[:, None, :] * theta[:, :, None])  # (A, S, 3, 3)
    T = model.torque((turns @ R).reshape(-1, 3, 3), c).reshape(theta.shape + (3,))
    return -np.einsum("asi,ai->as", T, W)


@dataclass(frozen=True)
class StepTorque:
    """Drive torque ``T · n̂`` (N·m) along steps: ``start`` at the first orientation, ``peak`` its maximum,
    ``least`` its minimum before the last 10 % of the path, ``angle`` the step's length (rad)."""

    start: np.ndarray
    peak: np.ndarray
    least: np.ndarray
    angle: np.ndarray


def step_torque(model: TorqueModel, R_from, R_to, currents, samples: int = 41) -> StepTorque:
    """Drive torque along geodesics ``R(t) = exp(t ω) R_from``, ``ω = log(R_to R_fromᵀ)``, with the target
    state's ``currents (K, N)`` energised; ``n̂ = ω/|ω|``."""
    Ra = so3.as_rotations(R_from, "R_from").reshape(-1, 3, 3)
    Rb = so3.as_rotations(R_to, "R_to").reshape(-1, 3, 3)
    if Ra.shape != Rb.shape:
        raise bad_value("R_to", f"one rotation per R_from, shape {Ra.shape}", f"shape {Rb.shape}")
    c = np.broadcast_to(as_currents(currents, model.coil_count, model.failed), (len(Ra), model.coil_count))
    omega = so3.log(Rb @ np.swapaxes(Ra, 1, 2))
    angle = np.linalg.norm(omega, axis=1)
    n = omega / np.maximum(angle, 1e-300)[:, None]
    t = np.linspace(0.0, 1.0, samples)
    path = so3.exp(omega[:, None, :] * t[None, :, None]) @ Ra[:, None]  # (K, S, 3, 3)
    T = model.torque(path.reshape(-1, 3, 3), np.repeat(c, samples, axis=0)).reshape(len(Ra), samples, 3)
    drive = np.einsum("ksi,ki->ks", T, n)
    body = t < 0.9
    return StepTorque(drive[:, 0], drive.max(axis=1), drive[:, body].min(axis=1), angle)
