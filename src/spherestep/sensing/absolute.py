"""The magnetometer array calibrated against orientations known absolutely: the detent wells.

What the readings alone cannot give. Readings at unknown orientations fix each sensor's offset and gain and the
array's shape (:func:`~spherestep.sensing.calibrate`), but not a common turn ``Q`` of the array: for the rotor's
field ``Qᵀ B(Q x; R) = B(x; Qᵀ R)``, so a turned array at ``R`` reads what the nominal one reads at ``Qᵀ R`` —
the turn and the poses trade against each other exactly (on iron the cores, which do not turn, break the tie by
only their share of the field). An orientation known independently of the sensors is needed.

Which references are absolute. (1) The **detent wells**: with every coil off the iron rotor comes to rest in a
minimum of the detent energy, which the design fixes (the pole and core positions; :func:`detent_wells`, the minima
of the torque model's energy at zero current). Castor friction ``f`` stops it anywhere the detent torque is below
``f``: within ``f/k`` of the well along a direction of stiffness ``k`` (the prototype's wells: ``k`` 22–226 N·m/rad,
so 0.04 N·m leaves up to 0.1° in the softest direction of the softest well, 0.01° in the stiffest), so each well is
visited several times, released from a kick in a random direction each time (the rest points scatter over the dead
band, whose mean is the well), and the stiffest wells are chosen. They are absolute as far as the detent model is:
coils misplaced on the stator move the wells with them. (2) **Holds of commanded orientations** are known only
through the torque model (``b(R) + K(R) c = 0`` at rest says where the rotor is only if ``b`` and ``K`` are right,
friction aside), so they are not used here; a hold's orientation is what the calibrated sensors then report.

The fit. Sensor ``s`` at rest at reference ``W_k`` reads (the model of :class:`~spherestep.sensing.SensorErrors`
with the cores' field at the nominal positions, as the emulated motor has it)

    m_sk = g_s ⊙ A_sᵀ [B_rot(x_s; Qᵀ W_k) + Qᵀ B_core(x_s; W_k)] + o_s ,

linear in the offsets ``o_s`` and gains ``g_s`` and, about the current ``Q₀`` (``Q = exp([δ]×) Q₀``), in ``δ``:
``∂/∂δ = g_s ⊙ A_sᵀ Q₀ᵀ (−J_rot(Q₀ᵀ W_k) + [B_core]×)`` (``J_rot`` the table's rotation Jacobian). Gauss–Newton on
all of them at once (3 or 6 per sensor and 3 shared; ``3 K S`` equations), three rounds. The standard deviations
come from the residual's RMS and ``(XᵀX)⁻¹``, the turn's no smaller than a delete-one-well jackknife's (which sees
the rest points' scatter over the dead band, not in the readings' noise: the formal one alone was 5–8× optimistic);
the residual against the part's noise over the averaged samples says whether the model explains the readings.

Using it. :meth:`ArrayCalibration.correct` removes offsets and gains from readings; the nominal estimator on
corrected readings reports ``Qᵀ R``, so :meth:`ArrayCalibration.orientation` turns it back, ``R = Q R̂``;
:meth:`ArrayCalibration.estimator` builds the estimator that does both, with the fields that stay with the
stator (the cores', the coils') read in the turned axes (the drive room's sessions take the calibration as
``sensor_calibration=``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .array import SensorArray
from .estimate import Estimator
from .iron import IronFieldTable
from .model import field_model

ROUNDS = 3
WELL_SEPARATION = math.radians(1.0)  # two descents ending closer than this found the same well


@dataclass(frozen=True)
class Wells:
    """Minima of the detent energy: ``rotations (K, 3, 3)`` and their ``stiffness (K, 3)`` (N·m/rad, the Hessian's
    eigenvalues, ascending), stiffest first."""

    rotations: np.ndarray
    stiffness: np.ndarray

    def __len__(self) -> int:
        return len(self.rotations)

    def dead_band(self, friction: float) -> np.ndarray:
        """How far (rad) castor ``friction`` (N·m) can leave the rotor from each well: ``f / k_min``."""
        return float(friction) / self.stiffness[:, 0]


def detent_wells(model, count: int = 12, *, starts: int = 400, seed=0) -> Wells:
    """The ``count`` stiffest distinct minima (by their softest direction) of ``model``'s energy with every coil
    off, descended from ``starts`` Haar-random orientations (``seed``); a model without a detent has none."""
    from ..statics import equilibrium, is_torque_model

    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    if not model.has_bias:
        raise bad_value("model", "a model with a detent (an iron stator): an air-core rotor has no wells", "no detent")
    count = checks.count(count, "count")
    starts = checks.count(starts, "starts")
    eq = equilibrium(model, so3.random(starts, seed), np.zeros(model.coil_count))
    ok = np.flatnonzero(eq.converged & eq.is_minimum)
    order = ok[np.argsort(-eq.stiffness[ok, 0])]
    kept: list[int] = []
    for i in order:
        if all(so3.distance(eq.rotation[i], eq.rotation[j]) > WELL_SEPARATION for j in kept):
            kept.append(int(i))
        if len(kept) == count:
            break
    if len(kept) < count:
        raise bad_value("count", f"at most the {len(kept)} distinct wells found from {starts} starts (or more starts)",
                        count)
    return Wells(eq.rotation[kept].copy(), eq.stiffness[kept].copy())


def refined_wells(model, references) -> np.ndarray:
    """The wells ``references (K, 3, 3)`` (found on another model) as ``model`` has them: each descended at zero
    current from its reference (:func:`~spherestep.statics.equilibrium`), ``(K, 3, 3)``. The wells are absolute
    only as far as the detent model is: on the prototype, two coils misplaced by 1° move them by 0.05–0.19° and a
    detent 20 % stronger than its cores' coupling by 0.07°, so the array is calibrated again against the wells of
    the *calibrated* torque model (:func:`spherestep.drive.identify_motor`). InputError when a descent fails or
    ends more than 1° away (another well)."""
    from ..statics import equilibrium

    W = so3.as_rotations(references, "references").reshape(-1, 3, 3)
    eq = equilibrium(model, W, np.zeros(model.coil_count))
    far = so3.distance(eq.rotation, W) > WELL_SEPARATION
    if not np.all(eq.converged & eq.is_minimum) or np.any(far):
        raise bad_value("model", "a model whose wells lie within 1° of the references", "a descent that left its well")
    return eq.rotation.copy()


@dataclass(frozen=True)
class ArrayCalibration:
    """The array identified (module doc): ``offsets (S, 3)`` T and ``gains (S, 3)`` (sensor frame), the array's turn
    ``rotation (3, 3)`` about the centre, the standard deviations ``offsets_std (S, 3)`` T and ``rotation_std (3,)``
    rad (about the fixed axes), the RMS residual per channel ``residual_T``, the ``references`` used and whether
    ``gains`` were fitted (else 1)."""

    offsets: np.ndarray
    gains: np.ndarray
    rotation: np.ndarray
    offsets_std: np.ndarray
    rotation_std: np.ndarray
    residual_T: float
    references: int
    fitted_gains: bool

    @property
    def angle(self) -> float:
        """The array's turn found (rad)."""
        return float(so3.distance(self.rotation, np.eye(3)))

    def correct(self, readings) -> np.ndarray:
        """Readings ``(..., S, 3)`` with the offsets and gains removed, ``(m − o)/g``."""
        return (np.asarray(readings, dtype=float) - self.offsets) / self.gains

    def orientation(self, R) -> np.ndarray:
        """The true orientation ``Q R̂`` from the nominal estimator's ``R̂`` on corrected readings."""
        return self.rotation @ np.asarray(R, dtype=float)

    def estimator(self, design, array: SensorArray, cores: bool | None = None, known=()) -> CalibratedEstimator:
        """The estimator of ``array`` (nominal) reading through this calibration (:class:`CalibratedEstimator`):
        the design's field model (``cores`` as :func:`~spherestep.sensing.field_model`), with the cores' and the
        coils' fields, which do not turn with the array, read in its turned axes; ``known`` more known fields."""
        model = field_model(design, array.positions, cores)
        Q = self.rotation
        table = model.rotor if model.cores is None else IronFieldTable(model.rotor, _Turned(model.cores, Q))
        inner = Estimator(table, array.axes, array.part, (_TurnedKnown(model.coils, Q),
                                                           *(_TurnedKnown(k, Q) for k in known)))
        return CalibratedEstimator(inner, self)

    def to_dict(self, degrees: bool = True) -> dict:
        """The calibration as plain numbers (angles in degrees, ``degrees=False`` radians); :meth:`from_dict` reads
        it back."""
        k = 180.0 / math.pi if degrees else 1.0
        unit = "deg" if degrees else "rad"
        return {"references": self.references, "fitted_gains": self.fitted_gains,
                f"rotation_angle_{unit}": self.angle * k, f"rotation_vector_{unit}": (so3.log_single(self.rotation) * k).tolist(),
                f"rotation_std_{unit}": (self.rotation_std * k).tolist(), "offsets_T": self.offsets.tolist(),
                "offsets_std_T": self.offsets_std.tolist(), "gains": self.gains.tolist(), "residual_T": self.residual_T}

    @classmethod
    def from_dict(cls, data: dict) -> ArrayCalibration:
        """The calibration from :meth:`to_dict`'s dict (either unit); InputError naming a missing or bad key."""
        unit = "deg" if "rotation_vector_deg" in data else "rad"
        k = math.pi / 180.0 if unit == "deg" else 1.0
        try:
            offsets = np.asarray(data["offsets_T"], dtype=float)
            out = cls(offsets, np.asarray(data["gains"], dtype=float),
                      so3.exp(np.asarray(data[f"rotation_vector_{unit}"], dtype=float) * k),
                      np.asarray(data["offsets_std_T"], dtype=float),
                      np.asarray(data[f"rotation_std_{unit}"], dtype=float) * k, float(data["residual_T"]),
                      int(data["references"]), bool(data["fitted_gains"]))
        except KeyError as exc:
            raise bad_value(str(exc.args[0]), "a key of ArrayCalibration.to_dict()", "missing") from None
        except (TypeError, ValueError):
            raise bad_value("sensor calibration", "the numbers of ArrayCalibration.to_dict()", "malformed values") from None
        if offsets.ndim != 2 or offsets.shape[1] != 3 or out.gains.shape != offsets.shape:
            raise bad_value("offsets_T", "per-sensor offsets and gains of shape (S, 3)", f"shape {offsets.shape}")
        return out


@dataclass(frozen=True, eq=False)
class _Turned:
    """A field that stays with the stator (the cores') as seen from the turned array in the nominal estimator's
    frame: ``R' = Qᵀ R`` gives ``Qᵀ B(Q R')``, its Jacobian ``Qᵀ J(Q R') Q``."""

    inner: object
    Q: np.ndarray

    def field(self, R) -> np.ndarray:
        return self.inner.field(self.Q @ np.asarray(R, dtype=float)) @ self.Q

    def field_and_jacobian(self, R):
        B, J = self.inner.field_and_jacobian(self.Q @ np.asarray(R, dtype=float))
        return B @ self.Q, self.Q.T @ J @ self.Q


@dataclass(frozen=True, eq=False)
class _TurnedKnown:
    """A known field (the coils') read in the turned array's axes: ``Qᵀ B(c)``."""

    inner: object
    Q: np.ndarray

    def field(self, currents) -> np.ndarray:
        return self.inner.field(currents) @ self.Q


class CalibratedEstimator:
    """An :class:`~spherestep.sensing.Estimator` (``inner``, in the frame ``R' = Qᵀ R`` of the nominal array) reading
    through an :class:`ArrayCalibration`: readings corrected, the prior turned into that frame, the estimate turned
    back — what the hardware room's :class:`~spherestep.hardware.FieldTracker` calls (``track_until``, ``solve``,
    ``table``, ``noise_T``)."""

    def __init__(self, inner: Estimator, calibration: ArrayCalibration):
        self.inner, self.calibration = inner, calibration
        self.table, self.noise_T = inner.table, inner.noise_T

    def _back(self, est):
        return replace(est, R=self.calibration.orientation(est.R))

    def track_until(self, readings, R_prev, currents=None, *args):
        Q = self.calibration.rotation
        return self._back(self.inner.track_until(self.calibration.correct(readings), Q.T @ R_prev, currents, *args))

    def solve(self, readings, R0, currents=None, **options):
        Q = self.calibration.rotation
        return self._back(self.inner.solve(self.calibration.correct(readings), Q.T @ R0, currents, **options))


def calibrate_array_absolute(design, array: SensorArray, readings, references, *, gains: bool = False,
                             cores: bool | None = None, rounds: int = ROUNDS) -> ArrayCalibration:
    """Offsets (and per-axis ``gains``) of each sensor and the array's turn (module doc) from ``readings (K, S, 3)``
    T (sensor frame, coils off, each the mean of several samples) taken with the rotor at rest at the known
    ``references (K, 3, 3)`` (detent wells, :func:`detent_wells`; repeat a well once per visit). ``cores``: model
    the iron cores' field (default on an iron design)."""
    m = np.asarray(readings, dtype=float)
    W = so3.as_rotations(references, "references").reshape(-1, 3, 3)
    S = len(array)
    if m.ndim != 3 or m.shape[1:] != (S, 3) or len(m) != len(W) or not np.all(np.isfinite(m)):
        raise bad_value("readings", f"finite readings (K, {S}, 3), one set per reference ({len(W)})", f"shape {m.shape}")
    per = 6 if gains else 3
    if 3 * len(W) * S < per * S + 3 + 3 or len(W) < 3:
        raise bad_value("references", f"at least 3 references ({per * S + 3} unknowns)", len(W))
    rounds = checks.count(rounds, "rounds")
    model = field_model(design, array.positions, cores)
    At = np.swapaxes(array.axes, 1, 2)
    o, g, Q, A, resid = _fit(model, At, m, W, gains, rounds)
    dof = max(resid.size - A.shape[1], 1)
    sigma2 = float(np.sum(resid ** 2)) / dof
    std = np.sqrt(np.maximum(np.diag(sigma2 * np.linalg.pinv(A.T @ A)), 0.0))
    rotation_std = std[-3:]
    _, well = np.unique(W.reshape(len(W), -1).round(9), axis=0, return_inverse=True)
    n = int(well.max()) + 1
    if n >= 4:  # delete-one-well jackknife: the rest points' scatter over each well's dead band included
        turns = np.array([so3.log_single(_fit(model, At, m[well != i], W[well != i], gains, rounds)[2] @ Q.T)
                          for i in range(n)])
        jack = np.sqrt((n - 1) / n * np.sum((turns - turns.mean(0)) ** 2, axis=0))
        rotation_std = np.maximum(rotation_std, jack)
    return ArrayCalibration(o, g, Q, std[:-3].reshape(len(array), -1)[:, :3], rotation_std,
                            float(np.sqrt(np.mean(resid ** 2))), len(W), bool(gains))


def _fit(model, At: np.ndarray, m: np.ndarray, W: np.ndarray, gains: bool, rounds: int):
    """Gauss–Newton (module doc): ``(offsets, gains, Q, the last design matrix, the residual (K, S, 3))``."""
    S, K, per = len(At), len(W), 6 if gains else 3
    Q, o, g = np.eye(3), np.zeros((S, 3)), np.ones((S, 3))
    for _ in range(rounds):
        BJ = [model.rotor.field_and_jacobian(R) for R in Q.T @ W]
        B, J = np.stack([b for b, _ in BJ]), np.stack([j for _, j in BJ])  # (K, S, 3), (K, S, 3, 3)
        Bc = model.cores.field(W) if model.cores is not None else np.zeros_like(B)
        local = np.einsum("sij,ksj->ksi", At, B + np.einsum("ji,ksj->ksi", Q, Bc))  # Aᵀ[B_rot + Qᵀ B_core]
        dQ = np.einsum("sij,ksjl->ksil", At, np.einsum("ji,ksjl->ksil", Q, so3.skew(Bc)) - J @ Q.T)
        X = np.zeros((K, S, 3, S * per + 3))
        for s in range(S):
            X[:, s, :, per * s:per * s + 3] = np.eye(3)  # ∂/∂o
            if gains:
                X[:, s, :, per * s + 3:per * s + 6] = local[:, s, :, None] * np.eye(3)  # ∂/∂g
        X[..., -3:] = g[None, :, :, None] * dQ
        A = X.reshape(-1, S * per + 3)
        step, *_ = np.linalg.lstsq(A, (m - (g * local + o)).reshape(-1), rcond=None)
        steps = step[:-3].reshape(S, per)
        o = o + steps[:, :3]
        if gains:
            g = g + steps[:, 3:]
        Q = so3.exp(step[-3:]) @ Q
    B = model.rotor.field(Q.T @ W)
    Bc = model.cores.field(W) if model.cores is not None else np.zeros_like(B)
    return o, g, Q, A, m - (g * np.einsum("sij,ksj->ksi", At, B + np.einsum("ji,ksj->ksi", Q, Bc)) + o)
