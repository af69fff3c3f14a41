"""Torque capability over SO(3): the torque the drive can give in every direction, orientation by orientation.

At orientation ``R`` the reachable torques are ``S(R) = {b(R) + K(R) c : c ∈ F}`` with the feasible currents
``F = {|c_k| ≤ u, c_k = 0 on failed coils, ‖c‖ ≤ ρ}`` (per unit; :mod:`.limits`). ``S`` is convex, so the torque
available in *every* direction — the radius of the largest ball about zero inside ``S`` — is the smallest value
of its support function over unit directions ``n``:

    r(R) = min_{‖n‖=1} h_S(n),   h_S(n) = n·b + h_F(Kᵀn),   h_F(g) = max_{c∈F} g·c .

``h_F`` is exact in closed form: the maximiser is ``c_k = sign(g_k) min(u_k, |g_k| s)`` with the scale ``s ≥ 0``
that puts ``c`` on the power sphere ``‖c‖ = ρ`` (or every live coil at its bound when that is inside the ball);
sorting the breakpoints ``u_k/|g_k|`` gives ``s`` segment by segment. The minimum over ``n`` is taken over a
Fibonacci set of directions, then refined by projected gradient descent on the sphere (``∇h_S = b + K c*``).
A negative ``r`` means zero torque is out of reach (a bias the coils cannot cancel).

The conditioning of ``K(R)`` (N·m per unit current) is reported by its singular values ``σ₁ ≥ σ₂ ≥ σ₃``:
``σ₃ ρ`` is the available torque if only the power limit mattered, and ``σ₁/σ₃`` the condition number.
Orientations are drawn uniformly on SO(3) (Haar measure, :func:`spherestep.so3.random`), so fractions of the
samples estimate fractions of SO(3) (binomial standard error ``√(p(1−p)/n)``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..statics import TorqueModel
from ..electrics import DriveLimits

PERCENTILES = (0, 5, 25, 50, 75, 95, 100)
THRESHOLDS = (0.5, 1.0, 1.5, 2.0)  # N·m
CHUNK = 64  # orientations per vectorised block of the direction search


def fibonacci_directions(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors (the Fibonacci lattice), ``(n, 3)``."""
    i = np.arange(n) + 0.5
    z = 1.0 - 2.0 * i / n
    phi = math.pi * (3.0 - math.sqrt(5.0)) * i
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def feasible_support(g: np.ndarray, u: np.ndarray, rho: float) -> tuple[np.ndarray, np.ndarray]:
    """``h_F(g) = max g·c`` over ``|c_k| ≤ u_k``, ``‖c‖ ≤ ρ`` and its maximiser, for ``g (..., N)``; returns
    ``(h (...), c (..., N))`` (see the module for the closed form)."""
    a = np.abs(g)
    ub = np.broadcast_to(u, a.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        bp = np.where(a > 0, ub / a, np.inf)  # the scale at which coil k saturates
    order = np.argsort(bp, axis=-1)
    bp_s = np.take_along_axis(bp, order, -1)
    a_s = np.take_along_axis(a, order, -1)
    u_s = np.take_along_axis(ub, order, -1)
    zero = np.zeros(a.shape[:-1] + (1,))
    S_u = np.concatenate([zero, np.cumsum(u_s * u_s, -1)], -1)  # Σ u² of the first j saturated coils
    G = np.sum(a * a, -1, keepdims=True) - np.concatenate([zero, np.cumsum(a_s * a_s, -1)], -1)
    G = np.maximum(G, 0.0)
    finite_bp = np.where(np.isfinite(bp_s), bp_s, 0.0)
    # power at each breakpoint: the first j+1 coils saturated, the rest at a·bp_j
    power_at = S_u[..., 1:] + finite_bp ** 2 * G[..., 1:]
    j = np.sum((power_at <= rho * rho) & np.isfinite(bp_s), axis=-1, keepdims=True)  # segment holding ρ
    Sj = np.take_along_axis(S_u, j, -1)
    Gj = np.take_along_axis(G, j, -1)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.where(Gj > 0, np.sqrt(np.maximum(rho * rho - Sj, 0.0) / np.where(Gj > 0, Gj, 1.0)), np.inf)
    upper = np.take_along_axis(np.concatenate([bp_s, np.full(zero.shape, np.inf)], -1), j, -1)
    s = np.minimum(s, upper)
    c = np.sign(g) * np.minimum(ub, a * np.where(np.isfinite(s), s, 0.0) + np.where(np.isfinite(s), 0.0, ub))
    return np.sum(c * g, -1), c


def available_torque(K, limits: DriveLimits | None = None, *, bias=None, failed=(), directions: int = 400,
                     refine: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """``r = min_n h_S(n)`` (N·m) and the minimising direction for torque matrices ``K (..., 3, N)`` and bias
    torques ``bias (..., 3)`` (default zero): the torque available in every direction (see the module)."""
    limits = DriveLimits() if limits is None else limits
    K = np.asarray(K, dtype=float)
    lead = K.shape[:-2]
    Kf = K.reshape((-1,) + K.shape[-2:])
    b = np.zeros((len(Kf), 3)) if bias is None else np.broadcast_to(np.asarray(bias, float), lead + (3,)).reshape(-1, 3)
    u = np.full(K.shape[-1], limits.per_unit_bound)
    if len(failed):
        u[list(failed)] = 0.0
    rho = limits.per_unit_power_radius
    dirs = fibonacci_directions(directions)
    radius = np.empty(len(Kf))
    weakest = np.empty((len(Kf), 3))

    def h(Kc, bc, n):  # support of S in directions n (k, 3): value and gradient b + K c*
        val, c = feasible_support(np.einsum("kan,ka->kn", Kc, n), u, rho)
        return val + np.sum(bc * n, -1), bc + np.einsum("kan,kn->ka", Kc, c)

    for s in range(0, len(Kf), CHUNK):
        Kc, bc = Kf[s:s + CHUNK], b[s:s + CHUNK]
        vals = feasible_support(np.einsum("kan,da->kdn", Kc, dirs), u, rho)[0] + bc @ dirs.T
        n = dirs[np.argmin(vals, axis=1)]
        val, grad = h(Kc, bc, n)
        step = np.full(len(Kc), 0.1)
        for _ in range(refine):
            tangent = grad - np.sum(grad * n, -1, keepdims=True) * n
            size = np.linalg.norm(tangent, axis=-1, keepdims=True)
            trial = n - step[:, None] * tangent / np.maximum(size, 1e-300)
            trial /= np.linalg.norm(trial, axis=-1, keepdims=True)
            tv, tg = h(Kc, bc, trial)
            better = tv < val
            n = np.where(better[:, None], trial, n)
            val = np.where(better, tv, val)
            grad = np.where(better[:, None], tg, grad)
            step = np.where(better, step * 1.5, step * 0.3)
        radius[s:s + CHUNK] = val
        weakest[s:s + CHUNK] = n
    return radius.reshape(lead), weakest.reshape(lead + (3,))


@dataclass(frozen=True)
class Capability:
    """The torque capability of a design over ``S`` orientations drawn uniformly on SO(3).

    ``rotations (S, 3, 3)``; ``radius (S,)`` the torque available in every direction (N·m); ``weakest (S, 3)``
    the direction where it is least; ``singular_values (S, 3)`` of ``K(R)`` (N·m per unit current, descending);
    ``bias (S,)`` ``‖τ(R, 0)‖`` (N·m); ``limits``; ``seed``.
    """

    rotations: np.ndarray
    radius: np.ndarray
    weakest: np.ndarray
    singular_values: np.ndarray
    bias: np.ndarray
    limits: DriveLimits
    seed: int

    @property
    def condition(self) -> np.ndarray:
        """``σ₁/σ₃`` of ``K(R)`` per orientation."""
        return self.singular_values[:, 0] / np.maximum(self.singular_values[:, 2], 1e-300)

    def percentiles(self, values=None, q=PERCENTILES) -> dict:
        """``{q: value}`` percentiles of ``values`` (default the available torque, N·m)."""
        values = self.radius if values is None else values
        return {int(p): float(v) for p, v in zip(q, np.percentile(values, q))}

    def fraction_at_least(self, torque: float) -> float:
        """Fraction of SO(3) (of the samples) where at least ``torque`` N·m is available in every direction."""
        return float(np.mean(self.radius >= torque))

    def to_dict(self, degrees: bool = True, thresholds=THRESHOLDS) -> dict:
        """Summary: percentiles of the available torque, ``σ₃``, ``σ₁`` and the condition number, the fractions
        at the ``thresholds`` (N·m), and the limits (no angles are reported, so ``degrees`` changes nothing)."""
        return {"samples": int(len(self.radius)), "seed": self.seed,
                "available_torque_N_m": self.percentiles(),
                "sigma_min_N_m_per_unit_current": self.percentiles(self.singular_values[:, 2]),
                "sigma_max_N_m_per_unit_current": self.percentiles(self.singular_values[:, 0]),
                "condition_number": self.percentiles(self.condition),
                "fraction_at_least": {f"{t:g}_N_m": self.fraction_at_least(t) for t in thresholds},
                "bias_torque_max_N_m": float(self.bias.max()),
                "limits": self.limits.to_dict()}


def torque_capability(design, model: TorqueModel | None = None, limits: DriveLimits | None = None, *,
                      samples: int = 1000, seed: int = 0, directions: int = 400) -> Capability:
    """The torque available in every direction, and the conditioning of ``K(R)``, at ``samples`` orientations
    drawn uniformly on SO(3) with ``seed`` (see the module). ``model`` and ``limits`` default to the design's own
    (:func:`spherestep.magnetics.design_model`: the core its coil states, the limits of its winding); a ``model``
    given without ``limits`` gets the paper's 24 V / 100 W supply at 1 A nominal.

    >>> from spherestep.motor import prototype
    >>> cap = torque_capability(prototype(), samples=20, seed=1)
    >>> cap.radius.shape, bool(cap.radius.min() > 0)
    ((20,), True)
    """
    if model is None:
        from ..magnetics import design_model

        own = design_model(design)
        model, limits = own.model, own.limits if limits is None else limits
    if not isinstance(model, TorqueModel):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    samples = checks.count(samples, "samples", 1, expected="a positive number of orientations")
    directions = checks.count(directions, "directions", 20)
    limits = DriveLimits() if limits is None else limits
    R = so3.random(int(samples), np.random.default_rng(seed))
    K = np.asarray(model.torque_matrix(R), dtype=float)
    bias = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))), dtype=float)
    radius, weakest = available_torque(K, limits, bias=bias, failed=model.failed, directions=int(directions))
    sv = np.linalg.svd(K, compute_uv=False)
    return Capability(R, radius, weakest, sv, np.linalg.norm(bias, axis=-1), limits, int(seed))


def figure_capability(cap: Capability, threshold: float = 1.0):
    """Map and distribution of the available torque: each sampled orientation drawn at the body point that faces
    the stator's centre (``Rᵀ(0, 0, −1)``, azimuth and elevation in degrees), coloured by ``r(R)`` (N·m); and
    the fraction of SO(3) with at least a given torque in every direction."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4.2), layout="constrained")
    ax, ax2 = fig.subplots(1, 2, width_ratios=[1.6, 1])
    down = np.einsum("kba,b->ka", cap.rotations, np.array([0.0, 0.0, -1.0]))
    az = np.degrees(np.arctan2(down[:, 1], down[:, 0]))
    el = np.degrees(np.arcsin(np.clip(down[:, 2], -1, 1)))
    sc = ax.scatter(az, el, c=cap.radius, s=12, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="torque available in every direction (N·m)")
    ax.set_xlabel("azimuth of the rotor point over the stator (°)")
    ax.set_ylabel("elevation (°)")
    ax.set_xlim(-180, 180)
    ax.set_ylim(-90, 90)
    ax.set_title(f"capability over SO(3), {len(cap.radius)} uniform orientations")
    levels = np.sort(cap.radius)
    ax2.plot(levels, 1.0 - np.arange(len(levels)) / len(levels), color="C0")
    ax2.axvline(threshold, color="C3", ls="--", lw=1)
    ax2.set_xlabel("torque in every direction (N·m)")
    ax2.set_ylabel("fraction of SO(3) with at least that")
    ax2.set_title(f"{100 * cap.fraction_at_least(threshold):.1f} % of SO(3) ≥ {threshold:g} N·m")
    ax2.grid(alpha=0.3)
    return fig
