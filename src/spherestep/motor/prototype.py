"""The built-in prototype, after Sec. II-B-3 and IV, and the choices the paper leaves open.

* Rotor: the icosahedral packing with six half circles per triangle (truncated icosahedron) refined once:
  92 poles (60 + 12 + 20). We put it in the rotor because its caps are nearly equal (radius ratio 1.44
  against 4.12 for the octahedral one), so equal magnets fit every cap, and its inertia is isotropic.
* Polarities: the 60 primary poles north-out (+1), the 32 poles filling the holes south-out (−1). Each
  symmetry orbit sums to zero, so the rotor has no net dipole, and a coil attracting one pole repels its
  unlike neighbours, which narrows the potential wells.
* Stator: the octahedral packing with six primary circles per triangle (truncated cuboctahedron) refined
  once (74 caps), of which the caps within 80° of the downward axis −z (below the ball, in the pedestal)
  and wide enough for a 2-in coil (angular radius ≥ the coil's) carry coils: 29 coils, under the 32
  channels of four relay boards. The 4 square holes in the cap (5.3°) are too small for a 2-in coil.
* Dimensions (Sec. IV-A): 12-in rotor, 2-in × 1.625-in electromagnets, 0.005-in gap. The paper does not
  give the magnets: we take 1-in × 0.5-in NdFeB cylinders (N42, remanence 1.32 T), which fit the
  smallest rotor cap.
"""

from __future__ import annotations

import math

from .design import MotorDesign, PolarityRule

ROTOR_PACKING = "truncated-icosahedron"
STATOR_PACKING = "truncated-cuboctahedron"
CAP_HALF_ANGLE_DEG = 80.0


def prototype() -> MotorDesign:
    """The prototype motor of the paper with the choices of this module's docstring."""
    return MotorDesign.from_packings(
        rotor=ROTOR_PACKING, rotor_refine=1, polarity=PolarityRule(primary=1, filled=-1),
        stator=STATOR_PACKING, stator_refine=1, stator_axis=[0.0, 0.0, -1.0],
        cap_half_angle=math.radians(CAP_HALF_ANGLE_DEG), coils="fit",
        sphere_diameter="12 in", magnet_diameter="1 in", magnet_length="0.5 in", coil_diameter="2 in",
        coil_length="1.625 in", air_gap="0.005 in", name="prototype",
    )
