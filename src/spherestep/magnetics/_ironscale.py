"""Any design's iron from stored tables: the scaling law of linear magnetostatics (issue 28 §3).

Scale every length of a design by ``s`` (rotor, magnets, gap, shell, cores and their grooves). With linear iron
(the same ``μr``) the magnets' field at corresponding points is unchanged, ``B'(s x) = B(x)`` (it depends on the
remanence and on ratios of lengths only), and the winding's field per ampere-turn goes as ``1/s``. A torque about
the sphere's centre is a volume integral of ``(field) × (field) × length`` over volumes, so

    τ_d' = s³ (B_r'/B_r)² τ_d,    τ_1' = s² (NI'/NI) (B_r'/B_r) τ_1,    X' = s³ (B_r'/B_r)² X

for the detent, the winding's part per nominal current (``NI`` the nominal ampere-turns; at a fixed current
density ``NI ∝ s²`` and ``τ_1 ∝ s⁴``) and the coupling energy of two magnets through a core — at the same angles,
which a scaling leaves alone. These are exact for the solved fields (the FEM and the moment method both scale with
the geometry), so a design whose iron geometry is a scaled copy of one with stored tables (the prototype's FEM
tables) reuses them scaled, at no cost. :func:`shape` is what must match: every length of the pair over the rotor
radius, and the core's ``μr``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._iron import IRON_LEVEL, CoreGeometry

SHAPE_RTOL = 1e-9  # shapes equal to this (relative, per ratio): the same geometry up to a scale
SHAPE_NAMES = ("magnet_diameter", "magnet_length", "coil_diameter", "coil_length", "air_gap", "rotor_shell",
               "pole_radius", "groove_radius", "groove_depth")


def shape(design, coil) -> tuple[np.ndarray, float]:
    """The pair's shape: ``(ratios, μr)``, the lengths :data:`SHAPE_NAMES` over the rotor radius ``R_s`` (the
    core's outer radius and height are the coil's diameter and length; its pole and groove from ``coil``)."""
    g = CoreGeometry.of(design, coil)
    lengths = np.array([design.magnet_diameter, design.magnet_length, design.coil_diameter, design.coil_length,
                        design.air_gap, design.rotor_shell, g.r_p, g.r_w, g.depth])
    return lengths / design.radius, g.mu_r


@dataclass(frozen=True)
class Scale:
    """How the tables of ``base`` carry over to a design of the same shape: the length ratio ``s`` and the
    factors of the detent (``s³ (B_r/B_r0)²``, also the coupling energy's) and of the winding's part per nominal
    current (``s² (NI/NI0) (B_r/B_r0)``)."""

    s: float
    detent: float
    linear: float

    def to_dict(self, degrees: bool = True) -> dict:
        return {"s": self.s, "detent": self.detent, "linear": self.linear}


def scale_between(design, coil, base, base_coil) -> Scale | None:
    """The :class:`Scale` taking ``base`` (with ``base_coil``) to ``design`` (with ``coil``), or None when their
    shapes differ (a ratio by more than :data:`SHAPE_RTOL`, or ``μr``)."""
    a, mu = shape(design, coil)
    b, mu0 = shape(base, base_coil)
    if mu != mu0 or not np.allclose(a, b, rtol=SHAPE_RTOL, atol=0.0):
        return None
    s = design.radius / base.radius
    br = design.remanence / base.remanence
    ni = CoreGeometry.of(design, coil).NI / CoreGeometry.of(base, base_coil).NI
    return Scale(s, s ** 3 * br ** 2, s ** 2 * ni * br)


def prototype_scale(design, coil, level: int = IRON_LEVEL) -> Scale | None:
    """The :class:`Scale` from the prototype (whose FEM-based tables are stored) to ``design`` with ``coil`` at
    the tables' mesh ``level``, or None (another shape or level)."""
    from ..motor import prototype
    from ..motor.coil import iron_coil

    if level != IRON_LEVEL or coil.core != "iron":
        return None
    return scale_between(design, coil, prototype(), iron_coil())


def scaled_design(design, s: float, name: str | None = None):
    """``design`` with every length ×``s`` (sphere, magnets, coils, gap, rotor shell, the pot's pole, wall and
    back; the wire, the supply and the angles unchanged): a test and a reference of the scaling law."""
    from dataclasses import replace

    from .. import checks

    s = checks.positive(s, "s", "a positive scale factor")
    coil = replace(design.coil, pole_diameter=s * design.coil.pole_diameter,
                   wall_thickness=s * design.coil.wall_thickness, back_thickness=s * design.coil.back_thickness)
    return replace(design, sphere_diameter=s * design.sphere_diameter, magnet_diameter=s * design.magnet_diameter,
                   magnet_length=s * design.magnet_length, coil_diameter=s * design.coil_diameter,
                   coil_length=s * design.coil_length, air_gap=s * design.air_gap,
                   rotor_shell=s * design.rotor_shell, coil=coil,
                   name=f"{design.name} x{s:g}" if name is None else name)
