"""The time-optimal turn with a bias torque (control.time_optimal): phase plane against closed forms, the tabulated
time law, the reachable interval against the allocation, and the iron prototype's demo turn."""

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.control import DriveLimits, TimeLaw, Trajectory, allocate_matrix
from spherestep.control.time_optimal import (TURN_MARGIN, banded_phase_plane, current_box, fastest_turn,
                                            phase_plane, reachable_interval)


def _law(pp, axis=(0.0, 0.0, 1.0), start=np.eye(3)):
    n = np.asarray(axis, float) / np.linalg.norm(axis)
    return TimeLaw(np.asarray(start, float), n, float(pp.s[-1]), 0.0, pp.times, pp.s, np.sqrt(pp.x), pp.sdd)


def test_constant_interval_gives_the_bang_bang_time():
    theta, A = 2.0, 3.0
    pp = phase_plane(np.linspace(0, theta, 201), np.full(201, -A), np.full(201, A))
    assert pp.feasible
    assert pp.duration == pytest.approx(2 * math.sqrt(theta / A), rel=1e-12)
    # asymmetric: accelerate at A, brake at D: v = √(2θAD/(A+D)), T = v/A + v/D (switch at a grid point)
    D = 1.0
    pp = phase_plane(np.linspace(0, theta, 401), np.full(401, -D), np.full(401, A))
    v = math.sqrt(2 * theta * A * D / (A + D))
    assert pp.duration == pytest.approx(v / A + v / D, rel=1e-3)
    assert np.sqrt(pp.x).max() == pytest.approx(v, rel=1e-3)


def test_speed_bands():
    theta, A = 2.0, 3.0
    s = np.linspace(0, theta, 201)
    # the same interval in every band: the bang-bang time; the top level caps the speed
    pp = banded_phase_plane(s, (1.0, 2.0, 10.0), lambda i, j: (-A, A))
    assert pp.duration == pytest.approx(2 * math.sqrt(theta / A), rel=1e-12)
    capped = banded_phase_plane(s, (0.5, 1.0), lambda i, j: (-A, A))
    assert np.sqrt(capped.x).max() == pytest.approx(1.0, rel=1e-12)
    assert capped.duration == pytest.approx(theta / 1.0 + 1.0 / A, rel=1e-3)
    # nested bands (a faster band's interval inside a slower one's): every piece within the band of its faster end
    levels = (0.5, 1.0, 1.5)
    bands = [(-3.0 + 0.5 * j, 3.0 - 1.0 * j) for j in range(3)]
    pp = banded_phase_plane(s, levels, lambda i, j: bands[j])
    sd = np.sqrt(pp.x)
    j = np.searchsorted(np.square(levels), np.maximum(pp.x[:-1], pp.x[1:]) - 1e-12)
    lo, hi = np.array(bands)[j].T
    assert np.all(pp.sdd <= hi + 1e-9) and np.all(pp.sdd >= lo - 1e-9) and sd.max() <= 1.5 + 1e-12
    # slower than the widest band alone, faster than the narrowest alone
    assert phase_plane(s, np.full(201, -3.0), np.full(201, 3.0), speed=1.5).duration < pp.duration
    assert pp.duration < phase_plane(s, np.full(201, -2.0), np.full(201, 1.0), speed=1.5).duration


def test_speed_cap_and_damping():
    theta, A = 2.0, 3.0
    s = np.linspace(0, theta, 401)
    pp = phase_plane(s, np.full(401, -A), np.full(401, A), speed=1.0)
    assert np.sqrt(pp.x).max() <= 1.0 + 1e-12
    assert pp.duration == pytest.approx(theta / 1.0 + 1.0 / A, rel=1e-3)  # trapezoid: θ/v + v/a
    beta = 0.5
    damped = phase_plane(s, np.full(401, -A), np.full(401, A), beta)
    sd = np.sqrt(damped.x)
    for v in (sd[:-1], sd[1:]):  # s̈ + β ṡ within [−A, A] at both ends of every piece
        assert np.all(damped.sdd + beta * v <= A + 1e-9) and np.all(damped.sdd + beta * v >= -A - 1e-9)
    assert damped.duration > phase_plane(s, np.full(401, -A), np.full(401, A)).duration


def test_infeasible_cases_are_named():
    s = np.linspace(0, 1, 11)
    hi = np.full(11, 2.0)
    hi[5] = -50.0  # a spot where the coils push backwards harder than the speed carries: cannot pass
    pp = phase_plane(s, np.full(11, -60.0), hi)
    assert not pp.feasible and "push" in pp.reason
    lo = np.full(11, -1.0)
    lo[0] = 0.5  # cannot hold at the start
    assert "start" in phase_plane(s, lo, np.full(11, 1.0)).reason
    assert not phase_plane(s, np.full(11, np.nan), np.full(11, 1.0)).feasible


def test_time_law_samples_rest_to_rest_with_consistent_derivatives():
    R0 = so3.random(1, 4)[0]
    s = np.linspace(0, 1.5, 151)
    lo = -2.0 - np.sin(3 * s)
    hi = 2.5 + np.cos(2 * s)
    pp = phase_plane(s, lo, hi)
    tr = Trajectory((_law(pp, (1.0, 0.5, 2.0), R0),))
    n = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])
    R, w, a = tr.sample(np.array([-1.0, 0.0, tr.duration, tr.duration + 1.0]))
    np.testing.assert_allclose(R[0], R0, atol=1e-12)
    np.testing.assert_allclose(R[-1], so3.exp(1.5 * n) @ R0, atol=1e-12)
    np.testing.assert_allclose(w, 0.0, atol=1e-12)
    np.testing.assert_allclose(a[[0, -1]], 0.0, atol=0)
    t = np.linspace(0.01, tr.duration - 0.01, 200)
    h = 1e-6
    Rp, wp, _ = tr.sample(t + h)
    Rm, wm, _ = tr.sample(t - h)
    _, w, a = tr.sample(t)
    np.testing.assert_allclose(so3.log(Rp @ np.swapaxes(Rm, 1, 2)) / (2 * h), w, atol=1e-6)
    kinks = np.abs(np.searchsorted(pp.times, t + h) - np.searchsorted(pp.times, t - h)) > 0
    np.testing.assert_allclose(((wp - wm) / (2 * h))[~kinks], a[~kinks], atol=1e-5)
    # s̈ within the interval at every sample (the law is piecewise constant between grid points: both ends)
    sdd = a @ n
    pos = so3.log(so3.as_rotations(tr.sample(t)[0]) @ R0.T) @ n
    assert np.all(sdd <= np.interp(pos, s, hi) + 0.06) and np.all(sdd >= np.interp(pos, s, lo) - 0.06)
    single = tr.at(float(t[17]))
    np.testing.assert_allclose(single[1], w[17], atol=1e-12)


def test_reachable_interval_matches_the_allocation():
    rng = np.random.default_rng(3)
    K = rng.normal(size=(4, 3, 12)) * 0.4
    b = rng.normal(size=(4, 3)) * 0.3
    d = np.array([0.3, -1.0, 0.5])
    n = d / np.linalg.norm(d)
    limits = DriveLimits()
    lo, hi = reachable_interval(K, b, d, limits)
    for k in range(4):
        for y in (lo[k], hi[k], 0.5 * (lo[k] + hi[k])):
            alloc = allocate_matrix(K[k], y * n - b[k], limits)[0]
            assert alloc.reachable, (k, y)
        for y in (hi[k] + 1e-4, lo[k] - 1e-4):
            assert not allocate_matrix(K[k], y * n - b[k], limits)[0].reachable
    # the back-EMF box: at speed v the motoring coils lose what their EMF takes; beyond the supply a coil must
    # brake (its box no longer holds 0), and where no current serves every speed of the band the box is empty
    lower, upper = current_box(K, n, limits, speed=2.0)
    g = np.einsum("man,a->mn", K, n) / (limits.resistance * limits.nominal_current ** 2)
    np.testing.assert_allclose(upper, 1.0 - np.maximum(g, 0) * 2.0)
    fast = 1.5 / np.abs(g).max()  # the best-aligned coil's EMF 1.5 × the supply: it brakes, within its bound
    lower, upper = current_box(K, n, limits, speed=fast)
    assert np.any(upper < 0) and np.all(lower <= upper) and np.all((upper >= 0) | (lower < 0))
    lower7, upper7 = current_box(K, n, limits, speed=2.0, scale=0.7)  # the whole EMF against 70 % of the supply
    np.testing.assert_allclose(upper7, 0.7 - np.maximum(g, 0) * 2.0)
    np.testing.assert_allclose(lower7, -0.7 + np.maximum(-g, 0) * 2.0)
    lower3, upper3 = current_box(K, n, limits, speed=2 * fast)  # 3 × the supply: no current serves every speed
    empty = np.any(lower3 > upper3, axis=1)
    assert np.any(empty)
    lo2, hi2 = reachable_interval(K, b, d, limits, speed=2 * fast)
    assert np.all(np.isnan(lo2[empty]))
    slow = 0.5 / np.abs(g).max()  # every coil's EMF within half the supply: the interval shrinks, not empty
    lo3, hi3 = reachable_interval(K, b, d, limits, speed=slow)
    assert np.all(hi3 <= hi + 1e-9) and np.all(lo3 >= lo - 1e-9) and not np.any(np.isnan(lo3))


@pytest.fixture(scope="module")
def iron_turn():
    from spherestep.commutation import turn
    from spherestep.dynamics import Rotor
    from spherestep.magnetics import design_model
    from spherestep.motor import prototype

    design = prototype()
    dm = design_model(design)
    inertia = Rotor.from_design(design).inertia
    R0 = turn(design, (1.0, 0.5, 2.0), 360.0).targets[0]
    return design, dm, inertia, R0, fastest_turn(dm.model, R0, (1.0, 0.5, 2.0), 2 * math.pi, inertia, dm.limits)


@pytest.mark.slow
def test_iron_turn_is_found_and_its_feed_forward_is_within_the_margin(iron_turn):
    design, dm, inertia, R0, ft = iron_turn
    tr = ft.trajectory
    # within MARGIN the detent forbids the turn itself; within TURN_MARGIN it is found (the last path tried)
    assert ft.candidates[0][1] is None and ft.candidates[-1][1] == pytest.approx(ft.duration)
    n = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])
    R_end, w_end, _ = tr.sample(np.array([tr.duration]))
    np.testing.assert_allclose(R_end[0], so3.exp(2 * math.pi * n) @ R0, atol=1e-9)
    assert np.linalg.norm(w_end) <= 1e-12
    assert tr.duration <= 1.5  # issue 25 §3's target (beats the demo's fixed 3.0 s)
    model, limits = dm.model, dm.limits
    m = ft.margin
    assert m == TURN_MARGIN
    scaled = limits.replace(max_current=m * limits.max_current, supply_power=m ** 2 * limits.supply_power)
    knots = np.concatenate([seg.t0 + seg.times for seg in tr.segments])
    rng = np.random.default_rng(0)
    for t, lim in ((rng.choice(knots, 60, replace=False), scaled), (rng.uniform(0, tr.duration, 60), limits)):
        R, w, a = tr.sample(t)
        K = np.asarray(model.torque_matrix(R))
        b = np.asarray(model.torque(R, np.zeros((len(R), model.coil_count))))
        for k in range(len(t)):  # the feed-forward I α within the margin at the grid points, within the limits between
            assert allocate_matrix(K[k], inertia * a[k], lim, bias=b[k])[0].reachable, t[k]


@pytest.mark.slow
def test_servo_tracks_the_iron_turn(iron_turn):
    from spherestep.dynamics.servo import simulate_servo
    from spherestep.sensing.sensor import NoisySensor

    design, dm, inertia, R0, ft = iron_turn
    run = simulate_servo(design, ft.trajectory, dm.model, limits=dm.limits,
                         sensor=NoisySensor(math.radians(0.02), rng=0), settle=0.3)
    # the feedback has 10 % of the drive and the supply's power (with the coils' L i di/dt) bounds the change of
    # the currents each period: the request is out of reach now and then (0.79)
    assert run.reachable.mean() >= 0.75
    assert math.degrees(run.tracking_error.max()) <= 0.5
    assert math.degrees(run.final_error) <= 0.05  # issue 25's targets: ≤ 0.5° on the way, ≤ 0.05° at the end


@pytest.mark.slow
def test_air_core_time_optimal_beats_the_trapezoid_and_respects_the_bound():
    from spherestep.commutation import turn
    from spherestep.control import bang_bang_time, plan_trapezoid, plan_turn
    from spherestep.dynamics import Rotor
    from spherestep.magnetics import design_model
    from spherestep.motor import prototype

    design = prototype()
    dm = design_model(design, "air")
    inertia = Rotor.from_design(design).inertia
    R0 = turn(design, (1.0, 0.5, 2.0), 90.0).targets[0]
    args = (dm.model, R0, (1.0, 0.5, 2.0), math.radians(90), inertia, dm.limits)
    fast = plan_turn(*args)
    assert isinstance(fast.segments[0], TimeLaw)
    assert bang_bang_time(*args) < fast.duration < plan_trapezoid(*args).duration


def test_headroom_and_smoothing():
    """The feed-forward's box keeps ``headroom × |g_k| ṡ`` of each coil's voltage for ``L di/dt``; the smoothed
    law is the moving average of the position: rest to rest, ``w`` longer, its acceleration continuous."""
    from spherestep.control.time_optimal import smoothed

    rng = np.random.default_rng(3)
    K = rng.normal(scale=0.2, size=(2, 3, 9))
    d = np.array([0.0, 0.6, 0.8])
    limits = DriveLimits()
    g = np.einsum("man,a->mn", K, d) / (limits.resistance * limits.nominal_current ** 2)
    lo0, hi0 = current_box(K, d, limits, speed=1.0)
    lo1, hi1 = current_box(K, d, limits, speed=1.0, headroom=0.1)
    inner = (hi0 < limits.per_unit_bound) & (lo0 > -limits.per_unit_bound)
    np.testing.assert_allclose((hi0 - hi1)[inner], 0.1 * np.abs(g)[inner])
    np.testing.assert_allclose((lo1 - lo0)[inner], 0.1 * np.abs(g)[inner])
    s = np.linspace(0, 1.5, 151)
    law = _law(phase_plane(s, np.full(151, -3.0), np.full(151, 3.0)), (1.0, 0.5, 2.0))
    w = 0.02
    sm = smoothed(law, w)
    assert sm.duration == pytest.approx(law.duration + w)
    assert sm.positions[-1] == pytest.approx(1.5) and sm.speeds[0] == sm.speeds[-1] == 0.0
    assert np.abs(sm.accelerations).max() <= 3.0 + 1e-6
    assert np.abs(np.diff(sm.accelerations)).max() <= 6.0 / w * 2.5e-4 * 1.01  # |Δs̈| ≤ 2A/w per step
    for t in (0.3, law.duration / 2, law.duration):  # the moving average of the position
        u = np.linspace(t - w, t, 2001)
        mean = np.trapezoid(np.where(u >= 0, law.profile(u)[0], 0.0), u) / w
        assert sm.profile_at(t)[0] == pytest.approx(mean, abs=1e-6)
