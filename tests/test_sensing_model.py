"""One field model for the magnetometers (spherestep.sensing.field_model) on the iron prototype: the emulated motor
reads what the simulated Hall sensor reads (the cores' field included), the hardware session's estimator fits it,
and accuracy() / calibrate() model the cores by default and say which model they used."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from spherestep import sensing, so3
from spherestep.errors import InputError
from spherestep.motor import prototype
from spherestep.sensing import iron


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def array8(design):
    """The hardware session's array (the first 8 of the default 24), noiseless: readings exact to the LSB."""
    a = sensing.default_array(design, 8)
    return replace(a, part=replace(a.part, noise_T=0.0))


def test_field_model_is_rotor_plus_cores_on_iron(design, array8):
    """On iron the model is the rotor's table plus iron_fields' cores and iron coils (the stored 24-sensor table
    serves any of its sensors); cores=False is the air-core model; cores=True on an air design is refused."""
    p = array8.positions
    model = sensing.field_model(design, p)
    assert model.name == "rotor + cores" and isinstance(model.table, iron.IronFieldTable)
    cores, coils = iron.iron_fields(design, p)
    full = iron.iron_fields(design, sensing.default_array(design).positions)[0]
    R = so3.random(3, 5)
    c = np.zeros(len(design.stator))
    c[[2, 7]] = [1.0, -0.5]
    np.testing.assert_allclose(model.field(R, c), sensing.FieldTable.build(design, p).field(R) + cores.field(R)
                               + coils.field(c), rtol=0, atol=1e-12)
    np.testing.assert_allclose(cores.field(R), full.field(R)[:, :8], rtol=0, atol=1e-7)  # float32 table
    assert np.sqrt(np.mean(cores.field(R) ** 2)) > 1e-3  # millitesla: what ignoring the cores misses
    air = sensing.field_model(design, p, cores=False)
    assert air.name == "rotor only" and air.cores is None and isinstance(air.coils, sensing.CoilField)
    air_design = replace(design, coil=replace(design.coil, core="air"))
    assert sensing.field_model(air_design, p).name == "rotor only"
    with pytest.raises(InputError, match="cores"):
        sensing.field_model(air_design, p, cores=True)


def test_emulated_motor_reads_the_cores_as_the_simulated_sensor_does(design, array8):
    """The emulated motor's magnetometer counts at an orientation and coil currents are the rotor's table, the
    cores' field and the iron coils' (iron_fields) to half an LSB, and the simulation's HallSensor reads the same;
    the rotor-only field misses them by millitesla."""
    from spherestep.drive.connect import emulated_motor
    from spherestep.magnetics import design_model

    own = design_model(design)
    R = so3.random(1, 11)[0]
    motor = emulated_motor(design, own.model, array8, drive=own.limits, R0=R)
    c = np.zeros(len(design.stator))
    c[[0, 4, 13]] = [0.8, -1.0, 0.4]
    motor.i = own.limits.amperes(c)
    counts, stale = motor.sense()
    m = counts * array8.part.lsb_T
    cores, coils = iron.iron_fields(design, array8.positions)
    rotor = sensing.FieldTable.build(design, array8.positions).field(R)
    expect = np.einsum("sji,sj->si", array8.axes, rotor + cores.field(R) + coils.field(c))
    assert stale == 0
    assert np.abs(m - expect).max() <= 0.5 * array8.part.lsb_T + 1e-12
    hall = sensing.HallSensor(design, array=array8, seed=0)
    assert np.abs(hall.readings(R, c) - m).max() <= array8.part.lsb_T + 1e-12
    rotor_only = np.einsum("sji,sj->si", array8.axes, rotor + coils.field(c))
    assert np.abs(m - rotor_only).max() > 1e-3


def test_session_estimator_fits_the_cores_on_the_emulated_iron_motor(design):
    """A 0.1 s hold on the emulated iron prototype in lockstep: the session's estimator (the cores modelled, the
    default) holds within 0.01°; told to ignore the cores it finds no orientation that fits the readings (RMS
    residual over 10 × the noise: the loop stops with SENSOR before its first cycle)."""
    from spherestep.control import Trajectory
    from spherestep.drive.session import servo_session

    R0 = so3.exp(np.radians(3.0) * np.array([0.2, 0.9, -0.4]))
    hold = Trajectory.hold(R0)
    on = servo_session(design, hold, 0.1, emulate=True, lockstep=True)
    assert on.report.outcome == "done" and on.report.cycles >= 45, on.report.to_dict()
    assert math.degrees(so3.distance(on.report.orientations[-1], on.held.R)) < 0.01
    off = servo_session(design, hold, 0.1, emulate=True, lockstep=True, cores=False)
    assert off.report.outcome == "SENSOR" and "fit no orientation" in off.report.message


def test_accuracy_on_iron_models_the_cores_and_says_so(design):
    """accuracy() on the iron prototype (readings with the cores' field and the iron coils): modelled, 0.004°
    RMS (measured 0.0038° at 30 samples); ignored (cores=False), tenths of a degree (0.71°). Each says its model."""
    array = sensing.default_array(design)
    on = sensing.accuracy(design, array, samples=12, seed=3)
    off = sensing.accuracy(design, array, samples=12, seed=3, cores=False)
    assert on.field_model == "rotor + cores" and off.field_model == "rotor only"
    assert on.to_dict()["field_model"] == "rotor + cores"
    assert math.degrees(on.rms) < 0.01 and math.degrees(off.rms) > 0.2
    assert math.degrees(on.rms) < 3 * math.degrees(on.predicted_rms)  # the noise's bound, not a bias


def test_calibrate_on_iron_fits_with_the_cores(design):
    """Self-calibration of 8 sensors (0.2 mm off, gains 1 % off, 50 µT offsets) from 40 noisy readings of the iron
    motor (rotor at the true positions, the cores' field): with the cores modelled the residual falls to the noise
    (0.109 mT for 0.100 after 5 rounds, as on a motor without cores) and the positions come back (0.23 -> 0.04 mm);
    without them it stays at millitesla (8.6 mT) and the positions wander (1.6 mm)."""
    array = sensing.default_array(design, 8)
    rng = np.random.default_rng(21)
    true_pos = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(array), 3)), rng.normal(0.0, 50e-6, (len(array), 3))
    R = so3.random(40, rng)
    cores = iron.iron_fields(design, array.positions)[0]  # at the nominal positions (module doc of calibration)
    B = sensing.rotor_field(design, true_pos, R) + cores.field(R)
    m = sensing.sense(array, B, rng) * gain + offset
    start = so3.exp(np.radians(0.5) * rng.normal(size=(len(R), 3)) / math.sqrt(3)) @ R
    cal = sensing.calibrate(design, array, m, start, rounds=5)
    assert cal.field_model == "rotor + cores"
    assert cal.residual_T[-1] < 1.2 * array.part.effective_noise_T
    before = np.sqrt(np.mean((array.positions - true_pos) ** 2))
    assert np.sqrt(np.mean((cal.array.positions - true_pos) ** 2)) < 0.3 * before
    ignored = sensing.calibrate(design, array, m, start, rounds=3, cores=False)
    assert ignored.field_model == "rotor only" and ignored.residual_T[-1] > 5 * array.part.effective_noise_T
