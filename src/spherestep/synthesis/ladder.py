"""The search's candidates and the cheap rungs of its fidelity ladder (issue 29 §2).

A :class:`Candidate` is a layout from the paper's constructions — rotor packing × stator packing, each refined
(holes filled, :func:`spherestep.packing.refine`), the stator cap — at a ball size, with parts by the sweep's rule
(:mod:`spherestep.explore.grid`: the prototype's parts scaled with the ball, shrunk where the packing is finer) and
coils built like the prototype's pot core scaled to the coil. :func:`evaluate` climbs the ladder for one layout and
returns one row per core the spec allows, stopping a row at the first rung it fails:

1. ``geometry`` (milliseconds): the motor builds, coils within the spec's limit, the stator's reach and the magnets'
   mass within the envelope, an iron core affordable (below);
2. ``states`` (about a second): stepper states, resolution and range (:meth:`MotorDesign.metrics`, no escape check),
   pruned by the relay resolution and, for relays, by the range;
3. ``capability`` (about a second): the torque available in every direction over the spec's range on the design's
   own model (:func:`spherestep.magnetics.design_model`, :func:`spherestep.control.available_torque`), its quantile
   at the spec's fraction, the worst single coil failure when asked, a relay state's holding torque when asked, and
   a bang-bang time estimate ``2 √(θ I / τ)`` for the stated turn (an objective at the median torque; the prune
   uses the largest sampled torque, so it only drops designs that are clearly too slow).

4. ``relays`` (relay specs, seconds): :func:`relay_rung`, the settled relay plan of the stated turn and the many-turn
   verdict (run serially by :class:`~.run.Ladder` or on Dask by :func:`~.tasks.relay_part`; it lives here, with
   the other rungs, so the run and its tasks do not import each other).

The costly rung, full simulation, is :mod:`.verify`, for the finalists only.

**Iron and cost.** An iron core whose magnet, coil and gap geometry and ampere-turns equal the prototype's reuses the
stored FEM pair table; any other iron design solves a moment-method table first (about a minute, measured for the
gallery). Below the ``thorough`` budget such rows stop at ``geometry`` with status ``costly``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import socket
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from .. import so3

KEY_VERSION = 2  # 2: the cheap rungs prune with a sampling allowance
SLACK = 0.05  # relative allowance of the cheap rungs' sampled estimates at 1000 samples (∝ 1/√samples): a
#              candidate is pruned only when clearly worse; verification, with more samples, decides
INCH = 0.0254
PROTOTYPE = {"sphere_diameter": 12 * INCH, "magnet_diameter": 1 * INCH, "magnet_length": 0.5 * INCH,
             "coil_diameter": 2 * INCH, "coil_length": 1.625 * INCH, "air_gap": 0.005 * INCH}
MIN_GAP = 0.1e-3  # m: a scaled-down air gap stays at least this
MIN_WIRE = 0.1e-3  # m
PROTOTYPE_LAYOUT = {"rotor": "truncated-icosahedron", "rotor_level": 1, "stator": "truncated-cuboctahedron",
                    "stator_level": 1, "cap_deg": 80.0}
N42 = 1.32  # T: the prototype's magnets (MotorDesign's default remanence)
GRADES = {N42: "N42", 0.7: "bonded NdFeB", 0.4: "sintered ferrite", 0.25: "bonded ferrite",
          0.2: "flexible ferrite"}  # remanence (T) → grade, typical values
WINDINGS = (4, 3, 2)  # coils on at once that a rewound coil shares the supply with (Candidate.wound_for)


@dataclass(frozen=True)
class Candidate:
    """One layout at one ball size: ``rotor``/``stator`` base packings refined ``*_level`` times, the stator cap
    ``cap_deg`` (degrees) about −z, the ball ``sphere_diameter`` (m); ``seed`` and ``samples`` of the measurements;
    ``gap_scale`` widens the air gap (the baseline's neighbourhood: a wider gap weakens the iron's detent faster
    than the coils' pull). Parts: ``remanence`` (T) the magnets' grade (:data:`GRADES`); ``wound_for`` 0 keeps the
    pot core's winding (AWG 29 scaled), ``n`` ≥ 1 rewinds it with the wire that draws the supply's share with ``n``
    coils on at once, ``I = P / (V n)`` (:func:`wire_for`): with iron the detent goes as ``B_r²`` and the winding's
    pull as ``B_r N I``, so both parts move the ratio that decides where a relay step lands (docs/synthesis.md).
    Cores are a row each (:func:`evaluate`)."""

    rotor: str
    rotor_level: int
    stator: str
    stator_level: int
    cap_deg: float
    sphere_diameter: float
    samples: int = 1000
    capability_samples: int = 64
    seed: int = 0
    gap_scale: float = 1.0
    remanence: float = N42
    wound_for: int = 0

    @property
    def scale(self) -> float:
        return self.sphere_diameter / PROTOTYPE["sphere_diameter"]

    @property
    def label(self) -> str:
        return (f"{self.rotor}/L{self.rotor_level} × {self.stator}/L{self.stator_level}, {self.cap_deg:g}°, "
                f"{1e3 * self.sphere_diameter:.4g} mm" + (f", gap ×{self.gap_scale:g}" if self.gap_scale != 1 else "")
                + (f", {self.remanence:g} T magnets" if self.remanence != N42 else "")
                + (f", rewound for {self.wound_for} on" if self.wound_for else ""))

    def key(self, spec_digest: str, core: str) -> str:
        """16 hex digits naming this candidate with ``core`` under a spec (its :attr:`~Spec.digest`)."""
        params = asdict(self)
        for name, default in (("gap_scale", 1.0), ("remanence", N42), ("wound_for", 0)):
            if params[name] == default:  # keys of the layouts without it stay as they were
                del params[name]
        text = json.dumps({"version": KEY_VERSION, "spec": spec_digest, "core": core} | params,
                          sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def point(self):
        """The sweep's :class:`~spherestep.explore.DesignPoint` of this layout (its part-size rule)."""
        from ..explore import DesignPoint

        s = self.scale
        P = PROTOTYPE
        return DesignPoint(rotor=self.rotor, rotor_level=self.rotor_level, stator=self.stator,
                           stator_level=self.stator_level, cap_half_angle_deg=self.cap_deg, samples=self.samples,
                           seed=self.seed, torque_states=0, sphere_diameter=self.sphere_diameter,
                           air_gap=(P["air_gap"] if s == 1.0 else max(MIN_GAP, P["air_gap"] * s)) * self.gap_scale,
                           magnet_diameter_max=P["magnet_diameter"] * s, magnet_diameter_min=0.25 * INCH * s,
                           magnet_length=P["magnet_length"] * s, coil_diameter_max=P["coil_diameter"] * s,
                           coil_diameter_min=0.5 * INCH * s, coil_length=P["coil_length"] * s)


def coil_for(design, core: str, spec, wound_for: int = 0):
    """The coil of ``design`` with ``core``: the prototype's pot core and winding scaled by the coil's diameter
    (pole, wall, wire) and length (back plate), on the spec's supply; the prototype's coil exactly at its size.
    ``wound_for`` ``n`` ≥ 1: rewound with the wire that draws ``P / (V n)`` (:func:`wire_for`), ``coils_on = n``."""
    from ..motor.coil import iron_coil

    k = design.coil_diameter / PROTOTYPE["coil_diameter"]
    h = design.coil_length / PROTOTYPE["coil_length"]
    base = iron_coil()
    coil = replace(base, core=core, pole_diameter=base.pole_diameter * k, wall_thickness=base.wall_thickness * k,
                   back_thickness=base.back_thickness * h, wire_diameter=max(MIN_WIRE, base.wire_diameter * k),
                   supply_voltage=spec.supply.voltage, supply_power=spec.supply.power)
    if wound_for:
        amps = spec.supply.power / (spec.supply.voltage * wound_for)
        coil = replace(coil, coils_on=wound_for, wire_diameter=wire_for(coil, design, amps))
    return coil


def wire_for(coil, design, amps: float) -> float:
    """The wire diameter (m, 0.1 µm) whose winding of ``coil`` on ``design``'s coil size draws ``amps`` at the
    supply voltage, ``V / R = I`` (``R ∝ 1/d⁴`` at a fixed fill: bisection in ``log d``; at least :data:`MIN_WIRE`):
    the thickest the supply's share allows, so the most ampere-turns ``N I`` (``∝ d²``) it affords."""
    size = (design.coil_diameter, design.coil_length)
    lo, hi = MIN_WIRE, 5e-3
    if coil.supply_voltage / replace(coil, wire_diameter=lo).resistance(*size) >= amps:
        return lo
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        if coil.supply_voltage / replace(coil, wire_diameter=mid).resistance(*size) < amps:
            lo = mid
        else:
            hi = mid
    return round(lo, 7)


def iron_is_stored(design) -> bool:
    """Whether the iron model of ``design`` reads stored tables, ready at once (the prototype's scaled, or the
    shape table; :func:`spherestep.explore.iron_is_stored`, the one check)."""
    from ..explore import iron_is_stored as stored

    return stored(design)


def range_orientations(spec, count: int, seed: int) -> np.ndarray:
    """``count`` orientations spread over the spec's range: Haar-uniform on SO(3) for ``all``; for a cone of
    half-angle α about ``a``, a uniform twist about ``a`` then a tilt whose direction is uniform on the cap of
    half-angle α (so ``R a`` is uniform on the cap)."""
    rng = np.random.default_rng(seed)
    if spec.range == "all":
        return so3.random(count, rng)
    a = spec.range.axis.vector
    twist = so3.rot(a, rng.uniform(0.0, 2 * math.pi, count))
    cos_t = 1.0 - rng.uniform(0.0, 1.0, count) * (1.0 - math.cos(spec.range.cone))
    tilt = np.arccos(np.clip(cos_t, -1.0, 1.0))
    helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    phi = rng.uniform(0.0, 2 * math.pi, count)
    axes = np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
    return so3.rot(axes, tilt) @ twist


def in_range(spec, R) -> np.ndarray:
    """Whether each orientation ``R (..., 3, 3)`` lies in the spec's range."""
    R = np.asarray(R)
    if spec.range == "all":
        return np.ones(R.shape[:-2], dtype=bool)
    a = spec.range.axis.vector
    return (R @ a) @ a >= math.cos(spec.range.cone) - 1e-12


def magnet_mass(design) -> float:
    """kg of the rotor's magnets (:func:`spherestep.gallery.magnet_mass`)."""
    from ..gallery import magnet_mass as mass

    return mass(design)


def change_from(candidate: Candidate, core: str, baseline: dict | None) -> float | None:
    """How far ``candidate`` with ``core`` is from the ``baseline`` layout (a dict as :data:`PROTOTYPE_LAYOUT` with
    ``core`` and ``sphere_diameter``): one per changed choice (rotor packing, its level, stator packing, its level,
    core, ball size, air gap, magnet grade, winding) plus the cap's change in tens of degrees, and for a changed
    part a tenth of the log of its ratio: ``|ln(B_r / B_r0)|`` for the grade, ``ln(4 / n)`` for a winding rewound
    for ``n`` coils on (so of two grades that work the nearer one is the smaller change). None without a baseline."""
    if baseline is None:
        return None
    steps = sum(getattr(candidate, k) != baseline[k] for k in ("rotor", "rotor_level", "stator", "stator_level"))
    steps += core != baseline["core"]
    steps += not math.isclose(candidate.sphere_diameter, baseline["sphere_diameter"], rel_tol=1e-9)
    steps += candidate.gap_scale != 1.0
    was = baseline.get("remanence", N42)
    if not math.isclose(candidate.remanence, was, rel_tol=1e-9):
        steps += 1.0 + 0.1 * abs(math.log(candidate.remanence / was))
    if candidate.wound_for:
        steps += 1.0 + 0.1 * math.log(4.0 / candidate.wound_for)
    return float(steps + abs(candidate.cap_deg - baseline["cap_deg"]) / 10.0)


def build(candidate: Candidate, core: str, spec, name: str | None = None):
    """The :class:`~spherestep.motor.MotorDesign` of ``candidate`` with ``core`` (the sweep's builder,
    :func:`spherestep.explore.build_design`, then the coil); ``explore.Unbuildable`` when it cannot be built."""
    from ..explore import Limits, build_design

    design = build_design(candidate.point(), Limits(budget_coils=spec.max_coils))
    return replace(design, coil=coil_for(design, core, spec, candidate.wound_for), remanence=candidate.remanence,
                   name=name or f"synth {candidate.key(spec.digest, core)}")


def capability_numbers(design, spec, R, *, failed_check: bool, directions: int = 200) -> dict:
    """The capability rung on the design's own model at orientations ``R``: the torque available in every
    direction, its quantile at ``1 − over_fraction`` and median, the largest detent torque, the worst quantile over
    single coil failures (when ``failed_check``); N·m."""
    from ..control import available_torque
    from ..magnetics import design_model

    own = design_model(design)
    K = np.asarray(own.model.torque_matrix(R), dtype=float)
    bias = np.asarray(own.model.torque(R, np.zeros((len(R), own.model.coil_count))), dtype=float)
    r, _ = available_torque(K, own.limits, bias=bias, failed=own.model.failed, directions=directions)
    q = 1.0 - spec.torque.over_fraction
    out = {"torque_quantile_Nm": float(np.quantile(r, q)), "torque_median_Nm": float(np.median(r)),
           "torque_max_Nm": float(np.max(r)),
           "torque_positive_fraction": float(np.mean(r > 0)), "detent_Nm": float(np.linalg.norm(bias, axis=-1).max()),
           "model": own.label}
    if failed_check:
        worst = math.inf
        for k in range(own.model.coil_count):
            rk, _ = available_torque(K, own.limits, bias=bias, failed=(k,), directions=directions)
            worst = min(worst, float(np.quantile(rk, q)))
        out["failed_coil_torque_Nm"] = worst
    return out


def step_torque(design, count: int, seed: int) -> float:
    """Median holding torque (N·m) of ``count`` random stepper states on the design's own model: each state's
    coils energised at its poles' polarities, the rotor settled (:func:`spherestep.statics.equilibrium`), the
    smallest peak restoring torque over the axes of :func:`spherestep.statics.holding_torque`."""
    from ..magnetics import design_model
    from ..statics import equilibrium, holding_torque

    states = design.states()
    model = design_model(design).model
    idx = np.sort(np.random.default_rng(seed).choice(len(states), size=min(count, len(states)), replace=False))
    currents = np.array([design.coil_currents(states.coils(int(i))) for i in idx])
    eq = equilibrium(model, states.rotations[idx], currents)
    ok = np.asarray(eq.converged, dtype=bool)
    if not ok.any():
        return math.nan
    return float(np.median(holding_torque(model, eq.rotation[ok], currents[ok]).torque))


def time_estimate(design, spec, torque: float) -> float:
    """``2 √(θ I / τ)`` (s): the bang-bang time of the spec's turn ``θ`` at a torque ``τ`` about the axis on the
    rotor's mean moment of inertia ``I`` (the fastest possible with ``τ`` throughout); inf for ``τ ≤ 0``."""
    if spec.speed is None or not torque > 0:
        return math.inf if spec.speed is not None else math.nan
    inertia = float(np.trace(design.inertia()) / 3.0)
    return 2.0 * math.sqrt(abs(spec.speed.turn) * inertia / torque)


def slack(samples: int) -> float:
    """The cheap rungs' allowance for sampling error with ``samples`` orientations: :data:`SLACK` · √(1000/n)."""
    return SLACK * math.sqrt(1000.0 / max(int(samples), 1))


def _row(candidate: Candidate, core: str, spec, baseline) -> dict:
    return {"key": candidate.key(spec.digest, core), "spec": spec.digest, "rotor": candidate.rotor,
            "rotor_level": candidate.rotor_level, "stator": candidate.stator, "stator_level": candidate.stator_level,
            "cap_deg": candidate.cap_deg, "sphere_diameter_mm": 1e3 * candidate.sphere_diameter, "core": core,
            "gap_scale": candidate.gap_scale,
            "change": change_from(candidate, core, baseline), "params": json.dumps(asdict(candidate), sort_keys=True),
            "worker": f"{socket.gethostname()}:{os.getpid()}"}


def evaluate(candidate: Candidate, spec, allow_costly: bool = False, baseline: dict | None = None) -> list[dict]:
    """The ladder's cheap rungs for ``candidate``: one row per core of the spec (module docstring). Never raises
    for a design that cannot be built or measured: the row says where it stopped (``stage``) and why."""
    return climb(candidate, spec, allow_costly, baseline)[0]


def climb(candidate: Candidate, spec, allow_costly: bool = False, baseline: dict | None = None,
          through: str = "capability") -> tuple[list[dict], dict]:
    """:func:`evaluate`'s rows and the designs it built, by core: the first live core's carries its stepper
    states (computed once, by the states rung), so a later rung on it does not enumerate them again. ``through``
    ``"states"`` stops after the shared rungs (geometry, states): a row still climbing has no ``status`` yet, and
    :func:`capability_rung` finishes it (the search runs that per core, as its own task)."""
    from ..explore import Unbuildable

    start = time.perf_counter()
    rows = {core: _row(candidate, core, spec, baseline) for core in spec.cores}

    def stop(cores, stage: str, status: str, reason: str):
        for core in cores:
            if rows[core].get("status") is None:
                rows[core].update(stage=stage, status=status, reason=reason)

    live = list(spec.cores)
    designs = {}
    try:  # --- rung 1: geometry ---
        for core in live:
            designs[core] = build(candidate, core, spec)
    except Unbuildable as exc:
        stop(live, "geometry", "pruned", f"{exc.status}: {exc.reason}")
        live = []
    for core in list(live):
        d = designs[core]
        row = rows[core]
        from ..explore import motor_fingerprint

        parts = (f"-{candidate.remanence:g}T" if candidate.remanence != N42 else "") + \
            (f"-w{candidate.wound_for}" if candidate.wound_for else "")  # the fingerprint is the layout's
        row.update(motor=motor_fingerprint(d) + core[0] + parts, coils=len(d.stator), rotor_poles=len(d.rotor), magnet_diameter_mm=1e3 * d.magnet_diameter,
                   coil_diameter_mm=1e3 * d.coil_diameter, air_gap_mm=1e3 * d.air_gap, magnet_mass_kg=magnet_mass(d))
        reach = d.air_gap + d.coil_length
        electrics = d.coil_electrics()
        power = math.nan if electrics.power is None else electrics.power
        row["power_W"] = float(power) * min(d.coil.coils_on, len(d.stator))
        row.update(remanence_T=float(d.remanence), ampere_turns=electrics.ampere_turns)
        why = None
        if spec.envelope.stator_reach is not None and reach > spec.envelope.stator_reach * (1 + 1e-9):
            why = f"the stator reaches {1e3 * reach:.3g} mm from the ball, over {1e3 * spec.envelope.stator_reach:.3g} mm"
        elif spec.envelope.mass_limit is not None and row["magnet_mass_kg"] > spec.envelope.mass_limit:
            why = f"{row['magnet_mass_kg']:.3g} kg of magnets, over {spec.envelope.mass_limit:.3g} kg"
        if why:
            stop([core], "geometry", "pruned", why)
            live.remove(core)
            continue
        if core == "iron":
            row["iron_stored"] = iron_is_stored(d)
            if not row["iron_stored"] and not allow_costly:
                stop([core], "geometry", "costly", "an iron core whose parts the stored tables do not cover (the "
                     "prototype's shape scaled, the shape table's magnets) solves a moment-method table first "
                     "(~1 min); searched with the thorough budget")
                live.remove(core)
    if live:  # --- rung 2: states (shared by the cores) ---
        d = designs[live[0]]
        try:
            m = d.metrics(samples=candidate.samples, seed=candidate.seed, escape=False)
        except Exception as exc:  # noqa: BLE001 (a design that breaks the metrics is recorded, not fatal)
            stop(live, "states", "failed", f"{type(exc).__name__}: {exc}")
            live = []
        else:
            for core in live:
                rows[core].update(states=m.states, resolution_median_deg=math.degrees(m.resolution_median_rad),
                                  resolution_p95_deg=math.degrees(m.resolution_p95_rad),
                                  range_fraction=m.range_fraction, reaches_all=bool(m.reaches_all))
            why = None
            if m.states == 0:
                why = "no stepper states"
            elif spec.relays and spec.range == "all" and not m.reaches_all:
                why = "the relay steps do not reach all of SO(3)"
            elif spec.precision.relay_resolution is not None and \
                    m.resolution_median_rad > spec.precision.relay_resolution * (1 + slack(candidate.samples)):
                why = (f"median resolution {math.degrees(m.resolution_median_rad):.3g}° over the required "
                       f"{math.degrees(spec.precision.relay_resolution):.3g}°")
            if why:
                stop(live, "states", "pruned", why)
                live = []
    if through == "states":
        seconds = time.perf_counter() - start
        for row in rows.values():
            row["seconds"] = seconds
        return list(rows.values()), {core: designs[core] for core in live}
    for core in live:  # --- rung 3: capability on the design's own model ---
        capability_rung(candidate, rows[core], designs[core], spec)
    seconds = time.perf_counter() - start
    for row in rows.values():
        row["seconds"] = seconds
    return list(rows.values()), designs


def capability_rung(candidate: Candidate, row: dict, design, spec) -> None:
    """Rung 3 on one core's ``row`` (its ``design``): the capability on the design's own model at the spec's
    range orientations, and the prunes that read it (module docstring); sets the row's ``stage``, ``status`` and
    ``reason``."""
    R = range_orientations(spec, candidate.capability_samples, candidate.seed)
    try:
        row.update(capability_numbers(design, spec, R, failed_check=spec.single_coil_failure and spec.servo))
        if spec.relays and spec.torque.step is not None:
            row["step_torque_Nm"] = step_torque(design, 4, candidate.seed)
    except Exception as exc:  # noqa: BLE001
        row.update(stage="capability", status="failed", reason=f"{type(exc).__name__}: {exc}")
        return
    row["time_estimate_s"] = time_estimate(design, spec, row["torque_median_Nm"])
    fastest = time_estimate(design, spec, row.pop("torque_max_Nm"))
    why = ""
    need = spec.torque.every_direction
    loose = 1 - slack(candidate.capability_samples * 15)  # 64 orientations ~ as noisy as 1000 for the median
    if spec.servo and need is not None and row["torque_quantile_Nm"] < need * loose:
        why = (f"{row['torque_quantile_Nm']:.3g} N·m in every direction over {spec.torque.over_fraction:.0%} of "
               f"the range, under {need:.3g}")
    elif spec.servo and row["torque_positive_fraction"] < spec.torque.over_fraction:
        why = f"torque in every direction on only {row['torque_positive_fraction']:.0%} of the range"
    elif spec.servo and spec.single_coil_failure and need is not None and \
            row["failed_coil_torque_Nm"] < need * loose:
        why = f"{row['failed_coil_torque_Nm']:.3g} N·m with the worst coil failed, under {need:.3g}"
    elif spec.relays and spec.torque.step is not None and not row["step_torque_Nm"] >= spec.torque.step:
        why = f"step torque {row['step_torque_Nm']:.3g} N·m under {spec.torque.step:.3g}"
    elif spec.speed is not None and spec.servo and fastest > spec.speed.within:
        why = (f"even a bang-bang turn at the largest sampled torque takes {fastest:.3g} s, over "
               f"{spec.speed.within:.3g} s")
    row.update(stage="capability", status="pruned" if why else "ok", reason=why)


def baseline_layout(spec) -> dict | None:
    """The layout the spec's ``baseline`` names ('prototype' or a design file built from named packings), as a
    dict of :data:`PROTOTYPE_LAYOUT`'s keys with ``core`` and ``sphere_diameter``; None without one."""
    if spec.baseline is None:
        return None
    if spec.baseline == "prototype":
        return PROTOTYPE_LAYOUT | {"core": "iron", "sphere_diameter": PROTOTYPE["sphere_diameter"], "remanence": N42}
    from ..design_file import read
    from ..errors import bad_value

    doc = read(spec.baseline).spec
    rotor, stator = doc.rotor, doc.stator
    if rotor.packing is None or stator.packing is None:
        raise bad_value("baseline", "a design file whose rotor and stator are named packings (a layout the search "
                        "enumerates), or 'prototype'", spec.baseline)
    return {"rotor": rotor.packing, "rotor_level": rotor.refine or 0, "stator": stator.packing,
            "stator_level": stator.refine or 0, "cap_deg": round(math.degrees(stator.cap_half_angle), 9),
            "core": (doc.coil.core if doc.coil is not None else None) or "iron",
            "sphere_diameter": doc.dimensions.sphere_diameter, "remanence": float(doc.remanence)}


def relay_rung(candidate: Candidate, row: dict, spec, design=None) -> None:
    """The ladder's relay rung, for relay specs: the settled relay plan of the stated turn (30° about z without
    one) on the design's own model, simulated as :func:`spherestep.drive.drive_turn` (``mode="settled"``) does
    (the same plan, tuning and :func:`spherestep.dynamics.simulate`), keeping each step's landing error; prunes the
    row unless every step lands within 0.5° of the plan and the plan's most coils at once draw at most the supply's
    power, then unless at least 95 % of 20 seeded random turns of 15-360° execute as well
    (:func:`spherestep.drive.many_turns`, stopping once that is out of reach). The plan is the design's relay
    planner's (the iron-aware one on iron). ``design``: the row's design as the cheap rungs built it (its stepper
    states already found), else built again. Records ``relay_worst_deg`` (the worst landing error),
    ``relay_peak_W`` and ``relay_turns_fraction``."""
    from ..drive import many_turns
    from ..drive.turn import Turn, choose_model
    from ..dynamics import simulate

    start = time.perf_counter()
    design = build(candidate, row["core"], spec) if design is None else design
    axis = spec.speed.axis.vector if spec.speed is not None else np.array([0.0, 0.0, 1.0])
    angle = spec.speed.turn if spec.speed is not None else math.radians(30.0)
    try:
        job = Turn(design, axis, angle, choose_model(design))
        plan, tuning = job.plan, job.tuning
        sim = simulate(design, plan, job.chosen.model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt)
    except Exception as exc:  # noqa: BLE001 (a plan that cannot be made is recorded)
        row.update(stage="relays", status="pruned", reason=f"no relay plan: {type(exc).__name__}: {exc}")
        return
    errors = np.asarray(sim.step_errors[1:], dtype=float)  # the steps, not the start
    on_plan = int(np.count_nonzero(errors <= sim.tolerance))
    limits = job.chosen.limits
    peak = max(len(s.coils) for s in plan.steps) * limits.relay_power
    row.update(relay_steps=len(errors), relay_steps_on_plan=on_plan, relay_executed=bool(sim.executed),
               relay_worst_deg=math.degrees(float(errors.max())) if len(errors) else 0.0, relay_peak_W=peak)
    if not sim.executed:
        row.update(stage="relays", status="pruned", reason=f"settled relay plan: {on_plan} of {len(errors)} steps "
                   f"within 0.5° of the plan (the worst {row['relay_worst_deg']:.3g}° off)")
    elif peak > spec.supply.power * (1 + 1e-9):
        row.update(stage="relays", status="pruned", reason=f"the relay plan energises coils drawing {peak:.3g} W at "
                   f"once, over the supply's {spec.supply.power:.3g} W")
    else:
        row["stage"] = "relays"
        try:
            many = many_turns(design, stop_early=True)  # the spec's turn passed above: 20 random ones now
        except Exception as exc:  # noqa: BLE001 (a verdict that cannot be reached is recorded)
            row.update(status="pruned", reason=f"many turns: {type(exc).__name__}: {exc}")
        else:
            row["relay_turns_fraction"] = many.fraction
            if not many.steps:
                row.update(status="pruned", reason=f"many turns: {many.line()}")
    row["seconds"] = row.get("seconds", 0.0) + time.perf_counter() - start
