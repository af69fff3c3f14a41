"""The motor's torque model with iron-cored coils: two pair tables on the machinery of :class:`TorqueMap`.

Each pole–coil pair with a linear core contributes (see :mod:`._iron`)

    τ_jk(α, c) = τ_d(α) + p_j c_k τ_1(α)

about the normal of the plane of ``v_k`` and ``w_j``: ``τ_d`` the detent (the magnet pulling on the iron it
magnetises, the same for both polarities, present with the coil off and in failed coils), ``τ_1`` the winding
plus the iron it magnetises, per nominal current. Both parts have the symmetry that makes :class:`TorqueMap`
exact, so the model is two maps over the same poles and coils,

    T(R, c) = D(R) + L(R) c,    D = TorqueMap(τ_d, all polarities +1).torque(R, 1),    L = TorqueMap(τ_1).K(R),

with energies ``E = Σ_jk e_d(α_jk) + Σ_jk p_j c_k e_1(α_jk)`` from the splines' antiderivatives, so
``T = −∂E/∂θ`` to rounding. A quadratic ``c²`` term would act between the winding and its own core only (no
torque on the rotor) as long as the iron stays linear; :func:`iron_saturation` checks that it does.
Pairwise superposition leaves out a magnet acting on another through a core and the cores on each other;
``data/iron_multibody.csv`` measures that against a full solve (docs/magnetics.md). ``iron_model(...,
coupling=True)`` adds the first (:mod:`._coupling`).

The prototype's tables (``spherestep/data/iron_pair_table.csv``: NGSolve FEM nodes below 21°, the moment method
from 21° on; ``python scripts/iron_tables.py fem-table``) are read, scaled by the law of :mod:`._ironscale`, for
the prototype and every scaled copy of its geometry; another magnet within the shape table's range is interpolated
from it (:func:`._ironscale.shape_table_tables`); any other geometry is solved by the moment method on first use
(minutes) and cached — its error near the axis is up to ~30 % of the peak (docs/magnetics.md).
"""

from __future__ import annotations

import math
from dataclasses import astuple, dataclass, replace
from functools import lru_cache
from importlib import resources

import numpy as np

from .. import so3
from ..errors import bad_value
from ..motor.coil import CoilSpec
from .._fast import Packed
from ..rotor_field import pack_terms
from ..statics import TorqueModelBase
from . import _iron, _ironcoupling, _ironforce, _ironscale
from ._coupling import COUPLING_ALPHA_DEG, COUPLING_DPHI_DEG, CoreCoupling
from ._model import as_rotations, currents_for, unflatten
from ._table import TorqueMap

TABLE_NODES_DEG = np.concatenate([np.arange(0.0, 30.0, 1.0), np.arange(30.0, 60.0, 2.0), np.arange(60.0, 180.1, 5.0)])
TABLE_FILE = "iron_pair_table.csv"
COUPLING_FILE = "iron_coupling_table.csv"


def pair_table(design, coil: CoilSpec, level: int = _iron.IRON_LEVEL, nodes_deg=TABLE_NODES_DEG):
    """``(τ_d, τ_1)`` (N·m) at ``nodes_deg`` by the method of moments, with the values at 0° and 180° set to
    their symmetric value 0 (the solve gives below 3e-3 N·m there)."""
    det, lin = _ironforce.pair_tables(design, coil, np.radians(nodes_deg), level)
    ends = np.isclose(nodes_deg, 0.0) | np.isclose(nodes_deg, 180.0)
    det[ends] = 0.0
    lin[ends] = 0.0
    return det, lin


def read_table(path) -> np.ndarray:
    """The numbers of a stored ``#``-commented CSV with one header line, ``(rows, columns)``."""
    lines = [line for line in path.read_text().splitlines() if line and not line.startswith("#")][1:]
    return np.array([[float(v) for v in line.split(",")] for line in lines])


def _key(design, coil: CoilSpec, level: int) -> tuple:
    """What the pair tables depend on, rounded (to 1 nm, 1e-9 A-turns) so that the same coil written another
    way (``0.286 mm`` or ``286 um`` of wire) finds the same tables."""
    return (round(design.radius, 9), round(design.magnet_diameter, 9), round(design.magnet_length, 9),
            round(design.coil_diameter, 9), round(design.coil_length, 9), round(design.air_gap, 9),
            round(design.rotor_shell, 9), round(design.remanence, 6),
            tuple(round(v, 9) for v in astuple(_iron.CoreGeometry.of(design, coil))), level)


@lru_cache(maxsize=8)
def _tables(key: tuple, design, coil: CoilSpec, level: int):
    scale = _ironscale.prototype_scale(design, coil, level)  # the prototype's shape: its tables, scaled
    if scale is not None:
        path = resources.files("spherestep.data") / TABLE_FILE
        if path.is_file():
            arr = read_table(path)
            return np.radians(arr[:, 0]), scale.detent * arr[:, 1], scale.linear * arr[:, 2]
    shaped = _ironscale.shape_table_tables(design, coil, level)  # another magnet: the shape table, scaled
    if shaped is not None:
        return shaped
    det, lin = _ironscale.cached("pair", key, lambda: _ironscale.solve_pair_tables(design, coil, level))
    return np.radians(TABLE_NODES_DEG), det, lin


@dataclass(frozen=True, eq=False)
class IronTorqueMap(TorqueModelBase):
    """Torque model of a stator with iron-cored coils (see the module docstring): a
    :class:`~spherestep.statics.TorqueModel` with a detent, ``torque(R, 0) ≠ 0``.

    ``detent`` and ``linear`` are :class:`TorqueMap` objects on the same poles and coils; ``coil`` the coil spec.
    """

    detent: TorqueMap
    linear: TorqueMap
    coil: CoilSpec
    coupling: CoreCoupling | None = None

    @classmethod
    def from_tables(cls, design, coil: CoilSpec, nodes, tau_detent, tau_linear, level: int = _iron.IRON_LEVEL,
                    coupling: CoreCoupling | None = None):
        """The model of ``design`` from pair tables ``τ_d``, ``τ_1`` (N·m) at ``nodes`` (rad, 0…π), and the
        ``coupling`` through the cores if given."""
        poles = design.rotor.centers.copy()
        coils = design.stator.centers.copy()
        detent = TorqueMap(poles, np.ones(len(poles)), coils, (), np.asarray(nodes), np.asarray(tau_detent), level)
        linear = TorqueMap(poles, design.polarity.astype(float), coils, tuple(design.failed_coils),
                           np.asarray(nodes), np.asarray(tau_linear), level)
        return cls(detent, linear, coil, coupling)

    @property
    def coil_count(self) -> int:
        return self.linear.coil_count

    @property
    def failed(self) -> tuple[int, ...]:
        return self.linear.failed

    def subset(self, coils) -> IronTorqueMap:
        """The same model with only the cores ``coils`` present (indices into the stator)."""
        idx = np.asarray(coils, dtype=int)
        failed = tuple(int(np.nonzero(idx == k)[0][0]) for k in self.failed if k in idx)

        def cut(m: TorqueMap, failed_):
            return TorqueMap(m.poles, m.polarity, m.coils[idx], failed_, m.nodes, m.tau, m.meshing)

        coupling = None if self.coupling is None else replace(self.coupling, coils=self.coupling.coils[idx])
        return IronTorqueMap(cut(self.detent, ()), cut(self.linear, failed), self.coil, coupling)

    def torque_on(self, R, currents, coils) -> np.ndarray:
        """Torque (N·m) with only the cores ``coils`` present, their currents taken from ``currents (N,)``."""
        idx = np.asarray(coils, dtype=int)
        return self.subset(idx).torque(R, np.asarray(currents, dtype=float)[..., idx])

    def _ones(self, R) -> np.ndarray:
        lead = np.shape(R)[:-2]
        return np.ones(lead + (self.coil_count,))

    def detent_torque(self, R) -> np.ndarray:
        """``D(R)`` (N·m, fixed frame): the torque with every coil off (with the coupling, its torque too)."""
        if self.coupling is not None:
            return self.torque(R, np.zeros(self.coil_count))
        return self.detent.torque(R, self._ones(R))

    has_bias = True  # the detent: torque with every coil off
    affine_in_currents = True  # the detent's terms and c_k times the winding's; the coupling's tables likewise

    def zonal_terms(self, currents) -> list | None:
        """The detent's and the coils' zonal terms (:func:`spherestep.rotor_field.pack_terms`); with the coupling
        the coupled model's two tabulated rotor functions (:class:`._coupling.CoupledTables`)."""
        if self.coupling is not None:
            return self.coupling.zonal_terms(self.detent, self.linear, self.as_currents(currents))
        return self.detent.zonal_terms(np.ones(self.coil_count)) + self.linear.zonal_terms(self.as_currents(currents))

    def packed_terms(self, currents) -> Packed | None:
        """The detent's and the coils' terms compiled (:func:`spherestep.rotor_field.pack_terms`; with the
        coupling, its tables)."""
        return pack_terms(self.zonal_terms(currents))

    def _coupled(self, R, torque: bool) -> np.ndarray | float:
        """The coupling's torque (``torque``) or energy at ``R (..., 3, 3)``, shaped like the pair terms' (0
        without)."""
        if self.coupling is None:
            return 0.0
        R = so3.as_rotations(R)
        Rf = R.reshape(-1, 3, 3)
        out = self.coupling.torque(Rf) if torque else self.coupling.energy(Rf)
        return out.reshape(R.shape[:-2] + out.shape[1:])

    def torque(self, R, currents) -> np.ndarray:
        """``D(R) + L(R) c`` (+ the coupling's torque) (N·m, fixed frame, about the centre), ``(K, 3)`` or
        ``(3,)``; with the coupling from its tables (:meth:`exact_torque`: the sums they interpolate)."""
        if self.coupling is not None:
            return self.evaluate(R, currents, 1)[1]
        return self.exact_torque(R, currents)

    def energy(self, R, currents) -> np.ndarray:
        """``Σ e_d(α_jk) + Σ p_j c_k e_1(α_jk)`` (+ the coupling's energy) (J); the pair terms are zero with
        every pole opposite every coil; with the coupling from its tables (:meth:`exact_energy`)."""
        if self.coupling is not None:
            return self.evaluate(R, currents, 0)[0]
        return self.exact_energy(R, currents)

    def exact_torque(self, R, currents) -> np.ndarray:
        """:meth:`torque` from the pair splines and the coupling's series (NumPy, ~0.1 s per orientation with
        the coupling): the reference of its tables."""
        c = self.as_currents(currents)
        return self.detent.torque(R, self._ones(R)) + self.linear.torque(R, c) + self._coupled(R, torque=True)

    def exact_energy(self, R, currents) -> np.ndarray:
        """:meth:`energy` from the pair splines and the coupling's series (the reference of its tables)."""
        c = self.as_currents(currents)
        return self.detent.energy(R, self._ones(R)) + self.linear.energy(R, c) + self._coupled(R, torque=False)

    def evaluate(self, R, currents, order: int) -> tuple[np.ndarray, ...]:
        """``(E,)``, ``(E, τ)`` or ``(E, τ, H)`` (J, N·m, N·m/rad); with the coupling all from its tables
        (the Hessian analytic), else energy and torque from the pair maps and the Hessian by differences."""
        if self.coupling is None:
            return super().evaluate(R, currents, order)
        Rf, batch = as_rotations(R)
        c = currents_for(currents, self.coil_count, self.failed, batch)
        out = self.coupling.fast_evaluate(self.detent, self.linear, Rf, c, order)
        return tuple(unflatten(np.asarray(a), batch) for a in out)

    def hessian(self, R, currents) -> np.ndarray:
        """``H = ∂²E/∂θ²`` (N·m/rad): with the coupling analytic from its tables, else by differences."""
        if self.coupling is None:
            return super().hessian(R, currents)
        return self.evaluate(R, currents, 2)[2]

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``∂T/∂c = L(R)`` (N·m per nominal current), ``(3, N)`` or ``(K, 3, N)``; independent of ``currents``."""
        if self.coupling is not None:
            Rf, batch = as_rotations(R)
            return unflatten(self.coupling.fast_torque_matrix(self.detent, self.linear, Rf, self.failed), batch)
        return self.linear.torque_matrix(R)

    def torque_reference(self, currents) -> np.ndarray:
        """``max|τ_d| + max|τ_1| Σ|c_k|`` (N·m): positive with every coil off, because of the detent."""
        c = np.asarray(currents, dtype=float)
        return float(np.max(np.abs(self.detent.tau))) + self.linear.torque_reference(c)


def iron_model(design, coil: CoilSpec | None = None, level: int = _iron.IRON_LEVEL, coupling: bool = False):
    """The torque model of ``design`` with coils built as ``coil`` (default ``design.coil``): an
    :class:`IronTorqueMap` for an iron core, today's air-core :class:`TorqueMap` for ``core="air"`` (at the
    coil's nominal ampere-turns; ``air_coil(design.coil_ampere_turns)`` reproduces it exactly). ``coupling=True``
    adds the coupling through the cores (:mod:`._coupling`, moment method) and evaluates the whole model from
    its cubed-sphere tables, compiled on every fast path (built on first use, a few seconds; the design's own
    model, :func:`~spherestep.magnetics.design_model`, is this one)."""
    coil = design.coil if coil is None else coil
    if not isinstance(coil, CoilSpec):
        raise bad_value("coil", "a spherestep.motor.coil.CoilSpec", type(coil).__name__)
    if coil.core == "air":
        tmap = TorqueMap.build(design)
        ni = coil.nominal_ampere_turns(design.coil_diameter, design.coil_length)
        if math.isclose(ni, design.coil_ampere_turns, rel_tol=1e-12):
            return tmap
        return TorqueMap(tmap.poles, tmap.polarity, tmap.coils, tmap.failed, tmap.nodes,
                         tmap.tau * (ni / design.coil_ampere_turns), tmap.meshing)
    key = _key(design, coil, level)
    nodes, det, lin = _tables(key, design, coil, level)
    cross = None
    if coupling:
        alpha, dphi, X = _coupling_table(key, design, coil, level)
        cross = CoreCoupling.from_table(design.rotor.centers, design.polarity, design.stator.centers, alpha, dphi, X)
    return IronTorqueMap.from_tables(design, coil, nodes, det, lin, level, cross)


@lru_cache(maxsize=4)
def _coupling_table(key: tuple, design, coil: CoilSpec, level: int):
    """``(alpha, dphi, X)`` of :func:`._ironcoupling.cross_energy_table`: the prototype's stored table
    (``spherestep/data/iron_coupling_table.csv``, ``python scripts/iron_tables.py coupling-table``), else solved
    (about a minute) and cached."""
    alpha, dphi = np.radians(COUPLING_ALPHA_DEG), np.radians(COUPLING_DPHI_DEG)
    scale = _ironscale.prototype_scale(design, coil, level)
    if scale is not None:
        path = resources.files("spherestep.data") / COUPLING_FILE
        if path.is_file():
            return alpha, dphi, scale.detent * read_table(path)[:, 3].reshape(len(alpha), len(alpha), len(dphi))
    shaped = _ironscale.shape_table_coupling(design, coil, level)  # another magnet: the coupling shape table
    if shaped is not None:
        return shaped

    def solve():
        _ironscale.report("iron: the coupling table by the moment method (about a minute, then cached on disk)")
        return (_ironcoupling.cross_energy_table(design, coil, alpha, dphi, level),)

    return alpha, dphi, _ironscale.cached("coupling", key, solve)[0]
