"""``ZonalKernel``: a Legendre series ``G(t) = Σ_l g_l P_l(t)`` with fast tabulated ``G, G', G''``.

The overlap of two zonal profiles centred on ``w`` and ``v`` depends only on ``t = w · v`` (Funk–Hecke):

    G(t) = ∫_{S²} f1(u · w) f2(u · v) du = Σ_l λ_l(f1) λ_l(f2) (2l+1)/(4π) P_l(t),

which is :meth:`ZonalKernel.overlap`. The pairwise form of the energy calls ``G`` and its derivatives for every
(pole, coil) pair and every orientation, so the series (cost ``O(L)`` per point by Clenshaw's recurrence,
:meth:`ZonalKernel.series`) is tabulated once as a piecewise quintic Hermite interpolant on ``[−1, 1]``: ``n``
equal intervals, on each the quintic matching ``G, G', G''`` at both ends (so the interpolant is ``C²``).
Evaluation costs one table look-up and a Horner step, ``O(1)`` per point. The table is refined (``n`` doubled
from 256) until, measured against the series at four interior points of every interval, the interpolant is
within ``rtol`` (default ``1e-12``) of ``max|G|`` on ``[−1, 1]`` and its derivative within ``10 rtol`` of
``max|G'|`` (or until rounding stops the derivative's error from falling; the value must still meet ``rtol``).
The measured relative errors of ``G, G', G''`` are kept in :attr:`ZonalKernel.table_error`; for the prototype's
default profiles they are about ``6e-14, 5e-12, 1e-9`` with 2048 intervals. The second derivative (used by
Hessians) is the interpolant's, accurate to about ``1e-9`` of ``max|G''|``.
"""

from __future__ import annotations

import numpy as np
from numpy.polynomial import legendre as npleg

from .. import checks
from ..errors import ComputationError, bad_value
from .profiles import ZonalProfile

_MAX_INTERVALS = 1 << 20
# monomial coefficients (rows c0..c5) of the quintic on [0, 1] from (y0, d0, s0, y1, d1, s1) = values, first
# and second derivatives (in the unit variable) at both ends
_QUINTIC = np.array([
    [1.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
    [-10.0, -6.0, -1.5, 10.0, -4.0, 0.5],
    [15.0, 8.0, 1.5, -15.0, 7.0, -1.0],
    [-6.0, -3.0, -0.5, 6.0, -3.0, 0.5],
])


class ZonalKernel:
    """``G(t) = Σ_{l=0}^{L} g_l P_l(t)`` on ``t ∈ [−1, 1]`` with a quintic Hermite table for fast evaluation.

    ``coefficients``: the ``g_l``, shape ``(L+1,)``. ``rtol``: accuracy of the tabulated ``G`` relative to
    ``max|G|`` (``G'`` to ``10 rtol`` of ``max|G'|``, see the module docstring). Arguments outside ``[−1, 1]``
    (rounding of dot products of unit vectors) are clipped. Attributes: ``intervals`` (table size),
    ``table_error`` (measured relative errors of ``G, G', G''``) and ``maxima`` (``max|G|, max|G'|, max|G''|``
    over ``[−1, 1]``).

    >>> k = ZonalKernel([0.0, 1.0])  # G(t) = P_1(t) = t
    >>> float(k.value(0.25)), float(k.derivative(0.25))
    (0.25, 1.0)
    """

    def __init__(self, coefficients, rtol: float = 1e-12):
        g = checks.real_array(coefficients, "coefficients")
        if g.ndim != 1 or len(g) == 0:
            raise bad_value("coefficients", "a non-empty 1-D array of Legendre coefficients", f"shape {g.shape}")
        self.coefficients = g.copy()
        self.coefficients.flags.writeable = False
        self.rtol = checks.fraction(rtol, "rtol")
        self._d1 = npleg.legder(g, 1) if len(g) > 1 else np.zeros(1)
        self._d2 = npleg.legder(g, 2) if len(g) > 2 else np.zeros(1)
        self._build()

    @classmethod
    def overlap(cls, first: ZonalProfile, second: ZonalProfile, lmax: int, rtol: float = 1e-12) -> ZonalKernel:
        """``G(t) = ∫ f1(u·w) f2(u·v) du`` truncated at degree ``lmax``: ``g_l = λ_l(f1) λ_l(f2) (2l+1)/(4π)``."""
        for label, profile in (("first", first), ("second", second)):
            if not isinstance(profile, ZonalProfile):
                raise bad_value(label, "a ZonalProfile", profile)
        lmax = checks.count(lmax, "lmax", minimum=0)
        degrees = np.arange(lmax + 1)
        g = first.legendre_coefficients(lmax) * second.legendre_coefficients(lmax) * (2 * degrees + 1) / (4 * np.pi)
        return cls(g, rtol)

    @property
    def lmax(self) -> int:
        """Degree ``L`` of the series."""
        return len(self.coefficients) - 1

    # --- exact series --------------------------------------------------------------------------------
    def series(self, t, order: int = 0) -> np.ndarray:
        """``G^(order)(t)`` (order 0, 1 or 2) from the Legendre series by Clenshaw's recurrence (``O(L)`` per point)."""
        coefficients = (self.coefficients, self._d1, self._d2)[_order(order)]
        return npleg.legval(np.clip(np.asarray(t, dtype=float), -1.0, 1.0), coefficients)

    # --- tabulated -----------------------------------------------------------------------------------
    @property
    def table(self) -> tuple[np.ndarray, float]:
        """``(coefficients (n, 6), n/2)``: interval ``k`` holds ``G`` as ``Σ_i c_i s^i`` in ``s = (t + 1) n/2 − k``."""
        return self._table, self._inv_h

    def value(self, t) -> np.ndarray:
        """``G(t)`` from the table."""
        x, piece = self._locate(t)
        c = self._table[piece]
        return c[..., 0] + x * (c[..., 1] + x * (c[..., 2] + x * (c[..., 3] + x * (c[..., 4] + x * c[..., 5]))))

    def derivative(self, t) -> np.ndarray:
        """``G'(t)`` from the table (the exact derivative of :meth:`value`)."""
        x, piece = self._locate(t)
        c = self._table[piece]
        return (c[..., 1] + x * (2 * c[..., 2] + x * (3 * c[..., 3] + x * (4 * c[..., 4] + x * 5 * c[..., 5])))) \
            * self._inv_h

    def evaluate(self, t, order: int = 1) -> tuple[np.ndarray, ...]:
        """``(G, G')`` for ``order = 1`` or ``(G, G', G'')`` for ``order = 2``, sharing one table look-up."""
        order = _order(order)
        x, piece = self._locate(t)
        c = self._table[piece]
        c0, c1, c2, c3, c4, c5 = (c[..., i] for i in range(6))
        value = c0 + x * (c1 + x * (c2 + x * (c3 + x * (c4 + x * c5))))
        first = (c1 + x * (2 * c2 + x * (3 * c3 + x * (4 * c4 + x * 5 * c5)))) * self._inv_h
        if order < 2:
            return value, first
        second = (2 * c2 + x * (6 * c3 + x * (12 * c4 + x * 20 * c5))) * self._inv_h**2
        return value, first, second

    def _locate(self, t) -> tuple[np.ndarray, np.ndarray]:
        s = (np.clip(np.asarray(t, dtype=float), -1.0, 1.0) + 1.0) * self._inv_h
        piece = np.minimum(s.astype(np.intp), self._n - 1)
        return s - piece, piece

    def _build(self) -> None:
        scales = [max(np.max(np.abs(self.series(np.cos(np.linspace(0, np.pi, 4097)), k))), np.finfo(float).tiny)
                  for k in range(3)]
        best = None
        n = 256
        while True:
            table, errors = self._tabulate(n, scales)
            if errors[0] <= self.rtol and errors[1] <= 10 * self.rtol:
                best = (n, table, errors)
                break
            if best is not None and errors[1] > 0.5 * best[2][1]:  # rounding floor: halving h no longer helps
                break
            best = (n, table, errors)
            if n >= _MAX_INTERVALS:
                break
            n *= 2
        n, table, errors = best
        if errors[0] > self.rtol:
            raise ComputationError(f"the table of G did not reach rtol = {self.rtol:g} (errors of G, G', G'': "
                                   f"{errors[0]:.2g}, {errors[1]:.2g}, {errors[2]:.2g} with {n} intervals)")
        self._table, self._n, self._inv_h = table, n, 0.5 * n
        self.table_error = tuple(float(e) for e in errors)
        self.intervals = n
        self.maxima = tuple(float(x) for x in scales)

    def _tabulate(self, n: int, scales) -> tuple[np.ndarray, tuple[float, float, float]]:
        """Quintic Hermite coefficients on ``n`` intervals and their errors relative to ``scales``."""
        knots = np.linspace(-1.0, 1.0, n + 1)
        h = 2.0 / n
        y, d, s = (self.series(knots, k) for k in range(3))
        ends = np.stack([y[:-1], h * d[:-1], h * h * s[:-1], y[1:], h * d[1:], h * h * s[1:]], axis=-1)
        self._table, self._n, self._inv_h = np.ascontiguousarray(ends @ _QUINTIC.T), n, 1.0 / h
        probe = (knots[:-1, None] + h * np.array([0.125, 0.375, 0.625, 0.875])).ravel()
        got = self.evaluate(probe, 2)
        errors = tuple(float(np.max(np.abs(got[k] - self.series(probe, k)))) / scales[k] for k in range(3))
        return self._table, errors


def _order(order) -> int:
    if isinstance(order, bool) or order not in (0, 1, 2):
        raise bad_value("order", "0, 1 or 2", order)
    return int(order)
