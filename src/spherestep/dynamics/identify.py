"""The rotor identified from its own moves: inertia ``I``, viscous damping ``b`` and castor (Coulomb) friction ``f``.

The equation is the rigid body's (:mod:`.rotor`), with the torque ``τ(R, c)`` of a (calibrated) torque model at the
recorded orientations and currents:

    I ω̇ = τ(R, c) − b ω − f ω/|ω| .

No derivative is taken of the record. Each equation multiplies it by a window ``φ(t) = sin²(π (t − a)/L)`` on
``[a, a + L]`` (zero, with its slope, at both ends) and integrates; by parts ``∫ φ ω̇ dt = −∫ φ' ω dt``, so

    ∫ φ τ dt = −I ∫ φ' ω dt + b ∫ φ ω dt + f ∫ φ ω̂ dt ,

three rows (x, y, z) linear in ``(I, b, f)`` per window. A coil current that follows its command late (a
current loop of time constant ``τ_c`` behind a held command: the period's mean is ``c_n − k (c_n − c_{n−1})``,
``k = (τ_c/h)(1 − e^{−h/τ_c})``) is one more unknown, ``k``, whose column is ``∫ φ K(R) (c_n − c_{n−1}) dt``
(``K = ∂τ/∂c``); ``lag=True`` fits it (a board's current loop; the emulated motor's is ~0.5 ms behind), reported
as ``current_lag = k h`` s. A calibrated model whose winding torque is off by a common factor (its detent
right) leaks into ``b`` and ``f`` (a move's winding torque is large and follows the speed: on the simulated servo,
realistic plant seed 21, a winding 3 % strong took the damping +38 % and the friction negative, 2 % random
per-coil errors left them within 0 % and 6 %), so ``winding=True`` fits that factor too, ``1 + s``, its column
``−∫ φ τ_w dt`` with ``τ_w = τ(R, c) − τ(R, 0)`` the model's winding torque (separate from ``I`` because the
detent's torque is not scaled; reported as ``winding_scale``). ``ω dt`` over a sample interval is the rotation the rotor
made, ``log(R_{n+1} R_nᵀ)``; ``ω̂`` its direction over ``±smooth`` s (central, less noisy); the integrals by the
midpoint rule on the intervals (``c[n]`` the current over ``[t_n, t_{n+1}]``, ``τ`` at the interval's middle
orientation). The windows tile, without overlap, the span in which the rotor moves faster than ``speed_floor``
(rad/s): at rest the friction is static, anything up to ``f``, which the equation cannot say.

The fit is least squares on the stacked rows, each row scaled by its window's length, with the windows the model
does not explain set aside: a window whose residual (the norm of its three rows) exceeds ``REJECT`` × the median
window's is dropped and the fit repeated (up to three times; on the emulated motor these are the few windows where
the servo lost the path and the coils, at their voltage limit, could not follow the commanded currents: residuals
0.07–0.2 N·m against ~0.003, seed 2). The standard deviations are ``σ √diag((XᵀX)⁻¹)`` with ``σ²`` the kept
residual sum of squares over ``rows − unknowns``. They are honest
when the windows' residuals are independent (the windows do not overlap) and the model's torque error is not
correlated with ``(I, b, f)``'s regressors; :meth:`RotorFit.residual` judges a fit on moves it was not fitted on.

The excitation (:func:`rotor_excitation`): trapezoidal turns about random axes at several cruise speeds, so that
``b ω`` (growing with speed) and ``f`` (constant) separate, each accelerating and braking at ``acceleration`` so
that ``I`` is seen; every move starts at rest where the last ended.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..control import ModelCache, Trajectory
from ..errors import bad_value
from ..statics import is_torque_model
from .rotor import Rotor

WINDOW = 0.2  # s, each equation's window
SPEED_FLOOR = 0.05  # rad/s: the rotor is taken to move above this speed
SMOOTH = 0.01  # s, the half-width of the central difference giving the motion's direction
REJECT = 6.0  # a window whose residual exceeds this many times the median window's is not explained: set aside


def rotor_excitation(start=None, *, speeds=(1.0, 2.5, 5.0), angle: float = math.radians(120.0),
                     acceleration: float = 6.0, repeats: int = 2, seed=0) -> tuple[Trajectory, ...]:
    """The moves to run (module doc): for each of ``repeats`` rounds, one trapezoidal turn of ``angle`` rad per
    cruise speed in ``speeds`` (rad/s), accelerating and braking at ``acceleration`` rad/s², each about a uniformly
    random axis (``seed``) from where the last ended (``start``, default the identity)."""
    R = np.eye(3) if start is None else so3.as_rotations(start, "start").reshape(3, 3)
    v = [checks.positive(s, "speeds", "positive cruise speeds in rad/s") for s in np.atleast_1d(speeds)]
    angle = checks.positive(angle, "angle", "a positive angle in radians")
    acceleration = checks.positive(acceleration, "acceleration", "a positive acceleration in rad/s²")
    repeats = checks.count(repeats, "repeats")
    rng = np.random.default_rng(seed)
    moves = []
    for _ in range(repeats):
        for speed in v:
            axis = rng.standard_normal(3)
            traj = Trajectory.turn(R, axis / np.linalg.norm(axis), angle, acceleration, speed)
            moves.append(traj)
            R = traj.end
    return tuple(moves)


def _windows(t: np.ndarray, moving: np.ndarray, window: float) -> list[tuple[float, float]]:
    """Non-overlapping windows of length ``window`` (the last ones stretched to fill) over the span from the first
    to the last moving interval."""
    idx = np.flatnonzero(moving)
    if len(idx) == 0:
        return []
    a, b = float(t[idx[0]]), float(t[idx[-1] + 1])
    n = int((b - a) // window)
    if n == 0:
        return []
    L = (b - a) / n
    return [(a + k * L, a + (k + 1) * L) for k in range(n)]


def window_equations(model, t, R, c, *, window: float = WINDOW, speed_floor: float = SPEED_FLOOR,
                     smooth: float = SMOOTH) -> tuple[np.ndarray, np.ndarray]:
    """``(X (3W, 5), y (3W,))``: the windowed equations ``y = X (I, b, f, k, s)`` (module doc) of one record ``t (T,)``
    s, ``R (T, 3, 3)``, ``c (T, N)`` per unit (``c[n]`` over ``[t_n, t_{n+1}]``) under the torque ``model``."""
    t = np.asarray(t, dtype=float)
    R = so3.as_rotations(R, "R").reshape(-1, 3, 3)
    c = np.asarray(c, dtype=float)
    if t.ndim != 1 or len(t) < 3 or len(R) != len(t) or c.ndim != 2 or len(c) < len(t) - 1 or np.any(np.diff(t) <= 0):
        raise bad_value("series", "times (T,) increasing, orientations (T, 3, 3), currents (T, N) or (T−1, N), T ≥ 3",
                        f"{t.shape}, {R.shape}, {c.shape}")
    h = np.diff(t)
    step = so3.log(R[1:] @ np.swapaxes(R[:-1], 1, 2))  # ω h per interval, fixed frame
    speed = np.linalg.norm(step, axis=1) / h
    tm = t[:-1] + 0.5 * h
    mid = so3.exp(0.5 * step) @ R[:-1]
    c = c[: len(h)]
    tau = _torques(model, mid, c)
    dtau = tau - _torques(model, mid, np.vstack([c[:1], c[:-1]]))  # K(R)(c_n − c_{n−1})
    wound = tau - _torques(model, mid, np.zeros_like(c))  # τ_w: the winding's share
    k = max(1, round(smooth / float(np.median(h))))  # the direction of motion over ±k intervals
    lo, hi = np.maximum(np.arange(len(h)) - k, 0), np.minimum(np.arange(len(h)) + k, len(h) - 1)
    wide = so3.log(R[hi + 1] @ np.swapaxes(R[lo], 1, 2))
    norm = np.linalg.norm(wide, axis=1, keepdims=True)
    direction = np.where(norm > 0, wide / np.where(norm > 0, norm, 1.0), 0.0)
    rows, rhs = [], []
    for a, b in _windows(t, speed > speed_floor, window):
        L = b - a
        s = np.clip((tm - a) / L, 0.0, 1.0)
        inside = (tm > a) & (tm < b)
        phi = np.where(inside, np.sin(np.pi * s) ** 2, 0.0)
        dphi = np.where(inside, np.pi / L * np.sin(2 * np.pi * s), 0.0)
        X = np.stack([-(dphi[:, None] * step).sum(0), (phi[:, None] * step).sum(0),
                      (phi[:, None] * direction * h[:, None]).sum(0), (phi[:, None] * dtau * h[:, None]).sum(0),
                      -(phi[:, None] * wound * h[:, None]).sum(0)], axis=1)
        rows.append(X / L)
        rhs.append((phi[:, None] * tau * h[:, None]).sum(0) / L)
    if not rows:
        return np.zeros((0, 5)), np.zeros(0)
    return np.concatenate(rows), np.concatenate(rhs)


def _torques(model, R: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``τ(R_n, c_n) (T, 3)``: an affine model by its compiled ``K(R)`` and bias (the servo law's exact cache),
    any other by its batched ``torque``."""
    if not model.affine_in_currents:
        return np.asarray(model.torque(R, c), dtype=float)
    cache = ModelCache(model, reuse=0.0)
    out = np.empty((len(R), 3))
    for n in range(len(R)):
        K, b = cache.at(R[n])
        out[n] = K @ c[n] if b is None else b + K @ c[n]
    return out


@dataclass(frozen=True)
class RotorFit:
    """The identified rotor: ``inertia`` kg·m², ``damping`` N·m·s/rad, ``friction`` N·m, their standard deviations
    ``std (3,)`` in that order, the residual's RMS ``sigma`` (N·m, per row), the ``equations`` (rows) and
    ``windows`` fitted (``rejected`` more set aside: module doc); with ``lag`` fitted, the currents' ``current_lag``
    (s, ``k h``) and its ``lag_std`` (else 0); with ``winding`` fitted, the model's winding torque's factor
    ``winding_scale`` (``1 + s``) ± ``winding_std`` (else 1 ± 0)."""

    inertia: float
    damping: float
    friction: float
    std: tuple[float, float, float]
    sigma: float
    equations: int
    windows: int
    current_lag: float = 0.0
    lag_std: float = 0.0
    period: float = 0.0
    rejected: int = 0
    winding_scale: float = 1.0
    winding_std: float = 0.0

    @property
    def rotor(self) -> Rotor:
        """The fitted :class:`Rotor` (a negative damping or friction, which noise can give, clipped to 0)."""
        return Rotor(self.inertia, max(self.damping, 0.0), max(self.friction, 0.0))

    def residual(self, model, series, **options) -> float:
        """RMS (N·m) of the windowed equations' residual on ``series`` (records not fitted: a held-out check;
        compare with :attr:`sigma`)."""
        X, y = _stack(model, series, options)
        if len(y) == 0:
            raise bad_value("series", "records in which the rotor moves", "no moving window")
        k = self.current_lag / self.period if self.period else 0.0
        x = np.array([self.inertia, self.damping, self.friction, k, self.winding_scale - 1.0])
        return float(np.sqrt(np.mean((y - X @ x) ** 2)))

    def to_dict(self) -> dict:
        """The fit as plain numbers (SI); :meth:`from_dict` reads it back."""
        return {"inertia_kg_m2": self.inertia, "damping_N_m_s": self.damping, "friction_N_m": self.friction,
                "inertia_std": self.std[0], "damping_std": self.std[1], "friction_std": self.std[2],
                "residual_N_m": self.sigma, "equations": self.equations, "windows": self.windows,
                "current_lag_s": self.current_lag, "current_lag_std_s": self.lag_std, "rejected_windows": self.rejected,
                "period_s": self.period, "winding_scale": self.winding_scale, "winding_std": self.winding_std}

    @classmethod
    def from_dict(cls, data: dict) -> RotorFit:
        """The fit from :meth:`to_dict`'s dict; InputError naming a missing or bad key."""
        try:
            return cls(float(data["inertia_kg_m2"]), float(data["damping_N_m_s"]), float(data["friction_N_m"]),
                       (float(data["inertia_std"]), float(data["damping_std"]), float(data["friction_std"])),
                       float(data["residual_N_m"]), int(data["equations"]), int(data["windows"]),
                       float(data["current_lag_s"]), float(data["current_lag_std_s"]), float(data["period_s"]),
                       int(data["rejected_windows"]), float(data.get("winding_scale", 1.0)),
                       float(data.get("winding_std", 0.0)))
        except KeyError as exc:
            raise bad_value(str(exc.args[0]), "a key of RotorFit.to_dict()", "missing") from None
        except (TypeError, ValueError):
            raise bad_value("rotor fit", "the numbers of RotorFit.to_dict()", "malformed values") from None


def _stack(model, series, options) -> tuple[np.ndarray, np.ndarray]:
    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    if not series:
        raise bad_value("series", "at least one record (t, R, c)", "none")
    parts = []
    for rec in series:
        if len(rec) != 3:
            raise bad_value("series", "records (t, R, c)", f"a record of {len(rec)} items")
        parts.append(window_equations(model, *rec, **options))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def _period(series) -> float:
    """The records' median sample interval (s)."""
    return float(np.median(np.concatenate([np.diff(np.asarray(rec[0], dtype=float)) for rec in series])))


def fit_rotor(model, series, *, lag: bool = False, winding: bool = False, window: float = WINDOW,
              speed_floor: float = SPEED_FLOOR, smooth: float = SMOOTH) -> RotorFit:
    """Least squares for ``(I, b, f)`` (module doc) from ``series``, records ``(t, R, c)`` (times s, orientations
    ``(T, 3, 3)``, per-unit currents ``(T, N)`` with ``c[n]`` over ``[t_n, t_{n+1}]``) of the moves of
    :func:`rotor_excitation`, under the torque ``model`` (the calibrated one); ``lag``: also the currents' lag
    behind their commands (the commanded currents of a board or the emulated motor); ``winding``: also the
    model's winding torque's common factor (a calibrated model's error that would leak into ``b`` and ``f``)."""
    window = checks.positive(window, "window", "a positive time in seconds")
    options = {"window": window, "speed_floor": checks.non_negative(speed_floor, "speed_floor"),
               "smooth": checks.positive(smooth, "smooth", "a positive time in seconds")}
    X, y = _stack(model, series, options)
    cols = [0, 1, 2] + ([3] if lag else []) + ([4] if winding else [])
    X = X[:, cols]
    if len(y) < 6:
        raise bad_value("series", f"moves spanning at least two {window:g}-s windows in motion", f"{len(y) // 3}")
    keep = np.ones(len(y) // 3, dtype=bool)
    for _ in range(4):
        rows = np.repeat(keep, 3)
        x, *_ = np.linalg.lstsq(X[rows], y[rows], rcond=None)
        norm = np.linalg.norm((y - X @ x).reshape(-1, 3), axis=1)
        again = norm <= REJECT * np.median(norm[keep])
        if np.array_equal(again, keep) or again.sum() < 2:
            break
        keep = again
    rows = np.repeat(keep, 3)
    X, y = X[rows], y[rows]
    r = y - X @ x
    sigma2 = float(r @ r) / max(len(y) - X.shape[1], 1)
    std = np.sqrt(np.maximum(np.diag(sigma2 * np.linalg.inv(X.T @ X)), 0.0))
    h = _period(series)
    w = cols.index(4) if winding else None
    return RotorFit(float(x[0]), float(x[1]), float(x[2]), (float(std[0]), float(std[1]), float(std[2])),
                    math.sqrt(sigma2), len(y), len(y) // 3, float(x[3] * h) if lag else 0.0,
                    float(std[3] * h) if lag else 0.0, h, int((~keep).sum()),
                    1.0 + float(x[w]) if winding else 1.0, float(std[w]) if winding else 0.0)
