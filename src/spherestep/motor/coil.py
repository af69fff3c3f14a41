"""The stator coil as built: its core (air or soft iron), its winding and its supply (Sec. IV).

The paper's electromagnets are off-the-shelf "wrapped soft iron cores", 2 in across and 1.625 in high, bolted to
the saddle through a threaded hole in the magnet, on "a standard 24-V magnet supply rated up to 100 W". A 2-in
holding electromagnet of that kind is a *pot core*: a steel cup whose centre pole carries the winding, the
winding sitting in the annular groove between the pole and the outer wall, closed by the back plate. This module
describes such a coil (all lengths in metres, SI throughout):

* core: ``"air"`` (today's model: the winding alone) or ``"iron"``; the iron's :class:`IronMaterial` (a linear
  relative permeability for the linear solve and a B–H curve for the saturation check) and the pot's
  proportions: centre-pole diameter, outer-wall thickness, back-plate thickness (a plain rod core is a pot
  with ``wall_thickness = back_thickness = 0``);
* winding: turns ``N`` from the groove's copper area, ``N = f · A_groove / (π d_w² / 4)`` (fill factor ``f``
  of bare copper over the groove's cross-section), resistance ``R = ρ_Cu N l_turn / (π d_w² / 4)`` with the mean
  turn ``l_turn = π (r_p + r_w)``;
* supply: the nominal current is what the supply can drive through one coil, ``I = min(V / R, P / (V n_on))``
  with ``n_on`` coils energised at once, and the nominal ampere-turns ``N I``.

The inductance needs the field: :func:`spherestep.magnetics.coil_inductance` computes it from the solved core.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .. import checks
from ..errors import bad_value

RHO_COPPER = 1.72e-8  # Ω·m at 20 °C (annealed copper, IEC 60028)
INCH = 0.0254

# Low-carbon steel (AISI 1010/1008, annealed), the usual body of holding electromagnets: representative points
# of its normal magnetisation curve (H in A/m, B in T), written after the "1010 Steel" entry of FEMM's material
# library (D. Meeker, femm.info) and the annealed low-carbon steel curves of the ASM Metals Handbook vol. 2. They
# are rounded typical values, not a certified curve of a particular batch: the knee is near 1.5 T and the steel
# is deep in saturation above ~2 T. The linear solve uses μr = 1000 (the estimate); the secant
# permeability B/(μ0 H) of this curve is 600–1700 between 0.4 and 1.4 T.
LOW_CARBON_STEEL_BH = (
    (0.0, 0.0), (238.7, 0.2003), (318.3, 0.3204), (358.1, 0.4004), (437.7, 0.6000), (477.5, 0.7201),
    (636.6, 1.0001), (795.8, 1.1102), (1114.1, 1.2503), (1273.2, 1.3002), (1591.5, 1.3702), (2228.2, 1.4503),
    (3183.1, 1.5203), (4774.6, 1.5805), (6366.2, 1.6204), (7957.7, 1.6505), (15915.5, 1.7503),
    (31831.0, 1.8602), (63662.0, 1.9903), (111408.5, 2.0803), (190985.9, 2.1703), (350000.0, 2.3050),
)


@dataclass(frozen=True)
class IronMaterial:
    """A soft-magnetic material: ``relative_permeability`` for the linear solve, the normal B–H curve ``bh``
    (``(H A/m, B T)`` pairs from (0, 0), increasing), its ``knee`` (T), and where the numbers come from."""

    name: str = "low-carbon steel (AISI 1010, annealed)"
    relative_permeability: float = 1000.0
    bh: tuple[tuple[float, float], ...] = LOW_CARBON_STEEL_BH
    knee: float = 1.5
    source: str = ("B–H: typical annealed AISI 1010 (after FEMM's '1010 Steel' and ASM Metals Handbook vol. 2), "
                   "rounded; μr = 1000 as in the issue's estimate")

    def __post_init__(self):
        checks.number(self.relative_permeability, "material.relative_permeability", low=1.0,
                      expected="a finite number >= 1")
        arr = np.asarray(self.bh, dtype=float)
        if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 2 or np.any(np.diff(arr, axis=0) <= 0) \
                or np.any(arr[0] != 0):
            raise bad_value("material.bh", "(H A/m, B T) pairs starting at (0, 0), both strictly increasing",
                            f"{len(arr)} points")
        checks.number(self.knee, "material.knee", low=0.0, high=float(arr[-1, 1]), low_open=True, high_open=True,
                      expected="a flux density (T) inside the B–H curve's range")
        object.__setattr__(self, "bh", tuple(tuple(p) for p in arr.tolist()))  # hashable, whatever was given

    def flux_density(self, H) -> np.ndarray:
        """``B(H)`` (T) on the normal curve, linear between points, odd in ``H`` (A/m); beyond the last point
        ``B`` grows with ``μ0`` per A/m."""
        arr = np.asarray(self.bh, dtype=float)
        h = np.abs(np.asarray(H, dtype=float))
        b = np.interp(h, arr[:, 0], arr[:, 1]) + 4e-7 * math.pi * np.maximum(h - arr[-1, 0], 0.0)
        return np.sign(H) * b

    def field_strength(self, B) -> np.ndarray:
        """``H(B)`` (A/m), the inverse of :meth:`flux_density` (odd in ``B``)."""
        arr = np.asarray(self.bh, dtype=float)
        b = np.abs(np.asarray(B, dtype=float))
        h = np.interp(b, arr[:, 1], arr[:, 0]) + np.maximum(b - arr[-1, 1], 0.0) / (4e-7 * math.pi)
        return np.sign(B) * h

    def to_dict(self) -> dict:
        return {"name": self.name, "relative_permeability": self.relative_permeability, "knee_T": self.knee,
                "bh_A_per_m_T": [list(p) for p in self.bh], "source": self.source}


@dataclass(frozen=True)
class CoilSpec:
    """One stator coil as built (SI units; see the module docstring for the formulas).

    ``core``: ``"air"`` or ``"iron"``; ``material``: the iron (ignored for air). Pot geometry (the outer
    diameter and height are the design's ``coil_diameter`` and ``coil_length``): ``pole_diameter`` (the centre
    pole, around which the winding sits), ``wall_thickness`` (outer wall), ``back_thickness`` (back plate).
    Winding: ``wire_diameter`` (bare copper), ``fill_factor`` (copper area / groove area). Supply:
    ``supply_voltage``, ``supply_power``, ``coils_on`` (coils energised at once, sharing the supply).
    ``ampere_turns`` fixes the nominal ampere-turns instead of deriving them (``air_coil()``: 1000).
    """

    core: str = "iron"
    material: IronMaterial = field(default_factory=IronMaterial)
    pole_diameter: float = 1.0 * INCH
    wall_thickness: float = 0.125 * INCH
    back_thickness: float = 0.375 * INCH
    wire_diameter: float = 0.286e-3  # AWG 29
    fill_factor: float = 0.6
    supply_voltage: float = 24.0
    supply_power: float = 100.0
    coils_on: int = 4
    ampere_turns: float | None = None

    def __post_init__(self):
        if self.core not in ("air", "iron"):
            raise bad_value("core", "'air' or 'iron'", self.core)
        if not isinstance(self.material, IronMaterial):
            raise bad_value("material", "a spherestep.motor.coil.IronMaterial", type(self.material).__name__)
        for name in ("pole_diameter", "wire_diameter", "supply_voltage", "supply_power"):
            checks.positive(getattr(self, name), name, "a finite positive number (SI units)")
        for name in ("wall_thickness", "back_thickness"):
            checks.non_negative(getattr(self, name), name, "a finite non-negative length in metres")
        checks.number(self.fill_factor, "fill_factor", low=0.0, high=0.9069, low_open=True,
                      expected="a copper fraction in (0, 0.907] (0.907: hexagonal packing)")
        object.__setattr__(self, "coils_on", checks.count(self.coils_on, "coils_on",
                                                          expected="a whole number of coils >= 1"))
        if self.ampere_turns is not None:
            checks.positive(self.ampere_turns, "ampere_turns", "a finite positive number or None")

    # --- geometry (needs the outer size of the coil) ---
    def groove(self, coil_diameter: float, coil_length: float) -> tuple[float, float, float]:
        """The winding's groove: inner radius ``r_p``, outer radius ``r_w`` and depth (m) from the face."""
        r_p = 0.5 * self.pole_diameter
        r_w = 0.5 * coil_diameter - self.wall_thickness
        depth = coil_length - self.back_thickness
        if not (0 < r_p < r_w) or depth <= 0:
            raise bad_value("coil", "a centre pole narrower than the groove and a back plate thinner than the coil",
                            f"pole radius {r_p:.4g} m, groove outer radius {r_w:.4g} m, depth {depth:.4g} m")
        return r_p, r_w, depth

    def turns(self, coil_diameter: float, coil_length: float) -> int:
        """``N = floor(f A_groove / (π d_w² / 4))``."""
        r_p, r_w, depth = self.groove(coil_diameter, coil_length)
        return int(self.fill_factor * (r_w - r_p) * depth / (0.25 * math.pi * self.wire_diameter ** 2))

    def resistance(self, coil_diameter: float, coil_length: float) -> float:
        """``R = ρ_Cu N π (r_p + r_w) / (π d_w² / 4)`` (Ω, copper at 20 °C)."""
        r_p, r_w, _ = self.groove(coil_diameter, coil_length)
        n = self.turns(coil_diameter, coil_length)
        return RHO_COPPER * n * math.pi * (r_p + r_w) / (0.25 * math.pi * self.wire_diameter ** 2)

    def nominal_current(self, coil_diameter: float, coil_length: float) -> float:
        """``I = min(V / R, P / (V n_on))`` (A)."""
        return min(self.supply_voltage / self.resistance(coil_diameter, coil_length),
                   self.supply_power / (self.supply_voltage * self.coils_on))

    def nominal_ampere_turns(self, coil_diameter: float, coil_length: float) -> float:
        """``N I`` at nominal current (or the fixed ``ampere_turns``)."""
        if self.ampere_turns is not None:
            return float(self.ampere_turns)
        return self.turns(coil_diameter, coil_length) * self.nominal_current(coil_diameter, coil_length)

    def power(self, coil_diameter: float, coil_length: float) -> float:
        """Electrical power (W) of one coil at nominal current, ``I² R``."""
        return self.nominal_current(coil_diameter, coil_length) ** 2 * self.resistance(coil_diameter, coil_length)

    def electrics(self, coil_diameter: float, coil_length: float) -> dict:
        """Turns, resistance (Ω), nominal current (A), ampere-turns, power per coil (W) and the supply's share."""
        return {"core": self.core, "turns": self.turns(coil_diameter, coil_length),
                "resistance_ohm": self.resistance(coil_diameter, coil_length),
                "nominal_current_A": self.nominal_current(coil_diameter, coil_length),
                "ampere_turns": self.nominal_ampere_turns(coil_diameter, coil_length),
                "power_W": self.power(coil_diameter, coil_length),
                "supply_V": self.supply_voltage, "supply_W": self.supply_power, "coils_on": self.coils_on}

    def to_dict(self) -> dict:
        d = asdict(self)
        d["material"] = self.material.to_dict()
        return d


def air_coil(ampere_turns: float = 1000.0) -> CoilSpec:
    """The air-core model at a fixed ``ampere_turns`` (the :class:`~spherestep.magnetics.TorqueMap` of a design
    at its ``coil_ampere_turns``)."""
    return CoilSpec(core="air", ampere_turns=ampere_turns)


def iron_coil(**changes) -> CoilSpec:
    """The prototype's coil as the paper built it: a pot-core holding electromagnet of low-carbon steel, AWG 29
    winding, 24 V / 100 W supply; ``changes`` override fields."""
    return replace(CoilSpec(), **changes)
