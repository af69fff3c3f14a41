"""The coupling through the cores: a rotor magnet in the iron that another magnet magnetises.

For linear iron the energy of the polarised cores in the magnets' field is ``W = −(1/2μ0) Σ_pq s_p s_q ∫ J_p·B_q``
(``J_p`` the polarization magnet ``p`` alone induces). The pair tables hold the ``p = q`` terms; the rest, one
core at a time, is

    E_c(R) = Σ_k Σ_{p<q} s_p s_q X(α_pk, α_qk, Δφ_pqk),

with ``α_pk`` the angle of pole ``p`` from coil ``k``'s axis, ``Δφ_pqk = φ_qk − φ_pk`` the azimuth between the
two poles about that axis, and ``X`` the coupling energy of two ``+1`` poles over one core
(:func:`spherestep.magnetics._ironcoupling.cross_energy_table`): tabulated on ``α`` (cubic splines in both angles) and
as a cosine series in ``Δφ`` through the table's uniform azimuths (exact at them; ``cos mΔφ`` is the core's
axisymmetry, and the ``m ≥ 1`` terms vanish on the axis). Pairs with a pole beyond the table's last angle (60°)
are left out: there ``X`` is 0.15 % of its peak, but a pole near a core's axis magnetises it strongly and many far
poles sit in its field, so the energy still moves by tens of % between 60° and 90° of reach; the torque, which is
what the statics and dynamics use, is checked against the full solve instead (docs/magnetics.md).

Torque ``τ = −∂E_c/∂θ`` for ``R → exp(θ̂) R`` (fixed frame), with ``w = R u``, ``v`` the coil axis:

    ∂α/∂θ = −(w × v)/sin α,   ∂φ/∂θ = (v − cos α w)/sin² α,   ∂Δφ/∂θ = ∂φ_q/∂θ − ∂φ_p/∂θ.

The coils' currents do not enter (the winding's field in the iron is linear in the current and couples to each
magnet alone: the pair tables' linear part holds it exactly). The cores' magnetising each other is not in it.

Taper. A pole's terms are weighted by ``w(α) = ½(1 + cos π(α − 50°)/(60° − 50°))`` between 50° and the table's
last angle (1 below), so that ``E_c`` is smooth where a pole leaves the reach (without it ``E_c`` jumps by
``X(60°, ·)``, 0.15 % of its peak, per pair, which a table on the sphere cannot interpolate). The torque includes
``∂w/∂α``.

Fast form. ``E_c = Σ_k G(x_k)``, ``x_k = Rᵀ v_k``: for a fixed coil the angles ``α_pk, Δφ_pqk`` are those of the
poles about ``x_k`` in the rotor's frame, so the coupling is a rotor function ``G`` on the sphere
(:mod:`spherestep.rotor_field`), like the pair tables' ``F_d(x) = Σ_j e_d(acos x·u_j)`` (every coil, current 1)
and ``F_1(x) = Σ_j p_j e_1(acos x·u_j)`` (current ``c_k``). :class:`CoupledTables` tabulates ``F_d + G`` and
``F_1`` on a cubed sphere (:mod:`spherestep._fast.spheretable`, cubic B-splines, :data:`TABLE_FACE` intervals per
face edge; ``G`` computed by :func:`spherestep._fast.coupling.coupling_energies` on a grid of
:data:`COUPLING_FACE` and interpolated onto it), so the whole coupled model is 29 table look-ups per orientation
plus one per energised coil, compiled on every fast path (equilibria, the integrator, the servo's ``K(R)`` and
bias). Against the sums it interpolates: ``tests/test_iron_coupling_fast.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RectBivariateSpline

from ..errors import bad_value
from ..rotor_field import RotorField, fast_evaluate, fast_torque_matrix

COUPLING_ALPHA_DEG = np.arange(0.0, 61.0, 2.0)  # table angles from a core's axis
COUPLING_DPHI_DEG = np.arange(0.0, 181.0, 15.0)  # table azimuths between the two poles
_TINY = 1e-9  # sin α below which a pole counts as on the axis (its azimuth undefined, its φ-terms zero)
TAPER_DEG = 50.0  # the poles' weight falls from 1 here to 0 at the table's last angle (module docstring)
TABLE_FACE = 256  # cubed-sphere intervals per face edge of the coupled model's tables (0.35° at a face's centre)
COUPLING_FACE = 128  # those of the grid G itself is computed on (smoother than the pair terms)


def taper(alpha: np.ndarray, reach: float, order: int = 0) -> np.ndarray:
    """The reach's weight ``w(α)`` (module docstring; ``order = 1``: ``dw/dα``), ``α`` and ``reach`` in rad."""
    start = math.radians(TAPER_DEG)
    z = np.clip((np.asarray(alpha, dtype=float) - start) / (reach - start), 0.0, 1.0)
    if order == 0:
        return 0.5 * (1.0 + np.cos(np.pi * z))
    inside = (z > 0.0) & (z < 1.0)
    return np.where(inside, -0.5 * np.pi / (reach - start) * np.sin(np.pi * z), 0.0)


@dataclass(frozen=True, eq=False)
class CoreCoupling:
    """``E_c(R)`` and its torque for ``poles (M, 3)``, ``polarity (M,)`` and ``coils (N, 3)`` from the table
    ``X (A, A, D)`` at ``alpha (A,)`` and uniform ``dphi (D,)`` on ``[0, π]`` (radians; see the module)."""

    poles: np.ndarray
    polarity: np.ndarray
    coils: np.ndarray
    alpha: np.ndarray
    series: tuple  # RectBivariateSpline of the cosine coefficient c_m(α_p, α_q), m = 0 … D − 1
    pairs: np.ndarray  # (P, 2) pole pairs p < q close enough to share a core

    @classmethod
    def from_table(cls, poles, polarity, coils, alpha, dphi, X) -> CoreCoupling:
        alpha, dphi, X = (np.asarray(a, dtype=float) for a in (alpha, dphi, X))
        m = np.arange(len(dphi))
        coeff = np.linalg.solve(np.cos(np.outer(dphi, m)), np.moveaxis(X, 2, 0).reshape(len(dphi), -1))
        coeff = coeff.reshape((len(m),) + X.shape[:2])
        coeff[1:, 0, :] = coeff[1:, :, 0] = 0.0  # on the axis the azimuth does not matter
        series = tuple(RectBivariateSpline(alpha, alpha, c, kx=3, ky=3) for c in coeff)
        u = np.asarray(poles, dtype=float)
        reach = np.cos(min(np.pi, 2.0 * alpha[-1]))
        p, q = np.nonzero(np.triu(u @ u.T >= reach, k=1))
        return cls(u, np.asarray(polarity, dtype=float), np.asarray(coils, dtype=float), alpha, series,
                   np.stack([p, q], axis=1))

    def _terms(self, R: np.ndarray):
        """Per (orientation, coil, pair) within reach: indices, the two poles' fixed-frame directions, and the
        angles ``α_p, α_q``, ``Δφ``."""
        w = np.einsum("kab,mb->kma", R, self.poles)  # (K, M, 3)
        cos = np.clip(w @ self.coils.T, -1.0, 1.0)  # (K, M, N)
        near = cos >= np.cos(self.alpha[-1])
        P, Q = self.pairs[:, 0], self.pairs[:, 1]
        k, n, i = np.nonzero(near[:, P, :] & near[:, Q, :])  # (orientation, pair, coil)
        p, q = P[n], Q[n]
        wp, wq, v = w[k, p], w[k, q], self.coils[i]
        cp, cq = cos[k, p, i], cos[k, q, i]
        ap, aq = np.arccos(cp), np.arccos(cq)
        dphi = np.arctan2(np.einsum("ta,ta->t", v, np.cross(wp, wq)), np.einsum("ta,ta->t", wp, wq) - cp * cq)
        return k, p, q, wp, wq, v, cp, cq, ap, aq, dphi

    def _values(self, ap, aq, dphi, order: int):
        """``X`` and, for ``order = 1``, ``∂X/∂α_p, ∂X/∂α_q, ∂X/∂Δφ`` at the terms (the series' splines)."""
        a, b = np.clip(ap, 0.0, self.alpha[-1]), np.clip(aq, 0.0, self.alpha[-1])
        X = np.zeros_like(ap)
        Xp, Xq, Xphi = (np.zeros_like(ap) for _ in range(3)) if order else (None, None, None)
        for m, spline in enumerate(self.series):
            cos, c = np.cos(m * dphi), spline.ev(a, b)
            X += c * cos
            if order:
                Xp += spline.ev(a, b, dx=1) * cos
                Xq += spline.ev(a, b, dy=1) * cos
                Xphi -= m * c * np.sin(m * dphi)
        return X, Xp, Xq, Xphi

    def energy(self, R) -> np.ndarray:
        """``E_c (K,)`` (J) at rotations ``R (K, 3, 3)`` (validated by the caller)."""
        k, p, q, *_, ap, aq, dphi = self._terms(R)
        X = self._values(ap, aq, dphi, 0)[0] * self._weight(ap) * self._weight(aq)
        return np.bincount(k, weights=self.polarity[p] * self.polarity[q] * X, minlength=len(R))

    def _weight(self, a: np.ndarray, order: int = 0) -> np.ndarray:
        return taper(a, self.alpha[-1], order)

    def torque(self, R) -> np.ndarray:
        """``τ = −∂E_c/∂θ (K, 3)`` (N·m, fixed frame) at rotations ``R (K, 3, 3)`` (module docstring)."""
        k, p, q, wp, wq, v, cp, cq, ap, aq, dphi = self._terms(R)
        X, Xp, Xq, Xphi = self._values(ap, aq, dphi, 1)
        up, uq = self._weight(ap), self._weight(aq)
        Xp, Xq, Xphi = (up * Xp + self._weight(ap, 1) * X) * uq, up * (uq * Xq + self._weight(aq, 1) * X), \
            up * uq * Xphi
        sp, sq = np.sin(ap), np.sin(aq)
        gradient = np.zeros((len(k), 3))
        for X_a, w, s in ((Xp, wp, sp), (Xq, wq, sq)):
            ok = s > _TINY
            gradient[ok] -= (X_a[ok] / s[ok])[:, None] * np.cross(w[ok], v[ok])
        for sign, w, c, s in ((-1.0, wp, cp, sp), (1.0, wq, cq, sq)):
            ok = s > _TINY
            gradient[ok] += (sign * Xphi[ok] / s[ok] ** 2)[:, None] * (v[ok] - c[ok, None] * w[ok])
        weight = self.polarity[p] * self.polarity[q]
        out = np.zeros((len(R), 3))
        np.add.at(out, k, -(weight[:, None] * gradient))
        return out

    def spline_coefficients(self) -> tuple[np.ndarray, np.ndarray]:
        """``(knots, C (D, n, n))``: the cubic B-splines of the series' coefficients ``c_m(α_p, α_q)`` (the same
        knots in both angles; ``C[m]`` symmetric, as the table is)."""
        full = np.asarray(self.series[0].tck[0], dtype=float)
        n = len(full) - 4
        C = np.stack([s.get_coeffs().reshape(n, n) for s in self.series])
        return full, 0.5 * (C + np.swapaxes(C, 1, 2))

    def tables(self, detent, linear) -> CoupledTables:
        """The coupled model's tables (module docstring) with the pair maps ``detent`` and ``linear``
        (:class:`~spherestep.magnetics.TorqueMap`), built once per content (a few seconds) and cached."""
        last = self.__dict__.get("_last")
        if last is not None and last[0] is detent and last[1] is linear:
            return last[2]
        key = _digest(self.poles, self.polarity, self.alpha, *(s.get_coeffs() for s in self.series))
        full = (key, _digest(detent.poles, detent.nodes, detent.tau, linear.polarity, linear.nodes, linear.tau))
        out = _TABLES.get(full)
        if out is None:
            coarse = _TABLES.get(key)
            if coarse is None:
                coarse = _TABLES[key] = self._coupling_table()
            out = _TABLES[full] = CoupledTables.build(detent, linear, coarse)
        object.__setattr__(self, "_last", (detent, linear, out))
        return out

    def _coupling_table(self) -> np.ndarray:
        """``G`` as cubed-sphere coefficients on :data:`COUPLING_FACE` (:mod:`spherestep._fast.spheretable`)."""
        from .._fast.coupling import coupling_energies, in_threads
        from .._fast.spheretable import face_coefficients, face_nodes

        nodes = face_nodes(COUPLING_FACE)
        knots, C = self.spline_coefficients()
        values = np.empty(nodes.shape[:-1]).reshape(-1)
        in_threads(coupling_energies, np.ascontiguousarray(nodes.reshape(-1, 3)), np.ascontiguousarray(self.poles.T),
                   np.ascontiguousarray(self.polarity), float(self.alpha[-1]), math.radians(TAPER_DEG),
                   np.ascontiguousarray(knots), np.ascontiguousarray(C), out=values)
        return face_coefficients(values.reshape(nodes.shape[:-1]))

    def fast_evaluate(self, detent, linear, R, c, order: int) -> tuple[np.ndarray, ...]:
        """``(E,)``, ``(E, τ)`` or ``(E, τ, H)`` of the coupled model (pairs + coupling) from the tables at
        validated ``R (K, 3, 3)`` and currents ``c (K, N)`` (failed coils at 0)."""
        t = self.tables(detent, linear)
        if len(R) == 1:  # one orientation: the single compiled calls
            R, c = R[0], c[0]
        a = fast_evaluate(t.bias, 1.0, self.coils, R, self._ones, order, 0.0)
        if not np.any(c):
            return tuple(x[None] for x in a) if R.ndim == 2 else a
        b = fast_evaluate(t.linear, 1.0, self.coils, R, c, order, 0.0)
        return tuple((x + y)[None] if R.ndim == 2 else x + y for x, y in zip(a, b))

    @property
    def _ones(self) -> np.ndarray:
        ones = self.__dict__.get("_ones_")
        if ones is None:
            ones = np.ones(len(self.coils))
            object.__setattr__(self, "_ones_", ones)
        return ones

    def fast_torque_matrix(self, detent, linear, R, failed) -> np.ndarray:
        """``K(R) (K, 3, N)`` of the coupled model (the coupling does not depend on the currents: ``F_1``'s)."""
        return fast_torque_matrix(self.tables(detent, linear).linear, 1.0, self.coils, failed, R)

    def zonal_terms(self, detent, linear, c) -> list:
        """The coupled model's energy as two terms for :func:`spherestep.rotor_field.pack_terms`: ``F_d + G`` at
        current 1 in every coil, ``F_1`` at ``c (..., N)``."""
        t = self.tables(detent, linear)
        return [(t.bias, 1.0, self.coils, np.ones(len(self.coils))), (t.linear, 1.0, self.coils, c)]


def _digest(*arrays) -> str:
    """A content key of ``arrays`` (their bytes and shapes)."""
    import hashlib

    h = hashlib.sha1()
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return h.hexdigest()


_TABLES: dict = {}  # content key -> G's coarse coefficients, or (key, pairs' key) -> CoupledTables


@dataclass(frozen=True, eq=False)
class CoupledTables:
    """The coupled iron model as two rotor functions on cubed-sphere tables (module docstring): ``bias`` holds
    ``F_d + G`` (every coil, current 1), ``linear`` ``F_1`` (coil ``k`` at ``c_k``); both
    :class:`~spherestep.rotor_field.RotorField` objects with compiled ``"sphere_table"`` kernels on the same
    poles."""

    bias: RotorField
    linear: RotorField

    @classmethod
    def build(cls, detent, linear, coupling_coefficients: np.ndarray, n: int = TABLE_FACE) -> CoupledTables:
        """From the pair maps ``detent``, ``linear`` (:class:`~spherestep.magnetics.TorqueMap`, sharing their
        nodes and poles) and ``G``'s coefficients on :data:`COUPLING_FACE`."""
        from .._fast.coupling import in_threads, zonal_energies
        from .._fast.spheretable import HALO, face_coefficients, face_nodes, sphere_values

        nodes = face_nodes(n)
        x = np.ascontiguousarray(nodes.reshape(-1, 3))
        poles = np.ascontiguousarray(detent.poles.T)
        breaks = np.ascontiguousarray(detent._e.x)
        energy = np.ascontiguousarray(np.stack([np.asarray(detent._e.c).T, np.asarray(linear._e.c).T]))
        if not np.array_equal(linear._e.x, breaks):
            raise bad_value("linear", "a pair table on the detent table's nodes", f"{len(linear._e.x) - 1} intervals")
        P = np.ascontiguousarray(np.stack([detent.polarity, linear.polarity]))
        values = np.empty((2, len(x)))
        in_threads(zonal_energies, x, poles, P, breaks, energy, out=values)
        G = np.empty(len(x))
        coarse = np.ascontiguousarray(coupling_coefficients.reshape(-1))
        sphere_values(coarse, coupling_coefficients.shape[1], 2.0 * COUPLING_FACE / math.pi, HALO, x, 0, G,
                      np.empty((0, 3)), np.empty((0, 3, 3)))
        shape = nodes.shape[:-1]
        fields = []
        for v, polarity in ((values[0] + G, detent.polarity), (values[1], linear.polarity)):
            coef = face_coefficients(v.reshape(shape))
            fields.append(RotorField(detent.poles, polarity, None, compiled=("sphere_table", (coef, n, HALO))))
        return cls(*fields)
