"""The rotor's field at the sensors, fast: one 1-D table per sensor radius, and the coils' known fields.

Why one angle suffices. Every rotor magnet is the same cylinder, axisymmetric about its radial axis
``w_j = R u_j`` with its centre on that axis. A sensor at ``x_s`` (radius ``r = |x_s|``, direction
``x̂_s``) sees magnet ``j`` from a point fixed, in the magnet's own frame, by ``c_sj = x̂_s · w_j`` alone, and
the field lies in the plane of ``w_j`` and ``x̂_s``:

    b_j(x_s) = p_j [ a_r(c_sj) w_j + β_r(c_sj) x̂_s ] ,     B_s(R) = Σ_j b_j(x_s)

with ``a_r``, ``β_r`` the field of one ``+1`` magnet on the ``z`` axis seen at ``r (sin α, 0, cos α)``, ``c = cos α``:
``β = B_x / sin α``, ``a = B_z − β c`` (both smooth in ``c``: ``B_ρ/ρ`` and ``B_z`` are even in ``ρ``). The table
holds ``a`` and ``β`` from magpylib at ``TABLE_NODES`` values of ``c`` evenly spaced in ``[−1, 1]``, interpolated
by a not-a-knot cubic spline; at ``c = ±1`` (``sin α = 0``) the ratio is taken at ``α = 1e-4`` rad (error
O(α²) ≈ 1e-8 relative).

Jacobian for a small turn ``R → exp(θ̂) R`` (``w_j → w_j + θ × w_j``, ``dc_sj = θ · (w_j × x̂_s)``):

    ∂B_s/∂θ = Σ_j p_j [ a'(c) w_j (w_j × x̂_s)ᵀ + β'(c) x̂_s (w_j × x̂_s)ᵀ ] − [ Σ_j p_j a(c) w_j ]×

A spherical-harmonic expansion outside the rotor would converge like ``(R_s/r)^l``: at 10 mm standoff
``R_s/r = 0.94`` needs degree ~200 for 1e-6, i.e. 4·10⁴ coefficients per sensor; this table costs a gather
and a cubic per magnet–sensor pair (92 × S).

Coils (and any other source whose field does not depend on ``R``) are *known fields*: objects with
``field(currents) -> (S, 3)`` tesla at the array's sensors. :class:`CoilField` is the air-core stator's
(linear in the currents, one magpylib call per coil at unit current); an iron-core model adds its own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import magpylib as magpy
import numpy as np
from scipy.interpolate import CubicSpline

from .. import checks, so3
from ..errors import bad_value
from ..magnetics import model_summary, rotor_collection, stator_coils

TABLE_NODES = 16385  # values of c in [−1, 1]; interpolation error measured in docs/sensing.md
POLE_ALPHA = 1e-4  # rad, where β = B_x / sin α is taken at c = ±1
C_MAX = 1.0 - 1e-12  # c is clipped here so that c = 1 falls in the last piece
GENERATORS = so3.skew(np.eye(3)).reshape(3, 9)  # [a]× = (a @ GENERATORS).reshape(3, 3)


def axial_field_table(design, radius: float, nodes: int = TABLE_NODES) -> tuple[np.ndarray, np.ndarray]:
    """``(c, ab)``: nodes ``c (n,)`` and ``ab (n, 2)`` = ``(a, β)`` in tesla for one ``+1`` rotor magnet seen
    from distance ``radius`` (m) from the sphere's centre (module doc), by magpylib."""
    c = np.linspace(-1.0, 1.0, nodes)
    alpha = np.arccos(c)
    alpha[0], alpha[-1] = np.pi - POLE_ALPHA, POLE_ALPHA
    magnet = magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                   polarization=(0.0, 0.0, design.remanence),
                                   position=(0.0, 0.0, model_summary(design)["magnet_centre_m"]))
    pts = radius * np.stack([np.sin(alpha), np.zeros_like(alpha), np.cos(alpha)], axis=1)
    B = magnet.getB(pts)
    beta = B[:, 0] / np.sin(alpha)
    a = B[:, 2] - beta * np.cos(alpha)
    return c, np.stack([a, beta], axis=1)


@dataclass(frozen=True, eq=False)
class FieldTable:
    """The rotor's field at fixed sensor positions for any orientation (module doc): ``field(R)`` and
    ``field_and_jacobian(R)``; ``poles (M, 3)`` body frame, ``polarity (M,)``, ``positions (S, 3)``."""

    poles: np.ndarray
    polarity: np.ndarray
    positions: np.ndarray
    directions: np.ndarray
    coefficients: np.ndarray  # (4, n_radii·(n−1)) complex a + iβ per power of t/h, highest first
    offsets: np.ndarray | None  # (S, 1): first piece of each sensor's radius (None: one radius)
    step: float  # h, node spacing in c
    skew_directions: np.ndarray  # (S, 3, 3): [x̂_s]×

    @classmethod
    def build(cls, design, positions, nodes: int = TABLE_NODES) -> FieldTable:
        """Tables for every distinct sensor radius of ``positions (S, 3)`` (radii equal to 1e-9 m share one)."""
        p = np.asarray(positions, dtype=float).reshape(-1, 3)
        r = np.linalg.norm(p, axis=1)
        if np.any(r <= design.radius):
            raise bad_value("positions", f"outside the rotor (radius > {design.radius:.4g} m)", float(r.min()))
        nodes = checks.count(nodes, "nodes", 5, expected="an integer ≥ 5 (table nodes in c = cos α)")
        radii, index = np.unique(np.round(r, 9), return_inverse=True)
        h = 2.0 / (nodes - 1)
        scale = np.array([h ** 3, h ** 2, h, 1.0])[:, None, None]  # powers of t = h·u
        coefs = []
        for radius in radii:
            c, ab = axial_field_table(design, float(radius), nodes)
            q = CubicSpline(c, ab, axis=0).c * scale  # (4, n−1, 2), polynomial in u ∈ [0, 1)
            coefs.append(q[..., 0] + 1j * q[..., 1])
        offsets = None if len(radii) == 1 else (index * (nodes - 1))[:, None].astype(np.intp)
        return cls(design.rotor.centers.copy(), design.polarity.astype(float), p, p / r[:, None],
                   np.ascontiguousarray(np.concatenate(coefs, axis=1)), offsets, h, so3.skew(p / r[:, None]))

    def _pieces(self, C: np.ndarray, derivative: bool = True):
        """``a + iβ`` (T) and its derivative in ``c`` (T) at ``C (..., S, M)`` (complex arrays, same shape)."""
        u = (C + 1.0) * (1.0 / self.step)
        k = u.astype(np.intp)
        t = u - k
        if self.offsets is not None:
            k += self.offsets
        q0, q1, q2, q3 = (row.take(k) for row in self.coefficients)
        val = ((q0 * t + q1) * t + q2) * t + q3
        if not derivative:
            return val, None
        return val, ((3.0 * q0 * t + 2.0 * q1) * t + q2) * (1.0 / self.step)

    def field(self, R) -> np.ndarray:
        """Rotor field ``(..., S, 3)`` tesla at the sensors, fixed frame, for rotations ``R (..., 3, 3)``."""
        W = np.asarray(R, dtype=float) @ self.poles.T  # (..., 3, M): columns w_j
        val, _ = self._pieces(np.minimum(self.directions @ W, C_MAX), derivative=False)  # c: (..., S, M)
        return (val.real * self.polarity) @ np.swapaxes(W, -1, -2) + (val.imag @ self.polarity)[..., None] * self.directions

    def field_and_jacobian(self, R):
        """``(B (S, 3), J (S, 3, 3))`` for one rotation: ``J = ∂B_s/∂θ`` for ``R → exp(θ̂) R``, evaluated as
        ``J_s = M_s [x̂_s]× + x̂_s (D_s × x̂_s)ᵀ − [A_s]×`` with ``M_s = Σ_j p_j a'_sj w_j w_jᵀ``,
        ``D_s = Σ_j p_j β'_sj w_j``, ``A_s = Σ_j p_j a_sj w_j`` (the module doc's sum, regrouped)."""
        W = np.asarray(R, dtype=float) @ self.poles.T  # (3, M)
        x = self.directions
        val, der = self._pieces(np.minimum(x @ W, C_MAX))
        Wp = W * self.polarity
        A = val.real @ Wp.T  # (S, 3)
        B = A + (val.imag @ self.polarity)[:, None] * x
        M = (der.real @ (W[:, None, :] * Wp[None, :, :]).reshape(9, -1).T).reshape(-1, 3, 3)
        D = der.imag @ Wp.T  # (S, 3)
        J = M @ self.skew_directions - x[:, :, None] * (self.skew_directions @ D[:, :, None]).reshape(-1, 1, 3)
        J -= (A @ GENERATORS).reshape(-1, 3, 3)  # − [A]×
        return B, J


def rotor_field(design, positions, R) -> np.ndarray:
    """Reference rotor field ``(K, S, 3)`` (tesla, fixed frame) by magpylib for rotations ``R (K, 3, 3)``."""
    R = so3.as_rotations(R, "R").reshape(-1, 3, 3)
    B = rotor_collection(design, R).getB(np.asarray(positions, dtype=float).reshape(-1, 3))
    return np.asarray(B).reshape(len(R), -1, 3)


@runtime_checkable
class KnownField(Protocol):
    """A field the estimator knows and subtracts: ``field(currents (N,) or (K, N)) -> (..., S, 3)`` tesla at
    the array's sensors (coils, iron, a calibration offset)."""

    def field(self, currents) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class CoilField:
    """The air-core coils' field at the sensors, linear in the currents: ``B = Σ_k c_k G_k`` with ``G (N, S, 3)``
    the field of coil ``k`` at unit current (magpylib, :func:`spherestep.magnetics.stator_coils`)."""

    per_coil: np.ndarray

    @classmethod
    def build(cls, design, positions) -> CoilField:
        p = np.asarray(positions, dtype=float).reshape(-1, 3)
        G = magpy.getB(stator_coils(design), p, sumup=False)
        return cls(np.asarray(G).reshape(len(design.stator), len(p), 3))

    def field(self, currents) -> np.ndarray:
        c = np.asarray(currents, dtype=float)
        if c.shape[-1:] != (self.per_coil.shape[0],):
            raise bad_value("currents", f"one current per coil ({self.per_coil.shape[0]})", f"shape {c.shape}")
        return np.einsum("...k,ksi->...si", c, self.per_coil)
