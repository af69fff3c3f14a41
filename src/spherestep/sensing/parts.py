"""Datasheet figures of the sensors the sensing room models (a magnetometer for the stator, an IMU for the rotor).

All values SI: tesla, tesla RMS per axis, hertz, rad/s, m/s². Each part names its source. Where a datasheet
figure could not be read here, the value is labelled an assumption in ``notes`` and in docs/sensing.md.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

from .. import checks


@dataclass(frozen=True)
class MagnetometerPart:
    """A 3-axis magnetometer: ``range_T`` (each axis saturates at ±range), ``noise_T`` (RMS noise per axis at
    the chosen averaging), ``lsb_T`` (one count of the output register), ``rate_Hz`` (3-axis update rate)."""

    name: str
    range_T: float
    noise_T: float
    lsb_T: float
    rate_Hz: float
    source: str
    notes: str = ""

    def __post_init__(self):
        for label in ("range_T", "lsb_T", "rate_Hz"):
            value = getattr(self, label)
            checks.positive(value, label, "a positive number")
        checks.non_negative(self.noise_T, "noise_T", "a non-negative RMS noise in tesla")

    @property
    def effective_noise_T(self) -> float:
        """RMS error per axis of a reading: noise and quantisation, ``sqrt(σ² + LSB²/12)``."""
        return float((self.noise_T ** 2 + self.lsb_T ** 2 / 12.0) ** 0.5)

    def to_dict(self) -> dict:
        return asdict(self)


# TI TMAG5273A2 (SLYS045A, 2021): 3-axis linear Hall sensor, ranges ±133 / ±266 mT (the x2 variants), 12-bit
# ADC with averaging up to 32x into a 16-bit result register, 20 kSPS for a single axis, I2C up to 1 MHz,
# SOT-23-6. The lower-range parts (MLX90393, LIS3MDL ±1.6 mT, MMC5983MA ±0.8 mT) saturate 10 mm from an N42
# magnet face (up to 0.18 T there), which is why this one.
TMAG5273A2 = MagnetometerPart(
    name="TMAG5273A2 (range ±266 mT)",
    range_T=0.266,
    noise_T=1.0e-4,
    lsb_T=0.266 / 32768,
    rate_Hz=20_000 / 3,
    source="TI SLYS045A (June 2021, rev. Sept 2021): ranges ±133/±266 mT, 12-bit ADC, 16-bit result, "
           "20 kSPS single axis, averaging up to 32x",
    notes="noise_T = 0.1 mT RMS per axis is our assumption for the ±266 mT range without averaging "
          "(the datasheet's §5.8 noise table was not available to us); rate = 20 kSPS / 3 axes",
)


@dataclass(frozen=True)
class ImuPart:
    """A 6-axis IMU plus a magnetometer: gyro noise density (rad/s/√Hz) and bias (rad/s, 1σ turn-on offset),
    accelerometer noise density (m/s²/√Hz) and bias (m/s²), magnetometer noise (T RMS per axis) and hard-iron
    bias (T, 1σ), sample rate (Hz)."""

    name: str
    gyro_noise_density: float
    gyro_bias: float
    accel_noise_density: float
    accel_bias: float
    mag_noise_T: float
    mag_bias_T: float
    rate_Hz: float
    source: str

    def to_dict(self) -> dict:
        return asdict(self)


# Bosch BMI270 (BST-BMI270-DS000): gyro output noise 0.007 °/s/√Hz, zero-rate offset ±0.5 °/s; accelerometer
# noise 160 µg/√Hz, zero-g offset ±20 mg. Magnetometer: Bosch BMM150 (BST-BMM150-DS001): resolution 0.3 µT,
# noise ~0.6 µT (x, y, regular preset). 1 kHz output data rate used here. Inside the rotor the magnets' field
# at the IMU is fixed in the body frame (a hard-iron offset, calibrated out); we keep a 1 µT residual.
BMI270_BMM150 = ImuPart(
    name="BMI270 + BMM150",
    gyro_noise_density=0.007 * 3.141592653589793 / 180.0,
    gyro_bias=0.5 * 3.141592653589793 / 180.0,
    accel_noise_density=160e-6 * 9.80665,
    accel_bias=0.020 * 9.80665,
    mag_noise_T=0.6e-6,
    mag_bias_T=1e-6,
    rate_Hz=1000.0,
    source="Bosch BST-BMI270-DS000 (gyro 0.007 °/s/√Hz, offset ±0.5 °/s; accel 160 µg/√Hz, offset ±20 mg); "
           "Bosch BST-BMM150-DS001 (noise ≈0.6 µT); hard-iron bias 1 µT after calibration is our assumption",
)
