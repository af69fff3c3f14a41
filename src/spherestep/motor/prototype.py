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

import numpy as np

from .. import packing as pk
from ..units import length
from .design import MotorDesign

ROTOR_PACKING = "truncated-icosahedron"
STATOR_PACKING = "truncated-cuboctahedron"
CAP_HALF_ANGLE_DEG = 80.0


def stator_in_cap(stator: pk.Packing, axis, cap_half_angle: float, min_radius: float = 0.0) -> pk.Packing:
    """The caps of ``stator`` whose centres lie within ``cap_half_angle`` of ``axis`` and whose radius is at
    least ``min_radius`` (room for a coil), in the packing's order."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    inside = (stator.centers @ axis >= math.cos(cap_half_angle) - 1e-12) & (stator.radii >= min_radius)
    return pk.Packing(stator.centers[inside], stator.radii[inside], name=stator.name, family=stator.family,
                      level=stator.level)


def prototype() -> MotorDesign:
    """The prototype motor of the paper with the choices of this module's docstring."""
    rotor = pk.refine(pk.by_name(ROTOR_PACKING), levels=1)
    base_count = len(pk.by_name(ROTOR_PACKING))
    polarity = np.where(np.arange(len(rotor)) < base_count, 1, -1)
    sphere_diameter = length("12 in")
    air_gap = length("0.005 in")
    coil_diameter = length("2 in")
    coil_angle = math.atan(0.5 * coil_diameter / (0.5 * sphere_diameter + air_gap))
    axis = np.array([0.0, 0.0, -1.0])
    cap = math.radians(CAP_HALF_ANGLE_DEG)
    stator = stator_in_cap(pk.refine(pk.by_name(STATOR_PACKING), levels=1), axis, cap, min_radius=coil_angle)
    return MotorDesign(
        rotor=rotor, polarity=polarity, stator=stator, stator_axis=axis, cap_half_angle=cap,
        sphere_diameter=sphere_diameter, magnet_diameter=length("1 in"), magnet_length=length("0.5 in"),
        coil_diameter=coil_diameter, coil_length=length("1.625 in"), air_gap=air_gap, name="prototype",
    )
