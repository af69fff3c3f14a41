"""The emulated motor as built, not as designed: :class:`PlantError`, the grammar of ``--plant-error``.

``--plant-error`` (``spherestep calibrate --emulate`` and ``spherestep move --emulate``) is a comma-separated list
of ``key=value`` (or the word ``realistic``, optionally followed by overrides: ``realistic,seed=3``):

=====================  ============================================================================================
``detent=F``           the detent table ×F (the gap)
``winding=F``          every coil's winding table ×F
``winding-spread=F``   each coil's gain uniform in ``1 ± F`` (its winding's torque, a column scale of ``K(R)``)
``dead=I[+J…]``        these coils carry no current (gain 0) without the controller knowing
``coil-offset=DEG``    the turned coils' fields each turned by DEG about a random axis through the sphere's centre
``misplaced=K``        how many coils are turned (random ones; default all)
``inertia=F``          the rotor's inertia ×F
``damping=NMS``        the rotor's viscous damping, N·m·s/rad (default the emulator's 0.01)
``friction=NM``        the rotor's Coulomb (castor) friction, N·m
``saturation=F``       the cores' flux limit: each winding's torque as ``F tanh(c / F)`` of its current ``c``
                       (per unit of the nominal current; :class:`~spherestep.magnetics.percoil.PerCoil`'s
                       ``knee``), a term no calibration fits: it must be refused, naming saturation
``sensor-offset=UT``   each Hall sensor's offset, normal with σ UT µT per axis
``sensor-bias=DEG``    the sensor array turned by DEG about a fixed (random) axis
``seed=N``             the seed of every random draw above (default 0)
=====================  ============================================================================================

``realistic`` is :data:`REALISTIC`: per-coil spread ±20 %, two coils misplaced by 1°, inertia ×1.3, damping
0.03 N·m·s/rad, friction 0.01 N·m, per-sensor offsets of 100 µT and the array turned by 0.1° (linear windings).

The torque terms build a :class:`~spherestep.magnetics.percoil.PerCoil` plant around the (scaled) model
(:func:`~spherestep.magnetics.mismatch.scaled_model`), the rotor terms a :class:`~spherestep.dynamics.Rotor`
(``rotor=`` of :func:`~spherestep.drive.connect`), the sensor terms the sensing room's sensor errors
(``sensor_errors=`` of the emulated motor).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from ..errors import bad_value

REALISTIC = ("winding-spread=0.2,coil-offset=1,misplaced=2,inertia=1.3,damping=0.03,friction=0.01,"
             "sensor-offset=100,sensor-bias=0.1")
EXPECTED = ("comma-separated key=value among detent=F, winding=F, winding-spread=F, dead=I[+J], coil-offset=DEG, "
            "misplaced=K, inertia=F, damping=NMS, friction=NM, saturation=F, sensor-offset=UT, sensor-bias=DEG, seed=N, "
            "or "
            "'realistic' (e.g. realistic,seed=3 or winding-spread=0.2,dead=4)")
# key -> (field, kind, low, high): the value's range (inclusive)
KEYS = {"detent": ("detent", float, 0.0, 100.0), "winding": ("winding", float, 1e-6, 100.0),
        "winding-spread": ("winding_spread", float, 0.0, 0.99), "dead": ("dead", "coils", 0, 10 ** 6),
        "coil-offset": ("coil_offset", float, 0.0, 10.0), "misplaced": ("misplaced", int, 1, 10 ** 6),
        "inertia": ("inertia", float, 0.1, 10.0), "damping": ("damping", float, 0.0, 10.0),
        "friction": ("friction", float, 0.0, 10.0), "saturation": ("saturation", float, 0.01, 100.0),
        "sensor-offset": ("sensor_offset", float, 0.0, 1e5),
        "sensor-bias": ("sensor_bias", float, 0.0, 10.0), "seed": ("seed", int, 0, 2 ** 32 - 1)}


@dataclass(frozen=True)
class PlantError:
    """How the emulated motor differs from its design (module docstring): table factors ``detent``,
    ``winding``; ``winding_spread`` (each gain in 1 ± it), ``dead`` coil indices, ``coil_offset`` (degrees) on
    ``misplaced`` coils (None: all); ``inertia`` (a factor), ``damping`` N·m·s/rad (None: the emulator's),
    ``friction`` N·m; ``saturation`` the windings' knee (per unit; None: linear); ``sensor_offset`` µT,
    ``sensor_bias`` degrees; ``seed``."""

    detent: float = 1.0
    winding: float = 1.0
    winding_spread: float = 0.0
    dead: tuple[int, ...] = ()
    coil_offset: float = 0.0
    misplaced: int | None = None
    inertia: float = 1.0
    damping: float | None = None
    friction: float = 0.0
    saturation: float | None = None
    sensor_offset: float = 0.0
    sensor_bias: float = 0.0
    seed: int = 0

    @classmethod
    def parse(cls, text: str, name: str = "--plant-error") -> PlantError:
        """The error ``text`` says (module docstring); InputError naming ``name`` and the grammar otherwise."""
        items = [t.strip() for t in str(text).split(",")]
        base = REALISTIC.split(",") if items[0] == "realistic" else []
        items = items[1:] if base else items
        out: dict = {}
        seen: set = set()
        for given, item in [(False, b) for b in base] + [(True, i) for i in items]:
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep or key not in KEYS:
                raise bad_value(name, EXPECTED, text)
            field_, kind, low, high = KEYS[key]
            if given and key in seen:
                raise bad_value(name, f"each key once ({key} given twice)", text)
            if given:
                seen.add(key)
            try:
                if kind == "coils":
                    parsed = tuple(int(v) for v in value.split("+"))
                    bad = any(v < low or v > high for v in parsed) or len(set(parsed)) != len(parsed)
                else:
                    parsed = kind(value)
                    bad = not (low <= parsed <= high) or (kind is float and not math.isfinite(parsed))
            except ValueError:
                bad = True
            if bad:
                what = "coil indices I+J…" if kind == "coils" else "a whole number" if kind is int else "a number"
                raise bad_value(name, f"{key}= {what} from {low:g} to {high:g}", text)
            out[field_] = parsed
        return cls(**out)

    # -- what it builds ----------------------------------------------------------------------------------------
    def gains(self, coil_count: int, name: str = "--plant-error") -> np.ndarray:
        """Each coil's gain ``(N,)``: ``winding`` × uniform in ``1 ± winding_spread``, 0 on the dead coils."""
        rng = np.random.default_rng([self.seed, 1])
        g = self.winding * (1.0 + self.winding_spread * rng.uniform(-1.0, 1.0, coil_count))
        for k in self.dead:
            if k >= coil_count:
                raise bad_value(name, f"dead= coil indices from 0 to {coil_count - 1}", self.dead)
            g[k] = 0.0
        return g

    def turns(self, coils: np.ndarray, name: str = "--plant-error") -> np.ndarray:
        """Each coil's field turn ``(N, 3)`` rad: ``coil_offset`` about a random axis perpendicular to the coil's
        centre ``coils (N, 3)`` on ``misplaced`` random coils (all by default), zero elsewhere."""
        N = len(coils)
        out = np.zeros((N, 3))
        if not self.coil_offset:
            return out
        if self.misplaced is not None and self.misplaced > N:
            raise bad_value(name, f"misplaced= at most {N} coils", self.misplaced)
        rng = np.random.default_rng([self.seed, 2])
        which = np.arange(N) if self.misplaced is None else np.sort(rng.choice(N, self.misplaced, replace=False))
        axes = rng.standard_normal((len(which), 3))
        axes -= np.sum(axes * coils[which], axis=1, keepdims=True) * coils[which]  # ⊥ the centre: a real move
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        out[which] = math.radians(self.coil_offset) * axes
        return out

    @property
    def torque_terms(self) -> bool:
        return bool(self.winding_spread or self.dead or self.coil_offset or self.detent != 1.0
                    or self.winding != 1.0 or self.saturation is not None)

    @property
    def sensor_terms(self) -> bool:
        return bool(self.sensor_offset or self.sensor_bias)

    def plant(self, model, name: str = "--plant-error"):
        """The torque model the emulated rotor obeys: ``model``'s detent ×``detent``, then per-coil gains, turns
        and the windings' knee (:class:`~spherestep.magnetics.percoil.PerCoil`); ``model`` itself when nothing
        differs."""
        from ..magnetics import IronTorqueMap
        from ..magnetics.mismatch import scaled_model
        from ..magnetics.percoil import PerCoil

        if not self.torque_terms:
            return model
        if self.coil_offset and not isinstance(model, IronTorqueMap):
            raise bad_value(name, "coil-offset only with an iron model (its pair terms are moved)",
                            type(model).__name__)
        base = scaled_model(model, detent=self.detent) if self.detent != 1.0 else model
        coils = model.linear.coils if isinstance(model, IronTorqueMap) else np.zeros((model.coil_count, 3))
        return PerCoil(base, self.gains(model.coil_count, name), self.turns(coils, name), self.saturation)

    def rotor(self, design):
        """The emulated rotor: the design's inertia ×``inertia``, ``damping`` (default the emulator's) and
        ``friction``."""
        from ..dynamics import Rotor
        from .connect import EMULATED_DAMPING

        base = Rotor.from_design(design)
        return Rotor(base.inertia * self.inertia, EMULATED_DAMPING if self.damping is None else self.damping,
                     self.friction)

    def sensor_errors(self, sensors, name: str = "--plant-error"):
        """The sensing room's ``SensorErrors`` for the array ``sensors`` (offsets normal with σ
        ``sensor_offset`` µT per axis, the array turned by ``sensor_bias`` degrees about a random axis), or None
        when there are none."""
        if not self.sensor_terms:
            return None
        from ..sensing import SensorErrors

        return SensorErrors.random(sensors, offset_T=self.sensor_offset * 1e-6, bias_deg=self.sensor_bias,
                                   seed=np.random.default_rng([self.seed, 3]))

    def to_dict(self) -> dict:
        out = asdict(self)
        out["dead"] = list(self.dead)
        return out
