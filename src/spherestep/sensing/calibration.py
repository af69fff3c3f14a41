"""Self-calibration of the array from readings at unknown orientations: sensor positions, gains, offsets.

Model of sensor ``s`` at pose ``k``: ``m_sk = g_s ⊙ A_sᵀ B(x_s; R_k) + o_s`` (per-axis gains ``g_s`` and offsets
``o_s`` in the sensor frame, position ``x_s``). Starting from the nominal array, alternate

1. the poses: ``R_k`` by the estimator on the corrected readings ``(m − o)/g`` (LM from the previous ``R_k``);
2. each sensor: one linearised least-squares step in ``(δx_s, δg_s, o_s)`` (9 unknowns, ``3K`` equations),
   ``m ≈ g ⊙ Aᵀ(B + G δx) + δg ⊙ AᵀB + o`` with ``G = ∂B/∂x`` the field's spatial gradient.

The gradient comes from the table without another model: the field outside the magnets is curl- and
divergence-free, so ``G`` is symmetric and traceless, and a turn of the rotor is a turn of the sensor the other
way, ``G [x]× = [B]× + J`` (``J = ∂B/∂θ``). That fixes ``G`` on the tangent plane; symmetry gives the mixed
radial terms and ``tr G = 0`` the radial one.

On an iron design the model's field is the rotor's plus the cores' it magnetises (:func:`.model.field_model`,
by default): the cores' term is the stored table's at the nominal positions, its own gradient left out of ``G``
(the rotation identity above holds for the rotor's field, which turns with the rotor, not for the cores', which
do not; the position step sees the rotor's gradient alone). That is exact only if the cores' field does not move
with the sensors; it does (1.7 mT/mm RMS per gradient entry: 0.2 mm position errors leave 0.4 mT of residual and
0.04° of orientation scatter, docs/sensing.md).

What is left undetermined: a common turn of every sensor and every pose about the centre changes nothing the
readings can see except through the sensors' axes (held at their nominal values), so the calibrated array's
frame is known only to about the turn of the true array against the nominal one (0.015° for 0.2 mm errors,
docs/sensing.md); one reference orientation fixes it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import so3
from .._fast.threads import single_blas_thread
from ..errors import bad_value
from .array import SensorArray
from .estimate import Estimator
from .field import FieldTable
from .iron import IronFieldTable
from .model import field_model


def field_gradient(B: np.ndarray, J: np.ndarray, positions: np.ndarray) -> np.ndarray:
    """Spatial gradients ``G (S, 3, 3)`` (T/m, ``G_ij = ∂B_i/∂x_j``) from the field ``B (S, 3)``, its rotation
    Jacobian ``J (S, 3, 3)`` and the positions (module doc)."""
    x = np.asarray(positions, dtype=float)
    r = np.linalg.norm(x, axis=1)
    n = x / r[:, None]
    e = np.eye(3)[np.argmin(np.abs(n), axis=1)]
    t1 = np.cross(n, e)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(n, t1)
    M = so3.skew(B) + J  # M θ = G (x × θ); for t ⟂ x, x × θ = t at θ = (t × x)/r², so G t = M (t × x)/r²
    Gt1 = np.einsum("sij,sj->si", M, np.cross(t1, x)) / (r ** 2)[:, None]
    Gt2 = np.einsum("sij,sj->si", M, np.cross(t2, x)) / (r ** 2)[:, None]
    T = np.stack([t1, t2, n], axis=2)  # columns: local basis
    g11, g12, g22 = (np.sum(t1 * Gt1, 1), 0.5 * (np.sum(t1 * Gt2, 1) + np.sum(t2 * Gt1, 1)), np.sum(t2 * Gt2, 1))
    g13, g23 = np.sum(n * Gt1, 1), np.sum(n * Gt2, 1)
    local = np.stack([np.stack([g11, g12, g13], 1), np.stack([g12, g22, g23], 1),
                      np.stack([g13, g23, -(g11 + g22)], 1)], 1)
    return T @ local @ np.swapaxes(T, 1, 2)


@dataclass(frozen=True)
class Calibration:
    """Calibrated ``array`` (corrected positions), per-axis ``gains (S, 3)`` and ``offsets (S, 3)`` (T, sensor
    frame), the estimated ``poses (K, 3, 3)``, the RMS residual per channel after each round (T) and the
    ``field_model`` fitted (:attr:`~spherestep.sensing.FieldModel.name`: ``"rotor + cores"`` or ``"rotor only"``)."""

    array: SensorArray
    gains: np.ndarray
    offsets: np.ndarray
    poses: np.ndarray
    residual_T: tuple[float, ...]
    field_model: str

    def correct(self, readings) -> np.ndarray:
        """Readings with offsets and gains removed: ``(m − o)/g``."""
        return (np.asarray(readings, dtype=float) - self.offsets) / self.gains


@single_blas_thread
def calibrate(design, array: SensorArray, readings, poses, rounds: int = 4, cores: bool | None = None) -> Calibration:
    """Self-calibration (module doc) from ``readings (K, S, 3)`` (sensor frame, coils off) taken at ``K``
    orientations known roughly as ``poses (K, 3, 3)`` (e.g. the nominal model's estimates). ``cores``: model the
    iron cores' field (default: on an iron design; ``False``: the rotor's field alone)."""
    m = np.asarray(readings, dtype=float)
    R = so3.as_rotations(poses, "poses").reshape(-1, 3, 3).copy()
    if m.ndim != 3 or m.shape[1:] != array.positions.shape or len(m) != len(R):
        raise bad_value("readings", f"one ({len(array)}, 3) set per pose, shape ({len(R)}, {len(array)}, 3)",
                        f"shape {m.shape}")
    S, K = len(array), len(R)
    nominal = field_model(design, array.positions, cores)  # the cores' term stays at the nominal positions
    pos = array.positions.copy()
    gains, offsets = np.ones((S, 3)), np.zeros((S, 3))
    At = np.swapaxes(array.axes, 1, 2)
    history = []
    for _ in range(int(rounds)):
        cur = SensorArray(pos, array.axes, array.part)
        rotor = FieldTable.build(design, pos)
        table = rotor if nominal.cores is None else IronFieldTable(rotor, nominal.cores)
        est = Estimator(table, array.axes, array.part)
        corrected = (m - offsets) / gains
        R = np.stack([est.solve(corrected[k], R[k]).R for k in range(K)])
        rows = np.empty((K, S, 3, 9))
        pred = np.empty((K, S, 3))
        for k in range(K):
            B, J = rotor.field_and_jacobian(R[k])
            G = field_gradient(B, J, cur.positions)  # the rotor's
            if nominal.cores is not None:
                B = B + nominal.cores.field(R[k])
            AB = np.einsum("sij,sj->si", At, B)
            pred[k] = gains * AB + offsets
            rows[k, :, :, :3] = gains[:, :, None] * (At @ G)  # ∂/∂δx
            rows[k, :, :, 3:6] = AB[:, :, None] * np.eye(3)  # ∂/∂δg
            rows[k, :, :, 6:] = np.eye(3)  # ∂/∂δo
        resid = m - pred
        history.append(float(np.sqrt(np.mean(resid ** 2))))
        for s in range(S):
            A = rows[:, s].reshape(-1, 9)
            step, *_ = np.linalg.lstsq(A, resid[:, s].reshape(-1), rcond=None)
            pos[s] += step[:3]
            gains[s] += step[3:6]
            offsets[s] += step[6:]
    return Calibration(SensorArray(pos, array.axes, array.part), gains, offsets, R, tuple(history), nominal.name)
