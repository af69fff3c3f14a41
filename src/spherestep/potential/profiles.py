"""Zonal profiles: the fields of one rotor pole and one stator coil as functions of ``t = u · w`` (Sec. III-B).

A pole centred on the unit vector ``w`` contributes ``f(u · w)`` at the point ``u`` of the sphere. Such a
*zonal* function has the expansion (addition theorem and Funk–Hecke)

    f(u · w) = Σ_l λ_l (2l+1)/(4π) P_l(u · w) = Σ_l Σ_m λ_l conj(Y_l^m(w)) Y_l^m(u),
    λ_l = 2π ∫_{−1}^{1} f(t) P_l(t) dt,

so its spherical Fourier coefficients (eq. (6)) are ``f̂(l, m) = λ_l conj(Y_l^m(w))`` and
``∫ f² du = Σ_l λ_l² (2l+1)/(4π)``. The ``λ_l`` are computed by quadrature on the profile's support (Fejér's
rule in ``t = cos ψ``), doubling the number of nodes until two rules agree to rounding.

The default profile is the von Mises–Fisher bump ``A exp(κ (t − 1))`` whose half width at half maximum is the
angular radius of the magnet's or coil's face (:meth:`VonMisesFisher.from_half_width`). It is smooth (its
``λ_l`` fall like ``exp(−l(l+1)/(2κ))``, so a modest band limit captures it) and the overlap of two such bumps
has a closed form (:meth:`VonMisesFisher.overlap`), used as an independent check. :class:`RaisedCosine` is a
compactly supported alternative closer to the paper's window function; its ``λ_l`` decay only algebraically.

See also: :class:`spherestep.potential.ZonalKernel` (the overlap ``G(t)`` of two profiles).
"""

from __future__ import annotations

import functools
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from .. import checks
from ..errors import ComputationError, bad_value

MAX_BANDLIMIT = 4096
_MAX_NODES = 1 << 13


class ZonalProfile(ABC):
    """A real function ``f(t)`` of ``t = u · w ∈ [−1, 1]``; subclasses define ``__call__`` (vectorised over ``t``)
    and, for compact support, ``support_min``: ``f(t) = 0`` for ``t < support_min`` (default ``−1``). Subclasses
    must be hashable (frozen dataclasses): coefficients are cached per profile.
    """

    support_min: float = -1.0

    @abstractmethod
    def __call__(self, t) -> np.ndarray:
        """``f(t)`` elementwise."""

    def legendre_coefficients(self, lmax) -> np.ndarray:
        """``λ_l = 2π ∫ f(t) P_l(t) dt`` for ``l = 0..lmax`` (Funk–Hecke eigenvalues), shape ``(lmax+1,)``.

        Fejér's first rule (Chebyshev nodes, :func:`_nodes`) on ``[support_min, 1]`` with ``n`` nodes, ``n`` doubled
        from ``max(128, 2 lmax + 8)`` until two successive rules agree to ``1e-13 · max|λ|``, or to ``1e-10`` once
        the change no longer shrinks (the rounding floor of very sharp profiles); ComputationError if ``2^13``
        nodes do not suffice. For the von Mises–Fisher bump of the prototype's magnets
        (``κ ≈ 200``) the result matches the Bessel closed form to ``1e-14 · λ_0`` up to ``l = 150``.
        """
        lmax = checks.count(lmax, "lmax", minimum=0)
        out = _legendre_coefficients(self, lmax)
        return out.copy()

    def bandwidth(self, tail=1e-10) -> int:
        """Smallest ``L`` with ``Σ_{l>L} λ_l² (2l+1) ≤ tail · Σ_l λ_l² (2l+1)``: the degree beyond which the
        profile's squared L² norm has lost less than the fraction ``tail``."""
        tail = checks.fraction(tail, "tail")
        return _bandwidth(self, tail)


def _legendre_table(lmax: int, x: np.ndarray) -> np.ndarray:
    """``P_l(x)`` for ``l = 0..lmax`` by Bonnet's recurrence, shape ``(lmax+1, len(x))``."""
    out = np.empty((lmax + 1, len(x)))
    out[0] = 1.0
    if lmax >= 1:
        out[1] = x
    for l in range(1, lmax):
        out[l + 1] = ((2 * l + 1) * x * out[l] - l * out[l - 1]) / (l + 1)
    return out


@functools.lru_cache(maxsize=16)
def _nodes(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Fejér's first rule on ``[−1, 1]``: nodes ``x_j = cos ψ_j``, ``ψ_j = (j + ½)π/n``, and weights
    ``w_j = (2/n) [1 − 2 Σ_{k=1}^{⌊n/2⌋} cos(2kψ_j)/(4k² − 1)]``; exact for degree ``n − 1``, exponentially
    convergent for analytic integrands, and, unlike large Gauss–Legendre rules, accurate to rounding near
    ``x = ±1`` where sharp profiles live."""
    psi = (np.arange(n) + 0.5) * np.pi / n
    k = np.arange(1, n // 2 + 1)
    w = (2.0 / n) * (1.0 - 2.0 * (np.cos(2.0 * np.outer(psi, k)) @ (1.0 / (4.0 * k * k - 1.0))))
    x = np.cos(psi)
    x.flags.writeable = w.flags.writeable = False
    return x, w


def _quadrature_rule(profile: ZonalProfile, lmax: int, n: int) -> np.ndarray:
    a = float(profile.support_min)
    x, w = _nodes(n)
    t = 0.5 * (1.0 - a) * x + 0.5 * (1.0 + a)
    weights = 0.5 * (1.0 - a) * w * np.asarray(profile(t), dtype=float)
    return 2.0 * np.pi * (_legendre_table(lmax, t) @ weights)


@functools.lru_cache(maxsize=128)
def _legendre_coefficients(profile: ZonalProfile, lmax: int) -> np.ndarray:
    n = max(128, 2 * lmax + 8)
    previous = _quadrature_rule(profile, lmax, n)
    last_change = np.inf
    while True:
        n *= 2
        current = _quadrature_rule(profile, lmax, n)
        scale = max(np.max(np.abs(current)), np.finfo(float).tiny)
        change = np.max(np.abs(current - previous)) / scale
        # converged, or at the rounding floor (sharp profiles are ill-conditioned in t: relative ~κ·1e-16)
        if change <= 1e-13 or (change <= 1e-10 and change > 0.25 * last_change):
            current.flags.writeable = False
            return current
        if n >= _MAX_NODES:
            raise ComputationError(f"Legendre coefficients of {profile!r} up to degree {lmax} did not settle "
                                   f"with {n} quadrature nodes (the profile is too rough)")
        previous, last_change = current, change


@functools.lru_cache(maxsize=128)
def _bandwidth(profile: ZonalProfile, tail: float) -> int:
    lmax = 32
    while True:
        lam = _legendre_coefficients(profile, lmax)
        energy = lam**2 * (2 * np.arange(lmax + 1) + 1)
        beyond = np.cumsum(energy[::-1])[::-1]  # beyond[l] = Σ_{l' ≥ l}
        total = beyond[0]
        if total == 0:
            raise bad_value("profile", "a profile that is not identically zero", profile)
        # the last degree must itself be negligible, or the tail beyond lmax is unknown
        if beyond[-1] <= 1e-3 * tail * total:
            ok = np.nonzero(np.append(beyond[1:], 0.0) <= tail * total)[0]
            return int(ok[0])
        if lmax >= MAX_BANDLIMIT:
            raise ComputationError(f"{profile!r} needs a band limit above {MAX_BANDLIMIT} for a tail of {tail:g}; "
                                   "use a smoother profile or pass bandlimit explicitly")
        lmax *= 2


@dataclass(frozen=True)
class VonMisesFisher(ZonalProfile):
    """``f(t) = A exp(κ (t − 1))``: peak ``A`` at ``t = 1``, half maximum at ``t = 1 − ln 2 / κ``.

    ``λ_l = 4π A e^(−κ) i_l(κ) = A (2π)^(3/2) κ^(−1/2) e^(−κ) I_(l+½)(κ)`` (modified spherical Bessel), and for large
    ``κ`` about ``(2π A/κ) exp(−l(l+1)/(2κ))``: a Gaussian of angular width ``κ^(−1/2)``.

    >>> f = VonMisesFisher.from_half_width(np.radians(5.0))
    >>> round(float(f(np.cos(np.radians(5.0)))), 12)
    0.5
    """

    kappa: float
    amplitude: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "kappa", checks.positive(self.kappa, "kappa"))
        object.__setattr__(self, "amplitude", checks.positive(self.amplitude, "amplitude"))

    @classmethod
    def from_half_width(cls, angle, amplitude=1.0) -> VonMisesFisher:
        """The bump falling to half its peak at the angular radius ``angle`` (radians, in (0, π/2]):
        ``κ = ln 2 / (1 − cos angle)``."""
        angle = checks.number(angle, "angle", low=0.0, high=math.pi / 2, low_open=True,
                              expected="an angular radius in (0, π/2] radians")
        return cls(math.log(2.0) / (1.0 - math.cos(angle)), amplitude)

    @property
    def half_width(self) -> float:
        """Angle (radians) at which the profile is half its peak: ``acos(1 − ln 2 / κ)``."""
        return math.acos(max(-1.0, 1.0 - math.log(2.0) / self.kappa))

    def __call__(self, t) -> np.ndarray:
        return self.amplitude * np.exp(self.kappa * (np.asarray(t, dtype=float) - 1.0))

    def exact_coefficients(self, lmax) -> np.ndarray:
        """``λ_l`` in closed form, ``A (2π)^(3/2) κ^(−1/2) ive(l+½, κ)`` (SciPy's scaled Bessel ``I``), for checks."""
        from scipy.special import ive

        lmax = checks.count(lmax, "lmax", minimum=0)
        return self.amplitude * (2 * np.pi) ** 1.5 / np.sqrt(self.kappa) * ive(np.arange(lmax + 1) + 0.5, self.kappa)

    def overlap(self, other: VonMisesFisher, t, derivative: int = 0) -> np.ndarray:
        """``G(t) = ∫ f(u·w) g(u·v) du`` for ``t = w · v`` in closed form (independent of any expansion), or its
        derivative ``G'(t)`` for ``derivative=1``.

        ``∫ exp(u · (κ1 w + κ2 v)) du = 4π sinh ρ / ρ`` with ``ρ = |κ1 w + κ2 v| = (κ1² + κ2² + 2 κ1 κ2 t)^½``, so
        ``G = 4π A1 A2 e^(−κ1−κ2) sinh ρ / ρ`` and ``G' = 4π A1 A2 e^(−κ1−κ2) κ1 κ2 (ρ cosh ρ − sinh ρ)/ρ³``, written
        with ``e^(ρ−κ1−κ2)`` factored out to avoid overflow.
        """
        if not isinstance(other, VonMisesFisher):
            raise bad_value("other", "a VonMisesFisher profile", other)
        if derivative not in (0, 1) or isinstance(derivative, bool):
            raise bad_value("derivative", "0 or 1", derivative)
        t = np.clip(checks.real_array(t, "t"), -1.0, 1.0)
        k1, k2 = self.kappa, other.kappa
        rho = np.maximum(np.sqrt(np.maximum(k1 * k1 + k2 * k2 + 2 * k1 * k2 * t, 0.0)), 1e-300)
        decay = np.exp(-2.0 * rho)
        scale = 4 * np.pi * self.amplitude * other.amplitude * np.exp(rho - k1 - k2)
        if derivative == 0:
            small = rho < 1e-4  # sinh ρ / ρ → 1 + ρ²/6
            ratio = np.where(small, (1.0 + rho * rho / 6.0) * np.exp(-rho), -np.expm1(-2.0 * rho) / (2.0 * rho))
            return scale * ratio
        small = rho < 1e-3  # (ρ cosh ρ − sinh ρ)/ρ³ → 1/3 + ρ²/30
        bracket = np.where(small, (1.0 / 3.0 + rho * rho / 30.0) * np.exp(-rho),
                           (rho * (1.0 + decay) + np.expm1(-2.0 * rho)) / (2.0 * rho**3))
        return scale * k1 * k2 * bracket


@dataclass(frozen=True)
class RaisedCosine(ZonalProfile):
    """``f = A (1 + cos(π ψ/ρ))/2`` for the angle ``ψ = acos t < ρ``, zero beyond: a smooth window of radius ``ρ``.

    Once differentiable at the rim, so ``λ_l`` decay only algebraically: use an explicit band limit.
    """

    radius: float
    amplitude: float = 1.0

    def __post_init__(self):
        if isinstance(self.radius, bool) or not isinstance(self.radius, (int, float, np.floating)) or \
                not 0 < self.radius <= math.pi:
            raise bad_value("radius", "an angular radius in (0, π] radians", self.radius)
        object.__setattr__(self, "radius", float(self.radius))
        object.__setattr__(self, "amplitude", checks.positive(self.amplitude, "amplitude"))

    @property
    def support_min(self) -> float:  # type: ignore[override]
        return math.cos(self.radius)

    def __call__(self, t) -> np.ndarray:
        psi = np.arccos(np.clip(np.asarray(t, dtype=float), -1.0, 1.0))
        return np.where(psi < self.radius, 0.5 * self.amplitude * (1.0 + np.cos(np.pi * psi / self.radius)), 0.0)
