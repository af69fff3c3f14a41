"""The top rung: a design checked against every requirement of a spec by full simulation (issue 29 §2–3).

:func:`verify` loads the design from its file text (fresh: nothing of the search is reused) and measures, each with
its own code path:

* the envelope: ball diameter, stator reach, magnets' mass, coil count, core;
* stepper states, resolution and range (:meth:`MotorDesign.metrics`);
* the torque available in every direction over the range on the design's own model, the worst single coil failure
  (:func:`spherestep.control.available_torque`), a relay state's holding torque;
* the stated turn driven by :func:`spherestep.drive.drive_turn`: the fastest servo turn (``mode="servo"``) and the
  paper's settled relay plan (``mode="settled"``, every step within 0.5° of the plan, its peak power within the
  supply's) as the spec's drive asks, and for relays the many-turn verdict (:func:`spherestep.drive.many_turns`:
  the spec's turn and 20 random ones, at least 95 % executed);
* holds at random orientations in the range: the servo (:func:`spherestep.dynamics.simulate_servo`) holding
  ``Trajectory.hold(R)`` for 0.5 s with the spec's sensor (the Hall array of ``sensing.hall_parts`` parts, else the
  drive room's noisy sensor, σ = :data:`spherestep.drive.SENSOR_NOISE` = 0.02°), the largest distance from ``R``;
* with a Hall array, its Monte Carlo accuracy (:func:`spherestep.sensing.accuracy`).

Each requirement is a :class:`Check` (required, achieved, met, margin); :class:`Verification` holds them all.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from ..units import result_dict
from .ladder import magnet_mass, range_orientations, step_torque

HOLD_SECONDS = 0.5


@dataclass(frozen=True)
class Check:
    """One requirement: ``name``, the ``required`` and ``achieved`` values as text for people, ``met``, and the
    ``margin``: achieved over required for a lower bound, required over achieved for an upper bound (≥ 1 when met;
    None where the requirement is yes/no)."""

    name: str
    required: str
    achieved: str
    met: bool
    margin: float | None

    def to_dict(self, degrees: bool = True) -> dict:
        return result_dict(self, degrees)


@dataclass(frozen=True)
class Verification:
    """Every requirement of ``spec`` checked on the design named ``design`` (``checks``), the measured
    ``numbers`` (SI, angles in degrees with ``_deg``), the ``seed`` and the ``seconds`` it took."""

    design: str
    checks: tuple[Check, ...]
    numbers: dict
    seed: int
    seconds: float

    @property
    def met(self) -> bool:
        return all(c.met for c in self.checks)

    @property
    def binding(self) -> Check | None:
        """The requirement with the smallest margin (the one that binds), of those with a margin."""
        graded = [c for c in self.checks if c.margin is not None and math.isfinite(c.margin)]
        return min(graded, key=lambda c: c.margin) if graded else None

    def to_dict(self, degrees: bool = True) -> dict:
        b = self.binding
        return {"design": self.design, "met": self.met, "binding": None if b is None else b.name,
                "checks": [c.to_dict() for c in self.checks], "numbers": _finite(self.numbers), "seed": self.seed,
                "seconds": self.seconds}


def _finite(d: dict) -> dict:
    return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}


def _at_least(name: str, achieved: float, required: float, fmt: str, unit: str) -> Check:
    ok = bool(achieved >= required)
    margin = achieved / required if required > 0 else (math.inf if ok else 0.0)
    return Check(name, f"≥ {required:{fmt}} {unit}".strip(), f"{achieved:{fmt}} {unit}".strip(), ok,
                 float(margin) if math.isfinite(achieved) else 0.0)


def _at_most(name: str, achieved: float, required: float, fmt: str, unit: str) -> Check:
    ok = bool(achieved <= required)
    margin = required / achieved if achieved > 0 else math.inf
    shown = f"{achieved:{fmt}} {unit}".strip() if math.isfinite(achieved) else "never"
    return Check(name, f"≤ {required:{fmt}} {unit}".strip(), shown, ok, float(margin) if math.isfinite(achieved)
                 else 0.0)


def _yes(name: str, required: str, achieved: str, ok: bool) -> Check:
    return Check(name, required, achieved, bool(ok), None)


def hold_errors(design, spec, count: int, seed: int) -> np.ndarray:
    """Largest distance (rad) from ``R`` of the servo holding ``Trajectory.hold(R)`` for :data:`HOLD_SECONDS` s at
    ``count`` random orientations in the spec's range, with the spec's sensor (module docstring)."""
    from ..control import Trajectory
    from .. import so3
    from ..drive import SENSOR_NOISE
    from ..dynamics import Rotor, simulate_servo
    from ..magnetics import design_model
    from ..sensing import NoisySensor

    own = design_model(design)
    rotor = Rotor.from_design(design)
    errors = []
    for k, R in enumerate(range_orientations(spec, count, seed + 7)):
        sensor = NoisySensor(SENSOR_NOISE, rng=seed + k)
        if spec.sensing is not None:
            from ..control.controller import CONTROL_RATE
            from ..sensing import HallSensor, default_array

            sensor = HallSensor(design, array=default_array(design, spec.sensing.hall_parts), current_error=0.01,
                                seed=seed + k, rate=CONTROL_RATE, start=R)
        run = simulate_servo(design, Trajectory.hold(R), own.model, limits=own.limits, rotor=rotor, sensor=sensor,
                             settle=HOLD_SECONDS)
        errors.append(float(so3.distance(run.orientations, R).max()))
    return np.asarray(errors)


def verify(design_text: str, spec, *, seed: int = 1, capability_samples: int = 200, samples: int = 4000,
           holds: int = 3, source: str = "<finalist>") -> Verification:
    """Check the design written in ``design_text`` (a design file's YAML) against every requirement of ``spec``
    (module docstring), with orientations drawn from ``seed``."""
    from ..control import available_torque
    from ..drive import drive_turn, many_turns
    from ..magnetics import design_model
    from ..motor import MotorDesign

    start = time.perf_counter()
    design = MotorDesign.loads(design_text, source=source)
    checks: list[Check] = []
    numbers: dict = {"rotor_poles": len(design.rotor), "coils": len(design.stator), "core": design.coil.core}
    env = spec.envelope
    low, high = env.ball_diameter
    D = design.sphere_diameter
    checks.append(_yes("ball diameter", f"{1e3 * low:.4g}–{1e3 * high:.4g} mm", f"{1e3 * D:.4g} mm",
                       low * (1 - 1e-9) <= D <= high * (1 + 1e-9)))
    if env.stator_reach is not None:
        checks.append(_at_most("stator reach", 1e3 * (design.air_gap + design.coil_length), 1e3 * env.stator_reach,
                               ".4g", "mm"))
    mass = magnet_mass(design)
    numbers["magnet_mass_kg"] = mass
    if env.mass_limit is not None:
        checks.append(_at_most("magnet mass", mass, env.mass_limit, ".3g", "kg"))
    checks.append(_at_most("coils", len(design.stator), spec.max_coils, "d", ""))
    checks.append(_yes("core", spec.core, design.coil.core, spec.core in ("either", design.coil.core)))
    checks.append(_yes("supply", f"{spec.supply.voltage:g} V, {spec.supply.power:g} W",
                       f"{design.coil.supply_voltage:g} V, {design.coil.supply_power:g} W",
                       design.coil.supply_voltage <= spec.supply.voltage * (1 + 1e-9)
                       and design.coil.supply_power <= spec.supply.power * (1 + 1e-9)))

    m = design.metrics(samples=samples, seed=seed, escape=False)
    numbers.update(states=m.states, resolution_median_deg=math.degrees(m.resolution_median_rad),
                   resolution_p95_deg=math.degrees(m.resolution_p95_rad), reaches_all=bool(m.reaches_all))
    if spec.relays:
        if spec.range == "all":
            checks.append(_yes("range (relays)", "all of SO(3)", "all of SO(3)" if m.reaches_all else
                               f"{m.range_fraction:.1%} within a step", m.reaches_all))
        else:
            R = range_orientations(spec, 500, seed + 3)
            dist, _ = design.states().nearest(R)
            inside = float(np.mean(dist <= design.max_step)) if m.states else 0.0
            checks.append(_yes("range (relays)", f"cone of {math.degrees(spec.range.cone):g}°",
                               f"{inside:.1%} of the cone within a step", inside >= 1.0))
        if spec.precision.relay_resolution is not None:
            checks.append(_at_most("relay resolution (median)", numbers["resolution_median_deg"],
                                   math.degrees(spec.precision.relay_resolution), ".3g", "°"))

    own = design_model(design)
    numbers["model"] = own.label
    if spec.servo:
        R = range_orientations(spec, capability_samples, seed)
        K = np.asarray(own.model.torque_matrix(R), dtype=float)
        bias = np.asarray(own.model.torque(R, np.zeros((len(R), own.model.coil_count))), dtype=float)
        r, _ = available_torque(K, own.limits, bias=bias, failed=own.model.failed)
        q = 1.0 - spec.torque.over_fraction
        numbers.update(torque_quantile_Nm=float(np.quantile(r, q)), torque_median_Nm=float(np.median(r)),
                       detent_Nm=float(np.linalg.norm(bias, axis=-1).max()))
        positive = float(np.mean(r > 0))
        checks.append(_yes("range (servo): torque in every direction > 0",
                           f"on ≥ {spec.torque.over_fraction:.0%} of the range", f"on {positive:.1%}",
                           positive >= spec.torque.over_fraction))
        if spec.torque.every_direction is not None:
            checks.append(_at_least(f"torque in every direction on {spec.torque.over_fraction:.0%} of the range",
                                    numbers["torque_quantile_Nm"], spec.torque.every_direction, ".3g", "N·m"))
            if spec.single_coil_failure:
                worst = min(float(np.quantile(available_torque(K, own.limits, bias=bias, failed=(k,))[0], q))
                            for k in range(own.model.coil_count))
                numbers["failed_coil_torque_Nm"] = worst
                checks.append(_at_least("torque with the worst single coil failed", worst,
                                        spec.torque.every_direction, ".3g", "N·m"))
        if spec.speed is not None:
            run = drive_turn(design, spec.speed.axis.vector, spec.speed.turn, mode="servo", seed=seed)
            numbers.update(servo_turn_s=float(run.time), servo_trajectory=run.details.trajectory,
                           servo_final_error_deg=math.degrees(run.final_error))
            checks.append(_at_most(f"servo turn of {math.degrees(spec.speed.turn):g}°", float(run.time),
                                   spec.speed.within, ".3g", "s"))
        hall_error = None
        if spec.sensing is not None:  # the sensing room places the array; on some designs it cannot
            from ..errors import InputError
            from ..sensing import default_array

            try:
                default_array(design, spec.sensing.hall_parts)
            except InputError as exc:
                hall_error = f"no Hall array: {exc}"
        if spec.precision.servo_hold is not None:
            sensor = (f"Hall array of {spec.sensing.hall_parts}" if spec.sensing is not None
                      else "sensor noise 0.02°")
            if hall_error is None:
                errors = hold_errors(design, spec, holds, seed)
                numbers["hold_error_max_deg"] = math.degrees(float(errors.max()))
                hold = _at_most("servo hold error", numbers["hold_error_max_deg"],
                                math.degrees(spec.precision.servo_hold), ".3g", "°")
                checks.append(replace(hold, achieved=f"{hold.achieved} (worst of {holds} holds, {sensor})"))
            else:
                checks.append(Check("servo hold error", f"≤ {math.degrees(spec.precision.servo_hold):.3g} °",
                                    hall_error, False, 0.0))
        if spec.sensing is not None:
            from ..sensing import accuracy, default_array

            name = f"Hall array of ≤ {spec.sensing.hall_parts} parts, RMS orientation error"
            need = math.degrees(spec.precision.servo_hold) if spec.precision.servo_hold is not None else None
            if hall_error is not None:
                checks.append(Check(name, "an array the sensing room can place", hall_error, False, None))
            else:
                acc = accuracy(design, default_array(design, spec.sensing.hall_parts), samples=40, seed=seed)
                numbers["hall_rms_deg"] = math.degrees(acc.rms)
                if need is not None:
                    checks.append(_at_most(name, math.degrees(acc.rms), need, ".3g", "°"))
                else:
                    checks.append(_yes(name, "estimates the orientation", f"RMS {math.degrees(acc.rms):.3g}°",
                                       math.isfinite(acc.rms)))
    if spec.relays:
        if spec.torque.step is not None:
            st = step_torque(design, 8, seed)
            numbers["step_torque_Nm"] = st
            checks.append(_at_least("step torque (median of 8 states)", st, spec.torque.step, ".3g", "N·m"))
        axis = spec.speed.axis.vector if spec.speed is not None else np.array([0.0, 0.0, 1.0])
        angle = spec.speed.turn if spec.speed is not None else math.radians(30.0)
        run = drive_turn(design, axis, angle, mode="settled")
        det = run.details
        numbers.update(relay_steps=det.steps, relay_steps_on_plan=det.steps_settled_on_plan,
                       relay_time_s=float(run.time))
        checks.append(_yes("settled relay plan executes (every step within 0.5° of the plan)",
                           f"{det.steps} of {det.steps} steps", f"{det.steps_settled_on_plan} of {det.steps} steps",
                           det.executed))
        many = many_turns(design, spec_turn=(axis, angle), seed=seed)
        numbers.update(relay_turns_fraction=many.fraction, relay_turns_worst_deg=math.degrees(many.worst))
        checks.append(_at_least(f"relay turns executed ({many.planner} planner: the spec's turn + {many.turns - 1} "
                                f"random of 15-360°, every step within 0.5°)", 100 * many.fraction,
                                100 * many.required, ".3g", "%"))
        numbers["relay_peak_W"] = float(run.peak_power)
        checks.append(_at_most("relay plan's peak power (its most coils at once)", float(run.peak_power),
                               spec.supply.power, ".3g", "W"))
        if spec.speed is not None and not spec.servo:
            checks.append(_at_most(f"relay turn of {math.degrees(angle):g}°", float(run.time), spec.speed.within,
                                   ".3g", "s"))
    return Verification(design.name, tuple(checks), numbers, int(seed), time.perf_counter() - start)
