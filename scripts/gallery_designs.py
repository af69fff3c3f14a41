"""Write the gallery's design files (src/spherestep/data/gallery/*.yaml) from their constructions.

Two of them list computed directions or cap indices (the as-built Johns Hopkins rotor: 60 + 20 poles of the
truncated icosahedron refined once; the NCSU stator: the 46 caps of the same 92-cap packing within 85° of a
five-fold axis), so they are generated here rather than typed; the comments in each file say what was assumed.
The sources and assumptions are also in ``spherestep.gallery`` (the table the CLI prints) and docs/gallery.md.

    .venv/bin/python scripts/gallery_designs.py [--check]

``--check`` writes nothing and exits 1 if a stored file differs from what this script would write.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from spherestep import packing as pk
from spherestep.atomic import write_text
from spherestep.sphere import angles

HERE = Path(__file__).resolve().parent.parent / "src" / "spherestep" / "data" / "gallery"

PROTOTYPE_PARTS = """\
dimensions:
  sphere_diameter: 12 in     # the paper, Sec. IV-A
  magnet_diameter: 1 in      # as our prototype reading (the paper and the press give no magnet size)
  magnet_length: 0.5 in
  coil_diameter: 2 in        # the paper, Sec. IV-A: 2-in x 1.625-in electromagnets
  coil_length: 1.625 in
  air_gap: 0.005 in          # the paper, Sec. IV-A

remanence: 1.32 T            # N42, as our prototype reading
coil_ampere_turns: 1000

coil:
  # The prototype's coil as built (prototype.yaml): a 2-in pot-core holding electromagnet on the paper's
  # 24-V, 100-W supply. Same magnet, coil and gap as prototype.yaml, so the iron model reuses its FEM table.
  core: iron
  material:
    name: low-carbon steel (AISI 1010, annealed)
    relative_permeability: 1000
    knee: 1.5 T
  pole_diameter: 1 in
  wall_thickness: 0.125 in
  back_thickness: 0.375 in
  wire_diameter: 286 um
  fill_factor: 0.6
  supply_voltage: 24 V
  supply_power: 100 W
  coils_on: 4
"""


def _vec(v) -> str:
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


def _wrapped(items: list[str], per_line: int, indent: int) -> str:
    """``items`` joined by ", ", ``per_line`` to a line, continuation lines indented by ``indent`` spaces."""
    lines = [", ".join(items[i:i + per_line]) for i in range(0, len(items), per_line)]
    return (",\n" + " " * indent).join(lines)


def jhu_rotor() -> tuple[np.ndarray, np.ndarray]:
    """The 80 poles: the truncated icosahedron's 60 caps, then the 20 caps filling its hexagonal holes (the
    refined packing's poles of the hexagon-hole radius, in its order); polarity +1 then −1."""
    full = pk.named("truncated-icosahedron", 1)
    base = len(pk.named("truncated-icosahedron", 0))
    filled = full.radii[base:]
    hexagon = base + np.flatnonzero(filled > filled.min() + 1e-6)  # 20 hexagon holes (12.16°) vs 12 pentagon (8.44°)
    idx = np.concatenate([np.arange(base), hexagon])
    return full.centers[idx], np.where(np.arange(len(idx)) < base, 1, -1)


def ncsu_stator() -> tuple[np.ndarray, list[int]]:
    """The five-fold axis through the first pentagon-hole cap of truncated-icosahedron/L1 and the indices of
    the 46 caps within 85° of it (all lie within 80.13°; the next ring is at 99.9°)."""
    full = pk.named("truncated-icosahedron", 1)
    base = len(pk.named("truncated-icosahedron", 0))
    filled = full.radii[base:]
    axis = full.centers[base + int(np.flatnonzero(filled < filled.min() + 1e-6)[0])]
    inside = np.degrees(np.arccos(np.clip(full.centers @ axis, -1, 1))) < 85.0
    return axis, np.flatnonzero(inside).tolist()


def jhu_text() -> str:
    centers, polarity = jhu_rotor()
    poles = "\n".join(f"    - {_vec(c)}" for c in centers)
    return f"""\
# spherestep design file; every field is described in docs/design-files.md
# Chirikjian & Stein's prototype as BUILT at Johns Hopkins (JHU Gazette, 16 Jan 2001: "80 permanent magnets" in a
# hollow sphere, a saddle of "16 circular electromagnets"). Our reconstruction (docs/gallery.md): the paper's
# icosahedral rotor packing (Sec. II-B-3, "six half circles per triangle" = the truncated icosahedron's 60 caps)
# with its 20 hexagonal holes filled (the circles at the icosahedron's face centres) and the 12 pentagonal holes
# left empty: 60 + 20 = 80; the paper's octahedral stator packing (six circles per triangle = the truncated
# cuboctahedron's 48 caps, not refined), the two rings of eight about its four-fold axis: 16 coils.
schema_version: 2
name: jhu-as-built

rotor:
  name: truncated-icosahedron + 20 hexagon holes
  # the 60 primary poles (north out), then the 20 poles in the hexagonal holes (south out): no net dipole
  polarity: [{_wrapped([f'{int(s):+d}' for s in polarity], 20, 13)}]
  poles:
{poles}

stator:
  # Truncated cuboctahedron (48 caps, Sec. II-B-3), not refined; the stator axis is a four-fold axis (-z).
  # Caps within 60 deg: the rings at 34.3 and 58.6 deg, 8 + 8 = 16 coils (the next ring, at 77.5 deg, would
  # make 24). Every cap is 12.46 deg, wider than a coil face (9.45 deg), so `fit` keeps all 16.
  packing: truncated-cuboctahedron
  refine: 0
  axis: [0, 0, -1]
  cap_half_angle: 60 deg
  coils: fit

{PROTOTYPE_PARTS}"""


def ncsu_text() -> str:
    axis, coils = ncsu_stator()
    phi, theta = angles(axis)
    return f"""\
# spherestep design file; every field is described in docs/design-files.md
# The stator layout of NCSU's permanent-magnet synchronous spherical motor (Shah & Buckner, Machines 10(8):612,
# 2022): poles on the faces of a Goldberg polyhedron GP(3,0), 92 faces (12 pentagons, 20 regular and 60 irregular
# hexagons), 46 of them on a hemisphere for a +/-40 deg range, iron (1018 steel) poles.
# A design file cannot state Goldberg faces; the project's packing with the same counts and symmetry orbits is
# the truncated icosahedron refined once: 60 caps (the 60 irregular hexagons) + 20 (the regular hexagons) +
# 12 (the pentagons) = 92, each cap centred where a GP(3,0) face is (up to the Goldberg polyhedron's own
# geometric freedom). The 46 poles: the caps within 85 deg of a five-fold axis (a pentagonal pole at the centre;
# all 46 lie within 80.1 deg). Our assumptions where the paper is silent here: the rotor (an octahedral packing,
# a different symmetry family from the stator, Sec. II-B-3: the truncated cuboctahedron's 48 caps), and the
# prototype's parts (12-in ball, 1-in x 0.5-in N42 magnets, 2-in pot-core coils) instead of NCSU's pole plates.
schema_version: 2
name: ncsu-goldberg

rotor:
  packing: truncated-cuboctahedron
  refine: 0
  polarity: {{primary: +1}}

stator:
  packing: truncated-icosahedron
  refine: 1
  # the five-fold axis through a pentagon-hole cap (phi, theta of the packing's own frame)
  axis: {{phi: {math.degrees(phi % (2 * math.pi))!r} deg, theta: {math.degrees(theta)!r} deg}}
  cap_half_angle: 85 deg
  # explicit indices: `fit` would drop the 12 pentagon caps (8.44 deg), narrower than a 2-in coil face
  coils: {coils}

overrides:
  max_coils: 46

{PROTOTYPE_PARTS}"""


HOBBY = """\
# spherestep design file; every field is described in docs/design-files.md
# A dodecahedral hobby motor, after F. Tavares, "Spherical Motors" (felipetavares.com, 5 Jul 2025): a spherical
# motor for antweight (100-500 g) combat robots whose sphere is a dodecahedron of 12 printed pentagonal plates.
# The part of the post we could read gives no magnets, coils or sizes: everything below except the dodecahedral
# layout is our assumption (docs/gallery.md). Rotor: the dodecahedron packing (20 caps, the corners where three
# plates meet) with its 12 holes filled (the plates' centres): 32 magnets. Stator: 12 coils of an octahedral
# packing (a different symmetry family, Sec. II-B-3) under the ball. Air-cored coils (the source is silent).
schema_version: 2
name: dodecahedral-hobby

rotor:
  packing: dodecahedron
  refine: 1
  polarity: {primary: +1, filled: -1}

stator:
  packing: rhombicuboctahedron
  refine: 0
  axis: [0, 0, -1]
  cap_half_angle: 80 deg
  coils: fit

dimensions:
  sphere_diameter: 60 mm
  magnet_diameter: 10 mm
  magnet_length: 5 mm
  coil_diameter: 20 mm
  coil_length: 12 mm
  air_gap: 0.5 mm

remanence: 1.32 T
coil_ampere_turns: 200

coil:
  core: air
  pole_diameter: 4 mm        # the winding's bore
  wall_thickness: 0 mm
  back_thickness: 0 mm
  wire_diameter: 300 um
  fill_factor: 0.6
  supply_voltage: 12 V       # a 3S lithium pack
  supply_power: 60 W
  coils_on: 4
"""

GIMBAL = """\
# spherestep design file; every field is described in docs/design-files.md
# A small gimbal-sized motor: not a published design, the paper's own construction (the rotor and stator
# packings of our prototype reading, neither refined) scaled to a 40-mm ball for a camera gimbal. Every size
# is our assumption (docs/gallery.md); air-cored coils.
schema_version: 2
name: gimbal-40mm

rotor:
  packing: truncated-icosahedron
  refine: 0
  polarity: {primary: +1}    # every magnet north out (as our prototype's 60 primary poles)

stator:
  packing: truncated-cuboctahedron
  refine: 0
  axis: [0, 0, -1]
  cap_half_angle: 80 deg
  coils: fit

dimensions:
  sphere_diameter: 40 mm
  magnet_diameter: 6 mm
  magnet_length: 3 mm
  coil_diameter: 8 mm
  coil_length: 8 mm
  air_gap: 0.3 mm

remanence: 1.32 T
coil_ampere_turns: 100

coil:
  core: air
  pole_diameter: 2 mm
  wall_thickness: 0 mm
  back_thickness: 0 mm
  wire_diameter: 200 um
  fill_factor: 0.6
  supply_voltage: 12 V
  supply_power: 20 W
  coils_on: 4
"""


def fingerprinted(text: str) -> str:
    """``text`` with the fingerprint of the motor it builds as its last line (the numbering its coil and pole
    lists and every plan or calibration made for it rely on: a machine that numbers otherwise refuses the file)."""
    from spherestep.motor import MotorDesign

    design = MotorDesign.loads(text)
    return text + f"# the coil and magnet numbering this file relies on (MotorDesign.fingerprint)\nfingerprint: " \
                  f"{design.fingerprint}\n"


def texts() -> dict[str, str]:
    """File name → text of every generated gallery design file."""
    return {name: fingerprinted(text) for name, text in (
        ("jhu-as-built.yaml", jhu_text()), ("ncsu-goldberg.yaml", ncsu_text()),
        ("dodecahedral-hobby.yaml", HOBBY), ("gimbal-40mm.yaml", GIMBAL))}


def main(argv: list[str]) -> int:
    check = "--check" in argv
    stale = []
    for name, text in texts().items():
        path = HERE / name
        if check:
            if not path.is_file() or path.read_text(encoding="utf-8") != text:
                stale.append(name)
        else:
            write_text(path, text)
            print(f"wrote {path}")
    if stale:
        print(f"differ from the script: {', '.join(stale)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
