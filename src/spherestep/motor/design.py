"""`MotorDesign`: where the rotor's magnets and the stator's coils are, and how big they are (Sec. II-B-3, IV).

Frames: rotor poles ``u_j`` are unit vectors in the rotor (body) frame; stator coils ``v_k`` in the fixed
frame. At orientation ``R`` pole ``j`` points along ``R u_j``. Polarity ``+1`` means the magnet's north
pole faces outwards; a coil driven with polarity ``s`` attracts poles of polarity ``s``. Lengths are metres.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from functools import cached_property

import numpy as np

from .. import checks
from .. import packing as pk
from ..channels import MAX_COILS, as_channel_map, default_channel_map
from ..errors import InputError, bad_value
from ..packing import Packing
from ..sphere import as_points, disc_angle
from ..units import length
from .coil import CoilSpec, IronMaterial, iron_coil

__all__ = ["DEFAULT_TOL", "MAX_COILS", "CoilElectrics", "MotorDesign", "PolarityRule", "check_fits", "default_channel_map"]

DEFAULT_TOL = math.radians(1.0)  # a pole within 1° of a coil's axis sits on it (2.7 mm on a 12-in rotor)
DIMENSIONS = ("sphere_diameter", "magnet_diameter", "magnet_length", "coil_diameter", "coil_length", "air_gap")
ROTOR_SHELL = 1.0 / 16.0 * 0.0254  # m: the default wall of the ball in front of the magnets (the paper gives none)


@dataclass(frozen=True)
class PolarityRule:
    """Polarity of a rotor built from a named packing: ``primary`` for the base packing's poles, ``filled`` for
    the poles refinement added (default ``−primary``). The prototype's rule is ``PolarityRule(+1, −1)``."""

    primary: int = 1
    filled: int | None = None

    def __post_init__(self):
        for label in ("primary", "filled"):
            value = getattr(self, label)
            if not (value is None and label == "filled"):
                object.__setattr__(self, label, checks.sign(value, f"polarity.{label}"))

    def signs(self, count: int, base: int) -> np.ndarray:
        """``±1`` for ``count`` poles whose first ``base`` belong to the base packing."""
        filled = -self.primary if self.filled is None else self.filled
        return np.where(np.arange(count) < base, self.primary, filled)


def _check_dimensions(values: dict) -> None:
    """The one check of a motor's sizes (metres): finite and positive (the air gap may be 0), magnets and coils
    smaller than the sphere. Raises InputError whose ``field`` is the size at fault."""
    for label in DIMENSIONS:
        if label == "air_gap":
            checks.non_negative(values[label], label, "a finite non-negative length in metres")
        else:
            checks.positive(values[label], label, "a finite positive length in metres")
    for label in ("magnet_diameter", "coil_diameter"):
        if values[label] >= values["sphere_diameter"]:
            raise bad_value(label, f"smaller than the sphere_diameter ({values['sphere_diameter']:.6g} m)",
                            values[label])


def _check_shell(shell, radius: float, magnet_diameter: float, magnet_length: float) -> float:
    """The rotor's wall (m): non-negative and thin enough that a magnet, its face's rim on the wall's inner
    surface, still fits inside the ball (``(R − t)² > r_m² + l_m²``)."""
    shell = checks.non_negative(shell, "rotor_shell", "a finite non-negative length in metres")
    room = radius - math.hypot(0.5 * magnet_diameter, magnet_length)
    if not shell < room:
        raise bad_value("rotor_shell", f"thinner than {room * 1e3:.4g} mm (the magnets must fit inside the ball)",
                        f"{shell * 1e3:.4g} mm")
    return float(shell)


def _open_angle(value, name: str, high: float, expected: str) -> None:
    """:func:`checks.number`, then inside ``(0, high)`` radians: a number outside is shown in degrees."""
    x = checks.number(value, name, expected=expected)
    if not 0 < x < high:
        raise bad_value(name, expected, f"{math.degrees(x):.6g}°")


def _check_cap(cap_half_angle, allow_hemisphere: bool) -> None:
    """The stator cap: an angle in (0, π) radians, under π/2 unless ``allow_hemisphere``."""
    _open_angle(cap_half_angle, "cap_half_angle", math.pi, "an angle between 0 and π radians (0° and 180°)")
    if cap_half_angle >= math.pi / 2 and not allow_hemisphere:
        raise bad_value("cap_half_angle", "under 90° (a stator covering less than a hemisphere gives the wide "
                        "range of motion, Sec. IV); set allow_hemisphere (overrides.allow_hemisphere in a design "
                        "file) to override", f"{math.degrees(cap_half_angle):.4g}°")


def _check_tol(tol) -> None:
    """How close a pole must sit to a coil: None (the default, 1°) or an angle in (0, 0.5) radians."""
    if tol is not None:
        _open_angle(tol, "tol", 0.5, "an angle between 0 and 0.5 radians (0° and 28.65°), like 1°")


def _stator_axis(axis) -> np.ndarray:
    """One unit 3-vector (the contract of :func:`~spherestep.sphere.as_points`), divided by its norm."""
    axis = as_points(axis, "stator_axis")
    if axis.shape != (3,):
        raise bad_value("stator_axis", "one unit 3-vector", f"shape {axis.shape}")
    return axis / np.linalg.norm(axis)


def _coil(value: CoilSpec | Mapping) -> CoilSpec:
    """A :class:`CoilSpec` as given, or built from a mapping of its fields (``material`` a mapping of
    :class:`IronMaterial`'s); the errors of a mapping name ``coil.<field>``."""
    if not isinstance(value, Mapping):
        return value  # MotorDesign checks its type
    known = {f.name for f in fields(CoilSpec)}
    unknown = sorted(str(k) for k in value if k not in known)
    if unknown:
        raise bad_value("coil", f"a mapping of CoilSpec's fields ({', '.join(sorted(known))})", unknown)
    values = dict(value)
    try:
        if isinstance(values.get("material"), Mapping):
            material = values["material"]
            names = {f.name for f in fields(IronMaterial)}
            if not set(material) <= names:
                raise bad_value("material", f"a mapping of IronMaterial's fields ({', '.join(sorted(names))})",
                                sorted(str(k) for k in material if k not in names))
            values["material"] = IronMaterial(**material)
        return CoilSpec(**values)
    except InputError as exc:
        error = InputError(f"coil.{exc}")
        error.field = f"coil.{exc.field}"
        raise error from None


def _packing(value: str | Packing, level: int, name: str) -> Packing:
    """A :class:`Packing` as given, or the named one refined ``level`` times (shared, :func:`packing.named`)."""
    if isinstance(value, Packing):
        if level:
            raise bad_value(f"{name}_refine", f"0 when {name} is a Packing (refine it with packing.refine)", level)
        return value
    if not isinstance(value, str) or value not in pk.names():
        raise bad_value(name, "a Packing or a packing name listed by `spherestep packings --all`", value)
    level = checks.count(level, f"{name}_refine", 0, expected="a non-negative integer number of refinement levels")
    return pk.named(value, level)


@dataclass(frozen=True)
class CoilElectrics:
    """The coil as built at a design's coil size (:meth:`MotorDesign.coil_electrics`), SI: its ``core``, the
    supply (``supply_voltage`` V, ``supply_power`` W shared by ``coils_on`` coils) and, when the winding fits
    (``misfit`` None), ``turns``, ``resistance`` (Ω), ``nominal_current`` (A: ``supply_power / coils_on`` at
    ``resistance``), ``ampere_turns`` (at the nominal current) and ``power`` (W a coil); when it does not,
    ``misfit`` says why and those five are None."""

    core: str
    supply_voltage: float
    supply_power: float
    coils_on: int
    turns: int | None = None
    resistance: float | None = None
    nominal_current: float | None = None
    ampere_turns: float | None = None
    power: float | None = None
    misfit: str | None = None

    @property
    def fits(self) -> bool:
        """True when the winding fits the coil's size (its five quantities are numbers)."""
        return self.misfit is None

    def to_dict(self) -> dict:
        """For people, units in the keys: ``core`` and either the winding and supply or ``winding`` (the misfit)."""
        if self.misfit is not None:
            return {"core": self.core, "winding": self.misfit}
        return {"core": self.core, "turns": self.turns, "resistance_ohm": self.resistance,
                "nominal_current_A": self.nominal_current, "ampere_turns": self.ampere_turns, "power_W": self.power,
                "supply_V": self.supply_voltage, "supply_W": self.supply_power, "coils_on": self.coils_on}


@dataclass(frozen=True, eq=False)
class MotorDesign:
    """A spherical stepper motor.

    ``rotor``: packing of permanent-magnet poles (body frame); ``polarity``: ±1 per pole; ``stator``:
    packing of the coils actually present (fixed frame), all within ``cap_half_angle`` (radians) of
    ``stator_axis``. Dimensions in metres: ``sphere_diameter``, magnet ``magnet_diameter`` × ``magnet_length``,
    coil ``coil_diameter`` × ``coil_length``, ``air_gap`` between rotor surface and coil faces, ``rotor_shell``
    the ball's wall in front of the magnets (the rim of a magnet's flat face on its inner surface; default
    :data:`ROTOR_SHELL`, 1/16 in; read by the iron model). ``tol`` (radians) is how close a pole must sit to a
    coil to count as held; ``channel_map`` gives each coil its (enable, polarity) relay channel.
    ``allow_hemisphere`` and ``max_coils`` lift the paper's limits.
    ``coil_ampere_turns`` drives the air-core torque model (:class:`~spherestep.magnetics.TorqueMap`); ``coil``
    is every coil as built (:class:`~spherestep.motor.coil.CoilSpec`: core, winding, supply; default the
    prototype's iron-cored :func:`~spherestep.motor.coil.iron_coil`), read by the iron model and the drive limits.
    Whether its winding fits the coil's size is checked where its electrics are computed (``CoilSpec.groove``).

    This class's checks are the only validation of a motor: every error is an
    :class:`~spherestep.errors.InputError` whose ``field`` names the field at fault (``stator[k]`` for coil
    ``k``). Build one from named packings with :meth:`from_packings`, from a design file with :meth:`load`.
    """

    rotor: Packing
    polarity: np.ndarray
    stator: Packing
    stator_axis: np.ndarray
    cap_half_angle: float
    sphere_diameter: float
    magnet_diameter: float
    magnet_length: float
    coil_diameter: float
    coil_length: float
    air_gap: float
    tol: float | None = None
    remanence: float = 1.32
    coil_ampere_turns: float = 1000.0
    name: str = "design"
    channel_map: np.ndarray | None = None
    allow_hemisphere: bool = False
    max_coils: int = MAX_COILS
    failed_coils: tuple[int, ...] = field(default=())
    coil: CoilSpec = field(default_factory=iron_coil)
    rotor_shell: float = ROTOR_SHELL

    def __post_init__(self):
        polarity = np.asarray(self.polarity)
        if polarity.shape != (len(self.rotor),) or not np.all(np.isin(polarity, (-1, 1))):
            raise bad_value("polarity", f"{len(self.rotor)} values, each +1 or -1 (one per rotor pole)",
                            f"shape {polarity.shape}" if polarity.shape != (len(self.rotor),) else polarity.tolist())
        axis = _stator_axis(self.stator_axis)
        _check_cap(self.cap_half_angle, self.allow_hemisphere)
        _check_dimensions({label: getattr(self, label) for label in DIMENSIONS})
        for label in ("remanence", "coil_ampere_turns"):
            checks.positive(getattr(self, label), label)
        object.__setattr__(self, "rotor_shell", _check_shell(self.rotor_shell, self.radius, self.magnet_diameter,
                                                             self.magnet_length))
        object.__setattr__(self, "max_coils", checks.count(self.max_coils, "max_coils", expected="a positive integer"))
        if len(self.stator) > self.max_coils:
            raise bad_value("stator", f"at most {self.max_coils} coils (four 8-relay boards, Sec. IV-B); raise "
                            "max_coils (overrides.max_coils in a design file) to override", f"{len(self.stator)} coils")
        off = np.degrees(np.arccos(np.clip(self.stator.centers @ axis, -1, 1))) - math.degrees(self.cap_half_angle)
        if np.any(off > 1e-9):
            k = int(np.argmax(off))
            raise bad_value(f"stator[{k}]", f"a coil within the stator cap ({math.degrees(self.cap_half_angle):.4g}° "
                            "about stator_axis): remove it or widen cap_half_angle", f"{off[k]:.4g}° outside it")
        _check_tol(self.tol)
        cmap = default_channel_map(len(self.stator)) if self.channel_map is None else self.channel_map
        cmap = as_channel_map(cmap, len(self.stator))
        bad = [k for k in self.failed_coils if not 0 <= k < len(self.stator)]
        if bad:
            raise bad_value("failed_coils", f"coil indices 0..{len(self.stator) - 1}", bad)
        if not isinstance(self.coil, CoilSpec):
            raise bad_value("coil", "a spherestep.motor.coil.CoilSpec (iron_coil(), air_coil() or CoilSpec(...))",
                            type(self.coil).__name__)
        object.__setattr__(self, "polarity", polarity.astype(int))
        object.__setattr__(self, "stator_axis", axis)
        object.__setattr__(self, "channel_map", cmap)
        object.__setattr__(self, "failed_coils", tuple(sorted(set(int(k) for k in self.failed_coils))))

    # --- the one builder ----------------------------------------------------------------------------
    @classmethod
    def from_packings(cls, *, rotor: str | Packing, stator: str | Packing, stator_axis, cap_half_angle: float,
                      sphere_diameter, magnet_diameter, magnet_length, coil_diameter, coil_length, air_gap,
                      rotor_refine: int = 0, stator_refine: int = 0,
                      polarity: PolarityRule | Sequence[int] = PolarityRule(1, -1),
                      coils: str | Sequence[int] = "fit", coil: CoilSpec | Mapping | None = None,
                      check_fit: bool = True, **options) -> MotorDesign:
        """A motor from packings: the one place where coil angle, polarity rule and cap selection are decided.

        ``rotor``/``stator``: a packing name (:func:`spherestep.packing.names`) refined ``rotor_refine`` /
        ``stator_refine`` times (:func:`spherestep.packing.named`), or a :class:`Packing`. ``polarity``: a
        :class:`PolarityRule` (primary poles of the base packing, then the filled ones; needs a named rotor), a
        mapping ``{"primary": 1, "filled": -1}`` of one, or one ±1 per pole. ``coils``: ``"fit"`` keeps the stator caps within ``cap_half_angle`` (rad) of
        ``stator_axis`` that are at least as wide as a coil face, ``atan(d_c / 2 / (R + g))``
        (:meth:`Packing.within_cap`); ``"all"`` keeps every cap; a list of cap indices keeps those, in order.
        Sizes are metres or strings with units (``"12 in"``, :func:`spherestep.units.length`). ``coil``: a
        :class:`~spherestep.motor.coil.CoilSpec`, a mapping of its fields (``material`` a mapping too; errors
        name ``coil.<field>``), or None for the default, the prototype's iron coil.
        ``check_fit`` also refuses overlapping magnets or coils (:func:`check_fits`). ``options`` are the
        remaining fields (``tol``, ``name``, ``channel_map``, ``max_coils``, ...). Errors are InputErrors whose
        ``field`` names the argument (``coils[k]`` for the ``k``-th listed cap).

        >>> design = MotorDesign.from_packings(
        ...     rotor="truncated-icosahedron", rotor_refine=1, stator="truncated-cuboctahedron", stator_refine=1,
        ...     stator_axis=[0, 0, -1], cap_half_angle=math.radians(80), sphere_diameter="12 in",
        ...     magnet_diameter="1 in", magnet_length="0.5 in", coil_diameter="2 in", coil_length="1.625 in",
        ...     air_gap="0.005 in")
        >>> len(design.rotor), len(design.stator)
        (92, 29)
        """
        sizes = dict(sphere_diameter=sphere_diameter, magnet_diameter=magnet_diameter, magnet_length=magnet_length,
                     coil_diameter=coil_diameter, coil_length=coil_length, air_gap=air_gap)
        sizes = {k: length(v, k, allow_zero=k == "air_gap") if isinstance(v, str) else v for k, v in sizes.items()}
        _check_dimensions(sizes)
        axis = _stator_axis(stator_axis)
        _check_cap(cap_half_angle, options.get("allow_hemisphere", False))
        rotor_packing = _packing(rotor, rotor_refine, "rotor")
        if isinstance(polarity, dict):
            polarity = PolarityRule(**polarity)
        if isinstance(polarity, PolarityRule):
            if isinstance(rotor, str):
                base = len(pk.named(rotor, 0))
            elif rotor.name in pk.names() and len(pk.named(rotor.name, 0)) <= len(rotor):
                base = len(pk.named(rotor.name, 0))
            else:
                raise bad_value("polarity", "one +1/-1 per pole for a rotor that is not a named packing",
                                polarity)
            polarity = polarity.signs(len(rotor_packing), base)
        full = _packing(stator, stator_refine, "stator")
        coil_angle = disc_angle(sizes["coil_diameter"], 0.5 * sizes["sphere_diameter"] + sizes["air_gap"])
        if isinstance(coils, str) and coils == "fit":
            chosen = full.within_cap(axis, cap_half_angle, min_radius=coil_angle)
            if len(chosen) == 0:
                raise bad_value("coils", f"'fit' selecting at least one cap of {full.label}: none within the cap is "
                                f"as wide as a coil ({math.degrees(coil_angle):.3g}°); widen the cap, use smaller "
                                "coils or another packing", "no cap")
        elif isinstance(coils, str) and coils == "all":
            chosen = full
        elif isinstance(coils, str):
            raise bad_value("coils", "'fit', 'all' or a list of cap indices", coils)
        else:
            chosen = full.subset(coils, name="coils")
        if coil is not None:
            options["coil"] = _coil(coil)
        if isinstance(options.get("rotor_shell"), str):
            options["rotor_shell"] = length(options["rotor_shell"], "rotor_shell", allow_zero=True)
        design = cls(rotor=rotor_packing, polarity=polarity, stator=chosen, stator_axis=axis,
                     cap_half_angle=cap_half_angle, **sizes, **options)
        if check_fit:
            check_fits(design)
        return design

    # --- design files ---------------------------------------------------------------------------------
    @classmethod
    def load(cls, path) -> MotorDesign:
        """Read a design file, YAML or ``.toml`` (see :mod:`spherestep.design_file`); DesignFileError naming
        the file's field otherwise."""
        from .. import design_file  # pydantic and YAML only when a file is read (design_file never imports motor)

        return design_file.build(design_file.read(path), cls)

    @classmethod
    def loads(cls, text: str, fmt: str = "yaml", source: str = "<design>") -> MotorDesign:
        """The design written in ``text`` (``fmt`` 'yaml' or 'toml'; ``source`` names it in errors)."""
        from .. import design_file

        return design_file.build(design_file.parse(text, fmt, source), cls)

    def dumps(self) -> str:
        """This design as the YAML text of a design file (checked to load back)."""
        from .. import design_file

        return design_file.dumps(self)

    def save(self, path):
        """Write this design to a YAML design file, atomically; returns the path."""
        from .. import design_file

        return design_file.save(self, path)

    # --- geometry -------------------------------------------------------------------------------------
    @property
    def radius(self) -> float:
        """Rotor radius (m)."""
        return 0.5 * self.sphere_diameter

    @property
    def magnet_angle(self) -> float:
        """Angular radius (rad) of a rotor magnet's face seen from the centre: ``atan(d_m / 2 / R)``."""
        return disc_angle(self.magnet_diameter, self.radius)

    @property
    def coil_angle(self) -> float:
        """Angular radius (rad) of a coil face at ``R + gap`` seen from the centre: ``atan(d_c / 2 / (R + g))``."""
        return disc_angle(self.coil_diameter, self.radius + self.air_gap)

    @property
    def state_tol(self) -> float:
        """Tolerance (rad) for a pole to sit on a coil: ``tol`` if set, else :data:`DEFAULT_TOL` (1°)."""
        return self.tol if self.tol is not None else DEFAULT_TOL

    @property
    def max_step(self) -> float:
        """Largest step (Park distance, rad) a pair of energised coils can pull the rotor through.

        A coil pulls a magnet while their faces overlap, i.e. while the pole is within
        ``coil_angle + magnet_angle`` of the coil's axis; a rotation by ``θ`` moves no pole by more than ``θ``,
        so from any orientation within that Park distance of a state, the state's holding poles are under
        their coils' faces.
        """
        return self.coil_angle + self.magnet_angle

    @property
    def active_coils(self) -> np.ndarray:
        """Indices of the coils that work (all but ``failed_coils``)."""
        return np.setdiff1d(np.arange(len(self.stator)), np.array(self.failed_coils, dtype=int))

    def coil_currents(self, coils) -> np.ndarray:
        """Currents ``(N,)`` of a mapping coil → current (e.g. ``self.states().coils(i)``): the one helper,
        :func:`spherestep.motor.states.coil_currents`, checked against this motor's coils and failed coils."""
        from .states import coil_currents

        return coil_currents(coils, len(self.stator), self.failed_coils)

    def without_coils(self, coils) -> MotorDesign:
        """The same motor with the given coils failed (they are never energised)."""
        return replace(self, failed_coils=tuple(self.failed_coils) + tuple(int(k) for k in coils))

    def inertia(self, shell_mass: float = 0.6, magnet_density: float = 7500.0) -> np.ndarray:
        """Rotor inertia tensor (kg·m²): a thin shell ``(2/3) m R²`` plus point magnets at ``R − l/2``."""
        r = self.radius - 0.5 * self.magnet_length
        m = magnet_density * math.pi * (0.5 * self.magnet_diameter) ** 2 * self.magnet_length
        u = self.rotor.centers
        return (2.0 / 3.0) * shell_mass * self.radius ** 2 * np.eye(3) + m * r ** 2 * (len(u) * np.eye(3) - u.T @ u)

    @cached_property
    def fingerprint(self) -> str:
        """What the coil and magnet *numbering* of this motor is: ``"sha256:"`` and the first 16 hex digits of the
        SHA-256 of the rotor's centres, its polarities and the stator's coil centres, in index order, each
        coordinate as a whole number of micro-units (``rint(1e6 x)``, int64). Plans, calibrations and design
        files record it; a file whose fingerprint differs names coils or magnets of another motor, or of this one
        numbered otherwise, and is refused (:func:`check_fingerprint`)."""
        import hashlib

        digest = hashlib.sha256()
        for part in (self.rotor.centers, self.polarity, self.stator.centers):
            digest.update(np.rint(1e6 * np.asarray(part, dtype=float)).astype(np.int64).tobytes())
            digest.update(b"|")
        return "sha256:" + digest.hexdigest()[:16]

    # --- stepper states and metrics ---------------------------------------------------------------------
    @cached_property
    def _states(self):
        from .states import find_states

        return find_states(self, self.state_tol)

    def states(self, tol: float | None = None):
        """The stepper states (:class:`~spherestep.motor.states.StepperStates`) at ``tol`` (default the design's)."""
        if tol is None or tol == self.state_tol:
            return self._states
        from .states import find_states

        _check_tol(tol)
        return find_states(self, float(tol))

    def metrics(self, samples: int = 20_000, seed: int = 0, escape: bool = True):
        """Design metrics, a :class:`~spherestep.motor.metrics.DesignMetrics` (angles in radians, ``*_rad``;
        ``.to_dict()`` in degrees); see :func:`spherestep.motor.metrics.design_metrics`."""
        from .metrics import design_metrics

        return design_metrics(self, samples=samples, seed=seed, escape=escape)

    def coil_electrics(self) -> CoilElectrics:
        """The coil as built at this design's coil size, a :class:`CoilElectrics` (the winding's quantities of
        :class:`CoilSpec`, or why the winding does not fit in ``misfit``)."""
        c, size = self.coil, (self.coil_diameter, self.coil_length)
        supply = dict(core=c.core, supply_voltage=c.supply_voltage, supply_power=c.supply_power, coils_on=c.coils_on)
        try:
            return CoilElectrics(**supply, turns=c.turns(*size), resistance=c.resistance(*size),
                                 nominal_current=c.nominal_current(*size), ampere_turns=c.nominal_ampere_turns(*size),
                                 power=c.power(*size))
        except InputError as exc:
            return CoilElectrics(**supply, misfit=str(exc))

    def summary(self) -> dict:
        """Poles, coils and dimensions as a JSON-ready dict (degrees and millimetres for people); ``coil`` is
        :meth:`coil_electrics` as a dict."""
        return {
            "name": self.name,
            "rotor": self.rotor.label,
            "rotor_poles": len(self.rotor),
            "stator": self.stator.label,
            "coils": len(self.stator),
            "failed_coils": list(self.failed_coils),
            "cap_half_angle_deg": math.degrees(self.cap_half_angle),
            "sphere_diameter_mm": 1e3 * self.sphere_diameter,
            "magnet_mm": [1e3 * self.magnet_diameter, 1e3 * self.magnet_length],
            "coil_mm": [1e3 * self.coil_diameter, 1e3 * self.coil_length],
            "air_gap_mm": 1e3 * self.air_gap,
            "rotor_shell_mm": 1e3 * self.rotor_shell,
            "coil": self.coil_electrics().to_dict(),
            "state_tol_deg": math.degrees(self.state_tol),
            "max_step_deg": math.degrees(self.max_step),
            "rotor_inertia_isotropy": self.rotor.inertia_isotropy(),
        }


def check_fits(design: MotorDesign) -> None:
    """Raise InputError (``field`` 'rotor' or 'stator') when magnets or coils overlap physically: two centres
    closer than the angular size of their faces (``2 × magnet_angle`` or ``2 × coil_angle``)."""
    from ..packing.core import arc_from_chord

    for label, part, packing_, half in (("rotor", "magnet", design.rotor, design.magnet_angle),
                                        ("stator", "coil", design.stator, design.coil_angle)):
        if len(packing_) < 2:
            continue
        dist, idx = packing_.tree.query(packing_.centers, k=2)
        sep = arc_from_chord(dist[:, 1])
        k = int(np.argmin(sep))
        if sep[k] < 2 * half - 1e-12:
            raise bad_value(label, f"{part}s that do not overlap (use smaller {part}s, {part}_diameter, or fewer "
                            "of them)", f"{part}s {k} and {int(idx[k, 1])} {np.degrees(sep[k]):.3f}° apart, each "
                            f"face spanning {np.degrees(half):.3f}°")


def check_fingerprint(design: MotorDesign, recorded, field: str, again: str) -> None:
    """Refuse a file made for another numbering: InputError naming ``field`` unless ``recorded`` is this design's
    :attr:`MotorDesign.fingerprint`; ``again`` says how to make the file anew (e.g. "plan the turn again with
    `spherestep plan`")."""
    if recorded is None:
        raise bad_value(field, f"the fingerprint of the motor the file was made for; this file has none (written "
                        f"before spherestep numbered coils and magnets alike on every machine): {again}", "nothing")
    if recorded != design.fingerprint:
        raise bad_value(field, f"{design.fingerprint}, the fingerprint of design {design.name!r} (its coil and "
                        f"magnet numbering): the file names coils or magnets of another motor or numbering; {again}",
                        recorded)

