"""Issue 39 §3: does the iron-aware relay planner step the prototype over SO(3), and which change makes it?

For the prototype as built (``motor.prototype()``: N42, iron pot cores, 24 V / 100 W, 29 coils) and for the levers
of ``scripts/relay_iron_levers.py`` (the prototype as the synthesis builds it for
``examples/specs/prototype-relays-iron.yaml``, one part changed), the many-turn verdict
(:func:`spherestep.drive.many_turns`: the spec's 30° about z plus ``--count`` seeded random turns of 15–360°, the
iron-aware planner, every step within 0.5° of its planned equilibrium).

Run: ``nice -n 5 python scripts/relay_iron_answer.py [--levers asbuilt,remanence,...] [--count 20] [--json F]``
(a design's 21 turns take 1-3 min on this machine).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from spherestep.drive import many_turns
from spherestep.magnetics import design_model
from spherestep.magnetics.mismatch import scaled_model
from spherestep.motor import prototype
from spherestep.synthesis import load_spec

LEVERS_SCRIPT = Path(__file__).with_name("relay_iron_levers.py")
SPEC_TURN = (np.array([0.0, 0.0, 1.0]), math.radians(30.0))


def _levers_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("relay_iron_levers", LEVERS_SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def designs(which: set[str], files=()):
    """``(lever, value, design)`` rows: the design files given, the prototype as built, then the levers asked
    for."""
    from spherestep.motor import MotorDesign

    for path in files:
        yield "design file", Path(path).name, MotorDesign.load(path)
    if "asbuilt" in which:
        yield "as built", "motor.prototype()", prototype()
    levers = _levers_module()
    spec = load_spec(levers.SPEC)
    d0 = levers.base_design(spec)
    if "remanence" in which:  # the prototype as built with another magnet grade (detent ∝ Br², pull ∝ Br)
        for br in (0.7, 0.4, 0.3, 0.25):
            yield "remanence (T)", f"{br:g}", replace(prototype(), remanence=br)
    if "winding" in which:
        for n_on in (3, 2):
            cap = spec.supply.power / (spec.supply.voltage * n_on)
            coil = replace(d0.coil, coils_on=n_on, wire_diameter=levers.wire_for_current(d0, cap))
            yield "winding (coils_on, I cap)", f"{n_on} on, {cap:.3g} A", replace(d0, coil=coil)
    if "combo" in which:
        for br in (0.7, 0.4):
            cap = spec.supply.power / (spec.supply.voltage * 3)
            coil = replace(d0.coil, coils_on=3, wire_diameter=levers.wire_for_current(d0, cap))
            yield "remanence + winding", f"{br:g} T, 3 on", replace(d0, remanence=br, coil=coil)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--levers", default="asbuilt,remanence,winding")
    ap.add_argument("--remanence", default=None, help="only these grades (T), e.g. 0.3,0.25")
    ap.add_argument("--count", type=int, default=20)
    ap.add_argument("--plants", default=None, help="run each design's plans also on these plants, "
                    "winding:detent[:coupling] scales, e.g. 0.85:1.2,0.85:1,1:1.2 (magnetics.mismatch.scaled_model;"
                    " the coupling through the cores, part of the detent, scaled as the detent unless given)")
    ap.add_argument("--design", action="append", default=[], help="a design file to judge (repeatable)")
    ap.add_argument("--plant-tol", type=float, default=None, help="with --robust: degrees within which the plants' "
                    "minima must lie of the planned one (default the planner's margin, 1.5)")
    ap.add_argument("--json", default=None)
    ap.add_argument("--robust", action="store_true", help="plan with the --plants as the iron planner's plants "
                    "(plans that hold on them too)")
    args = ap.parse_args()
    rows = []
    for lever, value, design in designs(set(args.levers.split(",")) - {""}, args.design):
        if args.remanence and lever.startswith("remanence") and value not in args.remanence.split(","):
            continue
        t0 = time.perf_counter()
        plants = [(1.0, 1.0, 1.0)] + [_scales(p) for p in (args.plants or "").split(",") if p]
        own = design_model(design).model
        hold_on = tuple(_plant(own, *p) for p in plants[1:]) if args.robust else ()
        tol = None if args.plant_tol is None else math.radians(args.plant_tol)
        for winding, detent, coupling in plants:
            t0 = time.perf_counter()
            plant = None if (winding, detent, coupling) == (1.0, 1.0, 1.0) else _plant(own, winding, detent, coupling)
            v = many_turns(design, plant=plant, count=args.count, spec_turn=SPEC_TURN, plan_plants=hold_on,
                           plant_tol=tol)
            row = {"lever": lever, "value": value,
                   "plant": {"winding": winding, "detent": detent, "coupling": coupling},
                   "planned_for_plants": bool(hold_on), "plant_tol_deg": args.plant_tol,
                   "seconds": time.perf_counter() - t0} | v.to_dict()
            rows.append(row)
            print(f"{lever:12s} {value:20s} plant w{winding:g} d{detent:g} c{coupling:g}"
                  f"{' planned for the plants' if hold_on else ''}: {v.line()} ({row['seconds']:.0f} s)", flush=True)
        if args.json:
            Path(args.json).write_text(json.dumps(rows, indent=1))


def _scales(text: str) -> tuple[float, float, float]:
    """``winding:detent[:coupling]`` as three scales, the coupling's the detent's unless given."""
    x = [float(v) for v in text.split(":")]
    return x[0], x[1], x[2] if len(x) > 2 else x[1]


def _plant(own, winding: float, detent: float, coupling: float):
    """The plant: ``own`` scaled (the coupling only where the model has it)."""
    return scaled_model(own, winding=winding, detent=detent,
                        coupling=coupling if getattr(own, "coupling", None) is not None else 1.0)


if __name__ == "__main__":
    main()
