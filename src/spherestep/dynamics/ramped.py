"""Ramped relay stepping: the plan's relay steps at a step rate that ramps up, cruises and ramps down, the rotor
carried from well to well by its momentum instead of settling in each.

Step-rate profile (the classic stepper ramp, constant acceleration in steps): after ``p`` steps the rate is
``f_p = min(√(f₀² + 2 A p), f_max, √(f₀² + 2 A (n − 1 − p)))`` (steps/s) — accelerate from ``f₀``, cruise at
``f_max``, decelerate symmetrically into the last step; step ``p + 1`` is energised ``1/f_p`` after step ``p``.
``A`` is chosen so the ramp reaches ``f_max`` in ``ramp_steps`` steps: ``A = (f_max² − f₀²)/(2 ramp_steps)``.
After the last step its coils stay on for ``settle`` seconds.

A step is *lost* when, at the moment the next step is energised, the rotor is more than two of the design's
largest steps (``2 design.max_step``: it has slipped to another pairing of poles rather than lagging behind
a step it is still carried into) from the orientation of the step it should be in, or when the rotor does not
end within ``tolerance`` (0.5°) of the plan's last state (a 360° turn ends where it began, so the end alone
would not catch a rotor that never moved). The pull-out rate is the highest cruise rate with no lost step
(:func:`pull_out_rate`: a sweep, then bisection).

Power: a relay puts the full supply voltage on each energised coil, ``P = Σ_on V I_n`` (24 W per coil at the
defaults); the coils' current rise (``L/R`` ≈ 0.8 ms) is neglected against step periods of tens of ms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..electrics import DriveLimits
from ..errors import bad_value
from ..motor import coil_currents
from .._fast.threads import single_blas_thread
from .rotor import Integrator, Rotor
from .simulate import EXECUTED_TOL

RAMP_STEPS = 8
START_RATE = 2.0  # steps/s


def step_intervals(n: int, max_rate: float, start_rate: float = START_RATE, ramp_steps: int = RAMP_STEPS
                   ) -> np.ndarray:
    """Time (s) from each of ``n`` steps to the next under the ramp of the module, ``(n,)`` (the last entry is
    the interval after the last step, at the start rate)."""
    if not (math.isfinite(max_rate) and max_rate > 0):
        raise bad_value("max_rate", "a positive step rate (steps/s)", max_rate)
    if not (math.isfinite(start_rate) and 0 < start_rate):
        raise bad_value("start_rate", "a positive step rate (steps/s)", start_rate)
    f0 = min(start_rate, max_rate)
    A = (max_rate ** 2 - f0 ** 2) / (2.0 * max(ramp_steps, 1))
    p = np.arange(n, dtype=float)
    rate = np.minimum.reduce([np.sqrt(f0 ** 2 + 2 * A * p), np.full(n, max_rate),
                              np.sqrt(f0 ** 2 + 2 * A * np.maximum(n - 1 - p, 0.0))])
    return 1.0 / rate


@dataclass(frozen=True)
class RampedSummary:
    """What a ramped run did (:meth:`RampedRun.summary`): ``arrival_time`` (s; ``inf`` when the rotor is not
    within the tolerance of the plan's last state at the end), ``last_step`` (s, when it was energised),
    ``lost_steps``, ``final_error`` to the turn's target and ``max_tracking_error`` to the energised step's state
    (rad), ``peak_power`` and ``mean_power`` (W)."""

    arrival_time: float
    last_step: float
    lost_steps: bool
    final_error: float
    max_tracking_error: float
    peak_power: float
    mean_power: float

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready; angles in degrees (``*_deg``) or radians (``*_rad``); an arrival that never happened is
        ``null``."""
        unit, conv = ("deg", math.degrees) if degrees else ("rad", float)
        return {"arrival_time_s": self.arrival_time if math.isfinite(self.arrival_time) else None,
                "last_step_s": self.last_step, "lost_steps": self.lost_steps,
                f"final_error_{unit}": conv(self.final_error),
                f"max_tracking_error_{unit}": conv(self.max_tracking_error),
                "peak_power_W": self.peak_power, "mean_power_W": self.mean_power}


@dataclass(frozen=True)
class RampedRun:
    """A ramped relay run: ``times (T,)`` s, ``orientations (T, 3, 3)``, ``currents (T, N)`` (per unit, ±1),
    ``step_times (n,)`` when each step was energised, ``lag (n,)`` rad from the rotor to the step it should be in
    when the next one is energised, ``planned (n+1, 3, 3)``, ``target`` the turn's end (3, 3), ``max_step`` and
    ``tolerance`` (rad), ``coil_power`` (W per energised coil)."""

    times: np.ndarray
    orientations: np.ndarray
    currents: np.ndarray
    step_times: np.ndarray
    lag: np.ndarray
    planned: np.ndarray
    target: np.ndarray
    max_step: float
    tolerance: float
    coil_power: float

    @property
    def final_error(self) -> float:
        """Park distance (rad) from the final orientation to the turn's target."""
        return float(so3.distance(self.orientations[-1], self.target))

    @property
    def lost(self) -> bool:
        """A step was lost (see the module)."""
        return bool(np.any(self.lag > 2.0 * self.max_step)) or \
            float(so3.distance(self.orientations[-1], self.planned[-1])) > self.tolerance

    def arrival_time(self) -> float:
        """First time (s) after which the rotor stays within ``tolerance`` of the plan's last state."""
        err = so3.distance(self.orientations, self.planned[-1])
        outside = np.flatnonzero(err > self.tolerance)
        if len(outside) == 0:
            return float(self.times[0])
        if outside[-1] == len(err) - 1:
            return math.inf
        return float(self.times[outside[-1] + 1])

    @property
    def power(self) -> np.ndarray:
        """Electrical power (W) per sample: ``coil_power`` × the number of energised coils."""
        return self.coil_power * np.count_nonzero(self.currents, axis=1)

    @property
    def step_targets(self) -> np.ndarray:
        """``(T, 3, 3)``: per sample, the planned state of the step energised then."""
        return self.planned[np.clip(np.searchsorted(self.step_times, self.times, side="right"), 0,
                                    len(self.planned) - 1)]

    def to_dict(self, degrees: bool = True) -> dict:
        """The :meth:`summary`, JSON-ready (angles in degrees; ``degrees=False`` gives radians)."""
        return self.summary().to_dict(degrees)

    def summary(self) -> RampedSummary:
        """Arrival time and last step (s), lost steps, final error to the turn's target and largest distance to
        the energised step's state (rad), peak and mean power (W)."""
        track = so3.distance(self.orientations, self.step_targets)
        return RampedSummary(self.arrival_time(), float(self.step_times[-1]), self.lost, self.final_error,
                             float(track.max()), float(self.power.max()), float(self.power.mean()))


@single_blas_thread
def run_ramped(design, plan, model, max_rate: float, *, rotor: Rotor, start_rate: float = START_RATE,
               ramp_steps: int = RAMP_STEPS, settle: float = 3.0, dt: float = 0.01,
               limits: DriveLimits | None = None, tolerance: float = EXECUTED_TOL, target=None) -> RampedRun:
    """Run ``plan``'s relay steps on the rotor under ``model`` at the ramp of the module with cruise rate
    ``max_rate`` (steps/s); ``dt`` the longest integration step (each step interval is cut into equal steps no
    longer than ``dt`` nor an eighth of the interval); ``target`` the turn's end (default the plan's last
    target)."""
    limits = DriveLimits() if limits is None else limits
    if not (math.isfinite(settle) and settle >= 0):
        raise bad_value("settle", "a non-negative time in seconds", settle)
    steps = plan.steps[1:]
    intervals = step_intervals(len(steps), max_rate, start_rate, ramp_steps)
    N = plan.coil_count
    R = plan.steps[0].achieved.copy()
    w = np.zeros(3)
    times, Rs, cs, lag, step_times = [np.zeros(1)], [R[None]], [coil_currents(plan.steps[0].coils, N)[None]], [], []
    t0 = 0.0
    for k, (step, span) in enumerate(zip(steps, intervals)):
        if k == len(steps) - 1:
            span = max(settle, span)
        c = coil_currents(step.coils, N)
        n_sub = max(1, int(math.ceil(span / min(dt, span / 8.0))))
        integ = Integrator(model, rotor, span / n_sub)
        step_times.append(t0)
        R, w, t, r = _run(integ, R, w, c, n_sub)
        times.append(t0 + t)
        Rs.append(r)
        cs.append(np.repeat(c[None], len(t), axis=0))
        lag.append(float(so3.distance(R, step.achieved)))
        t0 += span
    target = plan.targets[-1] if target is None else so3.as_rotations(target, "target")
    return RampedRun(np.concatenate(times), np.concatenate(Rs), np.concatenate(cs), np.array(step_times),
                     np.array(lag[:-1] + [0.0]), plan.achieved, target, float(design.max_step), float(tolerance),
                     limits.relay_power)


def _run(integ: Integrator, R, w, c, n_sub: int):
    """``Integrator.run`` for exactly ``n_sub`` steps of its ``dt``, skipping the energy bookkeeping."""
    torque = lambda Rb: integ.model.torque(Rb, c[None])  # noqa: E731
    Rb, wb, tau = R[None], w[None], None
    ts, Rs = [], []
    for n in range(1, n_sub + 1):
        Rb, wb, tau = integ.rotor.step(Rb, wb, torque, integ.dt, tau)
        ts.append(n * integ.dt)
        Rs.append(Rb[0])
    return Rb[0], wb[0], np.array(ts), np.array(Rs)


RATES = (1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 14.0, 20.0, 28.0, 40.0)  # steps/s, the default sweep


@dataclass(frozen=True)
class PullOut:
    """Result of :func:`pull_out_rate`: ``rate`` the highest cruise rate without a lost step (steps/s, ``0`` if
    none), its ``run``, every rate tried with whether it lost a step (``tried``, in the order run) and the run at
    the slowest rate tried (``slowest``: what happened when every rate loses a step)."""

    rate: float
    run: RampedRun | None
    tried: tuple[tuple[float, bool], ...]
    slowest: RampedRun | None = None


def pull_out_rate(design, plan, model, *, rotor: Rotor, rates=RATES, iterations: int = 3, **kwargs) -> PullOut:
    """The highest cruise step rate at which :func:`run_ramped` loses no step: every rate of ``rates`` is run
    (success need not be monotone in the rate: slow irregular steps can shake the rotor loose where fast ones
    average out), then the interval between the fastest success and the next rate tried above it is bisected
    ``iterations`` times (geometric mid-points)."""
    rates = sorted(float(r) for r in rates)
    if not rates or rates[0] <= 0:
        raise bad_value("rates", "positive step rates (steps/s)", rates)
    tried, runs = [], {}
    for rate in rates:
        run = run_ramped(design, plan, model, rate, rotor=rotor, **kwargs)
        tried.append((rate, run.lost))
        runs[rate] = run
    good = [r for r, lost in tried if not lost]
    if not good:
        return PullOut(0.0, None, tuple(tried), runs[rates[0]])
    best = max(good)
    above = [r for r in rates if r > best]
    if above:
        bad = above[0]
        for _ in range(iterations):
            mid = math.sqrt(best * bad)
            run = run_ramped(design, plan, model, mid, rotor=rotor, **kwargs)
            tried.append((mid, run.lost))
            runs[mid] = run
            if run.lost:
                bad = mid
            else:
                best = mid
    return PullOut(best, runs[best], tuple(tried), runs[rates[0]])
