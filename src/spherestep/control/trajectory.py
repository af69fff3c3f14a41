"""Trajectories on SO(3) in time: rest-to-rest turns about fixed axes with trapezoidal speed profiles.

A segment turns the rotor from ``R₀`` about the fixed unit axis ``n`` by ``θ``: ``R(t) = exp(s(t) [n]×) R₀``, so
the angular velocity (fixed frame) is ``ω = ṡ n`` and the angular acceleration ``α = s̈ n``. ``s(t)`` is the
trapezoidal profile: constant acceleration ``a`` up to the speed ``v`` (or to the midpoint, a triangle, when
``θ < v²/a``), cruise, constant deceleration ``a`` to rest. It is the time-optimal rest-to-rest profile under
``|s̈| ≤ a``, ``|ṡ| ≤ v`` (bang–coast–bang). It is *not* jerk-limited: the torque steps at the profile's corners,
which the coils follow within a few electrical time constants (``L/R`` ≈ 0.8 ms).
A path through waypoints is a chain of such segments, each along the geodesic between consecutive waypoints
(the rotor stops at each waypoint).

The acceleration comes from the torque the drive guarantees along the path: ``a = margin · min_path r(R) / I``
with ``r`` the torque available in every direction (:func:`~spherestep.control.capability.available_torque`),
sampled at the segment's orientations; the rest (``1 − margin``) is left to the feedback. For a rotor of
isotropic inertia ``I`` (the paper's balanced ball) the gyroscopic torque ``ω × Iω`` vanishes and the
feed-forward torque is ``I α``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .capability import available_torque, feasible_support
from ..electrics import DriveLimits

MARGIN = 0.7  # share of the guaranteed torque the trajectory may use; the rest is the feedback's


@dataclass(frozen=True)
class Segment:
    """One rest-to-rest turn: from ``start (3, 3)`` about ``axis (3,)`` by ``angle`` (rad, ≥ 0) beginning at
    ``t0`` (s); ``acceleration`` (rad/s²), ``peak_speed`` (rad/s, reached), ``ramp`` and ``cruise`` (s)."""

    start: np.ndarray
    axis: np.ndarray
    angle: float
    t0: float
    acceleration: float
    peak_speed: float
    ramp: float
    cruise: float

    @property
    def duration(self) -> float:
        return 2.0 * self.ramp + self.cruise

    @property
    def end(self) -> np.ndarray:
        return so3.exp(self.angle * self.axis) @ self.start

    def profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, ṡ, s̈)`` at times ``t`` (s, absolute), clamped to rest before and after the segment."""
        tau = np.clip(np.asarray(t, dtype=float) - self.t0, 0.0, self.duration)
        a, v, ta, tc = self.acceleration, self.peak_speed, self.ramp, self.cruise
        up, coast = tau < ta, tau < ta + tc
        down = self.duration - tau
        s = np.where(up, 0.5 * a * tau ** 2, np.where(coast, 0.5 * a * ta ** 2 + v * (tau - ta),
                                                       self.angle - 0.5 * a * down ** 2))
        sd = np.where(up, a * tau, np.where(coast, v, a * down))
        inside = (np.asarray(t) - self.t0 >= 0) & (np.asarray(t) - self.t0 < self.duration)
        sdd = np.where(inside, np.where(up, a, np.where(coast, 0.0, -a)), 0.0)
        return s, sd, sdd

    def profile_at(self, t: float) -> tuple[float, float, float]:
        """:meth:`profile` at one time ``t`` (s) in Python floats (the control loop's path; same formulas)."""
        a, v, ta, tc, T = self.acceleration, self.peak_speed, self.ramp, self.cruise, self.duration
        tau = min(max(t - self.t0, 0.0), T)
        if tau < ta:
            s, sd, sdd = 0.5 * a * tau ** 2, a * tau, a
        elif tau < ta + tc:
            s, sd, sdd = 0.5 * a * ta ** 2 + v * (tau - ta), v, 0.0
        else:
            down = T - tau
            s, sd, sdd = self.angle - 0.5 * a * down ** 2, a * down, -a
        return s, sd, (sdd if 0.0 <= t - self.t0 < T else 0.0)


def segment(start, axis, angle: float, acceleration: float, speed: float | None = None, t0: float = 0.0) -> Segment:
    """A trapezoidal turn (see the module); a negative ``angle`` turns about ``−axis``."""
    n = checks.axis(axis)
    if not math.isfinite(angle):
        raise bad_value("angle", "a finite angle in radians", angle)
    if angle < 0:
        n, angle = -n, -angle
    a = checks.positive(acceleration, "acceleration")
    v = math.inf if speed is None else checks.positive(speed, "speed")
    if angle * a <= v * v:  # triangle
        ta = math.sqrt(angle / a)
        return Segment(so3.as_rotations(start, "start"), n, float(angle), float(t0), a, a * ta, ta, 0.0)
    return Segment(so3.as_rotations(start, "start"), n, float(angle), float(t0), a, v, v / a, angle / v - v / a)


@dataclass(frozen=True)
class TimeLaw:
    """A rest-to-rest turn from ``start (3, 3)`` about ``axis (3,)`` by ``angle`` (rad, ≥ 0), beginning at ``t0``
    (s), along a tabulated time law (:mod:`.time_optimal`): knots ``times (K+1,)`` (s, from ``t0``),
    ``positions (K+1,)`` (rad, 0 … ``angle``), ``speeds (K+1,)`` (rad/s, 0 at both ends) and a constant
    acceleration per piece ``accelerations (K,)`` (rad/s²), so that in piece ``i``
    ``s = s_i + ṡ_i τ + ½ s̈_i τ²``, ``ṡ = ṡ_i + s̈_i τ`` (``τ = t − t0 − t_i``): ``s`` is C¹, ``s̈`` exact."""

    start: np.ndarray
    axis: np.ndarray
    angle: float
    t0: float
    times: np.ndarray
    positions: np.ndarray
    speeds: np.ndarray
    accelerations: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @property
    def end(self) -> np.ndarray:
        return so3.exp(self.angle * self.axis) @ self.start

    def profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(s, ṡ, s̈)`` at times ``t`` (s, absolute), clamped to rest before and after the segment."""
        rel = np.asarray(t, dtype=float) - self.t0
        tau = np.clip(rel, 0.0, self.duration)
        i = np.clip(np.searchsorted(self.times, tau, side="right") - 1, 0, len(self.accelerations) - 1)
        d = tau - self.times[i]
        a = self.accelerations[i]
        s = np.minimum(self.positions[i] + self.speeds[i] * d + 0.5 * a * d * d, self.angle)
        sd = np.maximum(self.speeds[i] + a * d, 0.0)
        sdd = np.where((rel >= 0) & (rel < self.duration), a, 0.0)
        return s, sd, sdd

    def profile_at(self, t: float) -> tuple[float, float, float]:
        """:meth:`profile` at one time ``t`` (s) in Python floats."""
        s, sd, sdd = self.profile(np.array([float(t)]))
        return float(s[0]), float(sd[0]), float(sdd[0])

    def to_dict(self, degrees: bool = True) -> dict:
        f = math.degrees if degrees else float
        unit = "deg" if degrees else "rad"
        return {"axis": self.axis.tolist(), f"angle_{unit}": f(self.angle), "t0_s": self.t0,
                "duration_s": self.duration, f"peak_speed_{unit}_per_s": f(float(self.speeds.max())),
                "pieces": len(self.accelerations)}


@dataclass(frozen=True)
class Trajectory:
    """A chain of :class:`Segment` (trapezoidal) or :class:`TimeLaw` (tabulated) turns about fixed axes, each
    starting where the previous ends, at rest."""

    segments: tuple[Segment | TimeLaw, ...]

    @property
    def duration(self) -> float:
        last = self.segments[-1]
        return last.t0 + last.duration

    @property
    def start(self) -> np.ndarray:
        return self.segments[0].start

    @property
    def end(self) -> np.ndarray:
        return self.segments[-1].end

    def sample(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(R (..., 3, 3), ω (..., 3) rad/s, α (..., 3) rad/s²)`` at times ``t`` (s); before the start the
        rotor rests at the start, after the end at the end."""
        t = np.asarray(t, dtype=float)
        starts = np.array([s.t0 for s in self.segments])
        idx = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.segments) - 1)
        R = np.empty(t.shape + (3, 3))
        w = np.empty(t.shape + (3,))
        a = np.empty(t.shape + (3,))
        for k, seg in enumerate(self.segments):
            m = idx == k
            if not np.any(m):
                continue
            s, sd, sdd = seg.profile(t[m])
            R[m] = so3.exp(s[..., None] * seg.axis) @ seg.start
            w[m] = sd[..., None] * seg.axis
            a[m] = sdd[..., None] * seg.axis
        return R, w, a

    def at(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`sample` at one time ``t`` (s): ``(R (3, 3), ω (3,), α (3,))``, without the batch overhead."""
        segs = self.segments
        k = len(segs) - 1
        while k > 0 and segs[k].t0 > t:
            k -= 1
        seg = segs[k]
        s, sd, sdd = seg.profile_at(float(t))
        n = seg.axis
        return so3.exp(s * n) @ seg.start, sd * n, sdd * n

    @classmethod
    def hold(cls, R) -> Trajectory:
        """The zero-length trajectory that rests at ``R (3, 3)``: ``(R, 0, 0)`` at every time."""
        R = so3.as_rotations(R, "R")
        if R.shape != (3, 3):
            raise bad_value("R", "one rotation matrix of shape (3, 3)", f"shape {R.shape}")
        return cls((segment(R, [0.0, 0.0, 1.0], 0.0, 1.0),))

    @classmethod
    def turn(cls, start, axis, angle: float, acceleration: float, speed: float | None = None) -> Trajectory:
        """One trapezoidal turn of ``angle`` (rad) about the fixed ``axis`` from ``start``."""
        return cls((segment(start, axis, angle, acceleration, speed),))

    @classmethod
    def through(cls, waypoints, acceleration: float, speed: float | None = None) -> Trajectory:
        """Geodesic segments through ``waypoints (W, 3, 3)`` (``W ≥ 2``), at rest at each."""
        W = so3.as_rotations(waypoints, "waypoints")
        if W.ndim != 3 or len(W) < 2:
            raise bad_value("waypoints", "at least two rotations, shape (W, 3, 3)", f"shape {W.shape}")
        segs, t0 = [], 0.0
        for Ra, Rb in zip(W[:-1], W[1:]):
            rv = so3.log(Rb @ Ra.T)
            angle = float(np.linalg.norm(rv))
            if angle == 0:
                continue
            seg = segment(Ra, rv, angle, acceleration, speed, t0)
            segs.append(seg)
            t0 += seg.duration
        if not segs:
            raise bad_value("waypoints", "at least two different orientations", "all equal")
        return cls(tuple(segs))


def path_capability(model, start, axis, angle: float, limits: DriveLimits | None = None, samples: int = 48
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Along the turn ``exp(s n) R₀``, ``s ∈ [0, θ]`` (``samples`` points): the torque available in every
    direction ``r`` (N·m) and the largest torques about ``+n`` and ``−n`` (the support ``h_S(±n)``, N·m)."""
    limits = DriveLimits() if limits is None else limits
    n = checks.axis(axis)
    s = np.linspace(0.0, float(angle), samples)
    R = so3.exp(s[:, None] * n) @ so3.as_rotations(start, "start")
    K = np.asarray(model.torque_matrix(R), dtype=float)
    bias = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))), dtype=float)
    r = available_torque(K, limits, bias=bias, failed=model.failed)[0]
    u = np.full(K.shape[-1], limits.per_unit_bound)
    if len(model.failed):
        u[list(model.failed)] = 0.0
    rho = limits.per_unit_power_radius
    plus = feasible_support(np.einsum("kan,a->kn", K, n), u, rho)[0] + bias @ n
    minus = feasible_support(np.einsum("kan,a->kn", K, -n), u, rho)[0] - bias @ n
    return r, plus, minus


def plan_turn(model, start, axis, angle: float, inertia: float, limits: DriveLimits | None = None, *,
              margin: float | None = None, damping: float = 0.0, speed: float | None = None, samples: int = 48,
              headroom: float | None = None) -> Trajectory:
    """The fastest rest-to-rest turn whose feed-forward torque ``I α + b ω − b(R)`` the coils give within
    ``margin`` (default :data:`~spherestep.control.time_optimal.TURN_MARGIN`, 0.9; ``MARGIN`` for a plan robust
    to a model error of ~15 %) of their limits all along the path, on any core (the iron's detent included): the
    turn about ``axis`` itself, or a detour through waypoints where the coils cannot hold against the detent
    (:func:`spherestep.control.time_optimal.fastest_turn`, whose :class:`FastestTurn` says which path and what
    was tried; at least ``samples`` grid pieces, ``speed`` caps ``|ω|``, ``headroom`` the share of each coil's
    back-EMF kept off the feed-forward's voltage, default ``HEADROOM``). Raises an ``InputError`` naming ``axis``
    when no path tried is feasible."""
    from .time_optimal import fastest_turn

    return fastest_turn(model, start, axis, angle, inertia, limits, margin=margin, damping=damping, speed=speed,
                        pieces=checks.count(samples, "samples", 2), headroom=headroom).trajectory


def plan_trapezoid(model, start, axis, angle: float, inertia: float, limits: DriveLimits | None = None, *,
                   margin: float = MARGIN, damping: float = 0.0, speed: float | None = None, samples: int = 48
                   ) -> Trajectory:
    """The fastest trapezoidal turn whose feed-forward torque ``I α + b ω`` stays within ``margin`` of the torque
    guaranteed in every direction along the path, ``τ_g = margin · min r`` (see the module; refuses a path where
    the bias exceeds what the coils can cancel: :func:`plan_turn` handles it). Without damping
    ``a = τ_g/I`` and no speed limit (a triangle unless ``speed`` is given); with viscous damping ``b`` the
    cruise speed ``v`` and acceleration ``a = (τ_g − b v)/I`` minimise ``T = θ/v + v/a``."""
    if not 0 < margin <= 1:
        raise bad_value("margin", "a fraction in (0, 1]", margin)
    if not (math.isfinite(damping) and damping >= 0):
        raise bad_value("damping", "a non-negative viscous damping (N·m·s/rad)", damping)
    I = checks.positive(inertia, "inertia")
    r = path_capability(model, start, axis, angle, limits, samples)[0]
    guaranteed = margin * float(r.min())
    if guaranteed <= 0:
        raise bad_value("axis", "a turn along which the drive can give torque in every direction",
                        f"{float(r.min()):.3g} N·m available")
    if damping == 0:
        return Trajectory.turn(start, axis, angle, guaranteed / I, speed)
    from scipy.optimize import minimize_scalar

    theta = abs(float(angle))
    v_top = guaranteed / damping if speed is None else min(speed, guaranteed / damping)
    best = minimize_scalar(lambda v: theta / v + v * I / (guaranteed - damping * v), bounds=(1e-6 * v_top,
                           (1 - 1e-6) * v_top), method="bounded", options={"xatol": 1e-9 * v_top})
    v = float(best.x)
    return Trajectory.turn(start, axis, angle, (guaranteed - damping * v) / I, v)


def plan_through(model, waypoints, inertia: float, limits: DriveLimits | None = None, *, margin: float = MARGIN,
                 samples: int = 24) -> Trajectory:
    """Geodesic segments through ``waypoints (W, 3, 3)``, at rest at each, with one acceleration
    ``a = margin · min r / I`` from the torque guaranteed along every segment (``samples`` orientations each)."""
    if not 0 < margin <= 1:
        raise bad_value("margin", "a fraction in (0, 1]", margin)
    W = so3.as_rotations(waypoints, "waypoints")
    if W.ndim != 3 or len(W) < 2:
        raise bad_value("waypoints", "at least two rotations, shape (W, 3, 3)", f"shape {W.shape}")
    least = math.inf
    for Ra, Rb in zip(W[:-1], W[1:]):
        rv = so3.log(Rb @ Ra.T)
        angle = float(np.linalg.norm(rv))
        if angle > 0:
            least = min(least, float(path_capability(model, Ra, rv, angle, limits, samples)[0].min()))
    if not least > 0:
        raise bad_value("waypoints", "a path along which the drive can give torque in every direction",
                        f"{least:.3g} N·m available")
    return Trajectory.through(W, margin * least / checks.positive(inertia, "inertia"))


def bang_bang_time(model, start, axis, angle: float, inertia: float, limits: DriveLimits | None = None,
                   samples: int = 48, *, damping: float = 0.0) -> float:
    """The least rest-to-rest time (s) of the turn along its own path, ``exp(s n) R₀``, with the coils at their
    full limits and the bias (detent) included: the time-optimal law of :mod:`.time_optimal` with margin 1
    (:func:`~spherestep.control.time_optimal.fastest_time`, at least ``samples`` grid pieces); ``inf`` if the coils
    cannot take the rotor along that path at all. :func:`plan_turn` at margin 1 on the same path takes this time."""
    from .time_optimal import fastest_time

    return fastest_time(model, start, axis, angle, inertia, limits, damping=damping,
                        pieces=checks.count(samples, "samples", 2))


def voltage_shortfall(model, start, axis, angle: float, inertia: float, duration: float,
                      limits: DriveLimits | None = None, samples: int = 72):
    """Where the triangle turn of ``duration`` (s) (acceleration ``4θ/T²``, peak ``2θ/T``) asks a torque that the
    coils give at rest but not at its speed: the first ``(s rad, ṡ rad/s, I s̈ N·m, (y₋, y₊) N·m)`` of ``samples``
    points along ``exp(s n) R₀`` where ``I s̈`` is outside the range the coils give at every speed up to ``ṡ``
    within the supply against their back-EMF (:func:`~spherestep.control.time_optimal.reachable_interval`) and
    inside the range at rest; ``None`` where the back-EMF allows the whole profile. (A torque the coils cannot give
    even at rest — the iron's detent across the path — is not the supply's limit; the planner detours there.)"""
    from .time_optimal import reachable_interval

    limits = DriveLimits() if limits is None else limits
    n = checks.axis(axis)
    theta = abs(float(angle))
    T = checks.positive(duration, "duration")
    a = 4.0 * theta / T ** 2
    s = np.linspace(0.0, theta, samples)
    speed = np.sqrt(2.0 * a * np.minimum(s, theta - s))
    need = np.where(s < theta / 2, inertia * a, -inertia * a)
    R = so3.exp(s[:, None] * n * math.copysign(1.0, angle)) @ so3.as_rotations(start, "start")
    d = n * math.copysign(1.0, angle)
    K = np.asarray(model.torque_matrix(R), dtype=float)
    b = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))), dtype=float)
    lo0, hi0 = reachable_interval(K, b, d, limits, failed=model.failed)
    for m in np.flatnonzero((lo0 <= need) & (need <= hi0)):
        lo, hi = reachable_interval(K[m:m + 1], b[m:m + 1], d, limits, failed=model.failed, speed=float(speed[m]))
        if not lo[0] <= need[m] <= hi[0]:
            return float(s[m]), float(speed[m]), float(need[m]), (float(lo[0]), float(hi[0]))
    return None


def triangle_time(model, start, axis, angle: float, inertia: float, duration: float,
                  limits: DriveLimits | None = None, *, tolerance: float = 0.05, samples: int = 72) -> float:
    """The shortest triangle-turn time (s, within ``tolerance``) from ``duration`` up that
    :func:`voltage_shortfall` allows: ``duration`` itself if it does, else bisection between the last time it
    refused and the first of ``duration · 1.5^k`` it allows (``inf`` past 16× ``duration``)."""
    def ok(T: float) -> bool:
        return voltage_shortfall(model, start, axis, angle, inertia, T, limits, samples) is None

    if ok(duration):
        return float(duration)
    low, high = float(duration), float(duration) * 1.5
    while not ok(high):
        low, high = high, high * 1.5
        if high > 16 * duration:
            return math.inf
    while high - low > tolerance:
        mid = 0.5 * (low + high)
        low, high = (low, mid) if ok(mid) else (mid, high)
    return high
