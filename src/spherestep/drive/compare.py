"""The same turn driven every way, side by side: :func:`compare_drives` → :class:`DriveComparison`.

One :class:`~spherestep.drive.turn.Turn` (one plan, one relay tuning) driven in each mode of ``modes`` (default
settled, ramped, servo) exactly as :func:`~spherestep.drive.drive_turn` drives it; with ``damped_servo`` the
servo also runs on the relay's tuned rotor (its damping fed forward), a like-for-like row. The servo runs on the
*physical* rotor: the paper's ball has no known viscous damping, and the relay's tuned damping (critical on the
softest well) is a device to make relay steps settle, not a measured property. The bang-bang bound is
:func:`~spherestep.control.bang_bang_time` on the capability along the path (``None`` where the model gives no
torque about the axis somewhere: the iron's detent).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import bad_value
from .result import DriveResult, RampedDetails
from .modes import DRIVE_MODES, MODES, Options
from .turn import Turn, choose_model

DEMO_AXIS = (1.0, 0.5, 2.0)
SENSOR_NOISE = math.radians(0.02)


@dataclass(frozen=True)
class DriveComparison:
    """The turn (unit ``axis``, ``angle`` rad) on the model labelled ``model``, each mode's :class:`DriveResult`
    (``results``, in the order asked; the damped servo is mode ``"servo"`` with the tuned damping in its details),
    the bang-bang lower bound ``bound`` (s; ``inf`` where there is none, see the module) for the servo's rotor and
    the ramped relays' ``pull_out_rate`` (steps/s; 0 when every rate lost a step or ramped was not driven)."""

    results: tuple[DriveResult, ...]
    axis: np.ndarray
    angle: float
    model: str
    bound: float
    pull_out_rate: float

    def result(self, mode: str) -> DriveResult:
        """The first result of ``mode``."""
        for r in self.results:
            if r.mode == mode:
                return r
        raise bad_value("mode", f"one of {[r.mode for r in self.results]}", mode)

    @property
    def ratio(self) -> float:
        """The servo's time over the bang-bang bound (``inf`` without either)."""
        servo = self.result("servo")
        return servo.time / self.bound if servo.arrived and math.isfinite(self.bound) else math.inf

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready (no ``inf``): a bound or ratio that does not exist is ``null``."""
        ratio = self.ratio
        return {"model": self.model, "axis": self.axis.tolist(),
                ("angle_deg" if degrees else "angle_rad"): math.degrees(self.angle) if degrees else self.angle,
                "bang_bang_bound_s": self.bound if math.isfinite(self.bound) else None,
                "servo_over_bound": ratio if math.isfinite(ratio) else None,
                "pull_out_rate_steps_per_s": self.pull_out_rate,
                "modes": [r.to_dict(degrees) for r in self.results]}


def compare_drives(design, axis=DEMO_AXIS, angle: float = 2 * math.pi, model=None, *, limits=None,
                   modes=MODES[::-1], sensor_noise: float = SENSOR_NOISE, rates=None, duration: float | None = None,
                   damped_servo: bool = False, tolerance: float | None = None, seed: int = 0,
                   progress: Callable[[str], None] | None = None) -> DriveComparison:
    """Drive the turn of ``angle`` rad about ``axis`` (fixed frame, from the stepper state nearest the identity) in
    each of ``modes`` on ``model`` (default the design's own, :func:`spherestep.magnetics.design_model`); see the
    module. ``tolerance`` (rad) judges every mode (default each mode's own, :mod:`~spherestep.drive.judgement`).
    ``rates`` the ramped cruise rates tried, ``duration`` the servo's time (default the fastest turn)."""
    from ..control import bang_bang_time
    from ..dynamics import Rotor

    modes = tuple(modes)
    if not modes or any(m not in MODES for m in modes):
        raise bad_value("modes", f"some of {', '.join(MODES)}", modes)
    job = Turn(design, axis, angle, choose_model(design, model, limits), tolerance, progress)
    results = []
    options = Options(duration, sensor_noise=sensor_noise, seed=seed, rates=rates)
    for mode in modes:
        results.append(DRIVE_MODES[mode].runs["simulated"](job, options))
        if mode == "servo" and damped_servo:  # the servo again on the relay tuning's damped rotor
            results.append(job.servo(duration, sensor_noise=sensor_noise, seed=seed + 1, rotor=job.tuning.rotor))
    try:
        bound = bang_bang_time(job.chosen.model, job.start, job.axis, job.angle, Rotor.from_design(design).inertia,
                               job.chosen.limits)
    except (ValueError, ArithmeticError):  # no torque about the axis somewhere on the path
        bound = math.inf
    bound = bound if math.isfinite(bound) and bound > 0 else math.inf
    pull = next((r.details.pull_out_rate for r in results if isinstance(r.details, RampedDetails)), 0.0)
    return DriveComparison(tuple(results), job.axis, job.angle, job.chosen.label, float(bound), float(pull))
