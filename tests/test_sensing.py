"""Tests of spherestep.sensing: field table, estimator on SO(3), symmetry, placement, coil subtraction, IMU."""

from __future__ import annotations

import math

import magpylib as magpy
import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.magnetics import rotor_collection, stator_coils
from spherestep.motor import prototype
from spherestep import sensing


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def array(design):
    return sensing.default_array(design)


@pytest.fixture(scope="module")
def estimator(design, array):
    table = sensing.FieldTable.build(design, array.positions)
    return sensing.Estimator(table, array.axes, array.part, (sensing.CoilField.build(design, array.positions),))


def test_default_array_fits_and_stays_in_range(design, array):
    assert len(array) == 24
    array.check_fits(design)  # clear of every coil, outside the ball
    r = np.linalg.norm(array.positions, axis=1)
    np.testing.assert_allclose(r, design.radius + sensing.array.STANDOFF, rtol=1e-12)
    # worst field over 300 random orientations stays below the part's range (no saturation by the rotor)
    B = sensing.rotor_field(design, array.positions, so3.random(300, 7))
    assert np.abs(B).max() < array.part.range_T


def test_collision_check(design):
    v = design.stator.centers[0]
    inside = v * (design.radius + design.air_gap + 0.5 * design.coil_length)
    assert sensing.coil_collisions(design, inside[None])[0]
    with pytest.raises(InputError, match="positions"):
        sensing.SensorArray.at(inside[None]).check_fits(design)
    cand = sensing.candidate_positions(design)
    assert len(cand) > 100 and not sensing.coil_collisions(design, cand).any()


def test_hall_sensor_noise_override(design, array):
    """``noise_T=0``: readings are the exact field rounded to the LSB; a negative noise is refused."""
    hall = sensing.HallSensor(design, array=array, noise_T=0.0)
    R = so3.random(1, 14)[0]
    m = hall.readings(R)
    exact = np.einsum("sji,sj->si", array.axes, hall.table.field(R))
    assert np.abs(m - exact).max() <= 0.5 * array.part.lsb_T + 1e-15
    with pytest.raises(InputError, match="noise_T"):
        sensing.HallSensor(design, array=array, noise_T=-1.0)
    direct = sensing.HallSensor(design, array=array, noise_T=0.0, truth="magpylib")
    assert np.abs(direct.readings(R) - m).max() <= array.part.lsb_T  # magpylib and the table agree to one LSB
    with pytest.raises(InputError, match="truth"):
        sensing.HallSensor(design, array=array, truth="exact")


def test_bad_array_input():
    with pytest.raises(InputError, match="positions"):
        sensing.SensorArray(np.zeros((2, 2)), np.zeros((2, 3, 3)))
    with pytest.raises(InputError, match="axes"):
        sensing.SensorArray(np.ones((1, 3)), np.ones((1, 3, 3)))


def test_table_matches_magpylib(design, array, estimator):
    """The 1-D table against magpylib's field of the whole rotor: within 1e-6 T (noise is 1e-4 T)."""
    R = so3.random(40, 3)
    exact = np.asarray(rotor_collection(design, R).getB(array.positions))
    np.testing.assert_allclose(estimator.table.field(R), exact, atol=1e-6, rtol=0)


def test_jacobian_matches_finite_differences(estimator):
    R = so3.random(1, 11)[0]
    _, J = estimator.table.field_and_jacobian(R)
    h = 1e-6
    fd = np.stack([(estimator.table.field(so3.exp(h * e) @ R) - estimator.table.field(so3.exp(-h * e) @ R))
                   / (2 * h) for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(J, fd, atol=1e-6 * np.abs(J).max())


def test_noiseless_recovery(design, array, estimator):
    """Random orientations from exact magpylib readings, starting 5° off: error below 1e-6 rad."""
    rng = np.random.default_rng(0)
    R = so3.random(15, rng)
    m = np.einsum("sji,ksj->ksi", array.axes, sensing.rotor_field(design, array.positions, R))
    for k in range(len(R)):
        axis = rng.normal(size=3)
        R0 = so3.exp(math.radians(5.0) * axis / np.linalg.norm(axis)) @ R[k]
        est = estimator.solve(m[k], R0)
        assert est.converged
        assert so3.distance(est.R, R[k]) < 1e-6


def test_noise_propagates_as_fisher_predicts(array, estimator):
    """1000 noisy readings at one orientation: the covariance of the error matches σ² (JᵀJ)⁻¹ within 20 %
    along each of its principal axes."""
    rng = np.random.default_rng(1)
    R = so3.random(1, rng)[0]
    B = estimator.table.field(R)
    errors = np.empty((1000, 3))
    for k in range(1000):
        est = estimator.track(sensing.sense(array, B, rng), R, iterations=2)  # Gauss–Newton from the truth
        errors[k] = so3.log(est.R @ R.T)
    predicted = estimator.solve(sensing.sense(array, B, noise=False), R).covariance
    w, V = np.linalg.eigh(predicted)
    empirical = np.cov(errors.T)
    ratio = np.diag(V.T @ empirical @ V) / w
    assert np.all(np.abs(ratio - 1.0) < 0.2), ratio


def test_coil_fields_subtracted_with_coils_energised(design, array, estimator):
    """Readings of the rotor with 6 coils at ±1 (magpylib, rotor and coils in one collection): with the
    coils' field subtracted the estimate is exact; without, it is off by far more than the noise."""
    rng = np.random.default_rng(2)
    c = np.zeros(len(design.stator))
    c[rng.choice(len(c), 6, replace=False)] = rng.choice([-1.0, 1.0], 6)
    R = so3.random(1, rng)[0]
    scene = magpy.Collection(rotor_collection(design, R[None]), *stator_coils(design, currents=c))
    m = np.einsum("sji,sj->si", array.axes, np.asarray(scene.getB(array.positions)).reshape(-1, 3))
    # the same field built the library's way
    np.testing.assert_allclose(sensing.true_field(design, array, R[None], c)[0],
                               np.einsum("sij,sj->si", array.axes, m), atol=1e-12)
    good = estimator.solve(m, R, currents=c)
    bad = estimator.solve(m, R, currents=None)
    assert so3.distance(good.R, R) < 1e-6
    assert so3.distance(bad.R, R) > math.radians(0.01)


def test_symmetry_group_and_identical_readings(design, array):
    G = sensing.symmetry_group(design)
    assert len(G) == 60
    products = np.einsum("aij,bjk->abik", G, G).reshape(-1, 3, 3)
    assert max(np.abs(G - P).max(axis=(1, 2)).min() for P in products) < 1e-12  # closed
    R = so3.random(1, 4)[0]
    B = sensing.rotor_field(design, array.positions, R @ G)  # magpylib, 60 orientations
    assert np.abs(B - B[0]).max() < 1e-12 < np.abs(B).max()
    marked = sensing.marked_design(design)
    assert np.sum(marked.polarity != design.polarity) == 1
    assert len(sensing.symmetry_group(marked)) == 1
    assert len(sensing.symmetry_group(marked, polarity=False)) == 60


def test_global_initialiser(design, array, estimator):
    """From no prior: the prototype's orientation up to its 60 symmetries; the marked rotor's exactly."""
    rng = np.random.default_rng(3)
    G = sensing.symmetry_group(design)
    for _ in range(3):
        R = so3.random(1, rng)[0]
        est = estimator.initialise(sensing.sense(array, estimator.table.field(R), rng))
        assert so3.distance(est.R[None], R @ G).min() < math.radians(0.05)
    marked = sensing.marked_design(design)
    hall = sensing.HallSensor(marked, array=array, seed=5)
    for _ in range(3):
        R = so3.random(1, rng)[0]
        assert so3.distance(hall.estimate(R), R) < math.radians(0.05)


def test_smallest_eigenvalue_and_greedy(design):
    A = np.random.default_rng(0).normal(size=(200, 3, 3))
    F = A @ np.swapaxes(A, 1, 2)
    np.testing.assert_allclose(sensing.smallest_eigenvalue(F), np.linalg.eigvalsh(F)[:, 0], atol=1e-10)
    cand = sensing.candidate_positions(design, count=600)
    pl = sensing.greedy_placement(design, 6, candidates=cand, rotations=30)
    assert len(set(pl.order.tolist())) == 6
    assert np.all(np.diff(pl.worst_information) >= 0)


def test_tracking_loop_and_fusion(design, array):
    """A 1 rad/s turn sampled at 1 kHz from a known start: the array tracks it, the IMU+array filter too."""
    rng = np.random.default_rng(4)
    dt, axis = 1e-3, rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    R0 = so3.random(1, rng)[0]
    path = [R0 @ so3.exp(axis * dt * k) for k in range(300)]
    c = np.zeros(len(design.stator))
    c[[2, 9]] = [1.0, -1.0]
    hall = sensing.HallSensor(design, array=array, current_error=0.01, seed=6)
    fused = sensing.FusedSensor(design, sensing.HallSensor(design, array=array, seed=7), dt, seed=8)
    R_est, err_h, err_f = R0, [], []
    for k, R in enumerate(path):
        R_est = hall.estimate(R, c, R_est)
        err_h.append(so3.distance(R_est, R))
        err_f.append(so3.distance(fused.estimate(R, c, R0 if k == 0 else None), R))
    assert max(err_h) < math.radians(0.03)
    assert max(err_f[50:]) < math.radians(0.03)


def test_every_sensor_keeps_the_protocol_and_its_latency(design, array):
    """One protocol (measure(t, R_true, currents), rate, latency): a sample every 1/rate s from t = 0, delivered
    latency s later, so what arrives at t is the rotor at t − latency."""
    turn = np.array([0.3, -0.2, 0.9])
    truth = [so3.exp(turn * 1e-3 * k) for k in range(40)]
    for sensor in (sensing.IdealSensor(rate=500.0, latency=0.003),
                   sensing.NoisySensor(0.0, rate=500.0, latency=0.003, rng=1),
                   sensing.HallSensor(design, array=array, noise_T=0.0, rate=500.0, latency=0.003,
                                      start=truth[0])):
        assert isinstance(sensor, sensing.OrientationSensor)
        got = {k: sensor.measure(k * 1e-3, truth[k], None) for k in range(40)}
        delivered = [k for k, m in got.items() if m is not None]
        assert delivered == list(range(3, 40, 2))
        for k in delivered:
            assert so3.distance(got[k], truth[k - 3]) < math.radians(1e-3), type(sensor).__name__
    imu = sensing.ImuSensor(design, 2e-3, seed=1, latency=0.004)
    assert imu.rate == pytest.approx(500.0) and imu.latency == 0.004
    assert [k for k in range(10) if imu.measure(k * 1e-3, truth[k]) is not None] == [4, 6, 8]
    with pytest.raises(InputError, match="latency"):
        sensing.IdealSensor(latency=-1.0)


def test_imu_alone_sees_tilt_and_heading(design):
    """The AHRS from a BMI270 + BMM150 model at rest: within a few degrees (its biases), not exact."""
    imu = sensing.ImuSensor(design, 1e-3, seed=9)
    R = so3.random(1, 10)[0]
    for _ in range(200):
        R_est = imu.estimate(R)
    assert so3.distance(R_est, R) < math.radians(10.0)


@pytest.mark.slow
def test_servo_runs_with_the_array_in_the_loop(design, array):
    """simulate_servo along a 20° turn with the magnetometer array as its sensor (known start): it tracks as
    well as with a perfect sensor (max error within 0.03°), the estimate within 0.01° RMS of the truth."""
    from spherestep.control import Trajectory
    from spherestep.dynamics import simulate_servo
    from spherestep.magnetics import torque_map

    R0 = so3.random(1, 4)[0]
    traj = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), acceleration=10.0)
    hall = sensing.HallSensor(design, array=array, current_error=0.01, seed=1, start=R0)
    assert isinstance(hall, sensing.OrientationSensor) and hall.rate == 1000.0
    run = simulate_servo(design, traj, torque_map(design), sensor=hall, settle=0.15)
    assert run.tracking_error.max() < math.radians(0.03)
    est = so3.distance(run.estimates, run.orientations)
    assert np.sqrt(np.mean(est ** 2)) < math.radians(0.01)
    assert so3.distance(run.orientations[-1], R0) == pytest.approx(math.radians(20), abs=math.radians(0.05))


def test_field_gradient_matches_magpylib(design, array, estimator):
    """The spatial gradient from the rotation Jacobian (curl- and divergence-free field) against central
    differences of magpylib's field in space: within 1e-5 of its size."""
    R = so3.random(1, 12)[0]
    B, J = estimator.table.field_and_jacobian(R)
    G = sensing.field_gradient(B, J, array.positions)
    h = 1e-6
    fd = np.stack([(sensing.rotor_field(design, array.positions + h * e, R)[0]
                    - sensing.rotor_field(design, array.positions - h * e, R)[0]) / (2 * h) for e in np.eye(3)], -1)
    np.testing.assert_allclose(G, fd, atol=1e-5 * np.abs(G).max())


@pytest.mark.slow
def test_self_calibration_recovers_positions_gains_offsets(design, array):
    """Sensors 0.2 mm off, gains 1 % off, offsets 50 µT: from 80 noisy readings at unknown orientations the
    positions come back to a fraction, the residual falls to the noise, and the orientation error (common turn
    removed) falls to the noise's level. The readings are the rotor's alone, so the fit is told so (``cores=False``;
    with the cores' field: tests/test_sensing_model.py)."""
    rng = np.random.default_rng(13)
    true_pos = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(array), 3)), rng.normal(0.0, 50e-6, (len(array), 3))
    R = so3.random(80, rng)
    m = sensing.sense(array, sensing.rotor_field(design, true_pos, R), rng) * gain + offset
    nominal = sensing.Estimator(sensing.FieldTable.build(design, array.positions), array.axes, array.part)
    start = np.stack([nominal.solve(m[k], R[k]).R for k in range(len(R))])
    cal = sensing.calibrate(design, array, m, start, rounds=3, cores=False)
    assert cal.field_model == "rotor only"
    before = np.sqrt(np.mean((array.positions - true_pos) ** 2))
    after = np.sqrt(np.mean((cal.array.positions - true_pos) ** 2))
    assert after < 0.3 * before
    assert cal.residual_T[-1] < 1.1 * array.part.effective_noise_T < cal.residual_T[0]
    est = sensing.Estimator(sensing.FieldTable.build(design, cal.array.positions), array.axes, array.part)
    Rt = so3.random(30, rng)
    mt = sensing.sense(array, sensing.rotor_field(design, true_pos, Rt), rng) * gain + offset
    E = np.stack([so3.log(est.solve(cal.correct(mt[k]), Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    E0 = np.stack([so3.log(nominal.solve(mt[k], Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    scatter = np.sqrt(np.mean(np.sum((E - E.mean(0)) ** 2, axis=1)))
    assert scatter < 0.5 * np.sqrt(np.mean(np.sum(E0 ** 2, axis=1)))
    assert scatter < math.radians(0.01)
