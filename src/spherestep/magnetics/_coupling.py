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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import RectBivariateSpline

COUPLING_ALPHA_DEG = np.arange(0.0, 61.0, 2.0)  # table angles from a core's axis
COUPLING_DPHI_DEG = np.arange(0.0, 181.0, 15.0)  # table azimuths between the two poles
_TINY = 1e-9  # sin α below which a pole counts as on the axis (its azimuth undefined, its φ-terms zero)


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
        X = self._values(ap, aq, dphi, 0)[0]
        return np.bincount(k, weights=self.polarity[p] * self.polarity[q] * X, minlength=len(R))

    def torque(self, R) -> np.ndarray:
        """``τ = −∂E_c/∂θ (K, 3)`` (N·m, fixed frame) at rotations ``R (K, 3, 3)`` (module docstring)."""
        k, p, q, wp, wq, v, cp, cq, ap, aq, dphi = self._terms(R)
        _, Xp, Xq, Xphi = self._values(ap, aq, dphi, 1)
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
