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

The fit. Parameters ``x = (s_d, s_1, δ_d, δ_1, g)``: the fitted tables are
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
:attr:`Calibration.consistent` (the residual after the fit within 5 % of the uncorrected model's; the simulated
plants reach 0.1 %) says when a fit does not explain its data, and the summary warns not to use it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from .. import checks, so3
from ..errors import bad_value
from ..statics import is_torque_model
from .limits import DriveLimits

CALIBRATION_FILE = "calibration.yaml"  # beside the design file
PRIOR = {"scale": 0.3, "node": 0.3, "curvature": 0.1, "coupling": 1.0}  # prior standard deviations (relative)
ENVELOPE_DEG = 5.0  # the envelope of a table: the largest |τ| within this many degrees of a node
UNSEEN = 0.5  # a parameter is not seen when its posterior variance exceeds this fraction of its prior's
SIGMA_FLOOR = 1e-6  # of the peak detent: the least noise assumed
def torque_text(value: float, digits: int = 3) -> str:
    """A torque for people: N·m from 1 N·m up, mN·m below (``1.09 N·m``, ``44.1 mN·m``; never ``1.09e+03 mN·m``)."""
    return f"{value:.{digits}g} N·m" if abs(value) >= 1.0 else f"{value * 1e3:.{digits}g} mN·m"


CONSISTENT = 0.05  # a fit whose residual RMS is above this fraction of the uncorrected model's does not explain the data


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
    """What :func:`collect_holds` recorded. Per hold ``i``: ``targets (H, 3, 3)``, the measured rest
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

    def __len__(self) -> int:
        return len(self.targets)

    def without_moves(self) -> Holds:
        """The same holds with only the hold equations (the static data: blind to the common scale)."""
        keep = np.array([k == "hold" for k in self.kinds])
        renum = np.cumsum(keep) - 1
        s = keep[self.sample_eq]
        return Holds(self.targets, self.orientations, self.currents, tuple(k for k in self.kinds if k == "hold"),
                     self.rhs[keep], self.sample_R[s], self.sample_c[s], self.sample_w[s], renum[self.sample_eq[s]],
                     self.inertia, self.damping, self.backend, self.drift)

    def to_dict(self, degrees: bool = True) -> dict:
        k = 180.0 / math.pi if degrees else 1.0
        err = so3.distance(self.orientations, self.targets) if len(self) else np.zeros(0)
        return {"holds": len(self), "equations": len(self.kinds), "samples": int(len(self.sample_R)),
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


@dataclass(frozen=True)
class Emulated:
    """The emulated motor as a backend of :func:`collect_holds`: ``plant`` the torque model the emulated rotor
    obeys (it should differ from the controller's), on the lockstep link (``lockstep``, the default) or a
    pseudo-terminal."""

    plant: object
    lockstep: bool = True


@dataclass(frozen=True)
class Port:
    """A coil controller on a serial ``device`` as a backend of :func:`collect_holds` (the drive room's session)."""

    device: str


def _series_equations(t, R, c, window: float, inertia: float, damping: float, every: int):
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


def collect_holds(design, backend, orientations, *, model=None, limits: DriveLimits | None = None,
                  move_time: float = 0.4, settle: float = 0.5, window: float = 0.25, moves: bool = True,
                  rate: float = 1000.0, quadrature: float = 0.004, progress=None) -> Holds:
    """Drive the servo (controller on ``model``, default the design's own) to each of ``orientations``
    (``(H, 3, 3)``, or a count for :func:`hold_orientations`) in turn and record the holds and moves (module
    docstring). ``backend``: a torque model (the simulated plant, :func:`spherestep.dynamics.simulate_servo` at
    ``rate`` Hz), an :class:`Emulated` motor or a :class:`Port` (the drive room's
    :func:`~spherestep.drive.session.servo_session`, 200 Hz, the magnetometers' estimate as the measurement and
    the commanded currents). Each move takes ``move_time`` s per 20° (at least ``move_time``), then ``settle``
    s at the target; the hold equation is the last ``window`` s; ``moves=False`` keeps only the holds.
    ``quadrature`` s: the move's integral by the midpoint rule on groups of periods this long (fewer samples
    to regress; 4 ms keeps it within 0.1 % at 1 kHz). ``progress(text, done, total)`` is told of each hold."""
    from ..dynamics import Rotor
    from ..magnetics import design_model

    if isinstance(orientations, (int, np.integer)) and not isinstance(orientations, bool):
        orientations = hold_orientations(int(orientations))
    targets = so3.as_rotations(orientations, "orientations").reshape(-1, 3, 3)
    if len(targets) == 0:
        raise bad_value("orientations", "at least one orientation", "none")
    own = design_model(design)
    model = own.model if model is None else model
    limits = own.limits if limits is None else limits
    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    move_time = checks.positive(move_time, "move_time", "a positive time in seconds")
    settle = checks.positive(settle, "settle", "a positive time in seconds")
    window = checks.positive(window, "window", "a positive time in seconds, shorter than settle")
    if window >= settle:
        raise bad_value("window", f"shorter than settle ({settle} s)", window)
    quadrature = checks.positive(quadrature, "quadrature", "a positive time in seconds")
    if is_torque_model(backend):
        name = "simulated"
        rotor = Rotor.from_design(design)
    elif isinstance(backend, Emulated):
        if not is_torque_model(backend.plant):
            raise bad_value("backend.plant", "a torque model", type(backend.plant).__name__)
        name = "emulated"
        rotor = Rotor.from_design(design, damping=0.01)  # the drive room's emulated rotor
    elif isinstance(backend, Port):
        name = f"port {backend.device}"
        rotor = Rotor.from_design(design, damping=0.01)
    else:
        raise bad_value("backend", "a torque model (the simulated plant), control.calibration.Emulated(plant) or "
                        "control.calibration.Port(device)", type(backend).__name__)
    rows, rest_R, rest_c, drift = [], [], [], []
    here = np.eye(3)
    for i, target in enumerate(targets):
        if progress is not None:
            progress(f"holding at orientation {i + 1} of {len(targets)} ({name})", i, len(targets))
        traj, _ = _move(here, target, move_time)
        t, R, c = _session(design, backend, traj, settle, here, model, limits, rate)
        every = max(1, round(quadrature / float(np.median(np.diff(t)))))
        eqs, speed = _series_equations(t, R, c, window, rotor.inertia, rotor.damping, every)
        rows.extend(e for e in eqs if moves or e[0] == "hold")
        here = R[-1]
        rest_R.append(R[-1])
        sel = t[:-1] >= t[-1] - window
        rest_c.append(c[:-1][sel].mean(axis=0))
        drift.append(speed)
    if progress is not None:
        progress(f"holding at orientation {len(targets)} of {len(targets)} ({name})", len(targets), len(targets))
    kinds = tuple(r[0] for r in rows)
    sample_eq = np.concatenate([np.full(len(r[4]), k) for k, r in enumerate(rows)])
    return Holds(targets, np.array(rest_R), np.array(rest_c), kinds, np.array([r[1] for r in rows]),
                 np.concatenate([r[2] for r in rows]), np.concatenate([r[3] for r in rows]),
                 np.concatenate([r[4] for r in rows]), sample_eq, rotor.inertia, rotor.damping, name,
                 np.array(drift))


def _move(start: np.ndarray, target: np.ndarray, move_time: float):
    """The triangular turn from ``start`` to ``target`` (``move_time`` per 20°, at least ``move_time``)."""
    from .trajectory import Trajectory

    rv = so3.log_single(target @ start.T)
    angle = float(np.linalg.norm(rv))
    if angle < 1e-9:
        return Trajectory.hold(target), 0.0
    T = move_time * max(1.0, math.sqrt(angle / math.radians(20.0)))
    return Trajectory.turn(start, rv / angle, angle, 4.0 * angle / T ** 2), T


def _session(design, backend, traj, settle: float, start, model, limits, rate: float):
    """``(t, R, c)``: one run of the servo along ``traj`` and ``settle`` s on: times (s), measured orientations
    and the currents per unit over each period."""
    if is_torque_model(backend):
        from ..dynamics import simulate_servo

        run = simulate_servo(design, traj, backend, limits=limits, controller_model=model, settle=settle,
                             start=start, rate=rate)
        return run.times, run.orientations, run.currents / limits.nominal_current
    from ..drive.session import servo_session

    port = backend.device if isinstance(backend, Port) else None
    emulate = isinstance(backend, Emulated)
    options = {"plant": backend.plant, "lockstep": backend.lockstep} if emulate else {}
    session = servo_session(design, traj, traj.duration + settle, port=port, emulate=emulate, model=model,
                            drive=limits, R0=start, **options)
    rep = session.report
    if rep.outcome == "INTERRUPT":  # the loop caught Ctrl-C or SIGTERM and switched every coil off: unwind on,
        stop = KeyboardInterrupt()  # saying whether the device acknowledged it (the CLI tells the user)
        stop.off_acknowledged = bool(rep.off_acknowledged)
        raise stop
    if rep.outcome != "done" or len(rep.times) < 4:
        raise bad_value("backend", "a motor that runs the servo to the end of each hold",
                        f"outcome {rep.outcome} ({rep.message})")
    t = np.asarray(rep.times, dtype=float)
    R = np.asarray(rep.orientations, dtype=float)
    c = np.asarray(rep.currents, dtype=float) / limits.nominal_current
    # the currents commanded in a cycle are driven from the next cycle's start (the session's one-period delay)
    c = np.vstack([np.zeros((1, c.shape[1])), c[:-1]])
    return t, R, c


# -- the fit -------------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Moved:
    """A node the fit moved beyond two standard deviations: ``table`` (``"detent"``/``"winding"``), ``angle``
    (rad), ``nominal``, ``fitted`` and ``std`` (N·m)."""

    table: str
    angle: float
    nominal: float
    fitted: float
    std: float

    def to_dict(self, degrees: bool = True) -> dict:
        return {"table": self.table, ("angle_deg" if degrees else "angle_rad"):
                math.degrees(self.angle) if degrees else self.angle,
                "nominal_Nm": self.nominal, "fitted_Nm": self.fitted, "std_Nm": self.std}


@dataclass(frozen=True, eq=False)
class Calibration:
    """A fitted torque model (module docstring): ``model`` the corrected
    :class:`~spherestep.magnetics.IronTorqueMap` (the base model's coupling kept); ``nodes`` (rad); the fitted
    tables ``detent``, ``winding`` and their standard deviations ``detent_std``, ``winding_std`` (N·m), the
    ``nominal_detent``/``nominal_winding`` they started from; the effective scales ``scale_detent``,
    ``scale_winding`` (``θ⁰·θ / θ⁰·θ⁰`` per table: what the global scale and the shape did together) and their
    ``scale_std``; the equations' residual RMS (N·m)
    ``residual_before`` (the base model) and ``residual_after``, ``sigma`` the noise it assumed; ``holds`` and
    ``equations`` counted; ``moved`` the nodes moved beyond 2σ; ``unseen`` what the data cannot see;
    ``coupling`` whether the fitted model has the cores' coupling, ``coupling_gain`` ± ``coupling_std`` its
    gain against the design's coupling (1: as modelled; 0: none); ``backend``; ``label``."""

    model: object
    nodes: np.ndarray
    detent: np.ndarray
    winding: np.ndarray
    detent_std: np.ndarray
    winding_std: np.ndarray
    nominal_detent: np.ndarray
    nominal_winding: np.ndarray
    scale_detent: float
    scale_winding: float
    scale_std: tuple[float, float]
    residual_before: float
    residual_after: float
    sigma: float
    holds: int
    equations: int
    moved: tuple[Moved, ...]
    unseen: tuple[str, ...]
    coupling: bool
    backend: str
    label: str = "calibrated"
    coupling_gain: float = 1.0
    coupling_std: float = 0.0
    design_fingerprint: str | None = None

    @property
    def consistent(self) -> bool:
        """Whether the fitted model explains the data: the residual RMS after the fit within
        :data:`CONSISTENT` of the uncorrected model's (else the holds were not at rest or the measurements are off,
        and the fit should not be used)."""
        return self.residual_after <= CONSISTENT * self.residual_before

    def summary(self) -> str:
        """Lines for people: residuals, scales, parameters moved, what was not seen."""
        lines = [] if self.consistent else [
            f"WARNING: the fit does not explain the data (residual {self.residual_after / self.residual_before:.0%} "
            "of the uncorrected model's): the rotor was not at rest in the holds or the measurements are off; do "
            "not use this calibration"]
        lines += [f"{self.holds} holds, {self.equations} equations ({self.backend}): residual RMS "
                 f"{torque_text(self.residual_before)} -> {torque_text(self.residual_after)} (noise taken "
                 f"{torque_text(self.sigma, 2)})",
                 f"detent table ×{self.scale_detent:.4f} ± {self.scale_std[0]:.4f}, winding table "
                 f"×{self.scale_winding:.4f} ± {self.scale_std[1]:.4f} (fitted against nominal, θ⁰·θ / θ⁰·θ⁰)",
                 ("no coupling through the cores" if not self.coupling else
                  f"the cores' coupling ×{self.coupling_gain:.4f} ± {self.coupling_std:.4f}" if self.coupling_std > 0
                  else f"the cores' coupling kept as modelled (×{self.coupling_gain:g})"),
                 f"{len(self.moved)} table nodes moved beyond 2σ"]
        for m in self.moved[:8]:
            lines.append(f"  {m.table} at {math.degrees(m.angle):g}°: {m.nominal:+.4g} -> {m.fitted:+.4g} "
                         f"± {m.std:.2g} N·m")
        if len(self.moved) > 8:
            lines.append(f"  ... and {len(self.moved) - 8} more")
        lines += [f"not seen: {u}" for u in self.unseen] or ["every parameter seen by the data"]
        return "\n".join(lines)

    def to_dict(self, degrees: bool = True) -> dict:
        k = 180.0 / math.pi if degrees else 1.0
        return {"label": self.label, "design_fingerprint": self.design_fingerprint, "backend": self.backend,
                "holds": self.holds, "equations": self.equations,
                "coupling": self.coupling, "coupling_gain": self.coupling_gain, "coupling_std": self.coupling_std,
                "consistent": self.consistent,
                ("nodes_deg" if degrees else "nodes_rad"): [float(x * k) for x in self.nodes],
                "detent_Nm": [float(x) for x in self.detent], "winding_Nm": [float(x) for x in self.winding],
                "detent_std_Nm": [float(x) for x in self.detent_std],
                "winding_std_Nm": [float(x) for x in self.winding_std],
                "nominal_detent_Nm": [float(x) for x in self.nominal_detent],
                "nominal_winding_Nm": [float(x) for x in self.nominal_winding],
                "scale_detent": self.scale_detent, "scale_winding": self.scale_winding,
                "scale_std": [float(x) for x in self.scale_std],
                "residual_before_Nm": self.residual_before, "residual_after_Nm": self.residual_after,
                "sigma_Nm": self.sigma, "moved": [m.to_dict(degrees) for m in self.moved],
                "unseen": list(self.unseen)}

    def save(self, path) -> Path:
        """Write the calibration atomically, as JSON when ``path`` ends in ``.json`` and as YAML otherwise
        (``calibration.yaml`` beside the design file is what :func:`spherestep.magnetics.design_model` reads with
        ``calibration=``; :meth:`load` reads both, JSON being YAML); returns the path."""
        import json

        import yaml

        from ..atomic import write_text

        data = self.to_dict(degrees=True)
        if Path(path).suffix.lower() == ".json":
            return write_text(path, json.dumps(data, indent=1) + "\n")
        text = "# spherestep torque calibration (spherestep.control.calibrate); tables in N·m at nodes in degrees\n"
        return write_text(path, text + yaml.safe_dump(data, sort_keys=False))

    @classmethod
    def load(cls, path, design) -> Calibration:
        """The calibration saved at ``path`` for ``design`` (its model rebuilt from the tables; the coupling
        re-read from the design's own when it had one). InputError naming ``calibration`` when the file is not
        one or does not fit the design."""
        import yaml

        from ..magnetics import IronTorqueMap, iron_model

        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
            nodes = np.radians(np.asarray(data["nodes_deg"], dtype=float))
            det = np.asarray(data["detent_Nm"], dtype=float)
            win = np.asarray(data["winding_Nm"], dtype=float)
            arrays = [np.asarray(data[k], dtype=float) for k in ("detent_std_Nm", "winding_std_Nm",
                                                                 "nominal_detent_Nm", "nominal_winding_Nm")]
            moved = tuple(Moved(m["table"], math.radians(m["angle_deg"]), m["nominal_Nm"], m["fitted_Nm"],
                                m["std_Nm"]) for m in data["moved"])
        except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
            raise bad_value("calibration", "a calibration file written by spherestep calibrate",
                            f"{path} ({type(exc).__name__}: {exc})") from None
        if not (len(nodes) == len(det) == len(win)) or not np.all(np.diff(nodes) > 0):
            raise bad_value("calibration", "tables with one value per increasing node", str(path))
        if design.coil.core != "iron":
            raise bad_value("calibration", "used with an iron-cored design", design.coil.core)
        from ..motor import check_fingerprint

        check_fingerprint(design, data.get("design_fingerprint"), "calibration.design_fingerprint",
                          f"calibrate again with `spherestep calibrate` ({path})")
        coupling = bool(data.get("coupling", False))
        gain = float(data.get("coupling_gain", 1.0))
        cross = scaled_coupling(iron_model(design, coupling=True).coupling, gain) if coupling else None
        model = IronTorqueMap.from_tables(design, design.coil, nodes, det, win, coupling=cross)
        return cls(model, nodes, det, win, *arrays, float(data["scale_detent"]), float(data["scale_winding"]),
                   tuple(float(x) for x in data["scale_std"]), float(data["residual_before_Nm"]),
                   float(data["residual_after_Nm"]), float(data["sigma_Nm"]), int(data["holds"]),
                   int(data["equations"]), moved, tuple(str(u) for u in data["unseen"]), coupling,
                   str(data["backend"]), str(data.get("label", "calibrated")), gain,
                   float(data.get("coupling_std", 0.0)), design.fingerprint)


def calibration_beside(design_path) -> Path | None:
    """The calibration file beside a design file (``calibration.yaml`` in its folder), or None if there is none."""
    path = Path(design_path).parent / CALIBRATION_FILE
    return path if path.is_file() else None


def _envelope(nodes: np.ndarray, table: np.ndarray) -> np.ndarray:
    """The largest ``|τ|`` within :data:`ENVELOPE_DEG` of each node (never 0: at least 1e-9 of the peak)."""
    near = np.abs(nodes[:, None] - nodes[None, :]) <= math.radians(ENVELOPE_DEG) + 1e-12
    env = np.max(np.where(near, np.abs(table)[None, :], 0.0), axis=1)
    return np.maximum(env, 1e-9 * np.max(np.abs(table)))


def _second_differences(n: int) -> np.ndarray:
    D = np.zeros((max(n - 2, 0), n))
    for i in range(n - 2):
        D[i, i:i + 3] = (1.0, -2.0, 1.0)
    return D


def _ranges(nodes_deg: np.ndarray, mask: np.ndarray) -> list[str]:
    """Contiguous runs of ``mask`` as ``"a°–b°"``."""
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


def calibrate(design, model, holds: Holds, *, prior: dict | None = None, scales: bool = True,
              coupling: bool | None = None) -> Calibration:
    """Fit the pair tables of the iron ``model`` (an :class:`~spherestep.magnetics.IronTorqueMap`, the
    controller's) to ``holds`` (:func:`collect_holds`) and return the :class:`Calibration` (module docstring).
    ``prior`` overrides the prior's standard deviations :data:`PRIOR` (keys ``scale``, ``node``, ``curvature``,
    ``coupling``); ``scales=False`` fits the shape corrections alone. ``coupling``: whether to fit the gain of the
    cores' coupling (the model's from 1, or the design's own from 0 for a pairwise model); default (None) only for
    a pairwise model — a coupled model's coupling is kept at its modelled strength, which lets the holds fix the
    tables' common scale (module docstring); ``False``: never."""
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
    nodes = model.linear.nodes
    n = len(nodes)
    d0, l0 = np.asarray(model.detent.tau, dtype=float), np.asarray(model.linear.tau, dtype=float)
    E = len(holds.kinds)
    Ad, Al = regression(model, holds.sample_R, holds.sample_c, holds.sample_w, holds.sample_eq, E)
    # the cores' coupling: its torque (the model's at gain 1, else the design's own at gain 0) is a column of its own
    cross, gain0 = model.coupling, 1.0
    if cross is None and coupling is not False:
        cross, gain0 = iron_model(design, model.coil, model.linear.meshing, coupling=True).coupling, 0.0
    fit_gain = cross is not None and (coupling is True or (coupling is None and gain0 == 0.0))
    offset = np.zeros((E, 3))
    if cross is not None:
        pair = IronTorqueMap(model.detent, model.linear, model.coil)
        whole = replace(pair, coupling=cross)
        tot = np.concatenate([whole.torque(holds.sample_R[i:i + 64], holds.sample_c[i:i + 64])
                              - pair.torque(holds.sample_R[i:i + 64], holds.sample_c[i:i + 64])
                              for i in range(0, len(holds.sample_R), 64)])  # in blocks: the coupling's memory
        offset = np.stack([np.bincount(holds.sample_eq, holds.sample_w * tot[:, a], minlength=E) for a in range(3)], 1)
    free = np.ones(n, dtype=bool)
    free[[0, n - 1]] = False  # τ(0) = τ(π) = 0 by symmetry
    ed, el = _envelope(nodes, d0), _envelope(nodes, l0)
    cols = [Ad @ d0, Al @ l0] if scales else []
    cols += [Ad[:, :, m] * ed[m] for m in np.nonzero(free)[0]] + [Al[:, :, m] * el[m] for m in np.nonzero(free)[0]]
    cols += [offset] if fit_gain else []
    X = np.stack(cols, axis=-1).reshape(3 * E, -1)
    base = Ad @ d0 + Al @ l0 + gain0 * offset
    y = (holds.rhs - base).reshape(-1)
    k = 2 if scales else 0
    nf = int(free.sum())
    P = np.zeros((X.shape[1], X.shape[1]))
    if scales:
        P[0, 0] = P[1, 1] = 1.0 / p["scale"] ** 2
    D2 = _second_differences(nf)
    for s0 in (k, k + nf):
        blk = slice(s0, s0 + nf)
        P[blk, blk] = np.eye(nf) / p["node"] ** 2 + D2.T @ D2 / p["curvature"] ** 2
    if fit_gain:
        P[-1, -1] = 1.0 / p["coupling"] ** 2
    # the fitted tables and their covariance: θ = (1 + s) θ⁰ + e ⊙ δ
    J = np.zeros((2 * n, X.shape[1]))
    if scales:
        J[:n, 0] = d0
        J[n:, 1] = l0
    fi = np.nonzero(free)[0]
    J[fi, k + np.arange(nf)] = ed[fi]
    J[n + fi, k + nf + np.arange(nf)] = el[fi]
    L = np.linalg.cholesky(P).T  # P = LᵀL
    floor = SIGMA_FLOOR * float(np.max(np.abs(d0)))
    sigma = max(float(np.sqrt(np.mean(y ** 2))), floor)
    for _ in range(3):
        A = np.vstack([X / sigma, L])
        b = np.concatenate([y / sigma, np.zeros(len(L))])
        x = np.linalg.lstsq(A, b, rcond=None)[0]
        H = X.T @ X / sigma ** 2
        cov = np.linalg.inv(H + P)
        dof = float(np.trace(cov @ H))
        res = y - X @ x
        sigma = max(float(np.sqrt(np.sum(res ** 2) / max(len(y) - dof, 1.0))), floor)
    H = X.T @ X / sigma ** 2
    cov = np.linalg.inv(H + P)
    prior_var = np.diag(np.linalg.inv(P))
    theta = np.concatenate([d0, l0]) + J @ x
    cov_theta = J @ cov @ J.T
    std = np.sqrt(np.maximum(np.diag(cov_theta), 0.0))
    # the effective scale of each table, θ⁰·θ / θ⁰·θ⁰ (what the scale and the shape together did), and its std
    g = np.zeros((2, 2 * n))
    g[0, :n] = d0 / (d0 @ d0)
    g[1, n:] = l0 / (l0 @ l0)
    eff = g @ theta
    eff_std = np.sqrt(np.maximum(np.diag(g @ cov_theta @ g.T), 0.0))
    det, win = theta[:n], theta[n:]
    # what the data cannot see
    ratio = np.diag(cov) / prior_var
    nodes_deg = np.degrees(nodes)
    unseen = []
    for name, s0 in (("detent", k), ("winding", k + nf)):
        mask = np.zeros(n, dtype=bool)
        mask[fi] = ratio[s0:s0 + nf] > UNSEEN
        runs = _ranges(nodes_deg, mask)
        if runs:
            unseen.append(f"{name} table shape at {', '.join(runs)} (posterior variance > {UNSEEN:g} of the prior's: "
                          "these pairs' torque is too small or too rarely met in the holds)")
    if scales:
        v = np.zeros(X.shape[1])
        v[0] = v[1] = 1.0  # both tables ×(1 + s): the direction static holds cannot see
        if fit_gain:
            v[-1] = gain0  # and the coupling with them
        post = float(v @ cov @ v)
        pri = float(v @ np.linalg.inv(P) @ v)
        if post / pri > UNSEEN:
            unseen.append(f"the common scale of both tables (± {math.sqrt(post / 2):.2g}; holds at rest see only "
                          "the ratio of detent to winding, a move's inertia fixes the scale)")
        for i, name in enumerate(("detent", "winding")):
            if ratio[i] > UNSEEN:
                unseen.append(f"the {name} scale (± {math.sqrt(cov[i, i]):.2g})")
    moved = []
    for name, fit, nom, sd in (("detent", det, d0, std[:n]), ("winding", win, l0, std[n:])):
        for m in fi:
            if abs(fit[m] - nom[m]) > 2.0 * sd[m] and abs(fit[m] - nom[m]) > 1e-3 * np.max(np.abs(nom)):
                moved.append(Moved(name, float(nodes[m]), float(nom[m]), float(fit[m]), float(sd[m])))
    moved.sort(key=lambda m: -abs(m.fitted - m.nominal) / max(m.std, 1e-300))
    gain, gain_std = (gain0 + float(x[-1]), math.sqrt(float(cov[-1, -1]))) if fit_gain else (gain0, 0.0)
    if fit_gain and ratio[-1] > UNSEEN:
        unseen.append(f"the coupling's gain (± {gain_std:.2g})")
    if fit_gain and gain0 == 0.0 and abs(gain) <= 2.0 * gain_std:
        cross = None  # a pairwise model whose data show no coupling stays pairwise
    fitted = IronTorqueMap.from_tables(design, model.coil, nodes, det, win, level=model.linear.meshing,
                                       coupling=None if cross is None else scaled_coupling(cross, gain))
    rms_before = float(np.sqrt(np.mean(y ** 2)))
    rms_after = float(np.sqrt(np.mean((y - X @ x) ** 2)))
    return Calibration(fitted, nodes.copy(), det, win, std[:n], std[n:], d0.copy(), l0.copy(),
                       float(eff[0]), float(eff[1]), (float(eff_std[0]), float(eff_std[1])),
                       rms_before, rms_after, sigma, len(holds), E, tuple(moved), tuple(unseen),
                       cross is not None, holds.backend, coupling_gain=gain, coupling_std=gain_std,
                       design_fingerprint=design.fingerprint)


def scaled_coupling(coupling, gain: float):
    """The cores' coupling (a :class:`~spherestep.magnetics.IronTorqueMap`'s ``coupling``) with its energy, hence
    its torque, ×``gain``: its series' spline coefficients scaled (the same splines otherwise)."""
    import copy

    if gain == 1.0:
        return coupling
    series = []
    for spline in coupling.series:
        out = copy.copy(spline)
        tx, ty, c = spline.tck
        out.tck = (tx, ty, np.asarray(c) * gain)
        series.append(out)
    return replace(coupling, series=tuple(series))


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
