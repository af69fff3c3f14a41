"""Build and measure one design of a sweep; every outcome is a row, including the designs that cannot be built.

Statuses (a design gets the first that applies, checked in the order the design is built: rotor size, part
sizes, coil count, fit, lookup grid, candidate count, metrics):

* ``too_large``: the rotor has more poles than ``Limits.max_rotor_poles``; or the tolerance is so close to
  half the pole spacing that the state lookup grid would need more than ``Limits.max_lookup_voxels`` voxels
  (:func:`lookup_voxels`: 13.7 M for a 182-pole rotor with poles 4.1° apart at 1°, 4–7 s and 0.9 GB to build); or
  state enumeration would start from more candidate alignments than ``Limits.max_candidates`` (memory and
  time grow with them: 114 240 for the prototype, 0.4 GB and 10 s; 502 680 for a 272-pole rotor on 21
  coils, 4 GB and 110 s);
* ``does_not_fit``: a magnet or coil would have to shrink below its minimum size, parts overlap
  (:func:`spherestep.motor.check_fits`), or the tolerance is not under half the pole spacing;
* ``over_budget``: more coils in the stator cap than ``Limits.budget_coils``;
* ``no_states``: fewer than two coils, or no orientation holds two poles on two coils;
* ``failed``: the metrics raised an error (its type and message are the reason);
* ``ok``: measured (when the holding torque could not be, the reason says why and its columns are empty).

The torques (holding and capability) are measured on the design's own model
(:func:`spherestep.magnetics.design_model`: the point's ``core``, the coil's own ampere-turns and drive limits);
``model`` names it. An iron core reads stored tables for the prototype's shape scaled by the law and for
magnets the shape table covers (:func:`iron_is_stored`); other parts would need a moment-method solve of minutes
per part size, which a sweep does not do, so their torque columns are empty and the reason says why (``--core
air`` measures every design).

The candidate count is the number of (coil pair, ordered pole pair) with arcs within ``2 tol`` of each
other, exactly the alignments :func:`spherestep.motor.find_states` starts from.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import socket
import sys
import time
from dataclasses import dataclass, replace

import numpy as np

from .. import checks
from ..errors import InputError, SpherestepError
from ..motor import MotorDesign, PolarityRule, check_fits
from ..motor.coil import iron_coil
from ..motor.states import candidate_count
from ..packing import named
from ..sphere import NearestPointGrid, shell_voxels
from .grid import DesignPoint, primary_ratio

CAPABILITY_SAMPLES = 100  # orientations per design for the torque capability (a sweep objective)
STATUSES = ("ok", "too_large", "does_not_fit", "over_budget", "no_states", "failed")
LIMIT_STATUSES = ("too_large", "over_budget")  # outcomes that depend on the sweep's limits, not the design


@dataclass(frozen=True)
class Limits:
    """What a sweep is willing to build and evaluate (not part of a design's key)."""

    budget_coils: int = 32
    max_rotor_poles: int = 300
    max_candidates: int = 200_000
    max_lookup_voxels: int = 4_000_000

    def __post_init__(self):
        for label in ("budget_coils", "max_rotor_poles", "max_candidates", "max_lookup_voxels"):
            object.__setattr__(self, label, checks.count(getattr(self, label), label, 2,
                                                         expected="an integer of at least 2"))


class Unbuildable(Exception):
    """A design the sweep records but does not measure: ``status`` (one of :data:`STATUSES`), ``reason`` and,
    once the stator is known, the number of ``coils``."""

    def __init__(self, status: str, reason: str, coils: int | None = None):
        super().__init__(reason)
        self.status = status
        self.reason = reason
        self.coils = coils


def part_sizes(point: DesignPoint) -> tuple[float, float]:
    """Magnet and coil diameters (m) by the rule of :mod:`spherestep.explore.grid`; Unbuildable if too small."""
    R = 0.5 * point.sphere_diameter
    rotor = named(point.rotor, point.rotor_level)
    room = 2 * R * math.tan(0.5 * rotor.min_separation())
    magnet = min(point.magnet_diameter_max, point.fill * room)
    if magnet < point.magnet_diameter_min:
        raise Unbuildable("does_not_fit", f"the rotor's closest poles leave room for a {1e3 * room:.3g} mm magnet, "
                          f"under the minimum {1e3 * point.magnet_diameter_min:.3g} mm")
    primary = float(named(point.stator, 0).radii[0])
    room = 2 * (R + point.air_gap) * math.tan(primary)
    coil = min(point.coil_diameter_max, point.fill * room)
    if coil < point.coil_diameter_min:
        raise Unbuildable("does_not_fit", f"the stator's primary caps leave room for a {1e3 * room:.3g} mm coil, "
                          f"under the minimum {1e3 * point.coil_diameter_min:.3g} mm")
    return magnet, coil


def build_design(point: DesignPoint, limits: Limits = Limits(), name: str | None = None) -> MotorDesign:
    """The :class:`~spherestep.motor.MotorDesign` of ``point`` (:meth:`MotorDesign.from_packings` with the
    prototype's polarity rule and 'fit' coils); Unbuildable with the status and reason otherwise."""
    rotor = named(point.rotor, point.rotor_level)
    if len(rotor) > limits.max_rotor_poles:
        raise Unbuildable("too_large", f"the rotor has {len(rotor)} poles, over the sweep's limit of "
                          f"{limits.max_rotor_poles}")
    magnet, coil = part_sizes(point)
    try:  # the coil budget is the sweep's, checked below; the design's own limit is set from the count
        design = MotorDesign.from_packings(
            rotor=point.rotor, rotor_refine=point.rotor_level, polarity=PolarityRule(1, -1), stator=point.stator,
            stator_refine=point.stator_level, stator_axis=point.stator_axis,
            cap_half_angle=math.radians(point.cap_half_angle_deg), coils="fit",
            sphere_diameter=point.sphere_diameter, magnet_diameter=magnet, magnet_length=point.magnet_length,
            coil_diameter=coil, coil_length=point.coil_length, air_gap=point.air_gap,
            tol=math.radians(point.tol_deg), name=name or f"explore {point.key}", max_coils=sys.maxsize,
            check_fit=False, coil=replace(iron_coil(), core=point.core),
        )
    except InputError as exc:
        if exc.field == "coils":  # 'fit' found no cap wide enough for a coil
            raise Unbuildable("no_states", "0 coils in the stator cap; a state needs two poles on two coils",
                              coils=0) from None
        raise Unbuildable("does_not_fit", str(exc)) from None
    coils = len(design.stator)
    if coils > limits.budget_coils:
        raise Unbuildable("over_budget", f"{coils} coils in the stator cap, over the budget of "
                          f"{limits.budget_coils}", coils=coils)
    if coils < 2:
        raise Unbuildable("no_states", f"{coils} coil{'s' if coils != 1 else ''} in the stator cap; a "
                          "state needs two poles on two coils", coils=coils)
    design = replace(design, max_coils=max(limits.budget_coils, coils))
    try:
        check_fits(design)
    except SpherestepError as exc:
        raise Unbuildable("does_not_fit", str(exc), coils=coils) from None
    return design


def motor_fingerprint(design: MotorDesign) -> str:
    """16 hex digits naming the physical motor: poles, polarities, coils, part sizes and tolerance (to 1e-9).

    Grid points can build the same motor (a stator refined once more whose new caps are all too small for a
    coil); their fingerprints are equal, so a proposal lists the motor once.
    """
    parts = [design.rotor.centers, design.polarity, design.stator.centers,
             [design.sphere_diameter, design.magnet_diameter, design.magnet_length, design.coil_diameter,
              design.coil_length, design.air_gap, design.state_tol]]
    digest = hashlib.sha256()
    for part in parts:
        digest.update(np.round(np.asarray(part, dtype=float), 9).tobytes())
    return digest.hexdigest()[:16]


def lookup_voxels(design: MotorDesign) -> float:
    """Voxels of the :class:`~spherestep.sphere.NearestPointGrid` that state enumeration builds on the poles:
    the shell of an ``n³`` cube (:func:`~spherestep.sphere.shell_voxels`, ``n`` from
    :meth:`~spherestep.sphere.NearestPointGrid.side`); infinite when ``tol`` is not under half the pole
    spacing. Time and memory (~70 bytes a voxel) grow with it."""
    separation = design.rotor.min_separation()
    if 0.5 * separation <= design.state_tol:
        return math.inf
    return float(len(shell_voxels(NearestPointGrid.side(separation, design.state_tol))))


def iron_is_stored(design: MotorDesign) -> bool:
    """Whether the iron model of ``design`` reads stored tables, ready at once: the prototype's FEM tables scaled
    by the law, or the shape table for other magnets (:func:`spherestep.magnetics.solve_needed`); any other iron
    design solves its tables by the moment method first (minutes)."""
    from ..magnetics import solve_needed

    return solve_needed(design, design.coil) is None


def unmeasured_iron(design: MotorDesign) -> str | None:
    """None when the sweep measures ``design``'s torques (an air core, or iron on stored tables,
    :func:`iron_is_stored`); else why not, for people."""
    from ..magnetics import solve_needed

    if design.coil.core != "iron":
        return None
    why = solve_needed(design, design.coil)
    if why is None:
        return None
    return (f"the iron model of these parts (magnet {1e3 * design.magnet_diameter:.3g} mm, coil "
            f"{1e3 * design.coil_diameter:.3g} mm) has no stored tables ({why}): a moment-method solve of minutes "
            "per part size, which a sweep does not do (--core air measures every design)")


def torque_capability_sample(design: MotorDesign, seed: int, samples: int = CAPABILITY_SAMPLES,
                             own=None) -> np.ndarray:
    """The torque (N·m) available in every direction at ``samples`` orientations drawn uniformly (``seed``), on
    the design's own model and drive limits (``own``, default :func:`spherestep.magnetics.design_model`;
    :func:`spherestep.control.torque_capability`)."""
    from ..control import torque_capability
    from ..magnetics import design_model

    own = design_model(design) if own is None else own
    return torque_capability(design, own.model, own.limits, samples=samples, seed=seed).radius


def holding_torques(design: MotorDesign, count: int, seed: int, own=None) -> np.ndarray:
    """Holding torques (N·m) of ``count`` stepper states drawn at random (``seed``), on the design's own model
    (``own``, default :func:`spherestep.magnetics.design_model`).

    Each state's coils are energised at its poles' polarities (the coil's nominal current), the rotor is
    settled into the equilibrium near the geometric state (:func:`spherestep.statics.equilibrium`; with iron
    the detent included), and the smallest peak restoring torque over 32 axes is its holding torque
    (:func:`spherestep.statics.holding_torque`). States whose equilibrium search does not converge are left out.
    """
    from ..magnetics import design_model
    from ..statics import equilibrium, holding_torque

    model = (design_model(design) if own is None else own).model
    states = design.states()
    idx = np.sort(np.random.default_rng(seed).choice(len(states), size=min(count, len(states)), replace=False))
    currents = np.array([design.coil_currents(states.coils(int(i))) for i in idx])
    eq = equilibrium(model, states.rotations[idx], currents)
    return holding_torque(model, eq.rotation, currents).torque[np.asarray(eq.converged, dtype=bool)]


def _torques(design: MotorDesign, point: DesignPoint, row: dict) -> None:
    """The holding torque and the capability of ``design`` into ``row`` on its own model (``row["model"]`` its
    label); the reason says why, when they cannot be measured (the kinematic metrics stand without them)."""
    from ..magnetics import design_model

    why = unmeasured_iron(design)
    if why is not None:
        row["reason"] = f"torques not measured: {why}"
        return
    try:
        own = design_model(design)
    except Exception as exc:  # noqa: BLE001 (e.g. a winding that does not fit the coil)
        row["reason"] = f"torques not measured: the design's model: {type(exc).__name__}: {exc}"
        return
    row["model"] = own.label
    try:
        torques = holding_torques(design, point.torque_states, point.seed, own)
    except Exception as exc:  # noqa: BLE001
        row["reason"] = f"holding torque not measured: {type(exc).__name__}: {exc}"
    else:
        row["holding_torque_states"] = len(torques)
        if len(torques):
            row.update(holding_torque_median_Nm=float(np.median(torques)),
                       holding_torque_min_Nm=float(torques.min()))
        else:
            row["reason"] = "holding torque not measured: no equilibrium search converged"
    available = torque_capability_sample(design, point.seed, own=own)
    row.update(capability_median_Nm=float(np.median(available)),
               capability_p5_Nm=float(np.percentile(available, 5)))


def _base_row(point: DesignPoint) -> dict:
    return {
        "key": point.key, "rotor": point.rotor, "rotor_level": point.rotor_level, "rotor_family": point.rotor_family,
        "rotor_poles": len(named(point.rotor, point.rotor_level)), "stator": point.stator,
        "stator_level": point.stator_level, "stator_family": point.stator_family, "family_rule": point.family_rule,
        "primary_ratio": primary_ratio(point.rotor, point.stator), "cap_half_angle_deg": point.cap_half_angle_deg,
        "tol_deg": point.tol_deg, "samples": point.samples, "seed": point.seed, "core": point.core,
        "inertia_isotropy": named(point.rotor, point.rotor_level).inertia_isotropy(),
    }


def evaluate(point: DesignPoint, limits: Limits = Limits()) -> dict:
    """One row of the results table for ``point`` (see :data:`spherestep.explore.store.SCHEMA` for the columns).

    Never raises for a design that cannot be built or measured: the row carries its status and reason.
    """
    start = time.perf_counter()
    row = _base_row(point)
    try:
        design = build_design(point, limits)
        row.update(motor=motor_fingerprint(design), coils=len(design.stator),
                   magnet_diameter_mm=1e3 * design.magnet_diameter, coil_diameter_mm=1e3 * design.coil_diameter,
                   max_step_deg=math.degrees(design.max_step))
        voxels = lookup_voxels(design)
        spacing = math.degrees(design.rotor.min_separation())
        if not math.isfinite(voxels):
            raise Unbuildable("does_not_fit", f"a tolerance of {point.tol_deg:g}° is not under half the "
                              f"{spacing:.3g}° pole spacing: one coil could hold two poles")
        row["lookup_voxels"] = int(voxels)
        if voxels > limits.max_lookup_voxels:
            raise Unbuildable("too_large", f"a tolerance of {point.tol_deg:g}° against poles {spacing:.3g}° apart "
                              f"needs a state lookup grid of {voxels:.3g} voxels, over the sweep's limit of "
                              f"{limits.max_lookup_voxels}")
        row["candidates"] = candidate_count(design)
        if row["candidates"] > limits.max_candidates:
            raise Unbuildable("too_large", f"{row['candidates']} candidate alignments, over the sweep's limit of "
                              f"{limits.max_candidates}")
        try:
            metrics = design.metrics(samples=point.samples, seed=point.seed)
        except Exception as exc:  # noqa: BLE001 (a design that breaks the metrics is recorded, not fatal)
            raise Unbuildable("failed", f"{type(exc).__name__}: {exc}") from None
        if metrics.states == 0:
            raise Unbuildable("no_states", "no orientation holds two poles on two coils")
        row.update(
            status="ok", reason="", states=metrics.states,
            resolution_median_deg=math.degrees(metrics.resolution_median_rad),
            resolution_p95_deg=math.degrees(metrics.resolution_p95_rad),
            resolution_max_deg=math.degrees(metrics.resolution_max_rad),
            range_fraction=metrics.range_fraction, state_graph_components=metrics.state_graph_components,
            reaches_all=metrics.reaches_all, escape_violations=len(metrics.escape_violations),
        )
        if point.torque_states:
            _torques(design, point, row)
    except Unbuildable as exc:
        row.update(status=exc.status, reason=exc.reason)
        if exc.coils is not None:
            row["coils"] = exc.coils
    row["seconds"] = time.perf_counter() - start
    row["worker"] = f"{socket.gethostname()}:{os.getpid()}"
    row["params"] = json.dumps(point.params, sort_keys=True)
    return row
