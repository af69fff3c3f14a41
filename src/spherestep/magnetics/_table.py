"""The torque map: every pole–coil interaction from one table of one angle.

Why one angle suffices. Pole ``j`` (magnet axis along ``w_j = R u_j``, centre at ``(R_s − l_m/2) w_j``) and
coil ``k`` (axis ``v_k``, centre at ``(R_s + g + l_c/2) v_k``) are both axisymmetric about axes through the
sphere's centre. Their relative position is fixed by the angle ``α_jk = acos(v_k · w_j)`` alone, and the
pair is symmetric under the mirror through the plane of ``v_k`` and ``w_j``; torque is a pseudovector, so
the torque of the pair about the centre is normal to that plane:

    T_jk = p_j c_k τ(α_jk) (v_k × w_j) / sin α_jk = p_j c_k g(α_jk) (v_k × w_j),   g(α) = τ(α) / sin α,

with ``τ(α)`` the torque (N·m) on a ``+1`` pole from a ``+1`` coil at unit current, positive when it turns
the pole away from the coil's axis (an attracting coil gives ``τ < 0`` near the axis). The force is linear
in the magnet's polarization and in the coil's, hence the factors ``p_j c_k``; magnet–magnet forces are
internal to the rotor and exert no torque on it. The whole motor is then

    T(R, c) = Σ_k c_k v_k × Σ_j p_j g(α_jk) w_j ,   E(R, c) = Σ_jk p_j c_k e(α_jk),   e(α) = −∫_0^α τ,

with ``T = −∂E/∂θ`` for a small turn ``θ`` of the rotor (``dE = −T · dθ``). This decomposition is exact for
the model of :mod:`._model`; only the table's interpolation is added: ``τ`` is computed by ``getFT`` at
151 angles (0.5° steps to 40°, where all the structure is, 2° steps beyond) and interpolated by one cubic
spline (not-a-knot; the table's ``τ(0)`` and ``τ(π)`` come out below 1e-13 N·m, as symmetry requires).
``e`` is the spline's exact antiderivative, so torque and energy agree to rounding (``T = −∂E/∂θ``), which
the equilibrium search relies on. Against ``getFT`` at the mid-points between nodes the spline is within
1e-4 of the peak ``|τ|``; the table's mesh (1000 cells per magnet) is within 1e-3 of converged.

Rotor function. With ``x_k = Rᵀ v_k`` and ``w_j = R u_j``, ``α_jk = acos(x_k · u_j)``, so the whole map is one
function on the sphere in the body frame, ``F(x) = Σ_j p_j e(acos(x · u_j))``, with ambient gradient
``S(x) = Σ_j p_j g(acos(x · u_j)) u_j`` (``d e(acos t)/dt = g``): ``E = Σ_k c_k F(x_k)``,
``T = R Σ_k c_k x_k × S(x_k)`` and the Hessian from ``h'' = d g(acos t)/dt = −(τ' sin α − τ cos α)/sin³ α``
(:mod:`spherestep.rotor_field`). ``energy``, ``torque``, ``torque_matrix``, ``evaluate`` and ``hessian`` (now
analytic, no longer central differences) go through it, evaluated by the direct sum over the poles at the
energised coils only; the pair sums ``coil_torques``, ``torque_pairwise`` and ``energy_pairwise`` stay as the
reference. (The spline kernel is not band-limited, so ducc0's synthesis does not fit: its harmonic series is
still 7e-5 of the peak torque off at degree 384.)

A table per coil over SO(3) would need a 3-D grid per coil (29 × ~10⁵ orientations for 1° resolution);
this one is 151 numbers and is shared by every pole and coil. It is built once per magnet/coil geometry
(about a second) and cached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import magpylib as magpy
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from .._fast import Packed
from ..rotor_field import RotorField, fast_evaluate, fast_torque_matrix, pack_terms
from ..statics import TorqueModelBase
from ._direct import EPS
from ._model import MU0, as_meshing, as_rotations, currents_for, unflatten

TABLE_MESHING = 1000  # cells per magnet for the table (0.1 % of the peak pair torque)
CHUNK = 256  # orientations per vectorised block (bounds the (K, M, N) arrays)


def table_nodes() -> np.ndarray:
    """The table's angles (rad): 0.5° steps on [0°, 40°), 2° steps on [40°, 180°]."""
    return np.radians(np.concatenate([np.arange(0.0, 40.0, 0.5), np.arange(40.0, 180.0 + 1e-9, 2.0)]))


def pair_torque(design, alpha, meshing: int = TABLE_MESHING) -> np.ndarray:
    """``τ(α)`` (N·m) by ``magpylib.getFT``: torque about the sphere's centre on one ``+1`` pole at angle
    ``alpha`` (rad, any shape) from the axis of one ``+1`` coil at unit current, along ``v × w / |v × w|``.

    The coil's axis is ``z``; the magnet turns about ``y`` (a path of target positions and orientations),
    so ``w = (sin α, 0, cos α)`` and the torque's ``y`` component is ``τ``. The other components vanish by
    the mirror symmetry (they come out below 1e-12 of ``τ``).
    """
    a = np.asarray(alpha, dtype=float)
    return _pair_torque(_geometry_key(design), a.reshape(-1), as_meshing(meshing)).reshape(a.shape)


def _geometry_key(design) -> tuple:
    """Everything the pair torque depends on: rotor radius, magnet and coil sizes, gap (m), ``B_r`` (T), NI."""
    return (design.radius, design.magnet_diameter, design.magnet_length, design.coil_diameter,
            design.coil_length, design.air_gap, design.remanence, design.coil_ampere_turns)


def _pair_torque(key: tuple, alpha: np.ndarray, meshing: int) -> np.ndarray:
    radius, dm, lm, dc, lc, gap, br, ni = key
    w = np.stack([np.sin(alpha), np.zeros_like(alpha), np.cos(alpha)], axis=1)
    coil = magpy.magnet.Cylinder(dimension=(dc, lc), polarization=(0.0, 0.0, MU0 * ni / lc),
                                 position=(0.0, 0.0, radius + gap + 0.5 * lc))
    magnet = magpy.magnet.Cylinder(dimension=(dm, lm), polarization=(0.0, 0.0, br),
                                   position=(radius - 0.5 * lm) * w,
                                   orientation=Rotation.from_rotvec(np.outer(alpha, [0.0, 1.0, 0.0])))
    _, T = magpy.getFT(coil, magnet, pivot=(0.0, 0.0, 0.0), meshing=meshing, eps=EPS, squeeze=False)
    return T[0, :, 0, 1]


@lru_cache(maxsize=16)
def _table(key: tuple, meshing: int) -> tuple[np.ndarray, np.ndarray]:
    nodes = table_nodes()
    return nodes, _pair_torque(key, nodes, meshing)


@dataclass(frozen=True, eq=False)
class TorqueMap(TorqueModelBase):
    """Fast torque and energy of a design from the pair table ``τ(α)`` (see the module docstring); a
    :class:`~spherestep.statics.TorqueModel` (its Hessian by central differences of the torque).

    ``poles (M, 3)``, ``polarity (M,)`` (body frame), ``coils (N, 3)`` (fixed frame), ``failed`` coil
    indices; ``nodes`` (rad) and ``tau`` (N·m) the table, built with ``meshing`` cells per magnet.
    """

    poles: np.ndarray
    polarity: np.ndarray
    coils: np.ndarray
    failed: tuple[int, ...]
    nodes: np.ndarray
    tau: np.ndarray
    meshing: int

    has_bias = False  # linear in the currents: no torque with every coil off
    affine_in_currents = True  # packed terms Σ c_k F(x_k)

    def __post_init__(self):
        tau = CubicSpline(self.nodes, self.tau)
        slope = tau.derivative()
        object.__setattr__(self, "_tau", tau)
        object.__setattr__(self, "_e", tau.antiderivative())
        object.__setattr__(self, "_g_ends", (float(slope(0.0)), -float(slope(math.pi))))

    @classmethod
    def build(cls, design, meshing: int = TABLE_MESHING) -> TorqueMap:
        """The map of ``design`` (table cached per magnet and coil geometry)."""
        nodes, tau = _table(_geometry_key(design), as_meshing(meshing))
        return cls(design.rotor.centers.copy(), design.polarity.astype(float), design.stator.centers.copy(),
                   tuple(design.failed_coils), nodes, tau, int(meshing))

    @property
    def coil_count(self) -> int:
        return len(self.coils)

    def pair(self, alpha) -> np.ndarray:
        """Interpolated ``τ(α)`` (N·m) for angles ``alpha`` (rad) in ``[0, π]``."""
        return self._tau(np.clip(np.asarray(alpha, dtype=float), 0.0, math.pi))

    def _g(self, alpha: np.ndarray) -> np.ndarray:
        """``g(α) = τ(α) / sin α``, with its limits ``τ'(0)`` and ``−τ'(π)`` within 1e-6 rad of the ends."""
        s = np.sin(alpha)
        near = s < 1e-6
        g = self._tau(alpha) / np.where(near, 1.0, s)
        return np.where(near, np.where(alpha < 1.0, self._g_ends[0], self._g_ends[1]), g)

    def _zonal(self, t: np.ndarray, orders: tuple[int, ...]) -> tuple[np.ndarray, ...]:
        """The rotor function's kernel for ``orders`` (from 0, 1, 2): ``h(t) = e(acos t)``, ``h' = g(acos t)``,
        ``h'' = −(τ' sin α − τ cos α)/sin³ α`` (``α`` kept 1e-3 rad from the ends, where the quotient loses
        its digits)."""
        alpha = np.arccos(np.clip(t, -1.0, 1.0))
        out = []
        for n in orders:
            if n == 0:
                out.append(self.pair_energy(alpha))
            elif n == 1:
                out.append(self._g(alpha))
            else:
                a = np.clip(alpha, 1e-3, math.pi - 1e-3)
                s, c = np.sin(a), np.cos(a)
                out.append(-(self._tau(a, 1) * s - self._tau(a) * c) / s**3)
        return tuple(out)

    @property
    def rotor_field(self) -> RotorField:
        """``F(x) = Σ_j p_j e(acos(x · u_j))`` with its gradient and Hessian (see the module docstring)."""
        field = self.__dict__.get("_field")
        if field is None:
            spline = ("angle_spline", (self._tau.x, self._tau.c, self._e.c, self._g_ends))
            field = RotorField(self.poles, self.polarity, self._zonal, compiled=spline)
            object.__setattr__(self, "_field", field)
        return field

    def zonal_terms(self, currents) -> list:
        """``[(rotor_field, 1, coils, c)]`` for currents ``(..., N)``: the energy as a zonal sum
        (:func:`spherestep.rotor_field.pack_terms`)."""
        return [(self.rotor_field, 1.0, self.coils, self.as_currents(currents))]

    def packed_terms(self, currents) -> Packed:
        """The energy ``Σ_k c_k F(x_k)`` as one compiled zonal term (:func:`spherestep.rotor_field.pack_terms`;
        the compiled descent's and integrator's input)."""
        return pack_terms(self.zonal_terms(currents))

    def evaluate(self, R, currents, order: int) -> tuple[np.ndarray, ...]:
        """``(E,)``, ``(E, τ)`` or ``(E, τ, H)`` through the rotor function (J, N·m, N·m/rad); ``R (K, 3, 3)`` or
        ``(3, 3)``, currents ``(K, N)`` or ``(N,)``."""
        R, batch = as_rotations(R)
        c = currents_for(currents, len(self.coils), self.failed, batch)
        out = fast_evaluate(self.rotor_field, 1.0, self.coils, R, c, order, 0.0)
        return tuple(unflatten(a, batch) for a in out)

    def hessian(self, R, currents) -> np.ndarray:
        """``H = ∂²E/∂θ²`` (N·m/rad, fixed frame), analytic through the rotor function, ``(K, 3, 3)`` or ``(3, 3)``."""
        return self.evaluate(R, currents, 2)[2]

    def pair_energy(self, alpha) -> np.ndarray:
        """``e(α) = −∫_0^α τ`` (J): energy of a ``+1`` pole at ``alpha`` from a ``+1`` coil at unit current."""
        return -self._e(np.clip(np.asarray(alpha, dtype=float), 0.0, math.pi))

    def _angles(self, R: np.ndarray, coils: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        W = np.einsum("kab,mb->kma", R, self.poles)  # (K, M, 3) poles in the fixed frame
        cos = np.clip(np.einsum("kma,na->kmn", W, self.coils[coils]), -1.0, 1.0)
        return W, np.arccos(cos)

    def coil_torques(self, R, coils=None) -> np.ndarray:
        """``T_k(R)`` (N·m, fixed frame): torque of each coil in ``coils`` (default all) at unit current,
        ``(K, n, 3)``."""
        R, _ = as_rotations(R)
        idx = np.arange(len(self.coils)) if coils is None else np.asarray(coils, dtype=int)
        out = np.empty((len(R), len(idx), 3))
        for s in range(0, len(R), CHUNK):
            W, alpha = self._angles(R[s:s + CHUNK], idx)
            g = self._g(alpha)
            S = np.einsum("kmn,m,kma->kna", g, self.polarity, W)  # Σ_j p_j g(α_jk) w_j
            out[s:s + CHUNK] = np.cross(self.coils[idx][None], S)
        return out

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``K(R)`` (N·m per unit current), ``(3, N)`` or ``(K, 3, N)``: column ``k`` is coil ``k``'s torque at unit
        current, ``R (x_k × S(x_k))`` (zero for failed coils); the map is linear in the currents, so ``currents``
        does not matter."""
        R, batch = as_rotations(R)
        return unflatten(fast_torque_matrix(self.rotor_field, 1.0, self.coils, self.failed, R), batch)

    def torque_matrix_pairwise(self, R, currents=None) -> np.ndarray:
        """:meth:`torque_matrix` from the pair sums :meth:`coil_torques` (the reference)."""
        R, batch = as_rotations(R)
        live = np.setdiff1d(np.arange(len(self.coils)), self.failed)
        K = np.zeros((len(R), 3, len(self.coils)))
        K[:, :, live] = np.swapaxes(self.coil_torques(R, live), 1, 2)
        return unflatten(K, batch)

    def torque_reference(self, currents) -> np.ndarray:
        """``max|τ(α)| Σ_k |c_k|`` (N·m), shape ``currents.shape[:-1]``: the reference for torque tolerances."""
        return float(np.max(np.abs(self.tau))) * np.sum(np.abs(np.asarray(currents, dtype=float)), axis=-1)

    def _drive(self, R, currents) -> tuple[np.ndarray, tuple[int, ...], np.ndarray, np.ndarray]:
        R, batch = as_rotations(R)
        c = currents_for(currents, len(self.coils), self.failed, batch)
        active = np.nonzero(np.any(c != 0, axis=0))[0]
        return R, batch, c[:, active], active

    def torque(self, R, currents) -> np.ndarray:
        """Torque (N·m, fixed frame, about the centre) for rotations ``R (K, 3, 3)`` or ``(3, 3)`` and
        currents ``(K, N)`` or ``(N,)``: ``R Σ_k c_k x_k × S(x_k)`` through the rotor function; shape ``(K, 3)``
        or ``(3,)``."""
        R, batch = as_rotations(R)
        c = currents_for(currents, len(self.coils), self.failed, batch)
        return unflatten(fast_evaluate(self.rotor_field, 1.0, self.coils, R, c, 1, None, value=False)[1], batch)

    def torque_pairwise(self, R, currents) -> np.ndarray:
        """:meth:`torque` from the pair sums ``Σ_k c_k v_k × Σ_j p_j g(α_jk) w_j`` (the reference)."""
        R, batch, c, active = self._drive(R, currents)
        T = np.einsum("kn,kna->ka", c, self.coil_torques(R, active)) if len(active) else np.zeros((len(R), 3))
        return unflatten(T, batch)

    def energy(self, R, currents) -> np.ndarray:
        """Magnetic energy (J) of the rotor in the coils' field, ``Σ_k c_k F(x_k)`` through the rotor function,
        zero when every pole is on the far side of every coil (α = π); ``(K,)`` or a scalar."""
        return self.evaluate(R, currents, 0)[0]

    def energy_pairwise(self, R, currents) -> np.ndarray:
        """:meth:`energy` from the pair sums ``Σ_jk p_j c_k e(α_jk)`` (the reference)."""
        R, batch, c, active = self._drive(R, currents)
        E = np.zeros(len(R))
        if len(active):
            for s in range(0, len(R), CHUNK):
                _, alpha = self._angles(R[s:s + CHUNK], active)
                E[s:s + CHUNK] = np.einsum("kmn,m,kn->k", self.pair_energy(alpha), self.polarity, c[s:s + CHUNK])
        return unflatten(E, batch)


def torque_map(design, meshing: int = TABLE_MESHING) -> TorqueMap:
    """The :class:`TorqueMap` of ``design``."""
    return TorqueMap.build(design, meshing)


def torque_function(design, meshing: int = TABLE_MESHING):
    """A callable ``(R (K, 3, 3), currents (K, N)) -> torque (K, 3)`` in N·m (fixed frame, about the sphere's
    centre) for rigid-rotor dynamics, backed by the design's :class:`TorqueMap`.

    >>> import numpy as np
    >>> from spherestep.motor import prototype
    >>> f = torque_function(prototype())
    >>> f(np.eye(3)[None], np.zeros((1, 29))).shape
    (1, 3)
    """
    return TorqueMap.build(design, meshing).torque
