"""An IMU in the rotor, and a multiplicative extended Kalman filter (MEKF) on SO(3) that fuses it with the
magnetometer array.

IMU model (body frame, at the rotor's centre, so no centripetal acceleration), one sample per ``dt``:

    gyro  = ω + b_g + n_g,          n_g ~ N(0, ν_g² / dt)          (ν_g noise density, rad/s/√Hz)
    accel = Rᵀ (0, 0, g) + b_a + n_a, n_a ~ N(0, ν_a² / dt)
    mag   = Rᵀ (B_earth + B_coils(c)) + b_m + n_m

with biases drawn once per IMU (1σ from the part). The rotor's own field at the centre is constant in the body
frame (a hard-iron offset, calibrated out; ``b_m`` is the residual).

MEKF. State: ``R̂`` and gyro bias ``b̂``; error ``R = R̂ exp(δθ̂)`` (body frame), covariance ``P (6, 6)`` of
``(δθ, δb)``. Predict: ``R̂ ← R̂ exp((gyro − b̂) dt)``, ``Φ = [[exp(−ω̂ dt), −I dt], [0, I]]``,
``Q = diag(ν_g² dt I, ν_b² dt I)``. A vector measurement ``y = Rᵀ v + n`` has ``ŷ = R̂ᵀ v`` and
``H = [[ŷ]×, 0]``; an orientation measurement (the magnetometer array's estimate, fixed-frame covariance
``Σ``) has innovation ``log(R̂ᵀ R_meas)``, ``H = [I, 0]``, noise ``R̂ᵀ Σ R̂``. After each update
``R̂ ← R̂ exp(δθ̂)``, ``b̂ ← b̂ + δb``.
"""

from __future__ import annotations

import math

import numpy as np

from .. import checks, so3
from .field import CoilField
from .parts import BMI270_BMM150, ImuPart
from .sensor import SampledSensor

GRAVITY = 9.80665  # m/s²
EARTH_FIELD_T = np.array([20e-6, 0.0, -45e-6])  # a mid-latitude field (north, 0, down-ish), fixed frame
BIAS_WALK = 1e-5  # rad/s/√s, gyro bias random walk assumed by the filter


class Imu:
    """Samples of ``part`` at ``dt`` seconds for orientation ``R`` and body rate ``omega`` (rad/s), with the
    coils' field at the centre from ``coil_field`` (a :class:`CoilField` at the origin) when currents are given."""

    def __init__(self, part: ImuPart = BMI270_BMM150, dt: float = 1e-3, coil_field: CoilField | None = None,
                 rng=None):
        self.part, self.dt, self.coil_field = part, checks.positive(dt, "dt", "a positive time step in seconds"), \
            coil_field
        self.rng = np.random.default_rng(rng)
        self.gyro_bias = self.rng.normal(0.0, part.gyro_bias, 3)
        self.accel_bias = self.rng.normal(0.0, part.accel_bias, 3)
        self.mag_bias = self.rng.normal(0.0, part.mag_bias_T, 3)

    def reference_field(self, currents=None) -> np.ndarray:
        """Field at the IMU in the fixed frame: Earth's plus the coils' at ``currents``."""
        B = EARTH_FIELD_T.copy()
        if currents is not None and self.coil_field is not None:
            B = B + self.coil_field.field(currents)[0]
        return B

    def sample(self, R, omega, currents=None):
        """``(gyro (3,), accel (3,), mag (3,))`` in the body frame."""
        p, n = self.part, self.rng.normal
        R = so3.as_rotations(R, "R")
        gyro = np.asarray(omega, dtype=float) + self.gyro_bias + n(0.0, p.gyro_noise_density / math.sqrt(self.dt), 3)
        accel = R.T @ np.array([0.0, 0.0, GRAVITY]) + self.accel_bias + n(0.0, p.accel_noise_density / math.sqrt(self.dt), 3)
        mag = R.T @ self.reference_field(currents) + self.mag_bias + n(0.0, p.mag_noise_T, 3)
        return gyro, accel, mag


class Mekf:
    """The multiplicative EKF of the module doc. ``R`` the estimate, ``bias`` the gyro bias, ``P (6, 6)``."""

    def __init__(self, R0, part: ImuPart = BMI270_BMM150, dt: float = 1e-3, attitude_std: float = 0.05):
        self.R = so3.as_rotations(R0, "R0").reshape(3, 3).copy()
        self.bias = np.zeros(3)
        self.part, self.dt = part, float(dt)
        self.P = np.diag([attitude_std ** 2] * 3 + [part.gyro_bias ** 2] * 3)

    def predict(self, gyro) -> None:
        w = np.asarray(gyro, dtype=float) - self.bias
        step = so3.exp(w * self.dt)
        self.R = self.R @ step
        Phi = np.eye(6)
        Phi[:3, :3] = step.T
        Phi[:3, 3:] = -np.eye(3) * self.dt
        Q = np.diag([self.part.gyro_noise_density ** 2 * self.dt] * 3 + [BIAS_WALK ** 2 * self.dt] * 3)
        self.P = Phi @ self.P @ Phi.T + Q

    def _correct(self, z, H, Rn) -> None:
        S = H @ self.P @ H.T + Rn
        K = np.linalg.solve(S, H @ self.P).T
        dx = K @ z
        self.R = self.R @ so3.exp(dx[:3])
        self.bias = self.bias + dx[3:]
        I_KH = np.eye(6) - K @ H
        self.P = I_KH @ self.P @ I_KH.T + K @ Rn @ K.T  # Joseph form

    def update_vector(self, y, reference, std: float) -> None:
        """A body-frame reading ``y`` of the fixed-frame vector ``reference`` with RMS noise ``std`` per axis."""
        yhat = self.R.T @ np.asarray(reference, dtype=float)
        H = np.zeros((3, 6))
        H[:, :3] = so3.skew(yhat)
        self._correct(np.asarray(y, dtype=float) - yhat, H, np.eye(3) * std ** 2)

    def update_orientation(self, R_meas, covariance) -> None:
        """An orientation measurement with fixed-frame covariance ``covariance (3, 3)`` (rad²)."""
        z = so3.log(self.R.T @ np.asarray(R_meas, dtype=float))
        H = np.zeros((3, 6))
        H[:, :3] = np.eye(3)
        self._correct(z, H, self.R.T @ np.asarray(covariance) @ self.R)


def triad(accel, mag, gravity_ref, field_ref) -> np.ndarray:
    """Orientation ``R`` (body → fixed) from two body-frame vectors and their fixed-frame references (TRIAD,
    the first pair trusted exactly)."""
    def frame(a, b):
        e1 = a / np.linalg.norm(a)
        e2 = np.cross(a, b)
        e2 /= np.linalg.norm(e2)
        return np.stack([e1, e2, np.cross(e1, e2)], axis=1)
    return frame(np.asarray(gravity_ref, float), np.asarray(field_ref, float)) @ frame(np.asarray(accel, float),
                                                                                        np.asarray(mag, float)).T


class _MotionSensor(SampledSensor):
    """Shared by the IMU sensors: an :class:`~spherestep.sensing.sensor.OrientationSensor` sampling every ``dt``
    s (``rate = 1/dt``), ``latency`` s late; the true body rate from consecutive true orientations ``dt`` apart."""

    def __init__(self, design, dt: float, part: ImuPart, seed, latency: float = 0.0, start=None):
        self.imu = Imu(part, dt, CoilField.build(design, np.zeros((1, 3))), seed)
        super().__init__(1.0 / self.imu.dt, latency, start)
        self.dt = float(dt)
        self._R_last = None
        self.filter: Mekf | None = None

    def _sample(self, R_true, currents):
        R = so3.as_rotations(R_true, "R_true").reshape(3, 3)
        omega = np.zeros(3) if self._R_last is None else so3.log(self._R_last.T @ R) / self.dt
        self._R_last = R
        return self.imu.sample(R, omega, currents)


class ImuSensor(_MotionSensor):
    """IMU alone (AHRS): gyro prediction, accelerometer (gravity) and magnetometer (Earth + known coil
    field) updates; starts by TRIAD from its first sample (``R_prev`` is not used). The accelerometer's and
    magnetometer's offsets are not estimated: the filter treats them as extra white noise. ``estimate`` is
    called once per ``dt`` with the true orientation (by :meth:`measure`, the sensor protocol)."""

    def __init__(self, design, dt: float = 1e-3, part: ImuPart = BMI270_BMM150, seed=None, *,
                 latency: float = 0.0):
        super().__init__(design, dt, part, seed, latency)

    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        gyro, accel, mag = self._sample(R_true, currents)
        ref = self.imu.reference_field(currents)
        p = self.imu.part
        if self.filter is None:
            self.filter = Mekf(triad(accel, mag, [0.0, 0.0, GRAVITY], ref), p, self.dt)
            return self.filter.R.copy()
        self.filter.predict(gyro)
        self.filter.update_vector(accel, [0.0, 0.0, GRAVITY], p.accel_noise_density / math.sqrt(self.dt)
                                  + p.accel_bias)
        self.filter.update_vector(mag, ref, p.mag_noise_T + p.mag_bias_T)
        return self.filter.R.copy()


class FusedSensor(_MotionSensor):
    """Gyro prediction + the magnetometer array's estimate as an orientation update (with its Cramér–Rao
    covariance) every ``hall_every`` samples. ``hall`` is a :class:`~spherestep.sensing.sensor.HallSensor`.
    The first call starts from ``hall.estimate(R_true, currents, R_prev)``: give the known start as ``R_prev``
    (or ``start``) for a symmetric rotor (a symmetric copy ``R g`` would contradict the gyro, which sees the
    body rate)."""

    def __init__(self, design, hall, dt: float = 1e-3, part: ImuPart = BMI270_BMM150, hall_every: int = 1,
                 seed=None, *, latency: float = 0.0, start=None):
        super().__init__(design, dt, part, seed, latency, start)
        self.hall = hall
        self.hall_every = int(hall_every)
        self._count = 0

    def estimate(self, R_true, currents=None, R_prev=None) -> np.ndarray:
        gyro, _, _ = self._sample(R_true, currents)
        if self.filter is None:
            R0 = self.hall.estimate(R_true, currents, R_prev)
            self.filter = Mekf(R0, self.imu.part, self.dt, attitude_std=1e-3)
            return self.filter.R.copy()
        self.filter.predict(gyro)
        self._count += 1
        if self._count % self.hall_every == 0:
            R_hall = self.hall.estimate(R_true, currents, self.filter.R)
            self.filter.update_orientation(R_hall, self.hall.last.covariance)
        return self.filter.R.copy()
