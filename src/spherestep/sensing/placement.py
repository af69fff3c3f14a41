"""Where to put the magnetometers: greedy E-optimal design over SO(3), and accuracy against sensor count.

The Fisher information of sensor ``s`` about a small turn ``θ`` at ``R`` is ``F_s(R) = J_s(R)ᵀ J_s(R) / σ²``
(``J_s = ∂B_s/∂θ``, :meth:`FieldTable.field_and_jacobian`; isotropic noise, so the sensor's axes do not
matter). An array's information is the sum over its sensors; its worst case is
``λ_w = min_R λ_min(Σ_s F_s(R))`` over a near-uniform sample of SO(3) (super-Fibonacci), and ``1/√λ_w`` is the
Cramér–Rao bound on the error about the worst axis at the worst orientation. :func:`greedy_placement` adds,
one at a time, the collision-free candidate that raises ``λ_w`` most (ties broken by the mean ``λ_min``); the
order is nested, so the first ``k`` sensors are the ``k``-sensor design.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from .._fast.threads import single_blas_thread
from ..errors import bad_value
from .array import SensorArray, candidate_positions
from .estimate import super_fibonacci
from .field import FieldTable
from .model import field_model
from .parts import TMAG5273A2
from .readings import actual_currents, sense, true_field

DEFAULT_COUNT = 24
PLACEMENT_ROTATIONS = 240  # SO(3) sample for the worst case


def smallest_eigenvalue(F) -> np.ndarray:
    """Smallest eigenvalue of symmetric 3×3 matrices ``F (..., 3, 3)`` in closed form (the trigonometric
    solution of the characteristic cubic: ``λ = q + 2p cos(φ + 2π/3)``, ``q = tr F/3``,
    ``p = √(tr (F − qI)²/6)``, ``cos 3φ = det((F − qI)/p)/2``)."""
    F = np.asarray(F, dtype=float)
    q = np.trace(F, axis1=-2, axis2=-1) / 3.0
    Bm = F - q[..., None, None] * np.eye(3)
    p = np.sqrt(np.sum(Bm * Bm, axis=(-2, -1)) / 6.0)
    safe = np.where(p > 0, p, 1.0)
    b = Bm / safe[..., None, None]
    det = (b[..., 0, 0] * (b[..., 1, 1] * b[..., 2, 2] - b[..., 1, 2] * b[..., 2, 1])
           - b[..., 0, 1] * (b[..., 1, 0] * b[..., 2, 2] - b[..., 1, 2] * b[..., 2, 0])
           + b[..., 0, 2] * (b[..., 1, 0] * b[..., 2, 1] - b[..., 1, 1] * b[..., 2, 0]))
    r = np.clip(det / 2.0, -1.0, 1.0)
    phi = np.arccos(r) / 3.0
    return np.where(p > 0, q + 2.0 * p * np.cos(phi + 2.0 * np.pi / 3.0), q)


def information_per_sensor(design, positions, rotations, noise_T: float) -> np.ndarray:
    """``F (K, S, 3, 3)``: each sensor's Fisher information (rad⁻²) at each of ``rotations (K, 3, 3)``."""
    table = FieldTable.build(design, positions)
    F = np.empty((len(rotations), len(table.positions), 3, 3))
    for k, R in enumerate(rotations):
        _, J = table.field_and_jacobian(R)
        F[k] = np.swapaxes(J, 1, 2) @ J
    return F / noise_T ** 2


@dataclass(frozen=True)
class Placement:
    """Greedy order ``order (count,)`` into ``candidates (C, 3)``, and after each addition the worst-case
    smallest eigenvalue ``worst_information (count,)`` (rad⁻²) over the SO(3) sample."""

    candidates: np.ndarray
    order: np.ndarray
    worst_information: np.ndarray

    def array(self, count: int | None = None, part=TMAG5273A2) -> SensorArray:
        """The first ``count`` sensors (all by default) as a :class:`SensorArray` with radial frames."""
        k = len(self.order) if count is None else int(count)
        if not 1 <= k <= len(self.order):
            raise bad_value("count", f"a sensor count in [1, {len(self.order)}]", count)
        return SensorArray.at(self.candidates[self.order[:k]], part)

    def bound_deg(self) -> np.ndarray:
        """Worst-case Cramér–Rao standard deviation (degrees) about the worst axis after each addition."""
        with np.errstate(divide="ignore"):
            return np.degrees(1.0 / np.sqrt(np.maximum(self.worst_information, 0.0)))


@single_blas_thread
def greedy_placement(design, count: int = DEFAULT_COUNT, candidates=None, rotations: int = PLACEMENT_ROTATIONS,
                     part=TMAG5273A2) -> Placement:
    """Greedy E-optimal placement of ``count`` sensors (module doc); ``candidates`` default
    :func:`~spherestep.sensing.array.candidate_positions`."""
    cand = candidate_positions(design) if candidates is None else np.asarray(candidates, dtype=float)
    count = checks.count(count, "count", 1, len(cand), f"a sensor count in [1, {len(cand)}]")
    F = information_per_sensor(design, cand, super_fibonacci(int(rotations)), part.effective_noise_T)
    total = np.zeros((F.shape[0], 3, 3))
    chosen, worst = [], []
    free = np.ones(len(cand), bool)
    for _ in range(count):
        lam = smallest_eigenvalue(total[:, None] + F)  # (K, C)
        score = lam.min(axis=0) + 1e-6 * lam.mean(axis=0)
        score[~free] = -np.inf
        best = int(np.argmax(score))
        chosen.append(best)
        free[best] = False
        total += F[:, best]
        worst.append(float(lam[:, best].min()))
    return Placement(cand, np.array(chosen), np.array(worst))


_PLACEMENTS: dict[str, Placement] = {}


def _design_key(design) -> str:
    """A fingerprint of what the placement depends on: the poles, their polarity, the coils and the sizes."""
    h = hashlib.sha256()
    for arr in (design.rotor.centers, np.asarray(design.polarity, dtype=float), design.stator.centers,
                design.stator_axis, [design.cap_half_angle, design.radius, design.air_gap, design.magnet_diameter,
                                     design.magnet_length, design.coil_diameter, design.coil_length,
                                     design.remanence]):
        h.update(np.ascontiguousarray(np.asarray(arr, dtype=float)).tobytes())
    return h.hexdigest()


def default_array(design, count: int = DEFAULT_COUNT) -> SensorArray:
    """The first ``count`` sensors of the greedy placement for ``design`` (computed once per distinct design
    in a process: a few seconds)."""
    key = _design_key(design)
    if key not in _PLACEMENTS:
        if len(_PLACEMENTS) >= 8:
            _PLACEMENTS.pop(next(iter(_PLACEMENTS)))
        _PLACEMENTS[key] = greedy_placement(design, DEFAULT_COUNT)
    return _PLACEMENTS[key].array(count)


@dataclass(frozen=True)
class Accuracy:
    """Orientation error over ``samples`` Haar-random orientations for an array of ``sensors``: ``rms`` and
    ``worst`` (rad), ``predicted_rms`` the Cramér–Rao RMS from the Fisher information (rad), ``coil_residual_T``
    the RMS coil-field residual at the sensors (tesla), ``seconds_per_estimate`` the median time per estimate
    (s) and ``field_model`` the estimator's (:attr:`~spherestep.sensing.FieldModel.name`: ``"rotor + cores"`` or
    ``"rotor only"``)."""

    sensors: int
    samples: int
    rms: float
    worst: float
    predicted_rms: float
    coil_residual_T: float
    seconds_per_estimate: float
    field_model: str

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready: the angles in degrees (``*_deg``) or, with ``degrees=False``, radians (``*_rad``)."""
        unit, f = ("deg", math.degrees) if degrees else ("rad", float)
        return {"sensors": self.sensors, "samples": self.samples, f"rms_{unit}": f(self.rms),
                f"worst_{unit}": f(self.worst), f"predicted_rms_{unit}": f(self.predicted_rms),
                "coil_residual_T": self.coil_residual_T, "seconds_per_estimate": self.seconds_per_estimate,
                "field_model": self.field_model}


@single_blas_thread
def accuracy(design, array: SensorArray, samples: int = 200, coils_on: int = 4, current_error: float = 0.01,
             start_error: float = math.radians(1.0), seed=0, cores: bool | None = None) -> Accuracy:
    """Monte Carlo accuracy of ``array``: Haar-random orientations, readings of the rotor by magpylib plus, on an
    iron design, the cores it magnetises (:func:`~spherestep.sensing.field_model`'s table), with ``coils_on``
    random coils at random ±1 (true currents off by ``current_error`` RMS; on iron each winding with its core),
    the part's noise, saturation and LSB; the estimator subtracts the coils at the commanded currents and runs
    Levenberg–Marquardt from a start ``start_error`` rad off (a tracking loop's prior). ``cores``: what the
    estimator models (default: the cores on an iron design; ``False``: the air-core model of the motor, rotor and
    bare windings, against the same readings — the cost of ignoring the iron)."""
    rng = np.random.default_rng(seed)
    R = so3.random(samples, rng)
    N = len(design.stator)
    c = np.zeros((samples, N))
    for k in range(samples):
        on = rng.choice(N, size=min(coils_on, N), replace=False)
        c[k, on] = rng.choice([-1.0, 1.0], size=len(on))
    motor = field_model(design, array.positions)  # what the sensors see: the rotor, the cores on iron, the coils
    model = field_model(design, array.positions, cores, rotor=motor.rotor)  # what the estimator fits
    coils = motor.coils
    c_true = actual_currents(c, current_error, rng)
    B = true_field(design, array, R, c_true, coils)
    if motor.cores is not None:
        B = B + motor.cores.field(R)
    m = sense(array, B, rng)
    est = model.estimator(array)
    err = np.empty(samples)
    pred = np.empty(samples)
    times = np.empty(samples)
    for k in range(samples):
        axis = rng.normal(size=3)
        R0 = so3.exp(start_error * axis / np.linalg.norm(axis)) @ R[k]
        t0 = time.perf_counter()
        e = est.solve(m[k], R0, c[k])
        times[k] = time.perf_counter() - t0
        err[k] = so3.distance(e.R, R[k])
        pred[k] = np.trace(e.covariance)
    residual = coils.field(c_true) - coils.field(c)
    return Accuracy(len(array), samples, float(np.sqrt(np.mean(err ** 2))), float(err.max()),
                    float(np.sqrt(np.mean(pred))),
                    float(np.sqrt(np.mean(residual ** 2))), float(np.median(times)), model.name)
