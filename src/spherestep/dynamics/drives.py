"""The same turn driven three ways: settled relay stepping, ramped relay stepping, the servo — side by side.

* **settled**: today's demo path — the geometric plan of the turn (:func:`spherestep.commutation.turn`) run by
  :func:`~spherestep.dynamics.simulate` with :func:`~spherestep.dynamics.tune`'s rotor, dwell and time step;
  time = steps × dwell.
* **ramped**: the same plan, same rotor, the step rate ramped (:mod:`.ramped`) at the pull-out rate found by
  :func:`~spherestep.dynamics.ramped.pull_out_rate`; time = arrival within 0.5° of the plan's last state.
* **servo**: :func:`~spherestep.control.plan_turn` (trapezoidal, within the guaranteed torque along the path)
  tracked by :func:`~spherestep.dynamics.servo.simulate_servo` at 1 kHz with a noisy sensor; time = arrival
  within 0.05° of the end, for good. The servo runs on the *physical* rotor, :meth:`Rotor.from_design`: the
  paper's ball has no known viscous damping, and the tuned damping of the relay simulation (critical on the
  softest well, 0.26 N·m·s/rad for the prototype: 1.6 N·m of drag at one turn per second) is a device to make
  relay steps settle, not a measured property. Relay stepping needs that damping: without it the rotor never
  settles. ``damped_servo=True`` also runs the servo on the tuned rotor (damping fed forward), for a like-for-like
  row.

Every mode reports: time (s), final error (deg, to the turn's end), maximum tracking error (deg; relay modes:
to the target of the energised step; servo: to the trajectory), peak and mean electrical power (W; relays:
``V I_n`` per energised coil; servo: ``Σ v i`` drawn from the supply). The bang-bang bound is
:func:`~spherestep.control.bang_bang_time` on the capability along the path.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import so3
from ..control import DriveLimits, bang_bang_time, plan_turn
from ..errors import bad_value
from .ramped import RATES, pull_out_rate
from .rotor import Rotor
from .servo import NoisySensor, ServoRun, simulate_servo
from .simulate import simulate
from .tuning import tune

DEMO_AXIS = (1.0, 0.5, 2.0)
SENSOR_NOISE = math.radians(0.02)


@dataclass(frozen=True)
class DriveResult:
    """One mode's numbers: ``mode``; ``time`` (s); ``final_error`` and ``max_tracking_error`` (rad); ``peak_power``
    and ``mean_power`` (W); ``details`` (mode-specific, JSON-ready)."""

    mode: str
    time: float
    final_error: float
    max_tracking_error: float
    peak_power: float
    mean_power: float
    details: dict = field(default_factory=dict)

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready; a mode that never arrives (time ``inf``, errors NaN) has ``null`` there."""
        unit, conv = ("deg", math.degrees) if degrees else ("rad", float)
        out = {"mode": self.mode, "time_s": self.time, f"final_error_{unit}": conv(self.final_error),
               f"max_tracking_error_{unit}": conv(self.max_tracking_error), "peak_power_W": self.peak_power,
               "mean_power_W": self.mean_power}
        return {k: v if isinstance(v, str) or math.isfinite(v) else None for k, v in out.items()} | \
            {"details": self.details}


@dataclass(frozen=True)
class DriveComparison:
    """The three modes (``results``, in the order settled, ramped, servo[, servo on the damped rotor]), the
    turn (``axis``, ``angle`` rad), the bang-bang lower bound ``bound`` (s) for the servo's rotor,
    ``pull_out_rate`` (steps/s) and the servo's run ``servo_run`` (for the report's figure:
    ``dynamics.move.figure_drive(run.times, run.tracking_error, run.currents, run.power)``)."""

    results: tuple[DriveResult, ...]
    axis: np.ndarray
    angle: float
    bound: float
    pull_out_rate: float
    servo_run: ServoRun | None = None

    def result(self, mode: str) -> DriveResult:
        for r in self.results:
            if r.mode == mode:
                return r
        raise bad_value("mode", f"one of {[r.mode for r in self.results]}", mode)

    @property
    def ratio(self) -> float:
        """The servo's time over the bang-bang bound."""
        return self.result("servo").time / self.bound

    def to_dict(self, degrees: bool = True) -> dict:
        return {"axis": self.axis.tolist(), ("angle_deg" if degrees else "angle_rad"):
                math.degrees(self.angle) if degrees else self.angle,
                "bang_bang_bound_s": self.bound, "servo_over_bound": self.ratio,
                "pull_out_rate_steps_per_s": self.pull_out_rate,
                "modes": [r.to_dict(degrees) for r in self.results]}


def _relay_tracking(times, orientations, step_times, targets) -> float:
    idx = np.clip(np.searchsorted(step_times, times, side="right"), 0, len(targets) - 1)
    return float(so3.distance(orientations, targets[idx]).max())


def relay_drives(design, plan, model, tuning, limits: DriveLimits, rates=RATES):
    """The relay modes of ``plan`` on ``model`` with ``tuning``'s rotor, dwell and time step: ``(settled, ramped,
    pull_out)`` — the settled steps (:func:`~spherestep.dynamics.simulate`) and the ramped steps at the pull-out
    rate over ``rates`` (:func:`~spherestep.dynamics.ramped.pull_out_rate`; time ``inf`` when every rate loses a
    step). A relay coil draws ``V I_n``."""
    end = plan.targets[-1]
    coil_power = limits.supply_voltage * limits.nominal_current
    sim = simulate(design, plan, model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    step_times = tuning.dwell * np.arange(len(plan.steps) - 1)
    p = coil_power * np.count_nonzero(sim.active_coils, axis=1)
    settled = DriveResult("settled", float(sim.times[-1]), float(so3.distance(sim.settled[-1], end)),
                          _relay_tracking(sim.times, sim.orientations, step_times, plan.targets),
                          float(p.max()), float(p.mean()),
                          {"steps": len(plan.steps) - 1, "dwell_s": tuning.dwell,
                           "damping_N_m_s_per_rad": tuning.rotor.damping, "executed": sim.executed,
                           "steps_settled_on_plan": int(np.count_nonzero(sim.step_errors <= sim.tolerance)),
                           "plan_tolerance_deg": math.degrees(sim.tolerance)})
    pull = pull_out_rate(design, plan, model, rotor=tuning.rotor, rates=rates, dt=tuning.dt)
    tried = [[r, bool(lost)] for r, lost in pull.tried]
    if pull.run is None:
        return settled, DriveResult("ramped", math.inf, math.nan, math.nan, math.nan, math.nan, {"tried": tried}), pull
    run = pull.run
    ramped = DriveResult("ramped", run.arrival_time(), run.final_error,
                         _relay_tracking(run.times, run.orientations, run.step_times, plan.targets),
                         float(run.power.max()), float(run.power.mean()),
                         {"pull_out_rate_steps_per_s": pull.rate, "last_step_s": float(run.step_times[-1]),
                          "tried": tried})
    return settled, ramped, pull


def compare_drives(design, axis=DEMO_AXIS, angle: float = 2 * math.pi, model=None, *,
                   limits: DriveLimits | None = None, sensor_noise: float = SENSOR_NOISE, rates=RATES,
                   damped_servo: bool = False, seed: int = 0) -> DriveComparison:
    """Drive the turn of ``angle`` rad about ``axis`` (fixed frame, from the stepper state nearest the identity)
    the three ways of the module on ``model`` (default the design's magnets' torque map)."""
    from ..commutation import turn

    if model is None:
        from ..magnetics import torque_map

        model = torque_map(design)
    limits = DriveLimits() if limits is None else limits
    if not (isinstance(angle, (int, float)) and math.isfinite(angle) and angle != 0):
        raise bad_value("angle", "a finite non-zero angle in radians", angle)
    plan = turn(design, axis, math.degrees(angle))
    n = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    start, end = plan.targets[0], plan.targets[-1]
    tuning = tune(design, model)
    settled, ramped, pull = relay_drives(design, plan, model, tuning, limits, rates)
    results = [settled, ramped]

    rotors = [("servo", Rotor.from_design(design))]
    servo_run = None
    if damped_servo:
        rotors.append(("servo (tuned damping)", tuning.rotor))
    for k, (mode, rotor) in enumerate(rotors):
        traj = plan_turn(model, start, n, angle, rotor.inertia, limits, damping=rotor.damping)
        run = simulate_servo(design, traj, model, limits=limits, rotor=rotor,
                             sensor=NoisySensor(sensor_noise, rng=seed + k), settle=0.5)
        s = run.summary()
        servo_run = run if k == 0 else servo_run
        results.append(DriveResult(mode, s["arrival_time_s"], float(so3.distance(run.orientations[-1], end)),
                                   float(run.tracking_error.max()), s["peak_power_W"], s["mean_power_W"],
                                   {"motion_time_s": traj.duration, "sensor_noise_deg": math.degrees(sensor_noise),
                                    "damping_N_m_s_per_rad": rotor.damping,
                                    "mean_copper_power_W": s["mean_copper_power_W"],
                                    "peak_current_A": s["peak_current_A"],
                                    "reachable_fraction": s["reachable_fraction"]}))
    bound = bang_bang_time(model, start, n, angle, Rotor.from_design(design).inertia, limits)
    return DriveComparison(tuple(results), n, float(angle), bound, pull.rate, servo_run)
