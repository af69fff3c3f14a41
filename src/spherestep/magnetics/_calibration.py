"""Calibrate the potential model of Sec. III-B from the simulated Fig. 6 curve, and test it against magpylib.

Calibration follows the paper: the lateral force of :func:`~._curve.force_curve` for ``x ≥ 0`` up to the
first zero crossing past its peak (where the coil stops pulling the magnet back; beyond it the force is a
weak push), the fourth-order polynomial fit (:func:`spherestep.potential.fit_force_curve`), its integral,
and the coil's profile fitted to that potential (:func:`spherestep.potential.fit_profile`) with the rotor's
profile held at the von Mises–Fisher bump whose half maximum is the magnet face's rim, and displacements
turned into angles by ``ψ = x / R_s`` (the magnet's face moves on the sphere of radius ``R_s``).

The comparison (:func:`compare_models`) draws random orientations (Haar) and random drives (2–4 coils with
random signs, the stepper's regime), and evaluates the torque three ways: ``getFT`` directly at a coarse
mesh (8 cells per magnet, 4 % of the peak pair torque; this is what makes 1000 orientations take tens of
seconds instead of over an hour), the torque map, and the calibrated potential model. It reports the
Pearson correlation of all torque components and the relative error ``‖T_pot − T_mag‖ / ‖T_mag‖`` (over the
whole sample, and the median per orientation). For stepper states, both models start from the geometric
states with the states' coils energised and settle to their own equilibria (:func:`~._statics.equilibrium`
and :func:`spherestep.statics.equilibrium`); the Park distance between the two is the state offset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..potential import MotorPotential, ProfileFit, VonMisesFisher, coil_currents, fit_profile
from ..statics import equilibrium as potential_equilibrium
from ._curve import ForceCurve, force_curve
from ._direct import torque as direct_torque
from ._statics import equilibrium
from ._table import TorqueMap

CURVE_DISPLACEMENTS = np.linspace(0.0, 0.060, 121)  # m: 0–60 mm in 0.5 mm steps, past the force's zero
COMPARE_MESHING = 8  # cells per magnet for the 1000-orientation direct comparison (coarse, see above)


def fit_limit(curve: ForceCurve) -> int:
    """Index of the last sample of the fit range: the first ``x ≥ 0`` past the attraction's peak where the
    lateral force is no longer restoring (``F ≥ 0``), or the last sample."""
    x, F = curve.displacement, curve.lateral
    order = np.argsort(x)
    pos = order[x[order] >= 0]
    if len(pos) < 5:
        raise bad_value("curve", "at least 5 displacements x >= 0 for a fourth-order fit", f"{len(pos)}")
    peak = int(np.argmin(F[pos]))
    after = np.nonzero(F[pos][peak:] >= 0)[0]
    return int(pos[peak + after[0]]) if len(after) else int(pos[-1])


@dataclass(frozen=True)
class Calibration:
    """The curve, the fit range's end ``limit`` (m), the :class:`~spherestep.potential.ProfileFit` and the
    calibrated :class:`~spherestep.potential.MotorPotential` (joules and N·m)."""

    curve: ForceCurve
    limit: float
    fit: ProfileFit
    model: MotorPotential


def calibrate(design, curve: ForceCurve | None = None) -> Calibration:
    """Fit the potential model to the Fig. 6 curve (default: :func:`force_curve` at ``CURVE_DISPLACEMENTS``)."""
    curve = force_curve(design, CURVE_DISPLACEMENTS) if curve is None else curve
    end = fit_limit(curve)
    x, F = curve.displacement, curve.lateral
    keep = (x >= 0) & (x <= x[end])
    rotor = VonMisesFisher.from_half_width(design.magnet_angle)
    fit = fit_profile(x[keep], F[keep], design.radius, rotor)
    return Calibration(curve, float(x[end]), fit, MotorPotential(design, rotor_profile=fit.rotor,
                                                                  stator_profile=fit.stator))


def random_drives(n_coils: int, samples: int, rng: np.random.Generator, failed=()) -> np.ndarray:
    """``(samples, n_coils)`` currents: 2–4 distinct working coils per row at ±1, the rest 0."""
    working = np.setdiff1d(np.arange(n_coils), np.asarray(failed, dtype=int))
    if len(working) < 2:
        raise bad_value("design", "at least two working coils", len(working))
    c = np.zeros((samples, n_coils))
    for row in c:
        n = int(rng.integers(2, min(4, len(working)) + 1))
        row[rng.choice(working, n, replace=False)] = rng.choice([-1.0, 1.0], n)
    return c


def _agreement(A: np.ndarray, B: np.ndarray) -> dict:
    """Correlation of all components, and ``‖A − B‖/‖B‖`` over the sample and median per row."""
    per_row = np.linalg.norm(A - B, axis=1) / np.maximum(np.linalg.norm(B, axis=1), 1e-300)
    return {"correlation": float(np.corrcoef(A.ravel(), B.ravel())[0, 1]),
            "relative_error": float(np.linalg.norm(A - B) / np.linalg.norm(B)),
            "median_relative_error": float(np.median(per_row))}


@dataclass(frozen=True)
class Comparison:
    """Torques at ``rotations``/``currents`` by ``direct`` getFT (``meshing`` cells), the ``map`` and the
    ``potential`` model (``(K, 3)``, N·m); ``offsets`` (rad) between the two models' equilibria from the
    geometric ``states`` (indices), and each model's distance from the geometric state."""

    rotations: np.ndarray
    currents: np.ndarray
    direct: np.ndarray
    map: np.ndarray
    potential: np.ndarray
    meshing: int
    states: np.ndarray
    offsets: np.ndarray
    map_shift: np.ndarray
    potential_shift: np.ndarray
    minima: tuple[float, float]

    def summary(self) -> dict:
        """JSON-ready numbers (degrees for the state offsets)."""
        deg = np.degrees
        return {
            "orientations": len(self.rotations), "direct_meshing": self.meshing,
            "potential_vs_direct": _agreement(self.potential, self.direct),
            "potential_vs_map": _agreement(self.potential, self.map),
            "map_vs_direct": _agreement(self.map, self.direct),
            "states": len(self.states),
            "state_offset_deg": {"median": float(np.median(deg(self.offsets))),
                                 "p95": float(np.percentile(deg(self.offsets), 95)),
                                 "max": float(deg(self.offsets).max()),
                                 "within_1deg": float(np.mean(self.offsets <= math.radians(1.0)))},
            "map_equilibrium_from_geometric_deg": {"median": float(np.median(deg(self.map_shift))),
                                                   "max": float(deg(self.map_shift).max())},
            "potential_equilibrium_from_geometric_deg": {"median": float(np.median(deg(self.potential_shift))),
                                                         "max": float(deg(self.potential_shift).max())},
            "minima_fraction": {"map": self.minima[0], "potential": self.minima[1]},
        }


def compare_models(design, calibration: Calibration, tmap: TorqueMap, *, samples: int = 1000, states: int = 300,
                   meshing: int = COMPARE_MESHING, seed: int = 0) -> Comparison:
    """Torque and stepper-state agreement of the calibrated potential model with magpylib (see the module)."""
    samples, states = checks.count(samples, "samples"), checks.count(states, "states")
    rng = np.random.default_rng(seed)
    R = so3.random(samples, rng)
    c = random_drives(len(design.stator), samples, rng, design.failed_coils)
    direct = direct_torque(design, R, c, meshing=meshing)
    fast = tmap.torque(R, c)
    model = calibration.model
    pot = model.torque(R, c)
    st = design.states()
    idx = np.sort(rng.choice(len(st), min(states, len(st)), replace=False))
    R0 = st.rotations[idx]
    cs = np.array([coil_currents(design, st.coils(int(i))) for i in idx])
    eq_map = equilibrium(tmap, R0, cs)
    eq_pot = potential_equilibrium(model, R0, cs)
    return Comparison(R, c, direct, fast, pot, meshing, idx, so3.distance(eq_map.rotation, eq_pot.rotation),
                      so3.distance(eq_map.rotation, R0), so3.distance(eq_pot.rotation, R0),
                      (float(np.mean(eq_map.is_minimum)), float(np.mean(eq_pot.is_minimum))))
