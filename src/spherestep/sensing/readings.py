"""What the magnetometers read: the rotor's and the coils' fields by magpylib, noise, saturation, quantisation.

``m_s = Q( clip( A_sᵀ (B_rotor(x_s; R) + B_coils(x_s; c_true) + B_extra(x_s)) + n_s , ±range ) )`` with
``n_s ~ N(0, σ² I)``, ``Q`` rounding to the part's LSB, and ``c_true = c (1 + ε_g) + ε_o`` the currents that
actually flow when ``c`` is commanded: ``ε_g, ε_o ~ N(0, current_error²)`` per coil and reading (a current
sense error; the estimator subtracts the coils' field at the commanded ``c``, so this is its residual).
"""

from __future__ import annotations

import magpylib as magpy
import numpy as np

from .. import checks, so3
from .field import CoilField, rotor_field


def true_field(design, array, R, currents=None, coil_field: CoilField | None = None, extra=()) -> np.ndarray:
    """Noise-free field ``(K, S, 3)`` (fixed frame, tesla): rotor by magpylib at ``R (K, 3, 3)``, coils at
    ``currents`` (``(N,)`` or ``(K, N)``) by magpylib (linear, so ``coil_field``'s unit-current fields are
    exact), and ``extra`` magpylib sources fixed in the stator."""
    R = so3.as_rotations(R, "R").reshape(-1, 3, 3)
    B = rotor_field(design, array.positions, R)
    if currents is not None:
        coils = coil_field or CoilField.build(design, array.positions)
        B = B + np.broadcast_to(coils.field(currents), B.shape)
    for source in extra:
        B = B + np.asarray(magpy.getB(source, array.positions)).reshape(1, -1, 3)
    return B


def sense(array, B, rng=None, noise: bool = True) -> np.ndarray:
    """Readings ``(..., S, 3)`` (sensor frame, tesla) of fixed-frame fields ``B (..., S, 3)``: rotate into each
    sensor's axes, add the part's noise (if ``noise``), clip at its range and round to its LSB."""
    part = array.part
    m = np.einsum("sji,...sj->...si", array.axes, np.asarray(B, dtype=float))
    if noise:
        m = m + np.random.default_rng(rng).normal(0.0, part.noise_T, m.shape)
    m = np.clip(m, -part.range_T, part.range_T)
    return np.round(m / part.lsb_T) * part.lsb_T


def actual_currents(currents, current_error: float, rng) -> np.ndarray:
    """Currents that flow when ``currents`` are commanded, with relative gain and offset errors of RMS
    ``current_error`` (per unit of nominal) per coil."""
    current_error = checks.non_negative(current_error, "current_error",
                                        "a non-negative RMS fraction of the nominal current")
    c = np.asarray(currents, dtype=float)
    if current_error == 0:
        return c
    rng = np.random.default_rng(rng)
    return c * (1.0 + rng.normal(0.0, current_error, c.shape)) + rng.normal(0.0, current_error, c.shape)
