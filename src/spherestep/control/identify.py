"""The fit of a calibration: tables, per-coil gains and placements, the coupling's gain — judged on held-out holds.

The model (:mod:`spherestep.magnetics.percoil` on the pair tables of :mod:`.calibration`)::

    τ(R, c) = Σ_jk [τ_d(α_jk) + p_j k_k c_k τ_1(α_jk)] (v_k' × w_j) / sin α_jk  +  g T_c(R),   v_k' = exp(ε_k) v_k

Parameters ``x = (s_d, [s_1], δ_d, δ_1, κ, ε, [g])``: the tables ``θ = (1 + s) θ⁰ + e ⊙ δ`` as in
:mod:`.calibration`; each live coil's gain ``k = 1 + κ`` (a column scale of ``K(R)``; the winding's common scale
``s_1`` is then left out: the gains' mean is that scale); each live coil's placement ``ε`` (two components, in
the tangent plane at its nominal centre: a turn about the centre itself changes nothing, the tables being
axisymmetric); ``g`` the cores' coupling gain. Gaussian prior (standard deviations :data:`PRIOR`: gains 0.3,
placements 1°, the rest as before). The placements and the gains make the model non-linear in ``x`` (the
product ``k_k θ_1``, the turned coils' angles): Gauss–Newton, :data:`ITERATIONS` steps from the nominal
model, each step's Jacobian rebuilt at the current ``x`` — the tables' columns analytic (:func:`regression` at
the moved coils and the scaled currents), the gains' columns the coils' own torques (exact: linear), the
placements' by central differences of ±:data:`TURN_STEP` of each coil's torque (:func:`coil_torques`). The
coupling's torque is taken at the nominal places and currents (a first-order term of a first-order term).

Held out. Every :data:`HELD_OUT`-th hold (its hold and its move equations) is not fitted. The calibration is
judged on them (:func:`verdict`): the held-out holds' residual RMS within :data:`HOLD_FACTOR` of the noise the
sensors imply, ``σ_hold² = σ_split² + (S σ_R)²``: ``σ_split`` the difference of each hold's equation on the two
halves of its window over 2 (same orientation and currents: model errors cancel, the loop's white noise does
not), and the measured orientation's error at rest ``σ_R`` (:data:`ORIENTATION_NOISE`, 0.025°: the Hall array's
estimate is biased by an orientation-dependent amount the window cannot see; on the emulated motor the exact
plant leaves 26 mN·m at the holds, 0.020° at their RMS stiffness of 72 N·m/rad; a good fit of the default plant,
0.052° at 95 N·m/rad, which 2.5 σ_hold admits) times the fitted model's RMS stiffness ``S`` at the held-out holds; and the held-out moves' residual at most :data:`MOVE_TOLERANCE` of the
torque they needed (a move integrates the commanded currents, whose lag no noise figure covers: the exact plant
leaves 0.81 of it on the emulated motor).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy import sparse
from scipy.interpolate import CubicSpline

from .. import checks, so3
from ..errors import bad_value
from ..magnetics.calibrated import Calibration, Moved, scaled_coupling
from .calibration import Holds, regression

PRIOR = {"scale": 0.3, "node": 0.3, "curvature": 0.1, "coupling": 1.0, "gain": 0.3, "turn": math.radians(1.0),
         "bend": 3.0}
ENVELOPE_DEG = 5.0  # the envelope of a table: the largest |τ| within this many degrees of a node
UNSEEN = 0.5  # a parameter is not seen when its posterior variance exceeds this fraction of its prior's
SIGMA_FLOOR = 1e-6  # of the peak detent: the least noise assumed
ITERATIONS = 3  # Gauss–Newton steps
HELD_OUT = 5  # every fifth hold is held out
HOLD_FACTOR = 2.5  # held-out holds' RMS residual within this many σ_hold: consistent
ORIENTATION_NOISE = math.radians(0.025)  # rad: the measured orientation's error at rest (module docstring)
MOVE_TOLERANCE = 1.0  # held-out moves' RMS residual within this fraction of the moves' RMS torque: consistent
DEAD = 0.2  # |k| below this: a dead coil
CHUNK = 256


# -- per-coil torques ----------------------------------------------------------------------------------------------
def coil_torques(nodes, detent, winding, poles, polarity, coils, R, currents, weights, equation, E: int,
                 turns=None):
    """``(D, W, dD, dW)``: per equation the weighted sums ``Σ_s w_s τ_k`` of each coil ``k``'s detent torque
    ``τ_k = v_k × Σ_j f(α_jk) w_j`` (``f = τ_d/sin α``; ``Σ_j τ_d(α_jk) (v_k × w_j)/sin α_jk``), ``(E, 3, N)``, and
    of its winding torque at its own current ``c_k v_k × Σ_j p_j f_1(α_jk) w_j``; with ``turns (N, B, 3)`` (unit
    rotation axes per coil) their derivatives ``(E, 3, N, B)`` for the coil turned about each axis (``v → v + δ
    ω × v``): ``(ω × v) × G + v × Σ_j f'(α_j) α_j' w_j`` with ``α' = −(ω × v)·w / sin α``. Coils at ``coils (N, 3)``,
    samples ``R (S, 3, 3)``, ``currents (S, N)``, ``weights (S,)``, ``equation (S,)``."""
    sd, s1 = CubicSpline(nodes, detent), CubicSpline(nodes, winding)
    dsd, ds1 = sd.derivative(), s1.derivative()
    N = len(coils)
    B = 0 if turns is None else turns.shape[1]
    A = None if turns is None else np.cross(turns, coils[:, None, :])  # (N, B, 3): ω × v
    D, W = np.zeros((E, N, 3)), np.zeros((E, N, 3))
    dD, dW = np.zeros((E, N, B, 3)), np.zeros((E, N, B, 3))
    for s0 in range(0, len(R), CHUNK):
        Rc, cc, wc, ec = (a[s0:s0 + CHUNK] for a in (R, currents, weights, equation))
        P = np.einsum("kab,mb->kma", Rc, poles)
        cos = np.clip(np.einsum("kma,na->kmn", P, coils), -1.0, 1.0)
        alpha = np.arccos(cos)
        sin = np.sin(alpha)
        ok = sin > 1e-4
        inv = np.where(ok, 1.0 / np.where(ok, sin, 1.0), 0.0)
        M = sparse.csr_matrix((wc, (ec, np.arange(len(ec)))), shape=(E, len(ec)))  # Σ_s w_s over each equation
        for spline, slope, out, dout, pk in ((sd, dsd, D, dD, None), (s1, ds1, W, dW, polarity)):
            tau = spline(alpha)
            f = tau * inv if pk is None else tau * inv * pk[None, :, None]
            G = np.einsum("kmn,kma->kna", f, P)
            scale = 1.0 if pk is None else cc[:, :, None]
            out += (M @ (scale * np.cross(coils[None], G)).reshape(len(ec), -1)).reshape(E, N, 3)
            if A is None:
                continue
            fp = (slope(alpha) * inv - tau * cos * inv ** 2)
            fp = fp if pk is None else fp * pk[None, :, None]
            for b in range(B):
                da = -np.einsum("na,kma->kmn", A[:, b], P) * inv
                H = np.einsum("kmn,kma->kna", fp * da, P)
                d = np.cross(A[None, :, b], G) + np.cross(coils[None], H)
                dout[:, :, b] += (M @ (scale * d).reshape(len(ec), -1)).reshape(E, N, 3)
    sw = (lambda X: np.swapaxes(X, 1, 2))
    return sw(D), sw(W), np.moveaxis(dD, 3, 1), np.moveaxis(dW, 3, 1)


def tangents(coils: np.ndarray) -> np.ndarray:
    """``(N, 2, 3)``: two unit vectors perpendicular to each coil's centre and to each other."""
    a = np.where(np.abs(coils[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    t1 = np.cross(coils, a)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    return np.stack([t1, np.cross(coils, t1)], axis=1)


# -- the fit -------------------------------------------------------------------------------------------------------
def _envelope(nodes: np.ndarray, table: np.ndarray) -> np.ndarray:
    near = np.abs(nodes[:, None] - nodes[None, :]) <= math.radians(ENVELOPE_DEG) + 1e-12
    env = np.max(np.where(near, np.abs(table)[None, :], 0.0), axis=1)
    return np.maximum(env, 1e-9 * np.max(np.abs(table)))


def _second_differences(n: int) -> np.ndarray:
    D = np.zeros((max(n - 2, 0), n))
    for i in range(n - 2):
        D[i, i:i + 3] = (1.0, -2.0, 1.0)
    return D


def _ranges(nodes_deg: np.ndarray, mask: np.ndarray) -> list[str]:
    out, start = [], None
    for i, m in enumerate(mask):
        if m and start is None:
            start = i
        if start is not None and (not m or i == len(mask) - 1):
            end = i if m else i - 1
            a, b = nodes_deg[start], nodes_deg[end]
            out.append(f"{a:g}°" if start == end else f"{a:g}°–{b:g}°")
            start = None
    return out


@dataclass(frozen=True)
class _Layout:
    """Where each group of parameters sits in ``x``."""

    scales: slice
    det: slice
    win: slice
    gains: slice
    turns: slice
    coupling: slice
    bend: slice
    size: int


def _layout(scales: bool, gains: bool, turns: bool, fit_gain: bool, nf: int, live: int, bend: bool) -> _Layout:
    sizes = [(2 if not gains else 1) if scales else 0, nf, nf, live if gains else 0, 2 * live if turns else 0,
             1 if fit_gain else 0, 1 if bend else 0]
    edges = np.concatenate([[0], np.cumsum(sizes)])
    sl = [slice(int(edges[i]), int(edges[i + 1])) for i in range(len(sizes))]
    return _Layout(*sl, int(edges[-1]))


def bent_currents(c: np.ndarray, u: float) -> tuple[np.ndarray, np.ndarray]:
    """``(σ, ∂σ/∂u)``: the saturating winding's current ``σ(c) = tanh(c √u) / √u`` (the knee ``1/√u``,
    :class:`~spherestep.magnetics.percoil.PerCoil`) and its derivative in the bend ``u = 1/knee² ≥ 0``; the series
    ``c − u c³/3 + 2u² c⁵/15`` (and its derivative) where ``|c| √u < 0.05`` (the two agree to 1e-9 there)."""
    q = math.sqrt(max(u, 0.0))
    z = c * q
    small = np.abs(z) < 0.05
    series = c - u * c ** 3 / 3.0 + 2.0 * u * u * c ** 5 / 15.0
    dseries = -c ** 3 / 3.0 + 4.0 * u * c ** 5 / 15.0
    if q == 0.0:
        return series, dseries
    th = np.tanh(z)
    sig = np.where(small, series, th / q)
    dsig = np.where(small, dseries, (c * (1.0 - th * th) / q - th / (q * q)) / (2.0 * q))
    return sig, dsig


def calibrate(design, model, holds: Holds, *, prior: dict | None = None, scales: bool = True,
              coupling: bool | None = None, gains: bool = True, turns: bool = True, saturation: bool = False,
              held_out: bool = True, iterations: int = ITERATIONS) -> Calibration:
    """Fit the iron ``model`` (an :class:`~spherestep.magnetics.IronTorqueMap`, the controller's) to ``holds``
    (:func:`spherestep.drive.collect_holds`) and judge it on the held-out holds (module docstring).
    ``prior`` overrides :data:`PRIOR`'s standard deviations; ``scales=False`` fits the shape corrections alone;
    ``coupling`` whether to fit the cores' coupling gain (default only for a pairwise model); ``gains``/``turns``
    each coil's gain/placement; ``saturation`` the windings' knee too (one bend ``u = 1/knee²`` shared by every
    winding, ``σ(c) = tanh(c √u)/√u`` in place of ``c``, kept ≥ 0: :func:`diagnose` asks for it to name a saturating
    motor); ``held_out=False`` fits every hold (no verdict)."""
    from ..magnetics import IronTorqueMap, iron_model

    if not isinstance(model, IronTorqueMap):
        raise bad_value("model", "an iron torque model (spherestep.magnetics.IronTorqueMap: the pair tables "
                        "it fits)", type(model).__name__)
    if not isinstance(holds, Holds):
        raise bad_value("holds", "a spherestep.control.Holds (collect_holds)", type(holds).__name__)
    if holds.sample_c.shape[1] != model.coil_count:
        raise bad_value("holds", f"currents for {model.coil_count} coils", f"{holds.sample_c.shape[1]} coils")
    p = dict(PRIOR)
    for key, value in (prior or {}).items():
        if key not in PRIOR:
            raise bad_value("prior", f"keys among {sorted(PRIOR)}", key)
        p[key] = checks.positive(value, f"prior[{key!r}]")
    iterations = checks.count(iterations, "iterations")
    lin = model.linear
    nodes, poles, pol, coils0 = lin.nodes, lin.poles, lin.polarity, lin.coils
    n, N = len(nodes), model.coil_count
    d0, l0 = np.asarray(model.detent.tau, dtype=float), np.asarray(lin.tau, dtype=float)
    E = len(holds.kinds)
    R, c, w, eq = holds.sample_R, holds.sample_c.copy(), holds.sample_w, holds.sample_eq
    c[:, list(model.failed)] = 0.0
    live = np.setdiff1d(np.arange(N), model.failed)
    hold_of = np.cumsum([k == "hold" for k in holds.kinds]) - 1
    test = (hold_of % HELD_OUT == HELD_OUT - 1) if held_out and len(holds) >= HELD_OUT else np.zeros(E, bool)
    rows = np.repeat(~test, 3)
    # the cores' coupling: its torque (the model's at gain 1, else the design's own at gain 0), nominal places
    cross, gain0 = model.coupling, 1.0
    if cross is None and coupling is not False:
        cross, gain0 = iron_model(design, model.coil, lin.meshing, coupling=True).coupling, 0.0
    fit_gain = cross is not None and (coupling is True or (coupling is None and gain0 == 0.0))
    offset = np.zeros((E, 3))
    if cross is not None:
        pair = replace(model, coupling=None)
        whole = replace(pair, coupling=cross)
        tot = np.concatenate([whole.torque(R[i:i + 64], c[i:i + 64]) - pair.torque(R[i:i + 64], c[i:i + 64])
                              for i in range(0, len(R), 64)])
        offset = np.stack([np.bincount(eq, w * tot[:, a], minlength=E) for a in range(3)], 1)
    free = np.ones(n, dtype=bool)
    free[[0, n - 1]] = False  # τ(0) = τ(π) = 0 by symmetry
    fi = np.nonzero(free)[0]
    nf = len(fi)
    ed, el = _envelope(nodes, d0), _envelope(nodes, l0)
    lay = _layout(scales, gains, turns, fit_gain, nf, len(live), saturation)
    # the prior's precision P = LᵀL
    P = np.zeros((lay.size, lay.size))
    P[lay.scales, lay.scales] = np.eye(lay.scales.stop - lay.scales.start) / p["scale"] ** 2
    D2 = _second_differences(nf)
    for blk in (lay.det, lay.win):
        P[blk, blk] = np.eye(nf) / p["node"] ** 2 + D2.T @ D2 / p["curvature"] ** 2
    P[lay.gains, lay.gains] = np.eye(lay.gains.stop - lay.gains.start) / p["gain"] ** 2
    P[lay.turns, lay.turns] = np.eye(lay.turns.stop - lay.turns.start) / p["turn"] ** 2
    P[lay.coupling, lay.coupling] = np.eye(lay.coupling.stop - lay.coupling.start) / p["coupling"] ** 2
    P[lay.bend, lay.bend] = np.eye(lay.bend.stop - lay.bend.start) / p["bend"] ** 2
    L = np.linalg.cholesky(P + 1e-12 * np.eye(lay.size)).T
    T = tangents(coils0)

    def unpack(x):
        s = x[lay.scales]
        det = (1.0 + s[0]) * d0 if scales else d0.copy()
        win = (1.0 + s[1]) * l0 if scales and not gains else l0.copy()
        det[fi] += ed[fi] * x[lay.det]
        win[fi] += el[fi] * x[lay.win]
        k = np.ones(N)
        if gains:
            k[live] += x[lay.gains]
        t = np.zeros((N, 3))
        if turns:
            e = x[lay.turns].reshape(-1, 2)
            t[live] = np.einsum("kb,kba->ka", e, T[live])
        g = gain0 + (x[lay.coupling][0] if fit_gain else 0.0)
        return det, win, k, t, g

    def linearise(x):
        det, win, k, t, g = unpack(x)
        coils = np.einsum("kab,kb->ka", so3.exp(t), coils0)
        cs, dcs = bent_currents(c, float(x[lay.bend][0])) if saturation else (c, None)
        ck = cs * k
        m = replace(lin, coils=coils)
        Ad, Al = regression(replace(model, detent=replace(model.detent, coils=coils), linear=m, coupling=None),
                            R, ck, w, eq, E)
        cols = []
        if scales:
            cols += [Ad @ d0] + ([] if gains else [Al @ l0])
        cols += [Ad[:, :, m_] * ed[m_] for m_ in fi] + [Al[:, :, m_] * el[m_] for m_ in fi]
        F = Ad @ det + Al @ win + g * offset
        if gains or turns:
            Dk, Wk, dD, dW = coil_torques(nodes, det, win, poles, pol, coils, R, cs, w, eq, E,
                                          T if turns else None)
        if gains:
            cols += [Wk[:, :, j] for j in live]
        if turns:
            diff = dD + dW * k[None, None, :, None]
            cols += [diff[:, :, j, b] for j in live for b in range(2)]
        if fit_gain:
            cols += [offset]
        if saturation:
            cols += [regression(replace(model, detent=replace(model.detent, coils=coils), linear=m, coupling=None),
                                R, dcs * k, w, eq, E)[1] @ win]
        return np.stack(cols, axis=-1).reshape(3 * E, -1), F.reshape(-1)

    y = holds.rhs.reshape(-1)
    floor = SIGMA_FLOOR * float(np.max(np.abs(d0)))
    x = np.zeros(lay.size)
    X, F = linearise(x)
    before = y - F
    sigma = max(float(np.sqrt(np.mean(before[rows] ** 2))), floor)
    for it in range(iterations):
        r = y - F
        for _ in range(2 if it == iterations - 1 else 1):
            A = np.vstack([X[rows] / sigma, L])
            b = np.concatenate([r[rows] / sigma, -L @ x])
            step = np.linalg.lstsq(A, b, rcond=None)[0]
            H = X[rows].T @ X[rows] / sigma ** 2
            cov = np.linalg.inv(H + P)
            dof = float(np.trace(cov @ H))
            res = r[rows] - X[rows] @ step
            sigma = max(float(np.sqrt(np.sum(res ** 2) / max(rows.sum() - dof, 1.0))), floor)
        x = x + step
        x[lay.bend] = np.maximum(x[lay.bend], 0.0)  # a winding that saturates, never one that grows
        if it < iterations - 1:
            X, F = linearise(x)
    after = r - X @ step  # the residual at the final x (to first order in the last step)
    H = X[rows].T @ X[rows] / sigma ** 2
    cov = np.linalg.inv(H + P)
    return _result(design, model, holds, locals())


def _result(design, model, holds, v) -> Calibration:
    """The :class:`Calibration` from the fit's variables ``v`` (its locals)."""
    from ..magnetics import IronTorqueMap
    from ..magnetics.percoil import PerCoil

    x, cov, P, lay, fi, nodes, n, N = (v[k] for k in ("x", "cov", "P", "lay", "fi", "nodes", "n", "N"))
    d0, l0, ed, el, live, T = (v[k] for k in ("d0", "l0", "ed", "el", "live", "T"))
    det, win, k, t, g = v["unpack"](x)
    # the tables' covariance through θ = (1 + s) θ⁰ + e ⊙ δ
    J = np.zeros((2 * n, lay.size))
    if v["scales"]:
        J[:n, lay.scales.start] = d0
        if not v["gains"]:
            J[n:, lay.scales.start + 1] = l0
    J[fi, np.arange(lay.det.start, lay.det.stop)] = ed[fi]
    J[n + fi, np.arange(lay.win.start, lay.win.stop)] = el[fi]
    cov_theta = J @ cov @ J.T
    std = np.sqrt(np.maximum(np.diag(cov_theta), 0.0))
    theta = np.concatenate([det, win])
    gsel = np.zeros((2, 2 * n))
    gsel[0, :n] = d0 / (d0 @ d0)
    gsel[1, n:] = l0 / (l0 @ l0)
    eff = gsel @ theta
    eff_std = np.sqrt(np.maximum(np.diag(gsel @ cov_theta @ gsel.T), 0.0))
    ratio = np.diag(cov) / np.diag(np.linalg.inv(P + 1e-12 * np.eye(lay.size)))
    nodes_deg = np.degrees(nodes)
    unseen = []
    for name, blk in (("detent", lay.det), ("winding", lay.win)):
        mask = np.zeros(n, dtype=bool)
        mask[fi] = ratio[blk] > UNSEEN
        runs = _ranges(nodes_deg, mask)
        if runs:
            unseen.append(f"{name} table shape at {', '.join(runs)} (posterior variance > {UNSEEN:g} of the prior's: "
                          "these pairs' torque is too small or too rarely met in the holds)")
    if v["scales"]:
        u = np.zeros(lay.size)  # both tables ×(1 + s) (the gains with the winding): what static holds cannot see
        u[lay.scales] = 1.0
        u[lay.gains] = 1.0
        u[lay.coupling] = v["gain0"]
        post, pri = float(u @ cov @ u), float(u @ np.linalg.inv(P + 1e-12 * np.eye(lay.size)) @ u)
        if post / pri > UNSEEN:
            unseen.append(f"the common scale of both tables (± {math.sqrt(post / 2):.2g}; holds at rest see only "
                          "the ratio of detent to winding, a move's inertia fixes the scale)")
    gain_std = np.zeros(N)
    if v["gains"]:
        gain_std[live] = np.sqrt(np.diag(cov)[lay.gains])
        blind = live[ratio[lay.gains] > UNSEEN]
        if len(blind):
            unseen.append(f"the gain of coil{'s' if len(blind) > 1 else ''} {', '.join(map(str, blind))}")
    turn_std = np.zeros(N)
    if v["turns"]:
        var = np.diag(cov)[lay.turns].reshape(-1, 2)
        turn_std[live] = np.sqrt(var.max(axis=1))
        blind = live[ratio[lay.turns].reshape(-1, 2).max(axis=1) > UNSEEN]
        if len(blind):
            unseen.append(f"the placement of {len(blind)} coil{'s' if len(blind) > 1 else ''} "
                          f"({', '.join(map(str, blind))}: prior kept, ±{math.degrees(v['p']['turn']):g}°)")
    moved = []
    for name, fit, nom, sd in (("detent", det, d0, std[:n]), ("winding", win, l0, std[n:])):
        for m in fi:
            if abs(fit[m] - nom[m]) > 2.0 * sd[m] and abs(fit[m] - nom[m]) > 1e-3 * np.max(np.abs(nom)):
                moved.append(Moved(name, float(nodes[m]), float(nom[m]), float(fit[m]), float(sd[m])))
    moved.sort(key=lambda m: -abs(m.fitted - m.nominal) / max(m.std, 1e-300))
    cross, gain0, fit_gain = v["cross"], v["gain0"], v["fit_gain"]
    coupling_std = math.sqrt(float(cov[lay.coupling, lay.coupling][0, 0])) if fit_gain else 0.0
    if fit_gain and ratio[lay.coupling][0] > UNSEEN:
        unseen.append(f"the coupling's gain (± {coupling_std:.2g})")
    if fit_gain and gain0 == 0.0 and abs(g) <= 2.0 * coupling_std:
        cross = None  # a pairwise model whose data show no coupling stays pairwise
    tables = IronTorqueMap.from_tables(design, model.coil, nodes, det, win, level=model.linear.meshing,
                                       coupling=None if cross is None else scaled_coupling(cross, g))
    bend = float(x[lay.bend][0]) if v["saturation"] else 0.0
    knee = 1.0 / math.sqrt(bend) if bend > 0.0 else None
    fitted = PerCoil(tables, k, t, knee) if (v["gains"] or v["turns"] or knee) else tables
    rows, test, before, after = v["rows"], v["test"], v["before"], v["after"]
    judged = verdict(holds, test, after.reshape(-1, 3), fitted)
    return Calibration(fitted, nodes.copy(), det, win, std[:n], std[n:], d0.copy(), l0.copy(),
                       float(eff[0]), float(eff[1]), (float(eff_std[0]), float(eff_std[1])),
                       float(np.sqrt(np.mean(before[rows] ** 2))), float(np.sqrt(np.mean(after[rows] ** 2))),
                       v["sigma"], len(holds), int(np.sum(~test)), tuple(moved), tuple(unseen),
                       cross is not None, holds.backend, coupling_gain=g, coupling_std=coupling_std,
                       design_fingerprint=design.fingerprint, gains=k, gains_std=gain_std, turns=t,
                       turns_std=turn_std, judged=judged, knee=knee)


def verdict(holds: Holds, test: np.ndarray, residual: np.ndarray, model) -> dict:
    """The held-out judgement (module docstring) from the residuals ``(E, 3)`` N·m at the final fit, the held-out
    equations ``test (E,)`` and the fitted ``model`` (its stiffness at the held-out holds): ``{"consistent",
    "held_out_holds", "hold_rms", "hold_noise", "split_noise", "stiffness", "move_rms", "move_torque"}`` (N·m,
    N·m/rad); ``consistent`` None when nothing was held out."""
    kinds = np.array(holds.kinds)
    noise = np.asarray(holds.noise, dtype=float)
    split = float(np.sqrt(np.mean(noise ** 2)) / 2.0) if noise.size else 0.0
    ho = test & (kinds == "hold")
    mv = test & (kinds == "move")
    which = (np.cumsum(kinds == "hold") - 1)[ho]  # the held-out holds' indices among the holds
    stiff = 0.0
    if len(which):
        H = np.asarray(model.hessian(holds.orientations[which], holds.currents[which]), dtype=float)
        stiff = float(np.sqrt(np.mean(np.sum(H ** 2, axis=(-2, -1)) / 3.0)))
    sigma = math.hypot(split, stiff * ORIENTATION_NOISE)
    out = {"held_out_holds": int(ho.sum()), "hold_noise": sigma, "split_noise": split, "stiffness": stiff,
           "hold_rms": float(np.sqrt(np.mean(residual[ho] ** 2))) if ho.any() else math.nan,
           "move_rms": float(np.sqrt(np.mean(residual[mv] ** 2))) if mv.any() else math.nan,
           "move_torque": float(np.sqrt(np.mean(holds.rhs[mv] ** 2))) if mv.any() else math.nan}
    if not ho.any():
        out["consistent"] = None
        return out
    good = out["hold_rms"] <= HOLD_FACTOR * sigma
    if mv.any():
        good = good and out["move_rms"] <= MOVE_TOLERANCE * out["move_torque"]
    out["consistent"] = bool(good)
    return out


def diagnose(design, model, holds: Holds, cal: Calibration, *, gains: bool, turns: bool, **options) -> tuple[str, ...]:
    """The terms an inconsistent ``cal`` lacks, by comparing fits (forward selection): each term the fit left out
    — a per-coil term (``gains``/``turns`` False) or the windings' saturation (``calibrate(saturation=True)``: one
    bend shared by every winding, which the per-coil gains cannot take: their torque grows linearly in the
    current, a saturated winding's falls below it as ``c³``) — is added in turn, keeping the one that leaves the
    smallest held-out residual, until a refit is consistent; those terms are named (a dead coil as such,
    saturation with its knee). No set consistent: the first term, if it halved the held-out holds' residual.
    Nothing helps: the held-out figures say which side disagrees — moves alone: the rotor's inertia, damping or
    friction; holds: the sensors' offsets. ``options`` go to :func:`calibrate`."""
    left = [t for t, on in (("gains", gains), ("turns", turns)) if not on] + ["saturation"]

    def refit(terms):
        return calibrate(design, model, holds, gains=gains or "gains" in terms, turns=turns or "turns" in terms,
                         saturation="saturation" in terms, **options)

    def name(term, fit) -> str:
        if term == "turns":
            return "coil placement"
        if term == "saturation":
            knee = f"knee {fit.knee:.2f} per unit current" if fit.knee else "no knee found"
            return f"saturation of the windings ({knee}: their torque falls below linear as |c|³)"
        dead = fit.dead_coils()
        return "per-coil gain spread" + (f" (dead coil{'s' if len(dead) > 1 else ''} {', '.join(map(str, dead))})"
                                         if dead else "")

    chosen: list[str] = []
    first = None
    while left:
        fits = {t: refit(chosen + [t]) for t in left}
        best = min(left, key=lambda t: fits[t].judged["hold_rms"])
        chosen.append(best)
        left.remove(best)
        first = first or fits[best]
        if fits[best].consistent:
            return tuple(name(t, fits[best]) for t in chosen)
    j = cal.judged
    if first.judged["hold_rms"] < 0.5 * j["hold_rms"]:
        return (name(chosen[0], first),)
    if j["hold_rms"] <= HOLD_FACTOR * j["hold_noise"]:
        return ("the rotor's inertia, damping or friction (the held-out moves disagree, the holds agree)",)
    return ("a sensor offset (the held-out holds disagree with every per-coil and saturation term fitted)",)
