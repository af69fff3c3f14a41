"""Current allocation: the coil currents that give a torque, at least copper power, within the drive's limits.

For a torque model linear in the currents, ``τ(R, c) = b(R) + K(R) c`` (``b = τ(R, 0)`` the bias or detent
torque, zero for the air-core magnets; ``K = ∂τ/∂c``, 3 × N, N·m per unit current). With per-unit currents ``c``
(amperes ``I_n c``; see :mod:`.limits`) the allocation is the quadratic program

    minimise ½‖c‖²   subject to   K c = τ* − b,   |c_k| ≤ u,   c_k = 0 for failed k,   ‖c‖ ≤ ρ,

``‖c‖²`` being the copper power ``Σ R I_n² c_k²`` over ``R I_n²``, ``u = I_max / I_n`` and ``ρ = √(P/R)/I_n``.
Because the objective *is* the power, the power limit never binds at the optimum of a reachable request: either the
least-power currents of the box-constrained problem satisfy ``‖c‖ ≤ ρ``, or no currents within the limits give
``τ*`` at all.

Exact fast path. The box-constrained problem has the 3-dimensional concave dual
``g(λ) = λ·t − Σ_k φ_k(K_kᵀλ)`` (``t = τ* − b``, ``φ_k(s) = ½s²`` for ``|s| ≤ u_k``, ``u_k|s| − ½u_k²``
beyond), whose maximiser gives the primal solution ``c_k = clip(K_kᵀλ, −u_k, u_k)``. ``∇g = t − K c(λ)`` is
piecewise linear, so a (semismooth) Newton iteration ``λ ← λ + (K_F K_Fᵀ)⁻¹ (t − K c(λ))`` over the free coils
``F = {k : |K_kᵀλ| < u_k}``, with backtracking on ``g``, ends at an exact KKT point in a few steps (the first step
from ``λ = (KKᵀ)⁻¹ t`` is the minimum-norm right inverse, which is already optimal when no coil saturates).
Accepted when ``‖K c − t‖`` is at rounding level and ``‖c‖ ≤ ρ``. :func:`least_power_box` is the NumPy form
(the reference); the loop runs it compiled, :func:`spherestep._fast.allocation.solve_box` (numba, equal to rounding, a
few µs).

General path (the request is out of reach, or Newton fails). The closest reachable torque: minimise
``‖K c − t‖²`` over the box and the power ball — by a compiled bisection on the ball's multiplier
(:func:`spherestep._fast.allocation.solve_reachable`, a box-constrained Tikhonov problem per step solved by the dual
Newton), or,
when that does not converge, as a second-order cone program solved by Clarabel (an interior point conic solver,
:func:`closest_reachable`) — then, among the currents that give that torque, the least-power ones by the fast path. The result
is flagged ``reachable=False``.

Relay mode (the paper's hardware, relays switching a coil to ``+V``, ``−V`` or off): ``c ∈ {−1, 0, +1}^N``, at
most ``⌊ρ²⌋`` coils on (and at most 4), the combination whose torque is nearest ``τ*`` — found exactly by
enumerating every signed set of at most two coils and every compatible pair of such sets.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..statics import TorqueModel
from ..electrics import DriveLimits

RELAY_MAX_COILS = 4  # exact enumeration up to four coils on (1.7 k half-sets, 2.8 M pairs for 29 coils)


@dataclass(frozen=True)
class Allocation:
    """Currents for a torque request: ``currents (N,)`` per unit of the nominal current; ``torque (3,)`` what they
    give with the bias (N·m, fixed frame); ``requested (3,)``; ``reachable`` (the request is met within the
    limits); ``power`` copper power (W); ``method`` ``"newton"``, ``"conic"`` or ``"relay"``."""

    currents: np.ndarray
    torque: np.ndarray
    requested: np.ndarray
    reachable: bool
    power: float
    method: str

    @property
    def error(self) -> float:
        """``‖τ − τ*‖`` (N·m)."""
        return float(np.linalg.norm(self.torque - self.requested))

    def to_dict(self) -> dict:
        return {"currents": self.currents.tolist(), "torque_N_m": self.torque.tolist(),
                "requested_N_m": self.requested.tolist(), "reachable": self.reachable,
                "error_N_m": self.error, "power_W": self.power, "method": self.method}


def _bounds(coil_count: int, failed, limits: DriveLimits) -> np.ndarray:
    """Per-unit current bounds ``u (N,)``: ``I_max/I_n``, zero on failed coils (cached, read-only)."""
    return _bounds_cached(int(coil_count), tuple(int(k) for k in failed), limits.per_unit_bound)


@lru_cache(maxsize=64)
def _bounds_cached(coil_count: int, failed: tuple[int, ...], bound: float) -> np.ndarray:
    u = np.full(coil_count, bound)
    if failed:
        u[list(failed)] = 0.0
    u.flags.writeable = False
    return u


def _check_torque(torque) -> np.ndarray:
    t = torque if isinstance(torque, np.ndarray) and torque.dtype == float else np.asarray(torque, dtype=float)
    if t.shape != (3,) or not np.all(np.isfinite(t)):
        raise bad_value("torque", "a finite torque vector (N·m) of shape (3,)", f"shape {t.shape}")
    return t


def _check_limits(limits) -> DriveLimits:
    if limits is None:
        return DriveLimits()
    if not isinstance(limits, DriveLimits):
        raise bad_value("limits", "a spherestep.control.DriveLimits", type(limits).__name__)
    return limits


def _solve3(A: np.ndarray, r: np.ndarray) -> np.ndarray | None:
    """``A⁻¹ r`` for a symmetric 3 × 3 ``A`` by the adjugate (Python floats: a tenth of ``np.linalg.solve``'s
    call overhead); ``None`` when ``A`` is singular to rounding."""
    (a, b, c), (_, d, e), (_, _, f) = A.tolist()
    x, y, z = r.tolist()
    m00, m01, m02 = d * f - e * e, c * e - b * f, b * e - c * d
    det = a * m00 + b * m01 + c * m02
    if not abs(det) > 1e-300 or abs(det) <= 1e-14 * abs(a * d * f):
        return None
    m11, m12, m22 = a * f - c * c, b * c - a * e, a * d - b * b
    return np.array([m00 * x + m01 * y + m02 * z, m01 * x + m11 * y + m12 * z, m02 * x + m12 * y + m22 * z]) / det


def least_power_box(K: np.ndarray, t: np.ndarray, u: np.ndarray, lam0: np.ndarray | None = None,
                    max_iter: int = 40, lower: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, bool]:
    """``argmin ½‖c‖²`` s.t. ``K c = t``, ``|c| ≤ u`` by semismooth Newton on the dual (see the module); with
    ``lower (N,)`` the box ``lower ≤ c ≤ u`` instead (``lower ≤ u``: per-coil asymmetric bounds, the servo's
    supply voltage against the back-EMF, which need not hold 0), ``φ_k(s) = s c_k − ½c_k²`` at ``c_k = clip(s, lower_k, u_k)``.

    Returns ``(c, λ, converged)``; ``converged`` means ``‖K c − t‖ ≤ 1e-11 (‖K‖ ‖u‖ + ‖t‖)``, which with
    ``c = clip(Kᵀλ, −u, u)`` is the exact KKT condition of the problem.
    """
    lo = -u if lower is None else lower
    big = np.maximum(np.abs(lo), np.abs(u))
    tol = 1e-11 * (math.sqrt(float(np.vdot(K, K)) * float(big @ big)) + math.sqrt(float(t @ t))) + 1e-300
    tol2 = tol * tol

    def dual(lm):
        s = K.T @ lm
        c = np.clip(s, lo, u)
        return float(lm @ t) - float((s * c - 0.5 * c * c).sum())

    lam = _solve3(K @ K.T, t) if lam0 is None else np.array(lam0, dtype=float)
    if lam is None:
        return np.zeros(K.shape[1]), np.zeros(3), False
    g = None
    for _ in range(max_iter):
        s = K.T @ lam
        c = np.clip(s, lo, u)
        r = t - K @ c
        if float(r @ r) <= tol2:
            return c, lam, True
        free = (lo < s) & (s < u)
        Kf = K[:, free]
        d = _solve3(Kf @ Kf.T, r)
        if d is None:
            return c, lam, False
        g = dual(lam) if g is None else g
        step = 1.0
        for _ in range(40):
            trial = lam + step * d
            gt = dual(trial)
            if gt >= g - 1e-15 * max(abs(g), 1.0):
                break
            step *= 0.5
        else:
            return c, lam, False
        lam, g = trial, gt
    c = np.clip(K.T @ lam, lo, u)
    r = t - K @ c
    return c, lam, bool(float(r @ r) <= tol2)


def closest_reachable(K: np.ndarray, t: np.ndarray, u: np.ndarray, rho: float, lower: np.ndarray | None = None
                      ) -> np.ndarray:
    """``argmin ‖K c − t‖²`` over ``|c| ≤ u`` (``lower ≤ c ≤ u`` with ``lower``), ``‖c‖ ≤ ρ`` (a second-order
    cone program, Clarabel); coils with ``u_k = 0`` and ``lower_k = 0`` are left out of the program and get
    ``c_k = 0``."""
    import clarabel
    from scipy import sparse

    lo = -u if lower is None else lower
    live = np.flatnonzero((u > 0) | (lo < 0))
    n = len(live)
    c = np.zeros(K.shape[1])
    if n == 0:
        return c
    Kl = K[:, live]
    P = sparse.csc_matrix(np.triu(Kl.T @ Kl))
    q = -(Kl.T @ t)
    eye = sparse.identity(n, format="csc")
    A = sparse.vstack([eye, -eye, sparse.csc_matrix((1, n)), -eye], format="csc")
    b = np.concatenate([u[live], -lo[live], [rho], np.zeros(n)])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-10
    solver = clarabel.DefaultSolver(P, q, A, b, [clarabel.NonnegativeConeT(2 * n), clarabel.SecondOrderConeT(n + 1)],
                                    settings)
    sol = solver.solve()
    x = np.asarray(sol.x, dtype=float)
    # Clarabel stops a hair outside the constraints; pull back into the feasible set exactly
    x = np.clip(x, lo[live], u[live])
    norm = np.linalg.norm(x)
    if norm > rho:
        x *= rho / norm
    c[live] = x
    return c


def allocate_matrix(K, torque, limits: DriveLimits | None = None, *, bias=None, failed=(),
                    lam0: np.ndarray | None = None, bounds=None, emf=None, previous=None, period: float = 0.0
                    ) -> tuple[Allocation, np.ndarray]:
    """:func:`allocate` given the torque matrix ``K (3, N)`` (N·m per unit current) and the bias torque ``bias``
    (N·m, default 0): returns the :class:`Allocation` and the dual ``λ`` (pass it back as ``lam0`` to warm-start
    the next call of a control loop). ``bounds``: per-coil ``(lower, upper)`` per-unit float arrays ``(N,)``
    (``lower ≤ upper``, trusted: the servo law's supply-voltage box of the period) in place of the limits'
    ``±u`` and ``failed``. ``emf``: the coils' back-EMF ``(N,)`` in per-unit volts, ``ê_k = e_k/(R I_n)``
    (trusted); the power ball then bounds the *supply* power ``Σ R i² + Σ e_k i_k ≤ P`` instead of the copper
    loss: ``‖c + ê/2‖² ≤ ρ² + ‖ê‖²/4``, solved as the same problem in ``z = c + ê/2`` (box and torque shifted);
    the least-norm ``z`` is the least-copper ``c`` (``Σ ê_k c_k = ω·K c/(R I_n²)`` is fixed by the torque).
    ``previous (N,)`` and ``period`` (s, > 0): also the power into the coils' inductance over one period from the
    ``previous`` currents, ``L I_n² (c² − c_prev²)/(2h)`` each: with ``a = 1 + T/(2h)`` (``T = L/R``),
    ``a‖c‖² + ê·c ≤ ρ² + (a − 1)‖c_prev‖²``, the ball ``‖c + ê/(2a)‖² ≤ (ρ² + (a − 1)‖c_prev‖²)/a + ‖ê‖²/(4a²)``.
    Currents over the copper's own bound ``‖c‖ ≤ ρ`` (braking: ``ê·c < 0``; the device refuses them) are
    allocated again within it, without ``emf``."""
    limits = _check_limits(limits)
    K = np.asarray(K, dtype=float)
    target = _check_torque(torque)
    b = np.zeros(3) if bias is None else np.asarray(bias, dtype=float)
    t = target - b
    if bounds is None:
        u, lower = _bounds(K.shape[1], failed, limits), None
    else:
        lower, u = bounds
    rho = limits.per_unit_power_radius
    shift = None
    if emf is not None:  # the supply's power: the ball centred at −ê/(2a), in z = c + ê/(2a)
        a, r2 = 1.0, rho * rho
        if previous is not None and period > 0:
            q = 0.5 * limits.time_constant / period
            a, r2 = 1.0 + q, (r2 + q * float(previous @ previous)) / (1.0 + q)
        shift = np.asarray(emf, dtype=float) / (2.0 * a)
        t = t + K @ shift
        lower = (-u if lower is None else lower) + shift
        u = u + shift
        rho = math.sqrt(r2 + float(shift @ shift))
    from .._fast import allocation as fast  # compiled: loaded on the first allocation, not with the room

    fast.warm(closest_reachable)
    c, lam, ok = fast.solve_box(K, t, u, None if lam0 is None else np.asarray(lam0, dtype=float), lower=lower)
    method, reachable = "newton", True
    if not ok or float(c @ c) > rho * rho * (1 + 1e-12):
        c_far = fast.solve_reachable(K, t, u, rho, lower)
        if c_far is None:  # the compiled bisection did not converge: the conic solver
            c_far = closest_reachable(K, t, u, rho, lower)
        t_r = K @ c_far
        reachable = bool(np.linalg.norm(t_r - t) <= 1e-7 * (np.linalg.norm(K) * rho + np.linalg.norm(t)))
        c2, lam2, ok2 = fast.solve_box(K, t_r, u, lower=lower)
        if ok2 and c2 @ c2 <= c_far @ c_far * (1 + 1e-12):
            c, lam = c2, lam2
        else:
            c = c_far
        method = "conic"
    if shift is not None:
        c = c - shift
        if float(c @ c) > limits.per_unit_power_radius ** 2 * (1 + 1e-12):  # the copper's own bound (the device's)
            return allocate_matrix(K, torque, limits, bias=bias, failed=failed, lam0=lam0, bounds=bounds)
    achieved = b + K @ c
    power = limits.nominal_power * float(c @ c)
    return Allocation(c, achieved, target, reachable, power, method), lam


def allocate(model: TorqueModel, R, torque, limits: DriveLimits | None = None, *, mode: str = "continuous",
             max_coils: int | None = None) -> Allocation:
    """Coil currents (per unit of the nominal current) giving ``torque`` (N·m, fixed frame) at orientation ``R``.

    ``mode="continuous"``: the least-power currents within ``limits`` (:class:`~spherestep.control.DriveLimits`,
    default the paper's 24 V / 100 W supply), exact (see the module); out of reach, the currents of the closest
    reachable torque, ``reachable=False``. ``mode="relay"``: currents in ``{−1, 0, +1}``, the combination of at
    most ``max_coils`` coils (default ``min(4, ⌊ρ²⌋)``) whose torque is nearest the request. The model's bias
    torque ``τ(R, 0)`` is included; failed coils carry nothing.

    >>> import numpy as np
    >>> from spherestep.motor import prototype
    >>> from spherestep.magnetics import torque_map
    >>> a = allocate(torque_map(prototype()), np.eye(3), [0.0, 0.0, 0.5])
    >>> bool(a.reachable), round(float(a.torque[2]), 9)
    (True, 0.5)
    """
    if not isinstance(model, TorqueModel):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    R = so3.as_rotations(R)
    if R.shape != (3, 3):
        raise bad_value("R", "one rotation matrix of shape (3, 3)", f"shape {R.shape}")
    limits = _check_limits(limits)
    K = np.asarray(model.torque_matrix(R), dtype=float)
    bias = np.asarray(model.torque(R, np.zeros(model.coil_count)), dtype=float)
    if mode == "continuous":
        return allocate_matrix(K, torque, limits, bias=bias, failed=model.failed)[0]
    if mode == "relay":
        return allocate_relay(K, torque, limits, bias=bias, failed=model.failed, max_coils=max_coils)
    raise bad_value("mode", "'continuous' or 'relay'", mode)


def _half_sets(live: np.ndarray, size: int) -> tuple[np.ndarray, np.ndarray]:
    """Every signed set of at most ``size`` (≤ 2) of the ``live`` coils: ``coils (H, 2)`` (−1 = none) and
    ``signs (H, 2)``."""
    coils, signs = [[-1, -1]], [[0.0, 0.0]]
    for k in live:
        for s in (1.0, -1.0):
            coils.append([k, -1])
            signs.append([s, 0.0])
    if size >= 2:
        i, j = np.triu_indices(len(live), 1)
        for si in (1.0, -1.0):
            for sj in (1.0, -1.0):
                coils.extend(np.stack([live[i], live[j]], 1).tolist())
                signs.extend([[si, sj]] * len(i))
    return np.array(coils, dtype=int), np.array(signs)


def allocate_relay(K, torque, limits: DriveLimits | None = None, *, bias=None, failed=(),
                   max_coils: int | None = None) -> Allocation:
    """Relay allocation given ``K (3, N)``: the currents in ``{−1, 0, +1}`` (at most ``max_coils`` non-zero)
    whose torque ``b + K c`` is nearest ``torque``, fewest coils among equals (exhaustive; see the module)."""
    limits = _check_limits(limits)
    K = np.asarray(K, dtype=float)
    target = _check_torque(torque)
    b = np.zeros(3) if bias is None else np.asarray(bias, dtype=float)
    if limits.per_unit_bound < 1:
        raise bad_value("limits.max_current", "at least the nominal current for relay drive",
                        limits.max_current)
    cap = min(RELAY_MAX_COILS, int(math.floor(limits.per_unit_power_radius ** 2 + 1e-9)))
    if max_coils is not None:
        cap = checks.count(max_coils, "max_coils", 0, cap,
                           f"an integer from 0 to {cap} (the supply's power and the exact search)")
    N = K.shape[1]
    if N > 62:
        raise bad_value("K", "at most 62 coils for the relay search", f"{N} coils")
    live = np.setdiff1d(np.arange(N), np.asarray(failed, dtype=int))
    coils, signs = _half_sets(live, min(2, cap))
    count = (coils >= 0).sum(axis=1)
    T = (K[:, np.maximum(coils, 0)] * (signs * (coils >= 0))[None]).sum(axis=2).T  # (H, 3)
    mask = np.where(coils >= 0, np.left_shift(np.int64(1), np.maximum(coils, 0)), 0).sum(axis=1)  # bit sets
    t = target - b
    TT = np.einsum("hi,hi->h", T, T)
    best = (np.inf, 0, 0)
    chunk = 256
    for s in range(0, len(coils), chunk):
        rest = t[None, :] - T[s:s + chunk]  # (a, 3)
        err = np.einsum("ai,ai->a", rest, rest)[:, None] + TT[None, :] - 2.0 * rest @ T.T  # ‖rest − T_b‖²
        n_on = count[s:s + chunk, None] + count[None, :]
        bad = ((mask[s:s + chunk, None] & mask[None, :]) != 0) | (n_on > cap)
        err = np.where(bad, np.inf, err + 1e-12 * (t @ t + 1.0) * n_on)
        a, bb = np.unravel_index(int(np.argmin(err)), err.shape)
        if err[a, bb] < best[0]:
            best = (float(err[a, bb]), s + a, bb)
    c = np.zeros(N)
    for h in best[1:3]:
        for k, sgn in zip(coils[h], signs[h]):
            if k >= 0:
                c[k] = sgn
    achieved = b + K @ c
    reachable = bool(np.linalg.norm(achieved - target) <= 1e-9 * (np.linalg.norm(target) + 1.0))
    return Allocation(c, achieved, target, reachable, float(limits.copper_power(c)), "relay")


def can_hold(K, bias, limits, failed=()) -> tuple[bool, float]:
    """``(reachable, unmet N·m)``: whether currents within ``limits`` cancel the ``bias`` torque through ``K``
    (zero net torque at rest, :func:`allocate_matrix`): whether a motor can hold that orientation at all."""
    a, _ = allocate_matrix(np.asarray(K, dtype=float), np.zeros(3), limits, bias=np.asarray(bias, dtype=float),
                           failed=failed)
    return bool(a.reachable), float(a.error)
