"""Every gallery design measured by the same code.

* stepper states, resolution (median and 95th percentile of the Park distance from uniform random orientations
  to the nearest state), range (``reaches_all``) and escape violations: :meth:`MotorDesign.metrics`;
* torque capability over SO(3) on the design's own model (the core its file states,
  :func:`spherestep.magnetics.design_model`): :func:`spherestep.control.torque_capability`, the torque available
  in every direction, its median and 5th percentile over uniform orientations, and the largest detent (bias)
  torque at zero current;
* mass of the magnets, ``M ρ π (d_m/2)² l_m`` with the NdFeB density :meth:`MotorDesign.inertia` uses; coils and
  their power at nominal current (:meth:`MotorDesign.coil_electrics`).

The fastest servo turn and relay stepping come from the drive room (``spherestep.drive``), which is being
rebuilt: :func:`drive_metrics` is the hook that will call it; until then it returns a
:class:`DriveMetrics` whose values are None with the reason.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import checks
from ..units import result_dict

MAGNET_DENSITY = 7500.0  # kg/m³, sintered NdFeB: the default of MotorDesign.inertia (magnet_density)
DRIVE_PENDING = "pending: the spherestep.drive room (fastest servo turn, relay stepping) is being rebuilt"


@dataclass(frozen=True)
class DriveMetrics:
    """What driving the motor gives: the fastest servo turn (s) and the fraction of relay steps that land
    within 0.5° of the plan; None with ``note`` saying why when not measured."""

    servo_turn_s: float | None
    relay_landed_fraction: float | None
    note: str

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict (no angles)."""
        return result_dict(self, degrees)


def drive_metrics(design) -> DriveMetrics:
    """THE HOOK for the fastest servo turn and relay stepping of ``design`` (issue 29 §4).

    The drive room (``spherestep.drive``: mode × backend → one result type) is being written; the old dynamics
    functions are not called here. When it lands, this function calls it (one servo turn at the fastest feasible
    time, one settled relay plan) and fills the two fields; the CSV columns and the CLI's columns exist already.
    """
    del design  # measured once the drive room lands
    return DriveMetrics(servo_turn_s=None, relay_landed_fraction=None, note=DRIVE_PENDING)


@dataclass(frozen=True)
class Measurement:
    """One gallery design measured (module docstring). Angles ``*_rad`` (``to_dict()`` gives ``*_deg``),
    torques N·m, mass kg, power W. ``escape_violations`` is the number of states with a 45° cone of directions
    and no next state, None when not checked; ``servo_turn_s`` and ``relay_landed_fraction`` come from
    :func:`drive_metrics` (None while the drive room is pending)."""

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

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict, angles in degrees (``*_deg``) when ``degrees``."""
        return result_dict(self, degrees)


def magnet_mass(design, density: float = MAGNET_DENSITY) -> float:
    """Mass (kg) of the rotor's magnets: ``M ρ π (d_m/2)² l_m``."""
    density = checks.positive(density, "density", "a density in kg/m³ > 0")
    return len(design.rotor) * density * math.pi * (0.5 * design.magnet_diameter) ** 2 * design.magnet_length


def measure(entry, *, samples: int = 20_000, capability_samples: int = 500, seed: int = 0,
            escape: bool = True) -> Measurement:
    """Measure ``entry`` (a :class:`~spherestep.gallery.Entry`): its design file loaded fresh, then the module's
    metrics with ``samples`` uniform orientations for the resolution and ``capability_samples`` for the torque
    capability (both from ``seed``); ``escape=False`` skips the escape check (the slowest part)."""
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
    drive = drive_metrics(design)
    return Measurement(
        key=entry.key, name=design.name, rotor_poles=len(design.rotor), coils=len(design.stator),
        core=design.coil.core, model=own.label, states=m.states, samples=samples, seed=seed,
        resolution_median_rad=m.resolution_median_rad, resolution_p95_rad=m.resolution_p95_rad,
        range_fraction=m.range_fraction, reaches_all=m.reaches_all,
        escape_violations=None if m.escape_violations is None else len(m.escape_violations),
        capability_samples=capability_samples, torque_median_N_m=pct[50], torque_p5_N_m=pct[5],
        bias_torque_max_N_m=float(cap.bias.max()), magnet_mass_kg=magnet_mass(design),
        coil_power_W=electrics.get("power_W"), supply_power_W=design.coil.supply_power,
        servo_turn_s=drive.servo_turn_s, relay_landed_fraction=drive.relay_landed_fraction)
