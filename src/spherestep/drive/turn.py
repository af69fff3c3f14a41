"""A turn prepared once (:class:`Turn`) and its three runs on the simulated motor; how each mode is chosen and driven
on each backend is :mod:`.modes` (:func:`~.modes.drive_turn`, one lookup in its registry).

The turn is ``angle`` rad about the fixed-frame ``axis`` from the stepper state nearest the identity (the
simulated motor; on a port or the emulated motor the rotor is taken to be at the identity).

* ``"settled"``: the paper's relay steps — the relay plan (:func:`spherestep.commutation.turn`: the iron-aware
  planner on a model with a detent — the iron —, the geometric one on air; ``planner`` overrides) run by
  :func:`spherestep.dynamics.simulate` with :func:`spherestep.dynamics.tune`'s rotor (damping critical on the
  softest well), dwell and time step; time = steps × dwell when the rotor ends within the plan's tolerance
  (0.5°) of the plan's last state.
* ``"ramped"``: the same plan's relay steps at the pull-out rate (:func:`spherestep.dynamics.pull_out_rate`); time
  = arrival within 0.5° of the plan's last state. A relay coil draws ``V I_n``.
* ``"servo"``: a rest-to-rest trajectory tracked by :func:`spherestep.dynamics.simulate_servo` at 1 kHz on the
  physical rotor (:meth:`~spherestep.dynamics.Rotor.from_design`, no damping) with the chosen sensor: the fastest
  turn within the torque guaranteed along the path (:func:`spherestep.control.plan_turn`), or a triangle profile
  of acceleration ``4θ/T²`` over ``duration`` ``T``. Where ``plan_turn`` refuses the model (the iron's detent:
  no torque in every direction somewhere on the path) the turn takes the fixed time ``T = 3 s · √(θ/2π)`` (the
  demo's 3.0 s for 360°, the same acceleration for other angles) and the result says so. Time = arrival within
  ``tolerance`` of the turn's end, for good.

The model is the design's own (:func:`spherestep.magnetics.design_model`: the iron model and the iron coil's
limits for the iron-cored prototype) unless ``model`` is given (a
:class:`~spherestep.magnetics.DesignModel`, or any torque model with ``limits``); every result names it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import InputError, bad_value
from .result import DriveResult, RampedDetails, ServoDetails, SettledDetails
from .judgement import MODE_TOLERANCE, SERVO_TOLERANCE

TOLERANCE = SERVO_TOLERANCE  # rad: a servo ending farther than this from the turn's end did not make it (judgement)
FIXED_SERVO_TIME = 3.0  # s for a full turn, where the fastest-turn planner refuses the model (module docstring)
SETTLE = 0.5  # s the servo runs beyond its trajectory


def fixed_servo_time(angle: float) -> float:
    """``3 s · √(|θ|/2π)``: the demo's hand-picked 3.0 s for 360° at the same peak acceleration ``4θ/T²``."""
    return FIXED_SERVO_TIME * math.sqrt(abs(angle) / (2 * math.pi))


@dataclass(frozen=True)
class Chosen:
    """The model a drive runs on: the torque ``model``, its ``limits`` and the ``label`` every result carries."""

    model: object
    limits: object
    label: str


def choose_model(design, model=None, limits=None) -> Chosen:
    """The design's own model (:func:`~spherestep.magnetics.design_model`) unless ``model`` is given: a
    :class:`~spherestep.magnetics.DesignModel` (its limits and label) or a torque model (``limits`` default the
    paper's 24 V / 100 W supply at 1 A, as :func:`~spherestep.control.torque_capability`)."""
    from ..magnetics import DesignModel, design_model
    from ..statics import TorqueModel

    if model is None or isinstance(model, DesignModel):
        own = design_model(design) if model is None else model
        return Chosen(own.model, own.limits if limits is None else limits, own.label)
    if not isinstance(model, TorqueModel):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel) or a magnetics.DesignModel",
                        type(model).__name__)
    if limits is None:  # as torque_capability: a bare model gets the paper's 24 V / 100 W supply at 1 A
        from ..electrics import DriveLimits

        limits = DriveLimits()
    return Chosen(model, limits, f"{type(model).__name__} (given)")


PLANNERS = ("auto", "iron", "geometric", "potential")


def relay_planner(design, planner: str = "auto", model=None) -> str:
    """``planner`` resolved: ``"auto"`` is ``"iron"`` where the rotor feels a detent — a ``model`` that declares
    ``has_bias`` (the iron model), or without a model an iron-cored design — and ``"geometric"`` otherwise (air)."""
    if planner not in PLANNERS:
        raise bad_value("planner", f"one of {', '.join(PLANNERS)}", planner)
    if planner == "auto":
        iron = design.coil.core == "iron" if model is None else bool(model.has_bias)
        return "iron" if iron else "geometric"
    return planner


def relay_tuning(design, model, planner: str):
    """The relay rotor a plan of ``planner`` runs with: :func:`spherestep.dynamics.iron_tuning` for the iron
    planner, :func:`spherestep.dynamics.tune` otherwise."""
    from ..dynamics import iron_tuning, tune

    return iron_tuning(design, model) if planner == "iron" else tune(design, model)


def relay_plan(design, axis, angle: float, steps: int | None = None, planner: str = "auto", model=None, *,
               limits=None, tuning=None, **options):
    """:func:`spherestep.commutation.turn` by ``planner`` (:func:`relay_planner`: ``"auto"`` the iron-aware one on
    a detent) with the defaults the commutation room cannot reach: for the iron planner the design's own model and
    limits (:func:`spherestep.magnetics.design_model`) unless ``model`` is given, and :func:`relay_tuning`'s rotor
    unless ``tuning`` is; ``options`` (``plants``, ``plant_tol``, ``thermal``, ``rate``) go to ``turn``."""
    from ..commutation import turn

    planner = relay_planner(design, planner, model)
    if planner == "iron":
        if model is None:
            from ..magnetics import design_model

            own = design_model(design)
            model, limits = own.model, own.limits if limits is None else limits
        tuning = relay_tuning(design, model, planner) if tuning is None else tuning
    return turn(design, axis, angle, steps, planner, model, limits=limits, tuning=tuning, **options)


class Turn:
    """A turn prepared once and driven any number of ways (:func:`~.modes.drive_turn`, :func:`~.compare.compare_drives`):
    the design, the unit ``axis``, ``angle`` (rad), the ``chosen`` model; the geometric ``plan`` and the relay
    ``tuning`` are made on first use."""

    def __init__(self, design, axis, angle: float, chosen: Chosen, tolerance: float | None = None,
                 progress: Callable[[str], None] | None = None, planner: str = "auto"):
        from ..commutation import turn_targets

        self.design, self.chosen = design, chosen
        self.planner = relay_planner(design, planner, chosen.model)
        self.axis = checks.axis(axis, "axis")
        self.angle = checks.number(angle, "angle", expected="a finite non-zero angle in radians")
        if self.angle == 0:
            raise bad_value("angle", "a finite non-zero angle in radians", angle)
        self.given = None if tolerance is None else checks.positive(tolerance, "tolerance", "a positive angle in rad")
        ends = turn_targets(design, self.axis, self.angle, steps=1)
        self.start, self.end = ends[0], ends[-1]
        self.say = progress or (lambda _: None)
        self._plan = self._tuning = None

    @property
    def plan(self):
        """The relay plan of the turn (:func:`spherestep.commutation.turn`) by ``planner``: the iron-aware one on
        an iron-cored design, the geometric one on air (:func:`relay_planner`; :func:`relay_plan`)."""
        if self._plan is None:
            self.say(f"commutating: the {self.planner} relay plan")
            self._plan = relay_plan(self.design, self.axis, self.angle, planner=self.planner,
                                    model=self.chosen.model, limits=self.chosen.limits,
                                    tuning=self.tuning if self.planner == "iron" else None)
        return self._plan

    @property
    def tuning(self):
        """The relay rotor's damping, dwell and time step on this model (:func:`relay_tuning`)."""
        if self._tuning is None:
            self.say("tuning the relay rotor's damping and dwell on the model's wells")
            self._tuning = relay_tuning(self.design, self.chosen.model, self.planner)
        return self._tuning

    def tolerance(self, mode: str) -> float:
        """The tolerance (rad) ``mode``'s result is judged by: the one given, else the mode's own
        (:data:`~spherestep.drive.judgement.MODE_TOLERANCE`: 0.05° for the servo, 0.5° for relay steps)."""
        return MODE_TOLERANCE[mode] if self.given is None else self.given

    def result(self, mode: str, backend: str, times, orientations, targets, sensor_error, currents, power,
               time: float, note: str, final_error: float, max_tracking_error: float, details) -> DriveResult:
        power = np.asarray(power, dtype=float)
        return DriveResult(mode, backend, self.chosen.label, self.axis, self.angle, np.asarray(times, dtype=float),
                           np.asarray(orientations), np.asarray(targets), np.asarray(sensor_error, dtype=float),
                           np.asarray(currents, dtype=float), power, float(time), note, float(final_error),
                           float(max_tracking_error), float(power.max()), float(power.mean()), self.tolerance(mode),
                           details)

    def settled(self) -> DriveResult:
        """The paper's relay steps, each settled (module docstring)."""
        from ..dynamics import simulate

        plan, tuning, limits = self.plan, self.tuning, self.chosen.limits
        self.say(f"simulating {len(plan.steps) - 1} settled relay steps")
        sim = simulate(self.design, plan, self.chosen.model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt,
                       record_every=1, tolerance=self.tolerance("settled"))
        targets = _step_targets(sim.times, tuning.dwell * np.arange(len(plan.steps) - 1), plan.targets)
        on_plan = int(np.count_nonzero(sim.step_errors[1:] <= sim.tolerance))  # the steps, not the start
        ends_on_plan = float(so3.distance(sim.settled[-1], plan.achieved[-1])) <= sim.tolerance
        blocked = plan.failures
        note = "" if ends_on_plan else (f"the rotor did not end within {math.degrees(sim.tolerance):g}° of the plan's "
                                        f"last state ({on_plan} of {len(plan.steps) - 1} steps settled on the plan)")
        if blocked:  # the rotor may follow the plan, but the plan does not make the turn
            note = (f"the plan is blocked at {len(blocked)} of {len(plan.steps) - 1} steps (first, step {blocked[0][0]}: "
                    f"{blocked[0][1].removeprefix('blocked: ')})" + (f"; {note}" if note else ""))
            ends_on_plan = False
        details = SettledDetails(len(plan.steps) - 1, tuning.dwell, tuning.rotor.damping, sim.executed, on_plan,
                                 sim.tolerance)
        return self.result("settled", "simulated", sim.times, sim.orientations, targets, np.zeros(len(sim.times)),
                           limits.amperes(sim.active_coils),
                           limits.relay_power * np.count_nonzero(sim.active_coils, axis=1),
                           float(sim.times[-1]) if ends_on_plan else math.inf, note,
                           float(so3.distance(sim.settled[-1], self.end)),
                           float(so3.distance(sim.orientations, targets).max()), details)

    def ramped(self, rates=None) -> DriveResult:
        """The relay steps ramped at the pull-out rate over ``rates`` (steps/s; default
        :data:`spherestep.dynamics.ramped.RATES`)."""
        from ..dynamics.ramped import RATES, pull_out_rate

        plan, tuning = self.plan, self.tuning
        self.say("finding the ramped relay steps' pull-out rate")
        pull = pull_out_rate(self.design, plan, self.chosen.model, rotor=tuning.rotor,
                             rates=RATES if rates is None else rates, dt=tuning.dt, limits=self.chosen.limits,
                             tolerance=self.tolerance("ramped"))
        run = pull.run if pull.run is not None else pull.slowest
        s = run.summary()
        note = ""
        if pull.run is None:
            note = f"steps lost at every rate tried ({', '.join(f'{r:g}' for r, _ in pull.tried)} steps/s)"
        elif not math.isfinite(s.arrival_time):
            note = f"not within {math.degrees(run.tolerance):g}° of the plan's last state at the end"
        details = RampedDetails(pull.rate, s.last_step, tuple((float(r), bool(lost)) for r, lost in pull.tried))
        return self.result("ramped", "simulated", run.times, run.orientations, run.step_targets,
                           np.zeros(len(run.times)), self.chosen.limits.amperes(run.currents), run.power,
                           s.arrival_time if pull.run is not None else math.inf, note, s.final_error,
                           s.max_tracking_error, details)

    def servo_trajectory(self, start, duration: float | None, rotor, headroom: float | None = None):
        """``(trajectory, kind, note)``: the fastest turn (``headroom`` of :func:`~spherestep.control.plan_turn`),
        the given ``duration``, or the fixed time where the planner refuses the model (module docstring)."""
        from ..control import Trajectory, plan_turn

        n, angle = self.axis, self.angle
        if duration is not None:
            return Trajectory.turn(start, n, angle, 4.0 * abs(angle) / duration ** 2), "given", ""
        self.say("planning the fastest turn within the guaranteed torque")
        try:
            return plan_turn(self.chosen.model, start, n, angle, rotor.inertia, self.chosen.limits,
                             damping=rotor.damping, headroom=headroom), "fastest", ""
        except InputError as exc:
            T = fixed_servo_time(angle)
            return (Trajectory.turn(start, n, angle, 4.0 * abs(angle) / T ** 2), "fixed",
                    f"the fastest-turn planner refused this model ({exc}); fixed time {T:.3g} s")

    def servo(self, duration: float | None = None, *, sensor: str = "ideal", sensor_noise: float = 0.0,
              seed: int = 0, rotor=None, settle: float = SETTLE) -> DriveResult:
        """The simulated servo (module docstring) on ``rotor`` (default the physical one)."""
        from ..dynamics import Rotor, simulate_servo

        rotor = Rotor.from_design(self.design) if rotor is None else rotor
        traj, kind, note = self.servo_trajectory(self.start, duration, rotor)
        self.say(f"simulating the servo over {traj.duration + settle:.3g} s at 1 kHz")
        run = simulate_servo(self.design, traj, self.chosen.model, limits=self.chosen.limits, rotor=rotor,
                             sensor=_sensor(self.design, sensor, sensor_noise, traj.start, seed), settle=settle)
        tolerance = self.tolerance("servo")
        time = run.arrival_time(tolerance)
        time = math.inf if time is None else float(time)
        sensor_error = so3.distance(run.estimates, run.orientations)
        details = ServoDetails(kind, note, float(traj.duration), sensor, sensor_noise, float(sensor_error.max()),
                               rotor.damping, float(run.copper_power.mean()), float(np.abs(run.currents).max()),
                               float(np.mean(run.reachable)))
        arrival = "" if math.isfinite(time) else (f"not within {math.degrees(tolerance):.3g}° of the turn's end "
                                                  f"at the end of the run ({run.times[-1]:.3g} s)")
        return self.result("servo", "simulated", run.times, run.orientations, run.targets, sensor_error,
                           run.currents, run.power, time, arrival, float(so3.distance(run.orientations[-1], self.end)),
                           float(run.tracking_error.max()), details)


def _step_targets(times, step_times, targets) -> np.ndarray:
    """Per sample, the target of the relay step energised then (steps energised at ``step_times``)."""
    return targets[np.clip(np.searchsorted(step_times, times, side="right"), 0, len(targets) - 1)]


def _sensor(design, kind: str, noise: float, start, seed: int):
    """The servo's orientation sensor of kind ``kind`` (see :func:`drive_turn`), at the control rate."""
    from ..sensing import NoisySensor
    from ..control.controller import CONTROL_RATE

    if kind == "ideal":
        return NoisySensor(noise, rng=seed)
    from ..sensing import HallSensor, ImuSensor

    if kind == "hall":
        return HallSensor(design, current_error=0.01, seed=seed, rate=CONTROL_RATE, start=start)
    return ImuSensor(design, 1.0 / CONTROL_RATE, seed=seed)


_LAST_BOUND: dict = {}
_LAST_VOLTAGE: dict = {}


def check_duration(design, axis, angle: float, chosen: Chosen, duration: float, name: str = "duration", *,
                   start=None) -> float | None:
    """Refuse (InputError naming ``name``) a servo time ``duration`` (s) shorter than the bang-bang bound of the
    turn on ``chosen``'s model (:func:`spherestep.control.bang_bang_time` on the physical rotor, from ``start``:
    default the stepper state nearest the identity). A whole number of turns ends where it starts, so a time too
    short to make it would otherwise end "on target" without having turned. Returns the bound (``None`` where
    there is none: somewhere on the path no torque about the axis, the iron's detent)."""
    from ..commutation import turn_targets
    from ..control import bang_bang_time
    from ..dynamics import Rotor

    n = checks.axis(axis, "axis")
    start = turn_targets(design, n, angle, steps=1)[0] if start is None else so3.as_rotations(start, "start")
    key = (id(chosen.model), chosen.limits, start.tobytes(), n.tobytes(), float(angle))
    if _LAST_BOUND.get("key") != key:  # the CLI checks before its work, drive_turn again: one evaluation
        try:
            bound = bang_bang_time(chosen.model, start, n, angle, Rotor.from_design(design).inertia, chosen.limits)
        except (ValueError, ArithmeticError):
            bound = math.nan
        _LAST_BOUND.update(key=key, bound=bound)
    bound = _LAST_BOUND["bound"]
    if not (math.isfinite(bound) and bound > 0):
        return None
    if duration < bound:
        turns = abs(angle) / (2 * math.pi)
        whole = abs(turns - round(turns)) < 1e-9
        why = (f"; a whole number of turns ({round(turns)} × 360°) ends where it starts, so a shorter time would "
               f"end on target without turning" if whole else "")
        raise bad_value(name, f"at least the bang-bang bound {bound:.3g} s for this {math.degrees(angle):g}° turn on "
                        f"the {chosen.label} model (the fastest the coils' limits allow){why}; give a longer time or "
                        f"leave it out for the fastest turn", duration)
    check_voltage(design, n, angle, chosen, duration, name, start)
    return bound


def check_voltage(design, axis, angle: float, chosen: Chosen, duration: float, name: str, start) -> None:
    """Refuse (InputError naming ``name``) a servo time whose triangle profile asks, somewhere on the path, a torque
    the coils give at rest but not at that speed within the supply against their back-EMF
    (:func:`spherestep.control.voltage_shortfall`), naming the shortest triangle time that the supply allows
    (:func:`spherestep.control.triangle_time`)."""
    from ..control import triangle_time, voltage_shortfall
    from ..dynamics import Rotor

    key = (id(chosen.model), chosen.limits, np.asarray(start).tobytes(), np.asarray(axis).tobytes(), float(angle),
           float(duration))
    if _LAST_VOLTAGE.get("key") != key:  # the CLI checks before its work, drive_turn again: one evaluation
        inertia = Rotor.from_design(design).inertia
        short = voltage_shortfall(chosen.model, start, axis, angle, inertia, duration, chosen.limits)
        fastest = None if short is None else triangle_time(chosen.model, start, axis, angle, inertia, duration,
                                                            chosen.limits)
        _LAST_VOLTAGE.update(key=key, short=short, fastest=fastest)
    short, fastest = _LAST_VOLTAGE["short"], _LAST_VOLTAGE["fastest"]
    if short is None:
        return
    s, speed, need, (lo, hi) = short
    least = f"at least {fastest:.3g} s" if math.isfinite(fastest) else "a longer time"
    raise bad_value(name, f"{least} for this {math.degrees(angle):g}° turn on the {chosen.label} model: in "
                    f"{duration:g} s the turn passes {math.degrees(s):.0f}° at {speed:.2g} rad/s, where the coils' "
                    f"back-EMF leaves the {chosen.limits.supply_voltage:g} V supply {lo:.3g} to {hi:.3g} N·m of the "
                    f"{need:.3g} N·m it needs; give that time or leave it out for the fastest turn the planner "
                    f"finds within the supply", duration)
