"""The coil as a circuit: what the drive can give the coils (currents, supply voltage and power), the coils'
resistance and inductance, and the one place a current changes unit.

The room sits below magnetics, control, dynamics and hardware and imports none of them.

Units. The torque models take currents *per unit of the coil's nominal current* ``c`` (``+1`` = nominal, the
current at which the magnets' torque map was built: ``coil_ampere_turns`` ampere-turns); amperes are
``i = I_n c``. Every limit here is stored in SI (A, V, W, Ω, H) and turned into per-unit bounds by
:meth:`DriveLimits.per_unit_bound` and :meth:`DriveLimits.per_unit_power_radius`.

Defaults, from the paper's supply (Sec. IV-B: a 24 V magnet supply rated to 100 W, relays switching coils on and
off). The paper gives no coil resistance; we take the coil that a relay at 24 V drives at its nominal current of
1 A, so ``R = 24 Ω`` and the map's 1000 ampere-turns are 1000 turns at 1 A. A coil then draws 24 W, and the 100 W
supply feeds four coils at nominal current, as many as the relay plans energise. The largest current an H-bridge
on 24 V can hold in a coil is ``V / R`` = 1 A. The inductance is Wheeler's multilayer formula
``L = 31.6 µH · N² r̄² / (6 r̄ + 9 l + 10 d)`` (metres) for 1000 turns wound from half the coil's radius to its
outer radius (``r̄`` the mean radius, ``d`` the winding depth, ``l`` the coil's length): 18.7 mH for the
prototype's 2 in × 1.625 in coil, an electrical time constant ``L/R`` of 0.78 ms. An iron-cored coil's own
inductance (``L / N²`` stored per core in :data:`IRON_PERMEANCE`; a core not stored is solved by
:func:`spherestep.magnetics.iron_inductance`, which passes its value in) is the default of
:meth:`DriveLimits.from_spec` for it. :meth:`DriveLimits.from_coil` takes the numbers from a coil specification
instead (``spherestep.motor.coil``).

Conversions, each written once here: per unit → A, ``i = I_n c`` (:meth:`DriveLimits.amperes`); A → per unit
(:meth:`DriveLimits.per_unit`); A ↔ mA on the wire (:func:`milliamperes`, :func:`from_milliamperes`). The
per-unit voltage bound ``V / (R I_n)`` (:attr:`DriveLimits.voltage_bound`: the supply in volts per the volts
that drive the nominal current through the coil) and the back-EMF factor ``1 / (R I_n²)``
(:attr:`DriveLimits.emf_factor`: a torque-per-unit-current times a speed, N·m·rad/s, in per-unit volts). The coil
as a circuit over an interval with its voltage held, exactly: :func:`rl_step`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from . import checks
from .errors import bad_value

SUPPLY_VOLTAGE = 24.0  # V, Sec. IV-B
SUPPLY_POWER = 100.0  # W, Sec. IV-B
NOMINAL_CURRENT = 1.0  # A: 1000 turns at 1 A give the torque map's 1000 ampere-turns
COIL_RESISTANCE = SUPPLY_VOLTAGE / NOMINAL_CURRENT  # Ω: a relay at 24 V drives the nominal current
TURNS = 1000


# An iron-cored coil's own inductance per turn squared, ``L / N²`` (H), solved by
# :func:`spherestep.magnetics.coil_inductance` (linear iron, method of moments at the default mesh level, rotor
# absent; ~17 s), keyed by :func:`core_key`: the prototype's coil (2824 turns: 0.6502 H, 4.1× Wheeler's 0.158 H).
# ``L ∝ N²`` for a given core (the iron is linear), so any winding of a stored core finds its value here.
IRON_PERMEANCE = {
    (0.0508, 0.041275, 0.0127, 0.022225, 0.03175, 1000.0): 8.153331960424327e-08,
}


def core_key(spec, design) -> tuple:
    """What an iron coil's ``L / N²`` depends on, rounded to 1 nm: the design's coil diameter and length, the
    spec's groove ``(r_p, r_w, depth)`` (m) and the core's relative permeability."""
    d, length = design.coil_diameter, design.coil_length
    return tuple(round(float(v), 9) for v in (d, length, *spec.groove(d, length))) + \
        (round(float(spec.material.relative_permeability), 6),)


def stored_permeance(key: tuple) -> float | None:
    """``L / N²`` (H) of the core ``key`` (:func:`core_key`) from :data:`IRON_PERMEANCE`: a stored core's, or
    ``s ×`` it for a core whose every length is a stored one's ×``s`` at the same permeability (linear
    magnetostatics is scale-free: the flux per ampere-turn, a permeance, scales as a length); else None."""
    if key in IRON_PERMEANCE:
        return IRON_PERMEANCE[key]
    for base, value in IRON_PERMEANCE.items():
        s = key[0] / base[0]
        if key[5] == base[5] and all(math.isclose(k, s * b, rel_tol=1e-7) for k, b in zip(key[:5], base[:5])):
            return s * value
    return None


def wheeler_inductance(turns: float, outer_radius: float, length: float, inner_radius: float) -> float:
    """Wheeler's multilayer air-core inductance (H): ``31.6e-6 N² r̄² / (6 r̄ + 9 l + 10 d)``, lengths in m,
    ``r̄ = (r_i + r_o)/2``, ``d = r_o − r_i`` (about 1 % for the usual proportions)."""
    mean = 0.5 * (inner_radius + outer_radius)
    depth = outer_radius - inner_radius
    return 31.6e-6 * turns ** 2 * mean ** 2 / (6.0 * mean + 9.0 * length + 10.0 * depth)


@dataclass(frozen=True)
class DriveLimits:
    """The drive's limits and the coils' electrics (SI), the same for every coil.

    ``nominal_current`` (A): the current of ``c = 1``; ``max_current`` (A): the most any coil may carry;
    ``supply_voltage`` (V) and ``supply_power`` (W): the supply, whose power bounds the copper loss
    ``Σ R i_k² ≤ P``; ``resistance`` (Ω) and ``inductance`` (H) of one coil. See the module for the defaults.
    """

    nominal_current: float = NOMINAL_CURRENT
    max_current: float = NOMINAL_CURRENT
    supply_voltage: float = SUPPLY_VOLTAGE
    supply_power: float = SUPPLY_POWER
    resistance: float = COIL_RESISTANCE
    inductance: float = wheeler_inductance(TURNS, 0.0254, 0.041275, 0.0127)

    def __post_init__(self):
        for name in ("nominal_current", "max_current", "supply_voltage", "supply_power", "resistance",
                     "inductance"):
            checks.positive(getattr(self, name), name)

    @classmethod
    def from_coil(cls, resistance: float, inductance: float, nominal_current: float, *,
                  supply_voltage: float = SUPPLY_VOLTAGE, supply_power: float = SUPPLY_POWER,
                  max_current: float | None = None) -> DriveLimits:
        """Limits for a coil of given ``resistance`` (Ω), ``inductance`` (H) and ``nominal_current`` (A) — the
        numbers a coil specification (``spherestep.motor.coil``) computes from its winding; ``max_current``
        defaults to what the supply voltage drives through the coil, ``V / R``."""
        r = checks.positive(resistance, "resistance")
        v = checks.positive(supply_voltage, "supply_voltage")
        return cls(nominal_current=checks.positive(nominal_current, "nominal_current"),
                   max_current=v / r if max_current is None else max_current, supply_voltage=v,
                   supply_power=supply_power, resistance=r, inductance=checks.positive(inductance, "inductance"))

    @classmethod
    def from_spec(cls, spec, design, inductance: float | None = None) -> DriveLimits:
        """Limits for the coils of ``design`` wound as ``spec`` (a coil-as-built specification such as
        ``spherestep.motor.coil.CoilSpec``: its ``resistance``, ``nominal_current`` and ``turns`` for the design's
        coil diameter and length, its ``supply_voltage`` and ``supply_power``). ``inductance`` (H) defaults to
        the coil's own: for an iron core (``spec.core == "iron"``) ``N²`` times the stored ``L / N²`` of its core
        (:func:`stored_permeance`; a core not stored: pass :func:`spherestep.magnetics.iron_inductance`), else
        Wheeler's air-core value for the spec's turns and groove (:func:`wheeler_inductance`). The torque model
        must then be built at ``N I_n`` ampere-turns."""
        d, length = design.coil_diameter, design.coil_length
        if inductance is None and spec.core == "iron":
            permeance = stored_permeance(core_key(spec, design))
            if permeance is None:
                raise bad_value("inductance", "the iron coil's own inductance in H for a core not stored "
                                "(spherestep.magnetics.iron_inductance(spec, design) solves it)", None)
            inductance = spec.turns(d, length) ** 2 * permeance
        elif inductance is None:
            r_p, r_w, depth = spec.groove(d, length)
            inductance = wheeler_inductance(spec.turns(d, length), r_w, depth, r_p)
        return cls.from_coil(spec.resistance(d, length), inductance, spec.nominal_current(d, length),
                             supply_voltage=spec.supply_voltage, supply_power=spec.supply_power)

    def replace(self, **changes) -> DriveLimits:
        """A copy with ``changes``."""
        return replace(self, **changes)

    @property
    def per_unit_bound(self) -> float:
        """The largest ``|c_k|``: ``max_current / nominal_current``."""
        return self.max_current / self.nominal_current

    @property
    def per_unit_power_radius(self) -> float:
        """``ρ`` with ``Σ c_k² ≤ ρ²`` ⇔ ``Σ R (I_n c_k)² ≤ P``: ``ρ = √(P / R) / I_n``."""
        return math.sqrt(self.supply_power / self.resistance) / self.nominal_current

    @property
    def voltage_bound(self) -> float:
        """The supply in per-unit volts, ``V / (R I_n)``: the largest steady ``|c_k + e_k/(R I_n)|``."""
        return self.supply_voltage / (self.resistance * self.nominal_current)

    @property
    def nominal_power(self) -> float:
        """``R I_n²`` (W): one coil's copper loss at the nominal current."""
        return self.resistance * self.nominal_current ** 2

    @property
    def emf_factor(self) -> float:
        """The back-EMF factor ``1 / (R I_n²)``: ``K_k·ω`` (N·m·rad/s per unit current) → per-unit volts
        (``e_k / (R I_n)`` with ``e_k = K_k·ω / I_n``)."""
        return 1.0 / self.nominal_power

    @property
    def relay_power(self) -> float:
        """``V I_n`` (W): what one coil switched onto the supply at its nominal current draws from it."""
        return self.supply_voltage * self.nominal_current

    def amperes(self, currents) -> np.ndarray:
        """Per-unit ``currents`` in amperes, ``i = I_n c`` (the drive's wire unit)."""
        return np.asarray(currents, dtype=float) * self.nominal_current

    def per_unit(self, amperes) -> np.ndarray:
        """Currents in amperes per unit of the nominal current, ``c = i / I_n``."""
        return np.asarray(amperes, dtype=float) / self.nominal_current

    def back_emf(self, torque_speed) -> np.ndarray:
        """The back-EMF ``e_k = K_k·ω / I_n`` (V) of ``torque_speed`` ``K_k·ω`` (N·m·rad/s per unit current)."""
        return np.asarray(torque_speed, dtype=float) / self.nominal_current

    @property
    def time_constant(self) -> float:
        """``L / R`` (s)."""
        return self.inductance / self.resistance

    def copper_power(self, currents):
        """``Σ R (I_n c_k)²`` (W) for per-unit ``currents (..., N)``."""
        c = np.asarray(currents, dtype=float)
        return self.nominal_power * np.sum(c * c, axis=-1)

    def to_dict(self) -> dict:
        """The limits (SI, keys with units) and the per-unit bounds."""
        d = asdict(self)
        return {"nominal_current_A": d["nominal_current"], "max_current_A": d["max_current"],
                "supply_voltage_V": d["supply_voltage"], "supply_power_W": d["supply_power"],
                "resistance_ohm": d["resistance"], "inductance_H": d["inductance"],
                "time_constant_s": self.time_constant, "per_unit_bound": self.per_unit_bound,
                "per_unit_power_radius": self.per_unit_power_radius}


def milliamperes(amperes) -> np.ndarray:
    """Currents in A as mA (the wire's and the device's unit): ``1000 i``."""
    return np.multiply(1000.0, np.asarray(amperes, dtype=float))


def from_milliamperes(milliamperes) -> np.ndarray:
    """Currents in mA as A: ``i_mA / 1000``."""
    return np.divide(np.asarray(milliamperes, dtype=float), 1000.0)


def centivolts(volts) -> np.ndarray:
    """Voltages in V as the wire's 10 mV units (a back-EMF estimate in ``DRIVE``): ``100 v``."""
    return np.multiply(100.0, np.asarray(volts, dtype=float))


def from_centivolts(centivolts) -> np.ndarray:
    """Voltages in the wire's 10 mV units as V: ``v_cV / 100``."""
    return np.divide(np.asarray(centivolts, dtype=float), 100.0)


def lag_weight(lag: float, period: float) -> float:
    """``β = (τ/h)(1 − e^{−h/τ})``: a current following its setpoints first order with time constant ``lag`` τ (s),
    the setpoint changed from ``c_prev`` to ``c`` at the start of a period ``h``, has the mean ``c − β (c − c_prev)``
    over it (0 without a lag)."""
    return lag / period * (1.0 - math.exp(-period / lag)) if lag > 0 else 0.0


def period_means(setpoints, lag: float, period: float) -> np.ndarray:
    """The mean current over each period of a current that follows ``setpoints`` ``(T, N)`` (each applied from its
    period's start, from rest at the first) first order with time constant ``lag`` (s), exactly:
    ``c_k − β (c_k − i_k)`` (:func:`lag_weight`) with ``i_k`` the current at the period's start,
    ``i_{k+1} = c_k + (i_k − c_k) e^{−h/τ}``."""
    c = np.asarray(setpoints, dtype=float)
    if lag <= 0:
        return c.copy()
    beta, decay = lag_weight(lag, period), math.exp(-period / lag)
    out, i = np.empty_like(c), np.zeros_like(c[0])
    for k, setpoint in enumerate(c):
        out[k] = setpoint - beta * (setpoint - i)
        i = setpoint + (i - setpoint) * decay
    return out


def rl_step(i, v, emf, resistance: float, inductance: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """One coil as an R–L circuit, ``L di/dt = v − R i − e``, over ``h`` s with ``v`` and ``emf`` held: the exact
    current at the end, ``i∞ + (i − i∞) e^{−x}`` (``i∞ = (v − e)/R``, ``x = h R / L``), and its mean over the
    interval, ``i∞ + (i − i∞)(1 − e^{−x})/x``; arrays broadcast. The coil model of the simulation's drive
    (:class:`spherestep.dynamics.CoilDrive`) and of the emulated motor (:class:`spherestep.hardware.EmulatedMotor`)."""
    i_inf = (np.asarray(v) - np.asarray(emf)) / resistance
    x = h * resistance / inductance
    decay = math.exp(-x)
    mean_factor = -math.expm1(-x) / x
    i = np.asarray(i, dtype=float)
    return i_inf + (i - i_inf) * decay, i_inf + (i - i_inf) * mean_factor
