"""Every gallery design measured by the same code.

* stepper states, resolution (median and 95th percentile of the Park distance from uniform random orientations
  to the nearest state), range (``reaches_all``) and escape violations: :meth:`MotorDesign.metrics`;
* torque capability over SO(3) on the design's own model (the core its file states,
  :func:`spherestep.magnetics.design_model`): :func:`spherestep.control.torque_capability`, the torque available
  in every direction, its median and 5th percentile over uniform orientations, and the largest detent (bias)
  torque at zero current;
* mass of the magnets, ``M ρ π (d_m/2)² l_m`` with the NdFeB density :meth:`MotorDesign.inertia` uses; coils and
  their power at nominal current (:meth:`MotorDesign.coil_electrics`).

* driving it (:func:`drive_metrics`, the drive room's :func:`spherestep.drive.drive_turn` on the design's own
  model): the servo's fastest 360° turn about :data:`DRIVE_AXIS` (``control.plan_turn``, time-optimal with the
  detent) — time to arrive for good, final and largest tracking error, mean electrical power — and the paper's
  settled relay plan for the same turn (executed or not, how many steps settled within 0.5° of the plan).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from .. import checks
from ..units import result_dict

MAGNET_DENSITY = 7500.0  # kg/m³, sintered NdFeB: the default of MotorDesign.inertia (magnet_density)
DRIVE_AXIS = (1.0, 0.5, 2.0)  # the gallery's turn: 360° about this axis (fixed frame, normalised by the drive room)
DRIVE_ANGLE = 2.0 * math.pi


@dataclass(frozen=True)
class DriveMetrics:
    """What driving the motor gives (:func:`drive_metrics`). Servo: ``servo_turn_s`` the time (s) to arrive for good
    on the fastest planned turn, ``servo_final_error_rad`` and ``servo_max_tracking_error_rad`` (Park distance to
    the turn's end and to the trajectory), ``servo_mean_power_W`` (electrical). Settled relays: ``relay_executed``
    (every step settled within the plan's tolerance), ``relay_steps`` and ``relay_steps_on_plan``,
    ``relay_landed_fraction = relay_steps_on_plan / relay_steps``. A value not measured is None and ``note`` says
    why (empty when all are measured)."""

    servo_turn_s: float | None
    servo_final_error_rad: float | None
    servo_max_tracking_error_rad: float | None
    servo_mean_power_W: float | None
    relay_executed: bool | None
    relay_steps: int | None
    relay_steps_on_plan: int | None
    relay_landed_fraction: float | None
    note: str

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict, angles in degrees (``*_deg``) when ``degrees``."""
        return result_dict(self, degrees)

    def measurement_fields(self) -> dict:
        """The :class:`Measurement` fields these fill (``note`` as ``drive_note``, None when empty)."""
        fields = {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "note"}
        return fields | {"drive_note": self.note or None}


def drive_metrics(design, *, axis=DRIVE_AXIS, angle: float = DRIVE_ANGLE, servo: bool = True,
                  relay: bool = True) -> DriveMetrics:
    """The servo's fastest turn and the settled relay plan of ``angle`` rad (default 360°) about ``axis`` (default
    :data:`DRIVE_AXIS`) on ``design``'s own model: :func:`spherestep.drive.drive_turn` with ``mode="servo"`` and
    ``mode="settled"`` (``servo=False``/``relay=False`` leave one out, None with the reason). The servo's values
    are None when the planner refused the model (the drive then falls back to a fixed time, which is not the
    fastest turn); its time alone is None when the rotor never arrived for good."""
    from ..drive import drive_turn

    notes = []
    s = dict.fromkeys(("servo_turn_s", "servo_final_error_rad", "servo_max_tracking_error_rad",
                       "servo_mean_power_W"))
    r = dict.fromkeys(("relay_executed", "relay_steps", "relay_steps_on_plan", "relay_landed_fraction"))
    if not servo:
        notes.append("servo: not measured")
    else:
        run = drive_turn(design, axis, angle, mode="servo")
        if run.details.trajectory != "fastest":
            notes.append(f"servo: {run.details.note}")
        else:
            s.update(servo_turn_s=run.time if run.arrived else None, servo_final_error_rad=run.final_error,
                     servo_max_tracking_error_rad=run.max_tracking_error, servo_mean_power_W=run.mean_power)
            if not run.arrived:
                notes.append(f"servo: {run.arrival_note}")
    if not relay:
        notes.append("relay: not measured")
    else:
        d = drive_turn(design, axis, angle, mode="settled").details
        r.update(relay_executed=d.executed, relay_steps=d.steps, relay_steps_on_plan=d.steps_settled_on_plan,
                 relay_landed_fraction=d.steps_settled_on_plan / d.steps if d.steps else None)
    return DriveMetrics(**s, **r, note="; ".join(notes))


@dataclass(frozen=True)
class Measurement:
    """One gallery design measured (module docstring). Angles ``*_rad`` (``to_dict()`` gives ``*_deg``),
    torques N·m, mass kg, power W. ``escape_violations`` is the number of states with a 45° cone of directions
    and no next state, None when not checked; the ``servo_*`` and ``relay_*`` fields come from
    :func:`drive_metrics` (:class:`DriveMetrics`), None when not measured, ``drive_note`` says why."""

    key: str
    name: str
    rotor_poles: int
    coils: int
    core: str
    model: str
    states: int
    samples: int
    seed: int
    resolution_median_rad: float
    resolution_p95_rad: float
    range_fraction: float
    reaches_all: bool
    escape_violations: int | None
    capability_samples: int
    torque_median_N_m: float
    torque_p5_N_m: float
    bias_torque_max_N_m: float
    magnet_mass_kg: float
    coil_power_W: float | None
    supply_power_W: float
    servo_turn_s: float | None
    relay_landed_fraction: float | None
    servo_final_error_rad: float | None = None
    servo_max_tracking_error_rad: float | None = None
    servo_mean_power_W: float | None = None
    relay_executed: bool | None = None
    relay_steps: int | None = None
    relay_steps_on_plan: int | None = None
    drive_note: str | None = None

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict, angles in degrees (``*_deg``) when ``degrees``."""
        return result_dict(self, degrees)


def magnet_mass(design, density: float = MAGNET_DENSITY) -> float:
    """Mass (kg) of the rotor's magnets: ``M ρ π (d_m/2)² l_m``."""
    density = checks.positive(density, "density", "a density in kg/m³ > 0")
    return len(design.rotor) * density * math.pi * (0.5 * design.magnet_diameter) ** 2 * design.magnet_length


def measure(entry, *, samples: int = 20_000, capability_samples: int = 500, seed: int = 0,
            escape: bool = True, drive: bool = True) -> Measurement:
    """Measure ``entry`` (a :class:`~spherestep.gallery.Entry`): its design file loaded fresh, then the module's
    metrics with ``samples`` uniform orientations for the resolution and ``capability_samples`` for the torque
    capability (both from ``seed``); ``escape=False`` skips the escape check, ``drive=False`` the drive
    (:func:`drive_metrics`: seconds to half a minute per design)."""
    from ..control import torque_capability
    from ..magnetics import design_model

    samples = checks.count(samples, "samples", 1, expected="a positive number of orientations")
    capability_samples = checks.count(capability_samples, "capability_samples", 1,
                                      expected="a positive number of orientations")
    design = entry.design()
    m = design.metrics(samples=samples, seed=seed, escape=escape)
    own = design_model(design)
    cap = torque_capability(design, own.model, own.limits, samples=capability_samples, seed=seed)
    pct = cap.percentiles(q=(5, 50))
    electrics = design.coil_electrics()
    drive = drive_metrics(design, servo=drive, relay=drive)
    return Measurement(
        key=entry.key, name=design.name, rotor_poles=len(design.rotor), coils=len(design.stator),
        core=design.coil.core, model=own.label, states=m.states, samples=samples, seed=seed,
        resolution_median_rad=m.resolution_median_rad, resolution_p95_rad=m.resolution_p95_rad,
        range_fraction=m.range_fraction, reaches_all=m.reaches_all,
        escape_violations=None if m.escape_violations is None else len(m.escape_violations),
        capability_samples=capability_samples, torque_median_N_m=pct[50], torque_p5_N_m=pct[5],
        bias_torque_max_N_m=float(cap.bias.max()), magnet_mass_kg=magnet_mass(design),
        coil_power_W=electrics.power, supply_power_W=design.coil.supply_power,
        **drive.measurement_fields())
