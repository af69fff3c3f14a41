"""The servo against a plant it does not know exactly (issue 25 §2): the extended observer's gains, the mismatched
plants (spherestep.magnetics.mismatch) and a shortened robustness table that fails with the observer off."""

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.control import GeometricPD, Observer, ServoLaw, Trajectory
from spherestep.control.controller import DISTURBANCE_BANDWIDTH, MOTION_BANDWIDTH, observer_gains
from spherestep.dynamics import Rotor
from spherestep.control.trajectory import MARGIN
from spherestep.dynamics.robustness import MAX_TRACKING, hold_errors, turn_run
from spherestep.errors import InputError
from spherestep.magnetics import design_model, iron_model
from spherestep.magnetics.mismatch import MISMATCH_CASES, CoupledPlant, scaled_model, shell_model
from spherestep.motor import prototype

HOLD = math.radians(0.05)


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def iron(design):
    return iron_model(design)


def _error_map(l1, l2, l3, inertia, h, n=1):
    g = 0.5 * (n + 1) / n
    A = np.array([[1.0, h, g * h * h], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
    L = np.array([[l1], [l2], [l3 / inertia]])
    return (np.eye(3) - L @ np.array([[1.0, 0.0, 0.0]])) @ A


@pytest.mark.parametrize("h, wo, wd, n", [(1e-3, 120.0, 60.0, 1), (1e-3, 250.0, 250.0, 1), (2e-3, 300.0, 100.0, 2),
                                          (5e-3, 1000.0, 400.0, 5), (1e-3, 20.0, 5.0, 1)])
def test_extended_observer_gains_place_the_poles_exactly(h, wo, wd, n):
    """The error map (1 − LC)A of n predictions and one correction has its eigenvalues at exp(−ω_oΔ) (twice) and
    exp(−ω_dΔ), to rounding, for any interval (so it is stable however late the measurement)."""
    inertia = 0.0724
    M = _error_map(*observer_gains(h, wo, wd, inertia, n), inertia, h, n)
    want = np.poly([math.exp(-wo * h)] * 2 + [math.exp(-wd * h)])
    np.testing.assert_allclose(np.poly(M), want, atol=1e-10)
    assert np.abs(np.linalg.eigvals(M)).max() < 1.0
    l1, l2, l3 = observer_gains(1e-6, wo, wd, inertia)  # small ωΔ: the continuous gains times Δ
    assert (l1 / 1e-6, l2 / 1e-6, l3 / 1e-6) == pytest.approx((2 * wo + wd, wo * wo + 2 * wo * wd,
                                                                inertia * wo * wo * wd), rel=2e-3)


def test_observer_estimates_a_constant_torque_and_the_second_order_one_does_not():
    """A rotor under an unknown constant torque d, measured every period: d̂ → d and the orientation estimate
    converges; without the disturbance state the estimate lags by d/(I ω_o²)."""
    inertia, h = 0.0724, 1e-3
    d = np.array([0.3, -0.5, 0.2])
    for wd in (0.0, 60.0):
        obs = Observer(np.eye(3), inertia=inertia, sensor_period=h, disturbance_bandwidth=wd)
        R, w = np.eye(3), np.zeros(3)
        for _ in range(1500):
            w = w + h * d / inertia
            R = so3.exp(h * w) @ R
            obs.predict(np.zeros(3), h)
            obs.correct(R)
        lag = float(so3.distance(obs.R, R))
        if wd:
            np.testing.assert_allclose(obs.d, d, atol=1e-6)
            assert lag < 1e-8
        else:
            assert np.all(obs.d == 0) and lag > 1e-5


def test_observer_late_and_irregular_measurements_with_the_disturbance_state():
    """Measurements 1, 2 and 5 periods apart and 3 ms late: the extended observer still converges on d."""
    inertia, h = 0.0724, 1e-3
    d = np.array([0.0, 0.4, -0.1])
    obs = Observer(np.eye(3), inertia=inertia, sensor_period=2 * h, disturbance_bandwidth=50.0)
    truth = []
    R, w, t = np.eye(3), np.zeros(3), 0.0
    gaps = [1, 2, 5, 2, 2, 1] * 80
    step = 0
    for gap in gaps:
        for _ in range(gap):
            w = w + h * d / inertia
            R = so3.exp(h * w) @ R
            t += h
            step += 1
            truth.append((t, R))
            obs.predict(np.zeros(3), h)
        late = [x for x in truth if x[0] <= t - 3e-3 + 1e-12]
        if late:
            obs.correct(late[-1][1], late[-1][0])
    np.testing.assert_allclose(obs.d, d, atol=2e-3)


def test_servo_law_cancels_its_disturbance_estimate(iron):
    """The law asks the allocation for τ* − d̂ (ServoCommand.requested) and reports d̂; off with 0."""
    traj = Trajectory.hold(so3.random(1, 3)[0])
    law = ServoLaw(iron, traj, GeometricPD(0.0724))
    assert law.observer.disturbance_bandwidth == MOTION_BANDWIDTH == 300.0 and law.observer.l3 > 0  # a detent
    air = ServoLaw(design_model(prototype(), "air").model, traj, GeometricPD(0.0724))
    assert (air.observer.disturbance_bandwidth, air.observer.motion_bandwidth) == (DISTURBANCE_BANDWIDTH, 300.0)
    assert ServoLaw(iron, traj, GeometricPD(0.0724), sensor_rate=200.0).observer.l3 == 0.0  # too slow a sensor
    law.step(0.0, traj.start)
    law.observer.d = np.array([0.1, 0.2, -0.3])
    cmd = law.step(1e-3, traj.start)
    free = law.controller.torque(cmd.estimate, cmd.velocity, *traj.at(1e-3))
    np.testing.assert_allclose(cmd.requested, free - cmd.disturbance, atol=1e-12)
    off = ServoLaw(iron, traj, GeometricPD(0.0724), disturbance_bandwidth=0.0)
    assert off.observer.l3 == 0.0
    with pytest.raises(InputError, match="disturbance_bandwidth"):
        ServoLaw(iron, traj, GeometricPD(0.0724), disturbance_bandwidth=-1.0)


def test_mismatched_plants(design, iron):
    """Scaling the iron model's two maps is exact; the shell's plants change the detent by ~±11 %, the winding by
    ~±3 % (gap smaller → stronger); the coupled plant matches the full coupled model near its anchor."""
    R = so3.random(4, 9)
    c = np.random.default_rng(1).normal(size=(4, iron.coil_count)) * 0.5
    b = iron.torque(R, np.zeros_like(c))
    np.testing.assert_allclose(scaled_model(iron, 0.85, 1.2).torque(R, c), 1.2 * b + 0.85 * (iron.torque(R, c) - b),
                               atol=1e-12)
    assert scaled_model(iron, 0.85, 1.2).packed_terms(c[0]) is not None  # the compiled paths kept
    thin, thick = shell_model(design, -0.3e-3), shell_model(design, 0.3e-3)
    ratio = [np.abs(m.detent_torque(R)).max() / np.abs(iron.detent_torque(R)).max() for m in (thin, thick)]
    assert 1.05 < ratio[0] < 1.2 and 0.8 < ratio[1] < 0.95
    with pytest.raises(InputError, match="change"):
        shell_model(design, -0.01)
    with pytest.raises(InputError, match="detent"):
        scaled_model(design_model(design, "air").model, 1.0, 1.2)
    assert [c.name for c in MISMATCH_CASES][:2] == ["winding ×0.85", "winding ×1.15"] and len(MISMATCH_CASES) == 8


@pytest.mark.slow
def test_coupled_plant_is_the_coupled_model_near_its_anchors(design):
    plant = CoupledPlant(iron_model(design, coupling=True))
    A = so3.random(1, 11)[0]
    z = np.zeros(plant.coil_count)
    plant.torque(A, z)
    errors = []
    for deg in (0.1, 1.0):  # first order: the error grows as the square of the distance to the anchor
        R = so3.exp(math.radians(deg) * np.array([0.6, 0.0, 0.8])) @ A
        approx = plant.torque(R, z) - plant.pairwise.torque(R, z)
        errors.append(float(np.linalg.norm(approx - plant.coupling_torque(R))))
    assert plant.anchors == 1
    assert errors[0] < 5e-3 and errors[1] < 0.06  # measured 0.003 and 0.047 N·m; the coupling is 0.5 N·m there


@pytest.mark.slow
@pytest.mark.parametrize("name", ["winding ×0.85", "shell −0.3 mm"])
def test_holds_and_a_turn_on_a_mismatched_plant_need_the_observer(design, name):
    """Shortened §2 table: 3 holds (within 0.05° after 1 s) and a 60° turn about (1, 0.5, 2) planned on the
    controller's model (end within 0.05° after 0.5 s, tracking within 0.5°), 0.02° noise; with the observer off
    the same runs miss (measured in benchmarks/bench_servo_robust.py)."""
    case = next(c for c in MISMATCH_CASES if c.name == name)
    plant, model = case.build(design)
    limits, rotor = design_model(design).limits, Rotor.from_design(design)
    results = {}
    for wd in (None, 0.0):
        holds = hold_errors(design, plant, model, limits, rotor, holds=3, seed=0, disturbance_bandwidth=wd)
        _, run = turn_run(design, plant, model, limits, rotor, angle=math.radians(60), disturbance_bandwidth=wd,
                          margin=MARGIN)  # the plan robust to the model's error (plan_turn's default uses 90 %)
        results[wd] = (max(holds), run.final_error, run.tracking_error.max(), run.power.mean())
    on, off = results[None], results[0.0]
    assert on[0] <= HOLD and on[1] <= HOLD and on[2] <= MAX_TRACKING and on[3] <= 100.0
    assert off[0] > HOLD or off[1] > HOLD  # without the disturbance estimate the model error shows


@pytest.mark.slow
def test_failed_coil_turn_with_the_disturbance_estimate(design):
    """The failed-coil turn of tests/test_servo.py (air-core map, 20° about (1, 0.5, 2)) with the law's default
    disturbance estimate: the same tracking bounds, the failed coil never driven."""
    from dataclasses import replace

    from spherestep.dynamics import simulate_servo
    from spherestep.magnetics import torque_map
    from spherestep.sensing import NoisySensor

    tmap = torque_map(design)
    R0 = so3.random(1, 4)[0]
    failed = (int(np.argmax(np.linalg.norm(tmap.torque_matrix(R0), axis=0))),)
    traj = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), acceleration=10.0)
    run = simulate_servo(design, traj, replace(tmap, failed=failed), rotor=Rotor.from_design(design),
                         sensor=NoisySensor(math.radians(0.02), rng=6), settle=0.15)
    assert np.all(run.currents[:, failed[0]] == 0)
    assert run.tracking_error.max() < math.radians(0.2) and run.final_error <= HOLD
    assert np.abs(run.disturbance).max() > 0  # the estimate ran


def test_model_cache_first_order_about_its_anchor(iron):
    """ModelCache.at(R, slope=True): K and b carried from the anchor to first order (3 evaluations of forward
    differences, once per anchor) — the detent's stiffness (~10² N·m/rad) no longer frozen within the reuse angle."""
    from spherestep.control import ModelCache

    exact = ModelCache(iron, reuse=0.0)
    errors = []  # (frozen, first order) of b and K, largest element, N·m
    for A in so3.random(6, 5):
        R = so3.exp(1e-3 * np.array([0.6, -0.48, 0.64])) @ A  # within the 2e-3 rad reuse angle
        cache = ModelCache(iron)
        cache.at(A)
        K0, b0 = (a.copy() for a in cache.at(R))
        K1, b1 = (a.copy() for a in cache.at(R, slope=True))
        K, b = exact.at(R)
        assert cache.evaluations == 1 and cache.slope_evaluations == 3
        errors.append([np.abs(x - y).max() for x, y in ((b0, b), (b1, b), (K0, K), (K1, K))])
    e = np.array(errors)
    assert np.all(e[:, 1] < e[:, 0]) and np.all(e[:, 3] < e[:, 2])
    assert e[:, 1].sum() < e[:, 0].sum() / 10 and e[:, 3].sum() < e[:, 2].sum() / 30  # measured 64x and 128x
    np.testing.assert_allclose(cache.at(A, slope=True)[0], cache.at(A)[0], rtol=0, atol=1e-12)  # the anchor's own
    cache.at(R, slope=True)
    assert cache.slope_evaluations == 3  # kept while the anchor is
    cache.at(so3.exp(np.array([0.0, 0.0, 3e-3])) @ A, slope=True)
    assert cache.evaluations == 2 and cache.slope_evaluations == 6  # a new anchor, new slopes


def test_rest_bandwidth_follows_the_coil():
    """With a bias the estimate's rest pole is 1/T (the coil's L/R), within [10/3 ω_c, ω_m], and in motion
    20/3 ω_c unless the rest pole is higher; the iron prototype's 0.65 H coil (T = 7.8 ms) gives 128 rad/s at rest,
    200 in motion. Without a bias 10/3 ω_c at rest and 10 ω_c in motion."""
    from spherestep.control.controller import disturbance_bandwidths

    assert disturbance_bandwidths(1000.0, 30.0, True, 7.8e-3) == pytest.approx((1 / 7.8e-3, 200.0))
    assert disturbance_bandwidths(1000.0, 30.0, True) == (300.0, 300.0)  # T unknown: the cap
    assert disturbance_bandwidths(1000.0, 30.0, True, 0.78e-3) == (300.0, 300.0)
    assert disturbance_bandwidths(1000.0, 30.0, True, 4e-3) == pytest.approx((250.0, 250.0))  # never below rest
    assert disturbance_bandwidths(1000.0, 30.0, True, 1.0) == pytest.approx((100.0, 200.0))
    assert disturbance_bandwidths(1000.0, 30.0, False, 7.8e-3) == pytest.approx((100.0, 300.0))
    with pytest.raises(InputError, match="time_constant"):
        disturbance_bandwidths(1000.0, 30.0, True, -1.0)
    limits = design_model(prototype()).limits
    law = ServoLaw(iron_model(prototype()), Trajectory.hold(np.eye(3)), GeometricPD(0.0724), limits=limits)
    assert law.observer.disturbance_bandwidth == pytest.approx(1 / limits.time_constant) \
        and 120 < law.observer.disturbance_bandwidth < 135 and law.observer.motion_bandwidth == pytest.approx(200.0)


@pytest.mark.parametrize("name, k", [("detent ×1.2", 4), ("winding ×0.85", 4), ("winding ×0.85", 14)])
def test_holds_near_the_bound_and_against_the_stiffness(design, name, k):
    """The holds the table missed with the iron coil's 0.65 H (benchmarks/bench_servo_robust.py, same orientation
    and noise seed, 1.2 s): #4 of so3.random(20, 0) needs four coils at 98 % of their bound (the old default, a
    300 rad/s estimate at rest, 0.089° / 0.057°: its noise rectified by the coils' slow rise near the bound), #14
    a detent stiffness of 226 N·m/rad (the law's K and b to first order at rest). Both within 0.05° now. The
    controller is the pairwise model these were measured with (MismatchCase(controller="pairwise"))."""
    from dataclasses import replace

    from spherestep.dynamics import hold
    from spherestep.sensing import NoisySensor

    case = replace(next(c for c in MISMATCH_CASES if c.name == name), controller="pairwise")
    plant, model = case.build(design)
    limits, rotor = design_model(design).limits, Rotor.from_design(design)
    target = so3.random(20, 0)[k]
    errors = {}
    for wd in (None, 300.0):
        run = hold(design, target, plant, duration=1.2, limits=limits, rotor=rotor, controller_model=model,
                   sensor=NoisySensor(math.radians(0.02), rng=1 + k), disturbance_bandwidth=wd)
        errors[wd] = run.tracking_error[run.times >= 1.0 - 1e-9].max()
    assert errors[None] <= HOLD
    if (name, k) == ("detent ×1.2", 4):
        assert errors[300.0] > HOLD  # the old rest pole misses it (measured 0.085°)


@pytest.mark.slow
def test_the_weakest_plant_tracks_the_turn_with_the_motion_pole_at_200(design):
    """The table's ×0.85 winding, ×1.2 detent plant under the design's coupled model (MismatchCase's default
    controller), the demo's 360° turn within MARGIN (planned on the pairwise model), 0.02° noise: with the
    estimate's motion pole at 20/3 ω_c (200 rad/s, the default with a bias) it tracks within 0.5° (measured
    0.32°); at the former 300 rad/s the noise pushes 6 % of the requests out of the back-EMF-limited supply box
    and it lags by 0.83°."""
    from spherestep.dynamics import simulate_servo
    from spherestep.dynamics.robustness import NOISE, TURN_AXIS, TURN_ANGLE
    from spherestep.commutation.turn import turn_targets
    from spherestep.control import plan_turn
    from spherestep.sensing import NoisySensor

    case = next(c for c in MISMATCH_CASES if c.name == "winding ×0.85, detent ×1.2")
    assert case.controller == "coupled" and next(c for c in MISMATCH_CASES if c.coupling).controller == "pairwise"
    plant, model = case.build(design)
    own = design_model(design)
    assert model.coupling is not None and plant.coupling is not None
    rotor = Rotor.from_design(design)
    start = turn_targets(design, TURN_AXIS, TURN_ANGLE, steps=1)[0]
    traj = plan_turn(design_model(design, coupling=False).model, start, TURN_AXIS, TURN_ANGLE, rotor.inertia,
                     own.limits, damping=rotor.damping, margin=MARGIN)
    out = {}
    for wm in (None, 300.0):
        run = simulate_servo(design, traj, plant, limits=own.limits, rotor=rotor, settle=0.2, controller_model=model,
                             sensor=NoisySensor(NOISE, rng=0), motion_bandwidth=wm)
        out[wm] = run.tracking_error.max()
    assert out[None] <= MAX_TRACKING < out[300.0]


def test_mismatch_case_controller():
    """A case's controller is 'coupled' (default) or 'pairwise'; the coupled plant only against the pairwise one."""
    from spherestep.magnetics.mismatch import MismatchCase

    assert MismatchCase("x").controller == "coupled" and MismatchCase("x").to_dict()["controller"] == "coupled"
    with pytest.raises(InputError, match="controller"):
        MismatchCase("x", controller="air")
    with pytest.raises(InputError, match="controller"):
        MismatchCase("x", coupling=True)
