"""Issue 29 §3: which lever makes the prototype on iron execute its settled relay plan (every step within 0.5°).

The prototype as the synthesis builds it for ``examples/specs/prototype-relays-iron.yaml`` (the search's own
``ladder.build`` of the baseline layout, the pot core wound for the spec's 24 V / 100 W), then one lever changed
at a time; for each: the settled relay plan of the spec's turn (30° about z) on the design's own iron model, as the
search's relay rung runs it (:func:`spherestep.drive.drive_turn`, ``mode="settled"``), and the worst landing error
(the largest distance of a step's settled orientation from its planned state).

Run: ``nice -n 5 python scripts/relay_iron_levers.py [--levers remanence,magnet,...] [--json data/x.json]``
(each row 5-30 s: a relay plan simulated on the iron model; the gap rows solve a moment-method table unless cached).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace

import numpy as np

from spherestep import so3
from spherestep.dynamics import simulate
from spherestep.magnetics import design_model, solve_needed
from spherestep.synthesis import load_spec
from spherestep.synthesis.ladder import INCH, PROTOTYPE, PROTOTYPE_LAYOUT, Candidate, build

SPEC = "examples/specs/prototype-relays-iron.yaml"


def landing(design) -> dict:
    """The settled relay plan of the spec's turn on ``design``'s own model: worst landing error (deg), steps on
    the plan, the plan's time (s) and the relay state's ampere-turns."""
    from spherestep.commutation import turn
    from spherestep.dynamics import tune

    own = design_model(design)
    plan = turn(design, np.array([0.0, 0.0, 1.0]), math.radians(30.0))
    tuning = tune(design, own.model)
    sim = simulate(design, plan, own.model, dwell=tuning.dwell, rotor=tuning.rotor, dt=tuning.dt, record_every=1)
    err = np.degrees(np.asarray(sim.step_errors[1:], dtype=float))
    el = design.coil_electrics()
    return {"worst_deg": float(err.max()), "on_plan": int(np.count_nonzero(err <= 0.5)), "steps": len(err),
            "executed": bool(sim.executed), "time_s": float(tuning.dwell * len(err)),
            "end_deg": float(np.degrees(so3.distance(sim.settled[-1], plan.achieved[-1]))),
            "ampere_turns": float(el.ampere_turns), "current_A": float(el.nominal_current),
            "coil_W": float(el.power), "model": own.label}


def base_design(spec, gap_scale: float = 1.0, **layout):
    c = Candidate(**(PROTOTYPE_LAYOUT | layout), sphere_diameter=PROTOTYPE["sphere_diameter"], gap_scale=gap_scale)
    return build(c, "iron", spec)


def wire_for_current(design, amps: float) -> float:
    """The wire diameter (m) whose winding draws ``amps`` at the supply voltage (``V / R = I``; R ∝ 1/d⁴)."""
    coil = design.coil
    lo, hi = 0.05e-3, 2e-3
    for _ in range(60):
        mid = math.sqrt(lo * hi)
        r = replace(coil, wire_diameter=mid).resistance(design.coil_diameter, design.coil_length)
        lo, hi = (mid, hi) if coil.supply_voltage / r < amps else (lo, mid)
    return math.sqrt(lo * hi)


def levers(spec, which: set[str]):
    """``(lever, value label, design)`` rows."""
    d0 = base_design(spec)
    yield "as built", "-", d0
    if "remanence" in which:  # magnet grade: detent ∝ Br², the winding's pull ∝ Br
        for br, grade in ((1.0, "bonded-NdFeB-ish"), (0.7, "bonded NdFeB"), (0.4, "sintered ferrite"),
                          (0.25, "bonded ferrite"), (0.15, "")):
            yield "remanence (T)", f"{br:g} {grade}".strip(), replace(d0, remanence=br)
    if "winding" in which:  # ampere-turns within the supply: thicker wire draws up to P / (V n_on)
        for n_on in (4, 3, 2):
            cap = spec.supply.power / (spec.supply.voltage * n_on)
            coil = replace(d0.coil, coils_on=n_on, wire_diameter=wire_for_current(d0, cap))
            yield "winding (coils_on, I cap)", f"{n_on} on, {cap:.3g} A", replace(d0, coil=coil)
    if "magnet" in which:  # the shape table's magnets (d_m/R 0.7/6-1.3/6, l_m/d_m 0.3-0.8): stored, instant
        for dm, asp in ((0.85, 0.5), (0.7, 0.5), (1.0, 0.3), (0.7, 0.3)):
            d = replace(d0, magnet_diameter=dm * INCH, magnet_length=dm * asp * INCH)
            yield "magnet (d in, l/d)", f"{dm:g} in, {asp:g}", d
    if "gap" in which:
        for k in (2.0, 4.0, 8.0):
            yield "air gap", f"x{k:g}", base_design(spec, k)
    if "unrefined" in which:  # the search's closest layout (the stator unrefined: 24 coils) with a part changed
        d1 = base_design(spec, stator_level=0)
        yield "stator unrefined", "-", d1
        for br in (1.0, 0.7, 0.4):
            yield "stator unrefined + remanence", f"{br:g} T", replace(d1, remanence=br)
        for n_on in (4, 2):
            cap = spec.supply.power / (spec.supply.voltage * n_on)
            coil = replace(d1.coil, coils_on=n_on, wire_diameter=wire_for_current(d1, cap))
            yield "stator unrefined + winding", f"{n_on} on, {cap:.3g} A", replace(d1, coil=coil)
    if "combo-fine" in which:  # the threshold, rewound for 3 coils on (the most a step of the plan energises)
        for br in (0.3, 0.2):
            cap = spec.supply.power / (spec.supply.voltage * 3)
            coil = replace(d0.coil, coils_on=3, wire_diameter=wire_for_current(d0, cap))
            yield "remanence + winding", f"{br:g} T, 3 on", replace(d0, remanence=br, coil=coil)
    if "combo" in which:  # grade and winding together
        for br in (0.7, 0.4, 0.3, 0.25, 0.2):
            for n_on in (3, 2):
                cap = spec.supply.power / (spec.supply.voltage * n_on)
                coil = replace(d0.coil, coils_on=n_on, wire_diameter=wire_for_current(d0, cap))
                yield "remanence + winding", f"{br:g} T, {n_on} on", replace(d0, remanence=br, coil=coil)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levers", default="remanence,winding,magnet,gap")
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    spec = load_spec(SPEC)
    rows = []
    for lever, value, design in levers(spec, set(args.levers.split(","))):
        why = solve_needed(design, design.coil)
        t0 = time.perf_counter()
        try:
            r = landing(design)
        except Exception as exc:  # noqa: BLE001 (a study row that fails is recorded)
            r = {"error": f"{type(exc).__name__}: {exc}"}
        r |= {"lever": lever, "value": value, "seconds": time.perf_counter() - t0, "solve": why}
        rows.append(r)
        if "error" in r:
            print(f"{lever:28s} {value:24s} ERROR {r['error']}", flush=True)
            continue
        print(f"{lever:28s} {value:24s} worst {r['worst_deg']:7.3f}°  on plan {r['on_plan']}/{r['steps']}  "
              f"NI {r['ampere_turns']:6.0f}  {r['current_A']:.3g} A {r['coil_W']:.3g} W  time {r['time_s']:.3g} s  "
              f"({r['seconds']:.1f} s)", flush=True)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
