"""Calibrating the iron motor's torque model from its own holds and moves (least squares on the pair tables).

The model. With linear iron the torque is (:class:`~spherestep.magnetics.IronTorqueMap`)

    τ(R, c) = Σ_jk [τ_d(α_jk) + p_j c_k τ_1(α_jk)] (v_k × w_j) / sin α_jk,

and each table is a cubic spline (not-a-knot) through its node values, so a spline's value is a fixed linear
combination of its nodes, ``τ(α) = Σ_m θ_m B_m(α)``: the torque is *linear* in the ``2 × 68`` node values,
``τ(R, c) = A_d(R) θ_d + A_1(R, c) θ_1``. :func:`regression` builds ``A`` analytically from the spline basis
(each pair's angle binned into its spline segment, the segment's polynomial moments summed, then one product
with the basis' coefficients); the model's own torque is ``A θ`` to rounding.

The measurements. ``R(t)``, ``c(t)`` sampled by the servo loop give, with the rotor's inertia ``I`` and damping
``b_v`` (``I ω̇ = τ − b_v ω``), two kinds of linear equations in ``θ`` (each a weighted sum of ``A(R_n, c_n)``):

* a *hold* (the last ``window`` s at the target): ``(1/T) ∫ τ dt = I (ω(T) − ω(0))/T + b_v ω̄`` — zero at
  rest: ``b(R) + K(R) c = 0``, which sees the *shape* of the tables but not their common scale (both
  tables ×s satisfy it too);
* a *move* (from rest at the previous hold to the end of this hold's window, length ``T``), the first moment
  of Newton's law, ``(2/T²) ∫ (T − t) τ dt = (2/T²) (I ∫ ω dt + b_v ∫ (T − t) ω dt)``: ``∫ ω dt`` is the
  rotation the rotor made, so this is absolute and fixes the scale (through the inertia, which a scale can
  weigh). Timing errors of the currents cancel to first order because the move starts and ends near rest.

The fit (:func:`spherestep.control.identify.calibrate`, which adds each coil's gain and placement and judges the fit
on held-out holds; its tables' part as follows). Parameters ``x = (s_d, s_1, δ_d, δ_1, g)``: the fitted tables are
``θ = (1 + s) θ⁰ + e ⊙ δ`` with ``θ⁰`` the model's tables, ``s`` a global scale per table (the winding's
``s_1`` the gain of the copper and the core, the detent's ``s_d`` that of the gap) and ``δ`` a shape
correction per node in units of the table's local envelope ``e`` (the largest ``|θ⁰|`` within 5°, so a 10 %
change means the same everywhere; the ends 0° and 180° stay 0 by symmetry); ``g`` the gain of the cores'
coupling (a magnet acting on another through a core: not a sum over pole–core pairs, so no table can take its
place), whose torque ``g T_c(R)`` (from the coupled model's tables; the design's own coupling at ``g = 0`` for a
pairwise model, the model's at ``g = 1`` for a coupled one) is a column of its own. Gaussian prior: ``s`` of
standard deviation 0.3, ``δ`` 0.3 and its second differences 0.1 (smooth shape changes), ``g`` 1.0, so the data
must speak to move a node. By default ``g`` is fitted only for a pairwise model: a coupled model's coupling at
its modelled strength lets the holds at rest see the tables' common scale (the coupling does not scale with them),
where with ``g`` free only the moves weigh it — and a move's currents are the commanded ones, which on a motor whose
current loop lags (the emulated iron motor: L/R = 7.8 ms, 200 Hz) bias the scale (×0.35–0.5 with ``g`` free on the
emulated motor at ×1.2 detent, ×0.85 winding). MAP by least squares on ``[X/σ; L] x = [y/σ; 0]`` (``LᵀL`` the prior's precision), with
``σ`` the residual RMS (re-estimated twice, from the effective degrees of freedom, floored at 1e-6 of the
peak detent). Posterior covariance ``(XᵀX/σ² + LᵀL)⁻¹``: a parameter whose posterior variance is more than
half its prior's is *not seen* by the data and is reported (:attr:`Calibration.unseen`), as is the common
scale when no move constrains it.

What it cannot fit: a torque that is neither a sum over pole–core pairs nor the modelled coupling's shape. The
coupling is ~0.35 N·m RMS at the prototype's holds, where the pair terms cancel it: without its gain
(``coupling=False`` on a pairwise model) least squares shrinks both tables towards zero.
:attr:`Calibration.consistent` (the held-out verdict: :func:`spherestep.control.identify.verdict`) says when a fit
does not explain its data; an inconsistent one is refused wherever it would be used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from .. import checks, so3
from ..magnetics.calibrated import Calibration, calibration_beside  # noqa: F401



# -- the regression ------------------------------------------------------------------------------------------------
def _basis(nodes: np.ndarray) -> np.ndarray:
    """The cubic spline basis' coefficients ``C (4, n−1, n)``: ``B_m(α) = Σ_p C[p, i, m] (α − x_i)^(3−p)`` on
    segment ``i`` (the not-a-knot spline of the unit vector ``e_m``, as the tables' own splines)."""
    return CubicSpline(nodes, np.eye(len(nodes)), axis=0).c


def regression(model, R, currents, weights=None, equation=None, equations: int | None = None,
               chunk: int = 128) -> tuple[np.ndarray, np.ndarray]:
    """``(A_d, A_1)``, each ``(E, 3, n)``: the weighted sums ``Σ_{s ∈ e} w_s A(R_s, c_s)`` of the torque's
    derivatives with respect to the detent's and the winding's node values (N·m per N·m of node) for samples
    ``R (S, 3, 3)``, ``currents (S, N)`` per unit, ``weights (S,)`` (default 1), grouped by ``equation (S,)``
    (default one per sample). ``model`` an :class:`~spherestep.magnetics.IronTorqueMap`; the torque of the pair
    terms is ``A_d θ_d + A_1 θ_1`` (module docstring)."""
    R = so3.as_rotations(R, "R").reshape(-1, 3, 3)
    S = len(R)
    c = np.asarray(currents, dtype=float).reshape(S, -1)
    w = np.ones(S) if weights is None else np.asarray(weights, dtype=float).reshape(S)
    eq = np.arange(S) if equation is None else np.asarray(equation, dtype=int).reshape(S)
    E = int(eq.max()) + 1 if equations is None else int(equations)
    lin = model.linear
    nodes = lin.nodes
    n = len(nodes)
    C = _basis(nodes)
    poles, coils, pol = lin.poles, lin.coils, lin.polarity
    c = c.copy()
    c[:, list(lin.failed)] = 0.0
    Md = np.zeros(E * (n - 1) * 4 * 3)
    Ml = np.zeros_like(Md)
    for s0 in range(0, S, chunk):
        Rc, wc, ec, cc = R[s0:s0 + chunk], w[s0:s0 + chunk], eq[s0:s0 + chunk], c[s0:s0 + chunk]
        W = np.einsum("kab,mb->kma", Rc, poles)  # (k, M, 3) poles in the fixed frame
        cos = np.clip(np.einsum("kma,na->kmn", W, coils), -1.0, 1.0)
        alpha = np.arccos(cos)
        sin = np.sin(alpha)
        cross = np.cross(coils[None, None, :, :], W[:, :, None, :])  # (k, M, N, 3): v_k × w_j
        u = cross / np.where(sin > 1e-12, sin, np.inf)[..., None]
        seg = np.clip(np.searchsorted(nodes, alpha, side="right") - 1, 0, n - 2)
        d = alpha - nodes[seg]
        wd = np.broadcast_to(wc[:, None, None], alpha.shape)
        wl = wc[:, None, None] * pol[None, :, None] * cc[:, None, :]
        base = (ec[:, None, None] * (n - 1) + seg) * 4
        for p in range(4):
            dp = d ** (3 - p)
            idx = ((base + p) * 3).ravel()
            for a in range(3):
                ua = u[..., a] * dp
                Md += np.bincount(idx + a, (wd * ua).ravel(), minlength=Md.size)
                Ml += np.bincount(idx + a, (wl * ua).ravel(), minlength=Ml.size)
    Md = Md.reshape(E, n - 1, 4, 3)
    Ml = Ml.reshape(E, n - 1, 4, 3)
    Ad = np.einsum("pim,eipa->eam", C, Md)
    Al = np.einsum("pim,eipa->eam", C, Ml)
    return Ad, Al


# -- the measurements ----------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Holds:
    """What :func:`spherestep.drive.collect_holds` recorded. Per hold ``i``: ``targets (H, 3, 3)``, the measured rest
    ``orientations (H, 3, 3)`` (the last sample) and the mean ``currents (H, N)`` per unit over the hold window.
    The equations (module docstring), ``E`` of them: ``kinds`` (``"hold"``/``"move"``), ``rhs (E, 3)`` N·m and
    the samples ``sample_R (S, 3, 3)``, ``sample_c (S, N)`` per unit, ``sample_w (S,)`` and ``sample_eq (S,)``
    (which equation) whose weighted torque sum each equates to its ``rhs``. ``inertia`` kg·m², ``damping``
    N·m·s/rad, ``backend`` says where they came from, ``drift (H,)`` rad/s the rotor's speed at the end."""

    targets: np.ndarray
    orientations: np.ndarray
    currents: np.ndarray
    kinds: tuple[str, ...]
    rhs: np.ndarray
    sample_R: np.ndarray
    sample_c: np.ndarray
    sample_w: np.ndarray
    sample_eq: np.ndarray
    inertia: float
    damping: float
    backend: str
    drift: np.ndarray = field(default_factory=lambda: np.zeros(0))
    noise: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    discarded: int = 0

    def __len__(self) -> int:
        return len(self.targets)

    def without_moves(self) -> Holds:
        """The same holds with only the hold equations (the static data: blind to the common scale)."""
        keep = np.array([k == "hold" for k in self.kinds])
        renum = np.cumsum(keep) - 1
        s = keep[self.sample_eq]
        return Holds(self.targets, self.orientations, self.currents, tuple(k for k in self.kinds if k == "hold"),
                     self.rhs[keep], self.sample_R[s], self.sample_c[s], self.sample_w[s], renum[self.sample_eq[s]],
                     self.inertia, self.damping, self.backend, self.drift, self.noise, self.discarded)

    def to_dict(self, degrees: bool = True) -> dict:
        k = 180.0 / math.pi if degrees else 1.0
        err = so3.distance(self.orientations, self.targets) if len(self) else np.zeros(0)
        return {"holds": len(self), "discarded": self.discarded, "equations": len(self.kinds),
                "samples": int(len(self.sample_R)),
                "backend": self.backend, "inertia_kg_m2": self.inertia,
                ("max_hold_offset_deg" if degrees else "max_hold_offset_rad"): float(np.max(err, initial=0.0) * k),
                ("max_drift_deg_s" if degrees else "max_drift_rad_s"): float(np.max(self.drift, initial=0.0) * k)}


def hold_orientations(count: int, *, step: float = math.radians(25.0), seed=0) -> np.ndarray:
    """``count`` orientations ``(count, 3, 3)`` on a random walk from the identity: each ``step`` rad about a
    uniformly random axis from the last (short moves, every pole–coil angle visited many times over)."""
    count = checks.count(count, "count")
    step = checks.positive(step, "step", "a positive angle in radians")
    rng = np.random.default_rng(seed)
    axes = rng.standard_normal((count, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    out = np.empty((count, 3, 3))
    R = np.eye(3)
    for i in range(count):
        R = so3.exp(step * axes[i]) @ R
        out[i] = R
    return out


def series_equations(t, R, c, window: float, inertia: float, damping: float, every: int):
    """The hold and move equations (module docstring) of one session's series ``t (T,)``, ``R (T, 3, 3)``,
    ``c (T, N)`` (``c[n]`` the current over ``[t_n, t_{n+1}]``; the rotor at rest at ``t_0``), the move's
    quadrature on groups of ``every`` periods: ``[(kind, rhs, R_s, c_s, w_s)]`` and the rotor's speed at the end
    (rad/s)."""
    h = np.diff(t)
    step = so3.log(R[1:] @ np.swapaxes(R[:-1], 1, 2))  # (T−1, 3): ω h per interval, fixed frame
    omega = step / h[:, None]
    tm = t[:-1] + 0.5 * h
    out = []
    # hold: the last `window` s, (1/T_w) ∫ τ dt = I Δω / T_w + b_v ∫ ω dt / T_w
    T1 = t[-1]
    sel = np.nonzero(tm >= T1 - window)[0]
    Tw = float(np.sum(h[sel]))
    w0 = omega[sel[:2]].mean(axis=0)
    w1 = omega[sel[-2:]].mean(axis=0)
    rhs = inertia * (w1 - w0) / Tw + damping * step[sel].sum(axis=0) / Tw
    Rs, cs, ws, _ = _groups(R, c, t, h, sel, max(1, every // 2))
    out.append(("hold", rhs, Rs, cs, ws / Tw))
    # move: from rest at t_0 to the end, (2/T²) ∫ (T − t) τ dt = (2/T²) (I ∫ ω dt + b_v ∫ (T − t) ω dt)
    T = T1 - t[0]
    lever = T - (tm - t[0])
    rhs = (inertia * step.sum(axis=0) + damping * (lever[:, None] * step).sum(axis=0)) * 2.0 / T ** 2
    Rs, cs, ws, tc = _groups(R, c, t, h, np.arange(len(h)), every)
    out.append(("move", rhs, Rs, cs, ws * (T - (tc - t[0])) * 2.0 / T ** 2))
    return out, float(np.linalg.norm(w1))


def _groups(R, c, t, h, idx: np.ndarray, every: int):
    """The intervals ``idx`` (consecutive) in groups of ``every``: the midpoint rule on each group — the
    orientation halfway along the geodesic between its ends, the mean current, its length and centre time."""
    groups = np.arange(len(idx)) // every
    first = idx[np.r_[0, np.nonzero(np.diff(groups))[0] + 1]]
    last = idx[np.r_[np.nonzero(np.diff(groups))[0], len(idx) - 1]] + 1  # end sample of each group
    length = t[last] - t[first]
    mean_c = np.stack([np.bincount(groups, h[idx] * c[idx, k]) for k in range(c.shape[1])], axis=1)
    mean_c /= length[:, None]
    half = 0.5 * so3.log(R[last] @ np.swapaxes(R[first], 1, 2))
    return so3.exp(half) @ R[first], mean_c, length, 0.5 * (t[first] + t[last])


def torque_error(model, plant, *, count: int = 200, seed=1) -> float:
    """The relative RMS torque error ``‖τ_model − τ_plant‖ / ‖τ_plant‖`` (N·m over N·m) at ``count`` random
    orientations (Haar) with random currents uniform in ``[−1, 1]`` per unit on every live coil."""
    count = checks.count(count, "count")
    rng = np.random.default_rng(seed)
    R = so3.random(count, rng)
    c = rng.uniform(-1.0, 1.0, (count, plant.coil_count))
    c[:, list(plant.failed)] = 0.0
    tp = np.asarray(plant.torque(R, c))
    tm = np.asarray(model.torque(R, c))
    return float(np.sqrt(np.sum((tm - tp) ** 2) / np.sum(tp ** 2)))
