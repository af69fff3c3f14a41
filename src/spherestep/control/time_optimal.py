"""The fastest rest-to-rest turn with a bias torque (the iron's detent): time-optimal path parametrisation.

Path and constraint. A piece of path is a turn about a fixed axis ``n``: ``R(s) = exp(s n) R₀``, ``s ∈ [0, θ]``
(rad; the unit-interval parameter of the literature is ``s/θ``), so ``ω = ṡ n`` and ``α = s̈ n``. For a rotor of
isotropic inertia ``I`` and viscous damping ``b_d`` the coils must supply

    K(R) c = (I s̈ + b_d ṡ) n − b(R),    c ∈ B(R, ṡ),  ‖c‖ ≤ ρ                          (per-unit currents)

with ``b(R) = τ(R, 0)`` the bias (detent) torque, ``ρ`` the power bound of :mod:`.allocation`, and ``B`` the box
of currents the drive can hold at that speed: ``|c_k| ≤ u`` (0 on failed coils) and the supply voltage against
the back-EMF, ``|R I_n c_k + e_k| ≤ V`` with ``e_k = K_k·ω/I_n`` (:func:`current_box`; the servo's coil model,
``dynamics.CoilDrive``, has the same limit: on the iron prototype ``e_k`` reaches 7.4 V per rad/s against a 24 V
supply, so the torque the coils can add falls fast with speed). The required torque lies on the line
``{y n − b}``; the reachable set is convex, so the feasible ``y = I s̈ + b_d ṡ`` at each ``s`` is an interval
``[y₋, y₊]`` (empty where the line misses the set). Each end is a small second-order cone program — maximise /
minimise ``y`` over ``(c, y)`` subject to ``K c − y n = −b``, the box and the power ball — solved by Clarabel (the
conic solver the allocation already uses). We did not use ``toppra``: its fast solver takes linear constraints
only, the power limit is a second-order cone (cvxpy only); and the damping torque being along the same ``n`` as
the inertial one, each stage is one interval in ``y`` — no need for TOPP-RA's sets in the ``(s̈, ṡ²)`` plane.

Speed bands. ``B`` shrinks as ``ṡ`` grows (each coil loses, on the side its back-EMF opposes, ``|g_k| ṡ`` with
``g_k = K_k·n/(R I_n²)``), so the interval computed with the box at ``v_j`` holds for every speed up to ``v_j``.
The phase plane uses ``SPEED_BANDS`` levels ``v_j`` (equal steps up to ``TOP_SPEED × v₀``, :func:`speed_levels`;
``v₀`` the speed at which the best-aligned coil's back-EMF equals the supply; ``TOP_SPEED`` = 2, the bound's: the
box itself caps the speed, and the servo's allocation keeps the same supply box each period from its estimated
``ω``, :class:`~spherestep.control.ServoLaw`); a piece whose larger end speed is in ``(v_{j−1}, v_j]`` uses band ``j`` (conservative by one band's width);
damping conservatively as ``D_j ≤ s̈ ≤ A_j − β v_j``, ``β = b_d/I``. The intervals are computed lazily, only in
the bands the passes visit.

Margin. The feed-forward may use ``margin`` of the current bound, of the supply voltage (the *whole* back-EMF
counted against it) and of the power radius: ``|c_k| ≤ m u``, ``|R I_n c_k + e_k| ≤ m V``, ``‖c‖ ≤ m ρ``.
Feedback currents within ``(1 − m)`` of the current, voltage and power bounds then add to the feed-forward's
without leaving the limits (triangle inequalities): the feedback, and the inductance's ``L di/dt``, keep ``1 − m``
of the drive whatever the detent and the speed cost the feed-forward. ``margin = 1`` gives the bound
(:func:`fastest_time`, :func:`~spherestep.control.bang_bang_time`). The default is ``MARGIN`` = 0.7 where the turn
itself is feasible within it, else the turn itself within ``TURN_MARGIN`` = 0.9, else detours (0.7, then 0.9): on
the iron prototype holding the rotor against the detent takes more than 80 % of a coil's current from 184° to
224° of the demo's turn, so within 0.7 only a detour resting at three waypoints is feasible (2.05 s), within 0.9
the turn itself (1.34 s, tracked within 0.15° on the design's model). The price is robustness: a plant whose
winding gives 15 % less torque cannot follow a plan that uses 90 % of the model's, so a turn on a motor not yet
calibrated should be planned with ``margin = MARGIN`` (docs/control.md, the table of §2). On the air-core map
the turn itself is feasible within 0.7, which its feedback needs (0.9 tracked 0.73°).

The coils' ``L di/dt``. Beyond the margin the feed-forward's box keeps ``HEADROOM`` (0.08) × each coil's own
back-EMF off its voltage, ``|R I_n c_k + e_k| ≤ m V − HEADROOM·|e_k|`` (``headroom`` of :func:`current_box`:
zero at rest, where holding against the detent needs the whole current, growing with the speed as the currents'
rate along the path does), and the time law is averaged over a moving window of ``SMOOTH`` (2) × ``L/R``
(:func:`smoothed`: its acceleration continuous, the turn ``w`` longer). On the iron prototype with the coil's own
0.65 H (``L/R`` = 7.8 ms) the demo's turn takes 1.475 s tracked within 0.22° where the bare law's 1.338 s was
tracked within 1.03° (docs/control.md). The bound (:func:`fastest_time`) keeps neither.

Phase plane. With ``x = ṡ²`` (``dx/ds = 2 s̈``) on a grid ``s_0 … s_K`` (step ≤ ``GRID_STEP``), each piece has a
constant ``s̈_i = (x_{i+1} − x_i)/(2Δ)`` (``s`` quadratic in ``t``, ``ṡ`` linear, exact), which must lie in the
band's interval at *both* its ends: ``D_i = max(y₋(s_i), y₋(s_{i+1}))/I``, ``A_i = min(y₊(s_i), y₊(s_{i+1}))/I``.
Backward pass (TOPP-RA's controllable sets): from rest at the end, the largest ``x_i`` from which some
``s̈ ∈ [D, A]`` lands below the next one, ``x_i = max_j min(v_j², min(x_{i+1}, v_j²) − 2Δ D_{ij})``. Forward
pass: greedy from rest, the largest ``x_{i+1} = min(x_i + 2Δ A_{ij}, x^max_{i+1}, v_j²)``. Without speed bands
(:func:`phase_plane`: one interval per point) this is the classical pair of integrations, ``x = min(forward,
backward)``, exact also for damping. A path is infeasible when a stage's interval is empty, when a pass cannot
keep ``x > 0`` inside the path (the coils cannot push the rotor through the detent at that speed, or cannot brake
before it), or when the coils cannot hold the rotor at rest at either end. Time ``Δt_i = 2Δ/(√x_i + √x_{i+1})``.

Paths tried (:func:`fastest_turn`): the turn about ``n`` itself; if infeasible, detours through waypoints around
the part of it where the coils (within the margin, at rest) cannot hold against the detent: that stretch (merged
with any within ``DETOUR_PAD``, then ``DETOUR_PAD`` beyond, out to where the coils hold) is replaced by two
geodesic pieces through ``exp(δ m) R(s_m)`` (``s_m`` its middle, ``m ⊥ n`` in ``DETOUR_DIRECTIONS`` directions,
tilts ``δ`` in ``DETOUR_TILTS``, smallest first, stopping at the first tilt with a feasible detour), at rest at
each waypoint, so that every piece turns about a fixed axis and the constraints stay exact. The fastest feasible
candidate wins.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import InputError, bad_value
from ..electrics import DriveLimits
from .trajectory import MARGIN, TimeLaw, Trajectory

GRID_STEP = math.radians(0.5)  # the phase plane's largest step along the path (rad)
MIN_PIECES = 16
DETOUR_TILTS = tuple(math.radians(d) for d in (8.0, 15.0, 25.0))
DETOUR_DIRECTIONS = 6
DETOUR_PAD = math.radians(10.0)
_TOL = 1e-9


def current_box(K, direction, limits: DriveLimits, *, failed=(), speed: float = 0.0, scale: float = 1.0,
                headroom: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Per-unit current bounds ``(lower, upper) (M, N)`` that hold for every speed ``ṡ ∈ [0, speed]`` (rad/s) along
    ``direction`` at orientations with torque matrices ``K (M, 3, N)``, within ``scale`` of the limits: ``|c_k| ≤
    scale·u`` and the supply voltage against the whole back-EMF, ``|R I_n c_k + e_k| ≤ scale·V`` with
    ``e_k = (K_k·n) ṡ / I_n`` (steady state), i.e. ``−scale·V/(R I_n) + max(0, −g_k) v ≤ c_k ≤ scale·V/(R I_n) −
    max(0, g_k) v``, ``g_k = K_k·n/(R I_n²)`` (the intersection of the boxes of every speed up to ``v``). A box
    need not hold 0: a coil whose back-EMF exceeds ``scale·V`` must carry a current that brakes the motion (what
    the H-bridge's coil does at ``|e_k| > V`` whatever its switches), and its torque is counted; where the box is
    empty (``|g_k| v > 2·scale·V/(R I_n)``) ``lower > upper``: no current serves every speed of the band. Failed
    coils 0. The rest, ``(1 − scale)`` of the current and of the voltage, is the feedback's (and the
    inductance's, ``L di/dt``)."""
    n = checks.axis(direction, "direction")
    g = np.einsum("man,a->mn", np.asarray(K, dtype=float), n) * limits.emf_factor
    u = scale * limits.per_unit_bound
    uv = scale * limits.voltage_bound
    keep = headroom * np.abs(g)
    upper = np.minimum(u, uv - (np.maximum(g, 0.0) + keep) * speed)
    lower = np.maximum(-u, -uv + (np.maximum(-g, 0.0) + keep) * speed)
    if len(failed):
        upper[:, list(failed)] = 0.0
        lower[:, list(failed)] = 0.0
    return lower, upper


def reachable_interval(K, bias, direction, limits: DriveLimits | None = None, *, failed=(), scale: float = 1.0,
                       speed: float = 0.0, headroom: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """For torque matrices ``K (M, 3, N)`` and bias torques ``bias (M, 3)``: the range ``[y₋, y₊]`` (N·m) of ``y``
    such that ``y d − b = K c`` for some currents in the :func:`current_box` for speeds up to ``speed`` along ``d``
    within ``scale`` of the limits and in the power ball ``scale·ρ`` (``d`` the unit ``direction``); NaN where no
    ``y`` is (see the module; two Clarabel second-order cone programs per orientation)."""
    import clarabel
    from scipy import sparse

    limits = DriveLimits() if limits is None else limits
    K = np.asarray(K, dtype=float).reshape((-1,) + np.shape(K)[-2:])
    b = np.asarray(bias, dtype=float).reshape(-1, 3)
    d = checks.axis(direction, "direction")
    lower, upper = current_box(K, d, limits, failed=failed, speed=speed, scale=scale, headroom=headroom)
    N = K.shape[-1]
    rho = limits.per_unit_power_radius * scale
    lo = np.full(len(K), np.nan)
    hi = np.full(len(K), np.nan)
    # the constraint matrix, column by column (CSC, built directly: scipy's stacking costs 3× the solve):
    # rows 0-2 K c − y d = −b; rows 3..3+N c ≤ upper; 3+N..3+2N −c ≤ −lower; 3+2N the cone's ρ; then −c
    rows_c = np.concatenate([np.zeros((N, 0), int), np.tile([0, 1, 2], (N, 1)),
                             np.stack([3 + np.arange(N), 3 + N + np.arange(N), 4 + 2 * N + np.arange(N)], 1)], 1)
    indices = np.concatenate([rows_c.ravel(), [0, 1, 2]]).astype(np.int64)
    indptr = np.concatenate([6 * np.arange(N + 1), [6 * N + 3]]).astype(np.int64)
    shape = (4 + 3 * N, N + 1)
    cones = [clarabel.ZeroConeT(3), clarabel.NonnegativeConeT(2 * N), clarabel.SecondOrderConeT(N + 1)]
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    settings.tol_gap_abs = settings.tol_gap_rel = settings.tol_feas = 1e-9
    P = sparse.csc_matrix((N + 1, N + 1))
    ok = (clarabel.SolverStatus.Solved, clarabel.SolverStatus.AlmostSolved)
    tail = np.tile([1.0, -1.0, -1.0], N)
    for m in range(len(K)):
        if np.any(lower[m] > upper[m]):  # a coil no current serves at every speed of the band
            continue
        data = np.concatenate([np.concatenate([K[m].T, tail.reshape(N, 3)], 1).ravel(), -d])
        A = sparse.csc_matrix((data, indices, indptr), shape=shape)
        rhs = np.concatenate([-b[m], upper[m], -lower[m], [rho], np.zeros(N)])
        ends = []
        for sign in (-1.0, 1.0):
            q = np.zeros(N + 1)
            q[-1] = sign  # minimise ±y
            sol = clarabel.DefaultSolver(P, q, A, rhs, cones, settings).solve()
            if sol.status not in ok:
                break
            ends.append(float(sol.x[-1]))
        if len(ends) == 2:
            hi[m], lo[m] = ends
    # Clarabel stops within its tolerance of the boundary: shrink by it, so the ends are inside
    pad = 1e-7 * (np.linalg.norm(K, axis=(1, 2)) * rho + np.linalg.norm(b, axis=1))
    lo, hi = lo + pad, hi - pad
    bad = ~(lo <= hi)
    lo[bad], hi[bad] = np.nan, np.nan
    return lo, hi


@dataclass(frozen=True)
class PhasePlane:
    """A time-optimal rest-to-rest law along ``s (K+1,)`` (rad): ``x (K+1,)`` = ``ṡ²`` (rad²/s²), ``sdd (K,)``
    per piece (rad/s²), ``times (K+1,)`` (s); or ``feasible=False`` with ``reason`` (and ``where``, rad: the first
    ``s`` the passes could not get through)."""

    s: np.ndarray
    x: np.ndarray
    sdd: np.ndarray
    times: np.ndarray
    feasible: bool
    reason: str = ""
    where: float = math.nan

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if self.feasible else math.inf


def _infeasible(s, reason, where) -> PhasePlane:
    e = np.zeros(0)
    return PhasePlane(np.asarray(s, float), e, e, e, False, reason, float(where))


def phase_plane(s, accel_min, accel_max, beta: float = 0.0, speed: float | None = None) -> PhasePlane:
    """The time-optimal rest-to-rest law on the grid ``s (K+1,)`` (rad, increasing) under
    ``accel_min(s) − β ṡ ≤ s̈ ≤ accel_max(s) − β ṡ`` at the grid points (rad/s², NaN = no motion passes), both
    ends of each piece, and ``ṡ ≤ speed`` if given: forward/backward passes in ``x = ṡ²`` (see the module)."""
    s = np.asarray(s, dtype=float)
    lo, hi = np.asarray(accel_min, float), np.asarray(accel_max, float)
    if np.any(np.isnan(lo)) or np.any(np.isnan(hi)):
        k = int(np.flatnonzero(np.isnan(lo) | np.isnan(hi))[0])
        return _infeasible(s, "the coils cannot give the torque the path needs against the bias", s[k])
    if not (lo[0] <= 0 <= hi[0]):
        return _infeasible(s, "the coils cannot hold the rotor at the start against the bias", s[0])
    if not (lo[-1] <= 0 <= hi[-1]):
        return _infeasible(s, "the coils cannot hold the rotor at the end against the bias", s[-1])
    A = np.minimum(hi[:-1], hi[1:])
    D = np.maximum(lo[:-1], lo[1:])
    if np.any(A < D):
        k = int(np.flatnonzero(A < D)[0])
        return _infeasible(s, "no acceleration keeps the torque within reach over a grid step", s[k])
    cap = math.inf if speed is None else speed * speed
    ds = np.diff(s)
    K = len(ds)
    # backward: the largest x_i from which the end is reached at rest with x ≤ cap (TOPP-RA's controllable set)
    kmax = np.zeros(K + 1)
    for i in range(K - 1, -1, -1):
        d, xn = ds[i], kmax[i + 1]
        c = xn - 2 * d * D[i]
        if c + (d * beta) ** 2 < 0:
            return _infeasible(s, "the coils cannot brake the rotor against the bias before the end", s[i + 1])
        x0 = min(xn - 2 * d * (D[i] - beta * math.sqrt(xn)), (d * beta + math.sqrt((d * beta) ** 2 + c)) ** 2, cap)
        if x0 <= 0 and i > 0:
            return _infeasible(s, "the coils cannot brake the rotor against the bias before the end", s[i])
        kmax[i] = max(x0, 0.0)
    # forward, greedy: the largest acceleration that stays within reach and within the controllable set
    x = np.zeros(K + 1)
    for i in range(K):
        d, xi = ds[i], x[i]
        c = xi + 2 * d * A[i]
        if c < 0:
            return _infeasible(s, "the coils cannot push the rotor through the bias at the speed it has", s[i])
        x1 = min(xi + 2 * d * (A[i] - beta * math.sqrt(xi)), (math.sqrt((d * beta) ** 2 + c) - d * beta) ** 2,
                 kmax[i + 1])
        if x1 <= 0 and i < K - 1:
            return _infeasible(s, "the coils cannot push the rotor through the bias at the speed it has", s[i])
        x[i + 1] = max(x1, 0.0)
    x[0] = x[-1] = 0.0
    sd = np.sqrt(x)
    sdd = np.diff(x) / (2 * ds)
    # the constraints at both ends of each piece, at both speeds (exact for β = 0 up to rounding)
    tol = _TOL * (1.0 + np.abs(A) + np.abs(D))
    for v in (sd[:-1], sd[1:]):
        if np.any(sdd > A - beta * v + tol) or np.any(sdd < D - beta * v - tol):
            k = int(np.flatnonzero((sdd > A - beta * v + tol) | (sdd < D - beta * v - tol))[0])
            return _infeasible(s, "no acceleration within reach at the speed the profile has there", s[k])
    dt = 2 * ds / (sd[:-1] + sd[1:])
    return PhasePlane(s, x, sdd, np.concatenate([[0.0], np.cumsum(dt)]), True)


def banded_phase_plane(s, levels, interval, beta: float = 0.0) -> PhasePlane:
    """The time-optimal rest-to-rest law on the grid ``s (K+1,)`` (rad) when the acceleration bounds depend on the
    speed in bands: ``interval(i, j) -> (accel_min, accel_max)`` (rad/s², NaN: none) at grid point ``i`` valid for
    every speed up to ``levels[j]`` (rad/s, increasing; the last is the speed cap), nested (a faster band's interval
    lies inside a slower one's), evaluated lazily. A piece uses the band of its larger end speed, at both its ends;
    damping conservatively, ``D_j ≤ s̈ ≤ A_j − β v_j``. Backward: the largest ``x_i`` over the bands from which the
    end is reached; forward: greedy, the largest ``x_{i+1}`` within the band and below the backward curve (TOPP-RA's
    two passes for interval constraints)."""
    s = np.asarray(s, dtype=float)
    ds = np.diff(s)
    K, L = len(ds), len(levels)
    v2 = [v * v for v in levels]
    memo: dict = {}

    def piece(i, j):
        if (i, j) not in memo:
            a0, a1 = interval(i, j), interval(i + 1, j)
            A = min(a0[1], a1[1]) - beta * levels[j]
            D = max(a0[0], a1[0])
            memo[i, j] = (D, A) if D <= A else None  # NaN compares False: None
        return memo[i, j]

    if not (interval(0, 0)[0] <= 0 <= interval(0, 0)[1]):
        return _infeasible(s, "the coils cannot hold the rotor at the start against the bias", s[0])
    if not (interval(K, 0)[0] <= 0 <= interval(K, 0)[1]):
        return _infeasible(s, "the coils cannot hold the rotor at the end against the bias", s[-1])
    kmax = np.zeros(K + 1)
    for i in range(K - 1, -1, -1):
        X, d, best = kmax[i + 1], ds[i], -math.inf
        slow = piece(i, 0)  # the widest interval: x_i ≤ X − 2Δ D_0 in every band
        top = L - 1 if slow is None else min(L - 1, int(np.searchsorted(v2, X - 2 * d * slow[0])))
        for j in range(top, -1, -1):
            if v2[j] <= best:
                break
            p = piece(i, j)
            if p is None:
                continue
            D, A = p
            cand = min(v2[j], min(X, v2[j]) - 2 * d * D)
            if cand >= max(0.0, -2 * d * A):
                best = max(best, cand)
        if not best > 0 and i > 0 or best < 0:
            return _infeasible(s, "the coils cannot brake the rotor against the bias before the end", s[i])
        kmax[i] = best
    x = np.zeros(K + 1)
    band = np.zeros(K, dtype=int)
    for i in range(K):
        xi, d, best = x[i], ds[i], (-math.inf, -1)
        for j in range(int(np.searchsorted(v2, xi - 1e-12)), L):
            p = piece(i, j)
            if p is None:
                continue
            D, A = p
            cand = min(xi + 2 * d * A, kmax[i + 1], v2[j])
            if cand >= max(0.0, xi + 2 * d * D) - 1e-12 and cand > best[0]:
                best = (cand, j)
            if cand < v2[j]:
                break
        if best[1] < 0 or (best[0] <= 0 and i < K - 1):
            return _infeasible(s, "the coils cannot push the rotor through the bias at the speed it has", s[i])
        x[i + 1], band[i] = max(best[0], 0.0), best[1]
    x[0] = x[-1] = 0.0
    sdd = np.diff(x) / (2 * ds)
    bounds = np.array([piece(i, j) for i, j in enumerate(band)])
    tol = _TOL * (1.0 + np.abs(bounds).max(axis=1))
    if np.any(sdd < bounds[:, 0] - tol) or np.any(sdd > bounds[:, 1] + tol):
        k = int(np.flatnonzero((sdd < bounds[:, 0] - tol) | (sdd > bounds[:, 1] + tol))[0])
        return _infeasible(s, "no acceleration within reach at the speed the profile has there", s[k])
    sd = np.sqrt(x)
    dt = 2 * ds / (sd[:-1] + sd[1:])
    return PhasePlane(s, x, sdd, np.concatenate([[0.0], np.cumsum(dt)]), True)


def _grid(angle: float, step: float, pieces: int) -> np.ndarray:
    return np.linspace(0.0, angle, max(pieces, int(math.ceil(angle / step))) + 1)


def geodesic_intervals(model, start, axis, angle: float, limits: DriveLimits | None = None, *,
                       scale: float = 1.0, speed: float = 0.0, step: float = GRID_STEP, pieces: int = MIN_PIECES):
    """``(s (K+1,) rad, y₋, y₊ (K+1,) N·m)`` along ``exp(s n) R₀``, ``s ∈ [0, angle]`` (``angle`` ≥ 0): the range of
    ``I s̈ + b_d ṡ`` the coils within ``scale`` of their limits give at each grid point at every speed up to
    ``speed`` (:func:`reachable_interval`)."""
    n = checks.axis(axis)
    s = _grid(float(angle), step, pieces)
    R = so3.exp(s[:, None] * n) @ so3.as_rotations(start, "start")
    K = np.asarray(model.torque_matrix(R), dtype=float)
    b = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))), dtype=float)
    lo, hi = reachable_interval(K, b, n, limits, failed=model.failed, scale=scale, speed=speed)
    return s, lo, hi


def _piece(model, Ra, rv, limits, inertia, damping, scale, step, pieces, levels, cache, headroom):
    """The time-optimal law for the geodesic piece ``exp(s r̂) Ra``, ``s ∈ [0, |rv|]``, the acceleration bounds
    in the speed bands ``levels`` (:func:`banded_phase_plane`, intervals by :func:`reachable_interval` on demand):
    ``(axis, angle, phase, (s, K, b))``."""
    angle = float(np.linalg.norm(rv))
    n = rv / angle
    key = (Ra.round(12).tobytes(), n.round(12).tobytes(), round(angle, 12))
    if key not in cache:
        s = _grid(angle, step, pieces)
        R = so3.exp(s[:, None] * n) @ Ra
        K = np.asarray(model.torque_matrix(R), dtype=float)
        b = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))), dtype=float)
        memo: dict = {}

        def interval(i, j):
            if (i, j) not in memo:
                lo, hi = reachable_interval(K[i:i + 1], b[i:i + 1], n, limits, failed=model.failed, scale=scale,
                                            speed=levels[j], headroom=headroom)
                memo[i, j] = (float(lo[0]) / inertia, float(hi[0]) / inertia)
            return memo[i, j]

        cache[key] = (n, angle, banded_phase_plane(s, levels, interval, damping / inertia), (s, K, b))
    return cache[key]


@dataclass(frozen=True)
class FastestTurn:
    """The fastest turn found: ``trajectory`` (a :class:`Trajectory` of :class:`TimeLaw` pieces), ``path``
    (``"geodesic"`` or a detour's description), ``waypoints (W, 3, 3)`` (where it rests, ends included),
    ``margin``; ``candidates``: ``(path, time s or None, reason)`` for every path tried, in order."""

    trajectory: Trajectory
    path: str
    waypoints: np.ndarray
    margin: float
    candidates: tuple[tuple[str, float | None, str], ...]

    @property
    def duration(self) -> float:
        return self.trajectory.duration

    def to_dict(self, degrees: bool = True) -> dict:
        return {"duration_s": self.duration, "path": self.path, "margin": self.margin,
                "waypoints": len(self.waypoints),
                "pieces": [seg.to_dict(degrees) for seg in self.trajectory.segments],
                "candidates": [{"path": p, "time_s": t, "reason": r} for p, t, r in self.candidates]}


def _chain(model, waypoints, limits, inertia, damping, scale, step, pieces, speed, cache, headroom=0.0, smooth=0.0):
    """Time-optimal pieces through ``waypoints``, at rest at each; ``(segments or None, reason, where)``."""
    segs, t0 = [], 0.0
    for Ra, _, rv in waypoints:
        n, angle, pp, intervals = _piece(model, Ra, rv, limits, inertia, damping, scale, step, pieces, speed, cache,
                                         headroom)
        if not pp.feasible:
            return None, pp.reason, pp.where, intervals
        law = TimeLaw(Ra, n, angle, t0, pp.times, pp.s, np.sqrt(pp.x), pp.sdd)
        if smooth > 0:
            law = smoothed(law, smooth * limits.time_constant)
        segs.append(law)
        t0 += law.duration
    return tuple(segs), "", math.nan, None


def smoothed(law: TimeLaw, width: float, step: float = 2.5e-4) -> TimeLaw:
    """``law`` with its position averaged over a moving window of ``width`` s: ``s_w(t) = (1/w) ∫_{t−w}^t s``
    (``s`` = 0 before the law, its angle after), so ``ṡ_w(t) = (s(t) − s(t − w))/w`` and ``s̈_w`` is ``s̈``
    averaged over the window: the acceleration (hence the coils' currents) moves at most ``|Δs̈|/w`` per second
    instead of jumping, and the turn lasts ``w`` longer, still rest to rest. Tabulated at ``step`` s (constant
    acceleration per step, speeds exact at the knots, positions integrated and scaled to end at the angle)."""
    T = law.duration + width
    t = np.linspace(0.0, T, max(2, int(math.ceil(T / step))) + 1)
    s_now = law.profile(law.t0 + t)[0]
    s_then = np.where(t >= width, law.profile(law.t0 + t - width)[0], 0.0)
    sd = np.maximum((s_now - s_then) / width, 0.0)
    sd[0] = sd[-1] = 0.0
    dt = np.diff(t)
    pos = np.concatenate([[0.0], np.cumsum(0.5 * dt * (sd[:-1] + sd[1:]))])
    k = law.angle / pos[-1]
    return TimeLaw(law.start, law.axis, law.angle, law.t0, t, pos * k, sd * k, np.diff(sd) * k / dt)


def _check(model, limits, inertia, damping, margin) -> tuple[float, float, float]:
    from ..statics import TorqueModel

    if not isinstance(model, TorqueModel):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    if limits is not None and not isinstance(limits, DriveLimits):
        raise bad_value("limits", "a spherestep.control.DriveLimits", type(limits).__name__)
    return (checks.positive(inertia, "inertia"), checks.non_negative(damping, "damping"),
            checks.number(margin, "margin", low=0.0, high=1.0, low_open=True, expected="a fraction in (0, 1]"))


def fastest_turn(model, start, axis, angle: float, inertia: float, limits: DriveLimits | None = None, *,
                 margin: float | None = None, damping: float = 0.0, speed: float | None = None,
                 step: float = GRID_STEP, pieces: int = MIN_PIECES, detours: bool = True,
                 top_speed: float | None = None, headroom: float | None = None, smooth: float | None = None
                 ) -> FastestTurn:
    """The fastest rest-to-rest turn of ``angle`` (rad) about the fixed ``axis`` from ``start`` whose feed-forward
    torque ``I α + b_d ω − b(R)`` the coils give within ``margin`` of their limits all along (see the module): the
    turn itself if feasible, else the fastest detour found; :class:`FastestTurn`. Default margin: ``MARGIN`` (0.7)
    if the turn itself is feasible within it, else the turn itself within ``TURN_MARGIN`` (0.9), else the detours
    within 0.7, then 0.9 (``FastestTurn.margin`` says which).
    Speeds up to ``top_speed × v₀`` (default ``TOP_SPEED`` = 2; :func:`speed_levels`) and ``speed`` if given.
    ``headroom`` (default ``HEADROOM``, 0.08) the share of each coil's back-EMF also kept off the feed-forward's
    voltage for ``L di/dt``, and ``smooth`` (default ``SMOOTH``, 2) the window, in multiples of ``L/R``, the time
    law is averaged over (:func:`smoothed`); both 0 for the bare time-optimal law (the bound's).
    Raises an ``InputError`` naming ``axis`` when no path tried is feasible."""
    I, bd, fixed = _check(model, limits, inertia, damping, MARGIN if margin is None else margin)
    margins = (fixed,) if margin is not None else (MARGIN, TURN_MARGIN)
    margin = fixed
    n = checks.axis(axis)
    theta = checks.number(angle, "angle", expected="a finite angle in radians")
    if speed is not None:
        speed = checks.positive(speed, "speed")
    if theta < 0:
        n, theta = -n, -theta
    R0 = so3.as_rotations(start, "start")
    if R0.shape != (3, 3):
        raise bad_value("start", "one rotation matrix of shape (3, 3)", f"shape {R0.shape}")
    end = so3.exp(theta * n) @ R0
    if theta == 0:
        law = TimeLaw(R0, n, 0.0, 0.0, np.zeros(2), np.zeros(2), np.zeros(2), np.zeros(1))
        return FastestTurn(Trajectory((law,)), "geodesic", np.stack([R0, R0]), margin, (("geodesic", 0.0, ""),))
    limits = DriveLimits() if limits is None else limits
    top = TOP_SPEED if top_speed is None else checks.positive(top_speed, "top_speed")
    headroom = HEADROOM if headroom is None else checks.non_negative(headroom, "headroom")
    smooth = SMOOTH if smooth is None else checks.non_negative(smooth, "smooth")
    levels = speed_levels(model, R0, n, theta, limits, top, speed)
    tried: list = []
    caches: dict = {m: {} for m in margins}
    best = None
    # the geodesic at each margin, then the detours at each: a margin above MARGIN only where the detent forces it
    for around in (False, True) if detours else (False,):
        for m in margins:
            if best is None:
                mark = len(tried)
                best = _fastest_at(model, R0, n, theta, end, limits, I, bd, m, step, pieces, levels, around,
                                   tried, caches[m], headroom, smooth)
                if len(margins) > 1:
                    tried[mark:] = [(f"{p} (margin {m:g})", T, r) for p, T, r in tried[mark:]]
                margin = m
    if best is None:
        reason = tried[0][2] if tried else ""
        raise bad_value("axis", "a turn whose torque the coils can give along the path" +
                        (" or a detour around it" if detours else ""), f"{reason} ({len(tried)} paths tried)")
    return FastestTurn(Trajectory(best[1]), best[2], best[3], margin, tuple(tried))


SPEED_BANDS = 24  # speed levels of the phase plane's bands
TOP_SPEED = 2.0  # × v₀: the planner's fastest band (the honest box caps the speed before it)
TURN_MARGIN = 0.9  # the feed-forward's share where the detent forbids the turn itself at MARGIN (module docstring)
HEADROOM = 0.08  # the supply voltage kept for the coils' L di/dt: this share of each coil's back-EMF (module docstring)
SMOOTH = 2.0  # × L/R: the window the time law's position is averaged over (module docstring)
BOUND_SPEED = 2.0  # × v₀: the bound's fastest band (that coil's back-EMF twice the supply)


def speed_levels(model, start, axis, angle: float, limits: DriveLimits, top: float, speed: float | None = None,
                 samples: int = 24) -> tuple[float, ...]:
    """The phase plane's speed levels (rad/s): ``SPEED_BANDS`` equal steps up to ``top × v₀`` (or ``speed``, the
    caller's cap, if lower), ``v₀ = V/(R I_n) / median_s max_k |g_k(s)|`` the speed at which the back-EMF of the
    coil most aligned with the turn, in the median orientation of the path, equals the supply
    (:func:`current_box`)."""
    s = np.linspace(0.0, angle, samples)
    R = so3.exp(s[:, None] * axis) @ start
    g = np.abs(np.einsum("man,a->mn", np.asarray(model.torque_matrix(R), float), axis))
    g *= limits.emf_factor
    v0 = limits.voltage_bound / float(np.median(g.max(axis=1)))
    cap = top * v0 if speed is None else min(speed, top * v0)
    return tuple(cap * (j + 1) / SPEED_BANDS for j in range(SPEED_BANDS))


def _fastest_at(model, R0, n, theta, end, limits, I, bd, margin, step, pieces, levels, detours, tried, cache,
                headroom=0.0, smooth=0.0):
    """In the speed bands ``levels``: the geodesic (``detours`` False) or the detours around its infeasible
    stretch: ``(T, segments, label, W)`` of the fastest feasible, or ``None``; appends every path to ``tried``."""
    args = (limits, I, bd, margin, step, pieces, levels, cache, headroom, smooth)
    cap = ""
    segs, reason, where, intervals = _chain(model, [(R0, end, theta * n)], *args)
    T = None if segs is None else segs[-1].t0 + segs[-1].duration
    if not detours:
        tried.append(("geodesic" + cap, T, reason))
        return None if segs is None else (T, segs, "geodesic" + cap, np.stack([R0, end]))
    if segs is not None:
        return None
    s, K, b = intervals
    lo, hi = reachable_interval(K, b, n, limits, failed=model.failed, scale=margin)
    sa, sb = _bad_stretch(s, lo, hi, where)
    sm = 0.5 * (sa + sb)
    e1 = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    Pa, Pm, Pb = (so3.exp(x * n) @ R0 for x in (sa, sm, sb))
    best = None
    for tilt in DETOUR_TILTS:  # the smallest tilt with a feasible detour: its fastest direction
        if best is not None:
            break
        for k in range(DETOUR_DIRECTIONS):
            phi = 2 * math.pi * k / DETOUR_DIRECTIONS
            m = math.cos(phi) * e1 + math.sin(phi) * e2
            W = [R0] * (sa > 0) + [Pa, so3.exp(tilt * m) @ Pm, Pb] + [end] * (sb < theta)
            legs = [(Wa, Wb, so3.log(Wb @ Wa.T)) for Wa, Wb in zip(W[:-1], W[1:])]
            if sa > 0:
                legs[0] = (R0, Pa, sa * n)
            if sb < theta:
                legs[-1] = (Pb, end, (theta - sb) * n)
            label = (f"detour: rest at {math.degrees(sa):.1f}°, {math.degrees(tilt):.0f}° off the axis at "
                     f"{math.degrees(sm):.1f}° (direction {math.degrees(phi):.0f}°), rest at "
                     f"{math.degrees(sb):.1f}°" + cap)
            segs, reason, _, _ = _chain(model, legs, *args)
            T = None if segs is None else segs[-1].t0 + segs[-1].duration
            tried.append((label, T, reason))
            if T is not None and (best is None or T < best[0]):
                best = (T, segs, label, np.stack(W))
    return best


def _bad_stretch(s, lo, hi, where):
    """The rest points ``(s_a, s_b)`` (rad) around the stretch of the turn where the coils cannot hold the rotor
    against the bias (``0 ∉ [y₋, y₊]``) nearest ``where`` (rad): stretches closer than ``DETOUR_PAD`` merged, then
    ``DETOUR_PAD`` beyond it, moved further out to the nearest point where the coils hold (the path's ends if
    none)."""
    can = (lo <= 0) & (0 <= hi)
    k = int(np.argmin(np.abs(s - where)))
    a = b = k
    while True:  # grow over every cannot-hold point within DETOUR_PAD of the stretch
        near = np.flatnonzero(~can & (s >= s[a] - DETOUR_PAD) & (s <= s[b] + DETOUR_PAD))
        na, nb = (min(a, int(near.min())), max(b, int(near.max()))) if len(near) else (a, b)
        if (na, nb) == (a, b):
            break
        a, b = na, nb
    a = int(np.searchsorted(s, s[a] - DETOUR_PAD))
    b = int(np.searchsorted(s, s[b] + DETOUR_PAD, side="right")) - 1
    while a > 0 and not can[a]:
        a -= 1
    while b < len(s) - 1 and not can[b]:
        b += 1
    return float(s[a]), float(s[b])


def fastest_time(model, start, axis, angle: float, inertia: float, limits: DriveLimits | None = None, *,
                 damping: float = 0.0, speed: float | None = None, step: float = GRID_STEP,
                 pieces: int = MIN_PIECES) -> float:
    """The bang-bang bound with the bias: the least rest-to-rest time (s) of the turn along its own path with the
    coils at their full limits (:func:`fastest_turn` with ``margin = 1``, no detour, speeds up to ``BOUND_SPEED ×
    v₀``); ``inf`` if even that is infeasible."""
    try:
        return fastest_turn(model, start, axis, angle, inertia, limits, margin=1.0, damping=damping, speed=speed,
                            step=step, pieces=pieces, detours=False, top_speed=BOUND_SPEED, headroom=0.0,
                            smooth=0.0).duration
    except InputError as error:
        if error.field != "axis":
            raise
        return math.inf
