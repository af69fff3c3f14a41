"""Which of the paper's constructions is the Johns Hopkins prototype as built (80 magnets, 16 coils)?

Prints, for every rotor of 80 poles that the paper's constructions give (a 60-cap semiregular packing of the
icosahedral family with one orbit of 20 holes filled) and every stator of 16 coils (a packing's caps that fit a
2-in coil within a stator cap under 90° about -z), the design metrics and the torque capability with the
prototype's parts (so the iron model is the stored FEM table). docs/gallery.md quotes the table.

    OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/gallery_jhu_candidates.py
"""

from __future__ import annotations

import math

import numpy as np

from spherestep import packing as pk
from spherestep.control import torque_capability
from spherestep.motor import MotorDesign

PARTS = dict(sphere_diameter="12 in", magnet_diameter="1 in", magnet_length="0.5 in", coil_diameter="2 in",
             coil_length="1.625 in", air_gap="0.005 in")


def rotors_80():
    """(label, packing, polarity): the 60 caps plus one orbit of 20 filled holes, for each icosahedral 60-cap
    packing that has such an orbit."""
    out = []
    for name in ("truncated-icosahedron", "truncated-dodecahedron", "rhombicosidodecahedron"):
        full, base = pk.named(name, 1), len(pk.named(name, 0))
        radii = np.round(full.radii[base:], 9)
        for r in np.unique(radii):
            orbit = base + np.flatnonzero(radii == r)
            if len(orbit) == 20:
                idx = np.concatenate([np.arange(base), orbit])
                label = f"{name} + 20 holes of {math.degrees(r):.2f}°"
                out.append((label, full.subset(idx, name=label), np.where(np.arange(80) < base, 1, -1)))
    return out


def stators_16():
    """(label, packing, refine, cap°): the smallest stator cap (whole degrees, under 90°) at which `fit` keeps
    exactly 16 coils, for every packing refined 0 or 1 times where that happens."""
    R, g = 0.5 * 12 * 0.0254, 0.005 * 0.0254
    coil = math.atan(0.0254 / (R + g))
    out = []
    for name in pk.names():
        for level in (0, 1):
            p = pk.named(name, level)
            for cap in range(30, 90):
                if len(p.within_cap(np.array([0.0, 0.0, -1.0]), math.radians(cap), min_radius=coil)) == 16:
                    out.append((f"{p.label} within {cap}°", name, level, cap))
                    break
    return out


def main() -> None:
    print("rotor | stator | family pair | states | res° median | p95° | reaches all | τ N·m median | τ p5")
    for rlabel, rotor, polarity in rotors_80():
        for slabel, name, level, cap in stators_16():
            d = MotorDesign.from_packings(rotor=rotor, polarity=polarity, stator=name, stator_refine=level,
                                          stator_axis=[0, 0, -1], cap_half_angle=math.radians(cap), **PARTS)
            m = d.metrics(escape=False)
            c = torque_capability(d, samples=300).percentiles(q=(5, 50))
            print(f"{rlabel} | {slabel} | I/{pk.by_name(name).family} | {m.states} | "
                  f"{math.degrees(m.resolution_median_rad):.2f} | {math.degrees(m.resolution_p95_rad):.2f} | "
                  f"{m.reaches_all} | {c[50]:.2f} | {c[5]:.2f}", flush=True)


if __name__ == "__main__":
    main()
