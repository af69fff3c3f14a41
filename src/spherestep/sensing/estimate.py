"""Orientation from magnetometer readings: Gauss–Newton / Levenberg–Marquardt on SO(3), and a global start.

Measurement model (sensor frame, tesla): ``m_s = A_sᵀ (B_s(R) + K_s(c)) + n_s`` with ``B_s(R)`` the rotor's field
(:class:`~spherestep.sensing.field.FieldTable`), ``K_s(c)`` the known fields (coils at the given currents) and
``n_s`` white noise of RMS ``σ`` per axis. Channels at the part's range are saturated and left out.

Update. With ``r = m − h(R)`` and ``J = ∂h/∂θ`` for ``R → exp(θ̂) R`` (fixed-frame small turn), the step is

    δ = (JᵀJ + λ diag(JᵀJ))⁻¹ Jᵀ r ,   R ← exp(δ̂) R

with ``λ = 0`` (Gauss–Newton) while the cost ``|r|²`` falls, raised tenfold (Levenberg–Marquardt) when a step
would raise it. The estimate's covariance is ``σ² (JᵀJ)⁻¹`` (rad², fixed frame), the inverse Fisher information.
In a loop, :meth:`Estimator.track` takes ``iterations`` steps from the previous estimate (one step suffices at
1 kHz: the start is within a few mrad, and Gauss–Newton converges quadratically from there).

Global start (no prior). :meth:`Estimator.initialise` scores a super-Fibonacci grid of rotations (Alexa 2022,
"Super-Fibonacci spirals", a near-uniform SO(3) grid) by the table, then refines the ``candidates`` best by
Levenberg–Marquardt and keeps the lowest cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.spatial.transform import Rotation

from .. import checks, so3
from ..errors import bad_value
from .field import FieldTable

PSI = 1.533751168755204288118041  # the super-Fibonacci constant (Alexa 2022), with √2
GRID = 2000  # rotations in the global start's grid (success rate measured in docs/sensing.md)
CHUNK = 250  # grid rotations per vectorised block


@lru_cache(maxsize=8)
def super_fibonacci(n: int) -> np.ndarray:
    """``n`` rotations spread nearly uniformly over SO(3) (Alexa 2022), ``(n, 3, 3)``."""
    n = checks.count(n, "n", 1, expected="a positive integer")
    s = np.arange(n) + 0.5
    r, R = np.sqrt(s / n), np.sqrt(1.0 - s / n)
    a, b = 2.0 * math.pi * s / math.sqrt(2.0), 2.0 * math.pi * s / PSI
    q = np.stack([r * np.sin(a), r * np.cos(a), R * np.sin(b), R * np.cos(b)], axis=1)
    grid = Rotation.from_quat(q).as_matrix()
    grid.flags.writeable = False  # cached: shared by every caller
    return grid


@dataclass(frozen=True)
class Estimate:
    """An orientation estimate: ``R``, the Fisher information ``information (3, 3)`` (rad⁻², fixed frame; its
    inverse :attr:`covariance` is the Cramér–Rao covariance), the RMS residual per channel ``residual_T``,
    the steps taken and whether the last step was below tolerance."""

    R: np.ndarray
    information: np.ndarray
    residual_T: float
    iterations: int
    converged: bool

    @property
    def covariance(self) -> np.ndarray:
        """``σ² (JᵀJ)⁻¹`` (rad², fixed frame)."""
        return np.linalg.inv(self.information)

    def to_dict(self, degrees: bool = True) -> dict:
        sd = np.sqrt(np.maximum(np.linalg.eigvalsh(self.covariance), 0.0))
        return {"R": self.R.tolist(), "std_axes_deg" if degrees else "std_axes_rad":
                (np.degrees(sd) if degrees else sd).tolist(), "residual_T": self.residual_T,
                "iterations": self.iterations, "converged": self.converged}


class Estimator:
    """Orientation from readings ``(S, 3)`` (sensor frame, tesla) of a sensor array (module doc).

    ``table``: the rotor's :class:`FieldTable` at the array's positions; ``axes (S, 3, 3)``: the sensors' axes;
    ``part``: the magnetometer (range, noise); ``known``: known-field objects (``field(currents) -> (S, 3)``)
    subtracted when currents are given."""

    def __init__(self, table: FieldTable, axes, part, known=()):
        self.table = table
        self.axes = np.ascontiguousarray(np.asarray(axes, dtype=float))
        self.axes_T = np.ascontiguousarray(np.swapaxes(self.axes, 1, 2))  # A_sᵀ
        self.part = part
        self.noise_T = part.effective_noise_T
        self.known = tuple(known)

    def known_field(self, currents) -> np.ndarray:
        """Sum of the known fields ``(S, 3)`` (fixed frame, tesla) at ``currents`` (zero for None)."""
        total = np.zeros(self.table.positions.shape)
        if currents is not None:
            for source in self.known:
                total = total + source.field(currents)
        return total

    def predict(self, R, currents=None) -> np.ndarray:
        """Noise-free readings ``(..., S, 3)`` (sensor frame) for rotations ``R (..., 3, 3)``."""
        B = self.table.field(R) + self.known_field(currents)
        return np.einsum("sij,...sj->...si", self.axes_T, B)

    def _prepare(self, readings, currents):
        """The rotor's measured field in the fixed frame ``(S, 3)`` and the channel weights in the sensor frame
        (``None`` when no channel is saturated: then the fixed-frame least squares is the same problem)."""
        m = np.asarray(readings, dtype=float)
        if m.shape != self.table.positions.shape or not np.all(np.isfinite(m)):
            raise bad_value("readings", f"finite sensor readings of shape {self.table.positions.shape} (tesla)",
                            f"shape {m.shape}")
        b = (self.axes @ m[:, :, None])[:, :, 0]
        if currents is not None:
            b = b - self.known_field(currents)
        saturated = np.abs(m) >= self.part.range_T * (1.0 - 1e-9)
        if not saturated.any():
            return b, None
        weight = (~saturated).astype(float)
        if weight.sum() < 3:
            raise bad_value("readings", "at least 3 unsaturated channels", int(weight.sum()))
        return b, weight

    def _normal_equations(self, R, b, weight):
        """``(H, g, cost)`` of the linearised least squares at ``R``: ``H = JᵀJ``, ``g = Jᵀ r``."""
        B, J = self.table.field_and_jacobian(R)
        r = b - B
        if weight is not None:  # sensor frame, saturated channels out
            r = (self.axes_T @ r[:, :, None])[:, :, 0] * weight
            J = (self.axes_T @ J) * weight[:, :, None]
        Jf = J.reshape(-1, 3)
        rf = r.reshape(-1)
        return Jf.T @ Jf, Jf.T @ rf, float(rf @ rf)

    def solve(self, readings, R0, currents=None, iterations: int = 30, tol: float = 1e-10) -> Estimate:
        """Levenberg–Marquardt from ``R0`` until the step is below ``tol`` rad (or ``iterations`` steps)."""
        b, weight = self._prepare(readings, currents)
        R = so3.as_rotations(R0, "R0").reshape(3, 3)
        return self._solve(b, weight, R, iterations, tol)

    def _solve(self, b, weight, R, iterations, tol):
        H, g, cost = self._normal_equations(R, b, weight)
        lam, converged, it = 0.0, False, 0
        while it < iterations:
            it += 1
            delta = np.linalg.solve(H + lam * np.diag(np.diag(H)), g)
            small = float(delta @ delta) < tol * tol
            R_new = so3.exp(delta) @ R
            H_new, g_new, cost_new = self._normal_equations(R_new, b, weight)
            if cost_new <= cost * (1.0 + 1e-9) or small:  # a rise at rounding level is convergence, not a failure
                R, H, g, cost = R_new, H_new, g_new, cost_new
                lam = 0.0 if lam < 1e-6 else lam * 0.1
                if small:
                    converged = True
                    break
            else:
                lam = max(10.0 * lam, 1e-4)
                if lam > 1e8:  # no step lowers the cost: a minimum to rounding
                    converged = True
                    break
        U, _, Vt = np.linalg.svd(R)  # re-orthonormalise against rounding drift
        return self._estimate(U @ Vt, H, cost, weight, it, converged)

    def track(self, readings, R_prev, currents=None, iterations: int = 1) -> Estimate:
        """``iterations`` Gauss–Newton steps from ``R_prev`` (the loop's update; no line search)."""
        b, weight = self._prepare(readings, currents)
        R = so3.as_rotations(R_prev, "R_prev").reshape(3, 3)
        for _ in range(iterations):
            H, g, cost = self._normal_equations(R, b, weight)
            delta = np.linalg.solve(H, g)
            R = so3.exp(delta) @ R
        return self._estimate(R, H, cost, weight, iterations, float(delta @ delta) < 1e-12)

    def track_until(self, readings, R_prev, currents=None, iterations: int = 1, max_iterations: int | None = None,
                    residual_limit: float = math.inf) -> Estimate:
        """:meth:`track` in rounds of ``iterations`` steps from ``R_prev`` while the RMS residual is over
        ``residual_limit`` (T), at most ``max_iterations`` steps in all (default one round): the one tracking
        update of :class:`~spherestep.sensing.HallSensor` (simulation) and the hardware's ``FieldTracker``."""
        limit = iterations if max_iterations is None else max(iterations, max_iterations)
        done, R = 0, R_prev
        while True:
            est = self.track(readings, R, currents, iterations)
            R, done = est.R, done + iterations
            if est.residual_T <= residual_limit or done >= limit:
                return est

    def _estimate(self, R, H, cost, weight, iterations, converged) -> Estimate:
        channels = self.table.positions.size if weight is None else weight.sum()
        return Estimate(R, H / self.noise_T ** 2, math.sqrt(cost / max(channels, 1.0)), iterations, converged)

    def initialise(self, readings, currents=None, grid: int = GRID, candidates: int = 6,
                   near_symmetry=None) -> Estimate:
        """Global estimate from no prior (module doc): grid scores, then LM from the best ``candidates``.
        ``near_symmetry (G, 3, 3)``: body-frame rotations under which the rotor is almost the same (a marked
        rotor's unmarked pattern, :func:`~spherestep.sensing.symmetry.symmetry_group` with
        ``polarity=False``); the best estimate ``R`` is then compared with every ``R g`` and the cheapest is
        refined, since the grid's best basins are often the wrong copies."""
        b, weight = self._prepare(readings, currents)
        G = super_fibonacci(int(grid))
        cost = np.empty(len(G))
        w = 1.0 if weight is None else weight
        bs = (self.axes_T @ b[:, :, None])[:, :, 0]
        for s in range(0, len(G), CHUNK):
            pred = np.einsum("sij,ksj->ksi", self.axes_T, self.table.field(G[s:s + CHUNK]))
            cost[s:s + CHUNK] = np.sum(((bs - pred) * w) ** 2, axis=(1, 2))
        best = None
        for k in np.argsort(cost)[:candidates]:
            est = self._solve(b, weight, G[k], 30, 1e-10)
            if best is None or est.residual_T < best.residual_T:
                best = est
        if near_symmetry is not None:
            copies = best.R @ np.asarray(near_symmetry, dtype=float)
            pred = np.einsum("sij,ksj->ksi", self.axes_T, self.table.field(copies))
            k = int(np.argmin(np.sum(((bs - pred) * w) ** 2, axis=(1, 2))))
            best = self._solve(b, weight, copies[k], 30, 1e-10)
        return best
