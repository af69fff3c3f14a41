"""Current allocation, torque capability and trajectories (spherestep.control) against independent solves."""

import itertools
import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import minimize

from spherestep import so3
from spherestep.control import (DriveLimits, Trajectory, allocate, allocate_matrix, allocate_relay,
                                available_torque, bang_bang_time, feasible_support, plan_through, plan_trapezoid,
                                plan_turn, torque_capability)
from spherestep.errors import InputError
from spherestep.magnetics import torque_map
from spherestep.motor import prototype

LIMITS = DriveLimits()
RHO = LIMITS.per_unit_power_radius


@pytest.fixture(scope="module")
def tmap():
    return torque_map(prototype())


@pytest.fixture(scope="module")
def matrices(tmap):
    return tmap.torque_matrix(so3.random(12, 5))


def slsqp_least_power(K, t, u):
    """Independent solve: SciPy SLSQP on min ‖c‖² s.t. K c = t, |c| ≤ u."""
    res = minimize(lambda c: c @ c, np.zeros(K.shape[1]), jac=lambda c: 2 * c, method="SLSQP",
                   bounds=[(-b, b) for b in u],
                   constraints=[{"type": "eq", "fun": lambda c: K @ c - t, "jac": lambda c: K}],
                   options={"ftol": 1e-14, "maxiter": 500})
    return res.x


def slsqp_closest(K, t, u, rho):
    """Independent solve of the closest reachable torque: min ‖K c − t‖² over the box and the power ball."""
    best = None
    for x0 in (np.zeros(K.shape[1]), np.clip(np.linalg.pinv(K) @ t, -u, u)):
        res = minimize(lambda c: np.sum((K @ c - t) ** 2), x0, jac=lambda c: 2 * K.T @ (K @ c - t),
                       method="SLSQP", bounds=[(-b, b) for b in u],
                       constraints=[{"type": "ineq", "fun": lambda c: rho * rho - c @ c, "jac": lambda c: -2 * c}],
                       options={"ftol": 1e-15, "maxiter": 1000})
        if best is None or res.fun < best.fun:
            best = res
    return best.x


def test_allocation_matches_an_independent_qp_and_meets_every_constraint(matrices):
    rng = np.random.default_rng(1)
    u = np.ones(29)
    for K in matrices:
        for size in (0.3, 1.0, 1.8):  # small: no coil saturates; larger: the box is active on some coils
            t = rng.normal(size=3)
            t *= size / np.linalg.norm(t)
            a, _ = allocate_matrix(K, t, LIMITS)
            assert a.reachable and a.method == "newton"
            np.testing.assert_allclose(K @ a.currents, t, atol=1e-9)
            assert np.abs(a.currents).max() <= 1 + 1e-12 and a.currents @ a.currents <= RHO ** 2 + 1e-9
            ref = slsqp_least_power(K, t, u)
            np.testing.assert_allclose(K @ ref, t, atol=1e-6)
            # optimal: no feasible currents use less power (to 1e-6 of the power)
            assert a.currents @ a.currents <= ref @ ref + 1e-6
            np.testing.assert_allclose(a.currents, ref, atol=1e-4)
            assert a.power == pytest.approx(LIMITS.resistance * (a.currents @ a.currents), rel=1e-12)


def test_box_active_cases_saturate_and_stay_optimal():
    rng = np.random.default_rng(7)
    limits = DriveLimits(max_current=0.3)  # a tight box: many coils at their bound
    u = np.full(29, 0.3)
    saturated = 0
    for _ in range(20):
        K = rng.normal(size=(3, 29))
        t = rng.normal(size=3) * 2.0
        a, _ = allocate_matrix(K, t, limits)
        if not a.reachable:
            continue
        saturated += int(np.sum(np.isclose(np.abs(a.currents), 0.3)))
        ref = slsqp_least_power(K, t, u)
        assert a.currents @ a.currents <= ref @ ref + 1e-6
        np.testing.assert_allclose(K @ a.currents, t, atol=1e-9)
    assert saturated > 10


def test_out_of_reach_gives_the_closest_reachable_torque(matrices):
    rng = np.random.default_rng(3)
    u = np.ones(29)
    for K in matrices[:6]:
        t = rng.normal(size=3)
        t *= 6.0 / np.linalg.norm(t)  # beyond the ~2.5 N·m the supply allows
        a, _ = allocate_matrix(K, t, LIMITS)
        assert not a.reachable and a.method == "conic"
        assert np.abs(a.currents).max() <= 1 + 1e-9 and a.currents @ a.currents <= RHO ** 2 * (1 + 1e-9)
        ref = slsqp_closest(K, t, u, RHO)
        assert a.error <= np.linalg.norm(K @ ref - t) + 1e-6
        assert a.error == pytest.approx(np.linalg.norm(K @ ref - t), abs=1e-5)


def test_allocated_currents_reproduce_the_torque_through_the_model(tmap):
    R = so3.random(4, 11)
    rng = np.random.default_rng(11)
    for Rk in R:
        t = rng.normal(size=3) * 0.6
        a = allocate(tmap, Rk, t)
        np.testing.assert_allclose(tmap.torque(Rk, a.currents), t, atol=1e-9)


def test_failed_coils_carry_nothing_and_the_torque_is_still_given(tmap):
    R = so3.random(1, 2)[0]
    K = tmap.torque_matrix(R)
    strongest = tuple(int(k) for k in np.argsort(-np.linalg.norm(K, axis=0))[:4])
    broken = replace(tmap, failed=strongest)
    t = np.array([0.4, -0.3, 0.5])
    a = allocate(broken, R, t)
    assert a.reachable
    assert np.all(a.currents[list(strongest)] == 0)
    np.testing.assert_allclose(broken.torque(R, a.currents), t, atol=1e-9)
    healthy = allocate(tmap, R, t)
    assert a.power > healthy.power  # working around the strongest coils costs power


def test_bias_torque_is_included():
    rng = np.random.default_rng(5)
    K = rng.normal(size=(3, 29))
    bias = np.array([0.2, -0.1, 0.05])
    t = np.array([0.5, 0.5, 0.0])
    a, _ = allocate_matrix(K, t, LIMITS, bias=bias)
    np.testing.assert_allclose(bias + K @ a.currents, t, atol=1e-10)
    np.testing.assert_allclose(a.currents, np.linalg.pinv(K) @ (t - bias), atol=1e-10)  # min-norm, box inactive


def test_compiled_newton_is_the_numpy_reference_to_rounding(matrices):
    """The loop's compiled semismooth Newton (numba) against the NumPy reference, cold and warm-started, with the
    box active or not, a failed coil, and requests out of reach (where both must say so)."""
    from spherestep._fast.allocation import solve_box as least_power_box_compiled
    from spherestep.control.allocation import least_power_box

    rng = np.random.default_rng(3)
    u = np.ones(29)
    u[4] = 0.0
    converged = 0
    for K in matrices:
        for size in (0.05, 0.5, 1.5, 6.0):
            t = size * rng.normal(size=3)
            for lam0 in (None, rng.normal(size=3)):
                c, lam, ok = least_power_box(K, t, u, lam0)
                c2, lam2, ok2 = least_power_box_compiled(K, t, u, lam0)
                assert ok == ok2
                if ok:
                    converged += 1
                    assert np.abs(c2 - c).max() <= 1e-12 and np.abs(lam2 - lam).max() <= 1e-9 * np.abs(lam).max()
                    assert np.linalg.norm(K @ c2 - t) <= 1e-10 * (np.linalg.norm(t) + 1)
                    assert np.all(np.abs(c2) <= u) and c2[4] == 0.0
    assert converged >= 60  # most requests are reachable: the comparison is not vacuous


def test_compiled_closest_reachable_is_at_least_as_close_as_clarabel(matrices):
    """Out of reach, the compiled bisection on the power ball's multiplier finds the closest reachable torque:
    within the box and the ball, as close to the request as Clarabel's conic solution (to 1e-7, and 1e-9 of ‖K‖‖u‖) and the same
    torque (to 1e-5 of the request: Clarabel stops at its own tolerance and is pulled back into the limits)."""
    from spherestep._fast.allocation import solve_reachable as closest_reachable_compiled
    from spherestep.control.allocation import closest_reachable

    rng = np.random.default_rng(4)
    u = np.ones(29)
    u[7] = 0.0
    solved = 0
    for K in matrices:
        for size in (0.5, 3.0, 30.0):
            t = size * rng.normal(size=3)
            c = closest_reachable_compiled(K, t, u, RHO)
            if c is None:
                continue
            solved += 1
            ref = closest_reachable(K, t, u, RHO)
            assert np.all(np.abs(c) <= u) and c @ c <= RHO * RHO * (1 + 1e-12) and c[7] == 0.0
            scale = np.linalg.norm(K) * np.linalg.norm(u) + np.linalg.norm(t)  # the solver's residual scale
            assert np.linalg.norm(K @ c - t) <= np.linalg.norm(K @ ref - t) * (1 + 1e-7) + 1e-9 * scale
            assert np.linalg.norm(K @ c - K @ ref) <= 1e-5 * np.linalg.norm(t)
    assert solved >= 30


def test_relay_allocation_is_the_best_combination():
    rng = np.random.default_rng(9)
    K = rng.normal(size=(3, 8))
    t = np.array([1.0, -2.0, 0.5])
    a = allocate_relay(K, t, LIMITS)
    best = min((np.linalg.norm(K @ np.array(c) - t), np.count_nonzero(c))
               for c in itertools.product((-1, 0, 1), repeat=8) if np.count_nonzero(c) <= 4)
    assert a.error == pytest.approx(best[0], abs=1e-12)
    assert set(np.unique(a.currents)) <= {-1.0, 0.0, 1.0} and np.count_nonzero(a.currents) <= 4


def test_allocation_rejects_bad_input(tmap):
    with pytest.raises(InputError, match="torque"):
        allocate(tmap, np.eye(3), [1.0, 2.0])
    with pytest.raises(InputError, match="mode"):
        allocate(tmap, np.eye(3), [0.0, 0.0, 0.1], mode="pwm")
    with pytest.raises(InputError, match="supply_power"):
        DriveLimits(supply_power=-1.0)


def test_feasible_support_matches_an_independent_maximisation():
    rng = np.random.default_rng(2)
    for u_val, rho in ((1.0, RHO), (0.3, RHO), (1.0, 10.0)):
        u = np.full(29, u_val)
        u[[3, 8]] = 0.0  # failed
        g = rng.normal(size=29)
        h, c = feasible_support(g, u, rho)
        res = minimize(lambda x, g=g: -g @ x, np.zeros(29), jac=lambda x, g=g: -g, method="SLSQP",
                       bounds=[(-b, b) for b in u],
                       constraints=[{"type": "ineq", "fun": lambda x, r=rho: r * r - x @ x, "jac": lambda x: -2 * x}],
                       options={"ftol": 1e-14, "maxiter": 500})
        assert h == pytest.approx(-res.fun, rel=1e-7)
        assert h == pytest.approx(g @ c, rel=1e-12)
        assert np.all(np.abs(c) <= u + 1e-12) and c @ c <= rho * rho * (1 + 1e-12)


def test_capability_is_the_largest_ball_in_the_reachable_set(tmap):
    cap = torque_capability(prototype(), tmap, samples=6, seed=4, directions=200)
    K = tmap.torque_matrix(cap.rotations)
    rng = np.random.default_rng(0)
    dirs = rng.normal(size=(40, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for k in range(len(K)):
        r, n = cap.radius[k], cap.weakest[k]
        # every torque of size 0.999 r is reachable; just beyond r along the weakest direction is not
        assert all(allocate_matrix(K[k], 0.999 * r * q, LIMITS)[0].reachable for q in dirs)
        assert not allocate_matrix(K[k], 1.002 * r * n, LIMITS)[0].reachable
        # random feasible currents never give more than r along the weakest direction
        c = rng.uniform(-1, 1, size=(20000, 29))
        c *= np.minimum(1.0, RHO / np.linalg.norm(c, axis=1))[:, None]
        assert (c @ K[k].T @ n).max() <= r + 1e-9
    sv = np.linalg.svd(K, compute_uv=False)
    np.testing.assert_allclose(cap.singular_values, sv, rtol=1e-12)
    d = cap.to_dict()
    assert d["available_torque_N_m"][0] == pytest.approx(cap.radius.min())
    assert 0 <= d["fraction_at_least"]["1_N_m"] <= 1


def test_available_torque_of_an_isotropic_ellipsoid_is_known():
    # K = s [I | 0]: only the power ball binds when ρ s is below the box corners: r = s ρ
    K = np.zeros((3, 29))
    K[:, :3] = 0.8 * np.eye(3)
    limits = DriveLimits(max_current=5.0)
    r, _ = available_torque(K, limits)
    assert float(r) == pytest.approx(0.8 * limits.per_unit_power_radius, rel=1e-9)
    r_box, _ = available_torque(K, DriveLimits(max_current=0.5))  # the box binds: 0.8 × 0.5 on each axis
    assert 0.4 <= float(r_box) <= 0.4 * (1 + 1e-6)  # a kinked minimum: the descent gets within 1e-6


def test_trapezoidal_turn_profile_and_derivatives():
    R0 = so3.random(1, 1)[0]
    axis = np.array([1.0, 0.5, 2.0])
    n = axis / np.linalg.norm(axis)
    tr = Trajectory.turn(R0, axis, math.radians(90), acceleration=3.0, speed=0.8)
    seg = tr.segments[0]
    assert tr.duration == pytest.approx(math.radians(90) / 0.8 + 0.8 / 3.0, rel=1e-12)
    R_end, w_end, _ = tr.sample(np.array([tr.duration + 1.0]))
    np.testing.assert_allclose(R_end[0], so3.exp(math.radians(90) * n) @ R0, atol=1e-12)
    assert np.linalg.norm(w_end) == 0
    t = np.linspace(0.01, tr.duration - 0.01, 50)
    h = 1e-6
    Rp, _, _ = tr.sample(t + h)
    Rm, _, _ = tr.sample(t - h)
    _, w, _ = tr.sample(t)
    np.testing.assert_allclose(so3.log(Rp @ np.swapaxes(Rm, 1, 2)) / (2 * h), w, atol=1e-6)
    assert np.abs(np.linalg.norm(w, axis=1)).max() <= 0.8 + 1e-12
    tri = Trajectory.turn(R0, axis, 0.5, acceleration=2.0)
    assert tri.duration == pytest.approx(2 * math.sqrt(0.5 / 2.0), rel=1e-12)
    assert seg.cruise > 0 and tri.segments[0].cruise == 0


def test_waypoints_chain_segments_at_rest():
    W = so3.random(3, 8)
    tr = Trajectory.through(W, acceleration=2.0)
    assert len(tr.segments) == 2
    R, w, _ = tr.sample(np.array([0.0, tr.segments[1].t0, tr.duration]))
    np.testing.assert_allclose(R, W, atol=1e-10)
    np.testing.assert_allclose(w, 0.0, atol=1e-12)


def test_planned_turn_stays_within_the_guaranteed_torque_and_above_the_bound(tmap):
    R0 = so3.random(1, 3)[0]
    inertia = 0.0724
    tr = plan_trapezoid(tmap, R0, [0, 1, 1], math.radians(60), inertia)
    bound = bang_bang_time(tmap, R0, [0, 1, 1], math.radians(60), inertia)
    assert bound < plan_turn(tmap, R0, [0, 1, 1], math.radians(60), inertia).duration < tr.duration
    damped = plan_trapezoid(tmap, R0, [0, 1, 1], math.radians(60), inertia, damping=0.25)
    seg = damped.segments[0]
    r_min = tr.segments[0].acceleration * inertia / 0.7
    assert inertia * seg.acceleration + 0.25 * seg.peak_speed <= 0.7 * r_min * (1 + 1e-9)
    assert damped.duration > tr.duration


def test_log_single_is_the_log_map():
    R = so3.random(500, 3)
    np.testing.assert_allclose(np.array([so3.log_single(r) for r in R]), so3.log(R), atol=1e-13)
    tiny = so3.exp(np.array([1e-10, -2e-10, 3e-10]))
    np.testing.assert_allclose(so3.log_single(tiny), [1e-10, -2e-10, 3e-10], rtol=1e-6)


def test_trajectory_hold_and_at():
    R = so3.random(1, 5)[0]
    hold = Trajectory.hold(R)
    assert hold.duration == 0.0
    for t in (0.0, 0.3, 7.0):
        Rt, w, a = hold.at(t)
        np.testing.assert_array_equal(Rt, R)
        assert not w.any() and not a.any()
    with pytest.raises(InputError, match="R"):
        Trajectory.hold(np.eye(3)[None].repeat(2, 0))
    turn = Trajectory.through(np.stack([R, so3.exp([0.3, 0.1, -0.2]) @ R, so3.exp([0.0, 0.9, 0.1]) @ R]), 4.0, 0.5)
    times = np.linspace(-0.1, turn.duration + 0.1, 97)
    Rs, ws, As = turn.sample(times)
    for k, t in enumerate(times):
        Rt, w, a = turn.at(t)
        np.testing.assert_allclose(Rt, Rs[k], atol=1e-14)
        np.testing.assert_allclose(w, ws[k], atol=1e-14)
        np.testing.assert_allclose(a, As[k], atol=1e-14)


def test_servo_law_units_cache_and_warm_start():
    """The law's one unit convention (per unit c, amperes I_n c), its K(R) cache and the promised torque."""
    from spherestep.control import GeometricPD, ModelCache, ServoLaw

    design = prototype()
    tmap = torque_map(design)
    R0 = so3.random(1, 8)[0]
    limits = DriveLimits(nominal_current=0.5, max_current=0.5)
    law = ServoLaw(tmap, Trajectory.hold(R0), GeometricPD(0.0724), limits=limits)
    off = so3.exp([0.01, 0.0, 0.0]) @ R0
    cmd = law.step(0.0, off)
    np.testing.assert_allclose(law.amperes(cmd.currents), 0.5 * cmd.currents)
    K = tmap.torque_matrix(off)
    np.testing.assert_allclose(cmd.torque, K @ cmd.currents, atol=1e-12)
    np.testing.assert_allclose(cmd.torque, cmd.requested, atol=1e-9)  # reachable: the promise is the request
    assert cmd.reachable and np.abs(cmd.currents).max() <= 1.0 + 1e-12
    cache = ModelCache(tmap)
    cache.at(R0)
    cache.at(so3.exp([1e-3, 0.0, 0.0]) @ R0)
    assert cache.evaluations == 1
    cache.at(so3.exp([3e-3, 0.0, 0.0]) @ R0)
    assert cache.evaluations == 2
    with pytest.raises(InputError, match="trajectory"):
        ServoLaw(tmap, "hold", GeometricPD(0.0724))


def test_limits_from_a_coil_spec():
    from spherestep.electrics import wheeler_inductance
    from spherestep.motor.coil import iron_coil

    design = prototype()
    spec = iron_coil()
    e = spec.electrics(design.coil_diameter, design.coil_length)
    limits = DriveLimits.from_spec(spec, design)
    assert limits.resistance == e["resistance_ohm"] and limits.nominal_current == e["nominal_current_A"]
    assert limits.max_current == pytest.approx(24.0 / e["resistance_ohm"])
    # ρ² R I_n² is the supply's power
    assert limits.per_unit_power_radius ** 2 * limits.resistance * limits.nominal_current ** 2 == pytest.approx(100.0)
    assert DriveLimits.from_spec(spec, design, inductance=0.5).time_constant == pytest.approx(0.5 / e["resistance_ohm"])
    # Wheeler's multilayer formula: L ∝ N², and the defaults' 18.7 mH for 1000 turns on the prototype's coil
    assert wheeler_inductance(2000, 0.0254, 0.041275, 0.0127) == pytest.approx(4 * DriveLimits().inductance)
    assert DriveLimits().inductance == pytest.approx(0.01871, rel=1e-3)


def test_plan_through_waypoints_uses_the_least_guaranteed_torque(tmap):
    W = so3.random(3, 12)
    inertia = 0.0724
    tr = plan_through(tmap, W, inertia, samples=8)
    a = tr.segments[0].acceleration
    assert all(seg.acceleration == a for seg in tr.segments)
    each = [plan_trapezoid(tmap, Ra, so3.log(Rb @ Ra.T), float(np.linalg.norm(so3.log(Rb @ Ra.T))), inertia,
                           samples=8)
            for Ra, Rb in zip(W[:-1], W[1:])]
    assert a == pytest.approx(min(p.segments[0].acceleration for p in each), rel=1e-12)
    R, _, _ = tr.sample(np.array([tr.duration]))
    np.testing.assert_allclose(R[0], W[-1], atol=1e-10)


def test_observer_gains_stay_stable_when_measurements_come_late():
    """Deadbeat gains (ω_o = 1/h) with measurements 1, 2 and 5 periods apart (a loop missing deadlines): the
    velocity error shrinks every correction (l₂Δ ≤ 1; the nominal l₂ = 1/h at Δ = 5h would multiply it by
    1 − l₂Δ = −4)."""
    from spherestep.control import Observer

    h = 5e-3
    obs = Observer(np.eye(3), inertia=0.07, bandwidth=1.0 / h, sensor_period=h)
    assert (obs.l1, obs.l2) == pytest.approx((1.0, 1.0 / h))
    true_w = np.array([0.0, 0.0, 2.0])
    t, errors = 0.0, []
    for gap in (1, 2, 5, 5, 2, 1, 5):
        t += gap * h
        obs.predict(np.zeros(3), gap * h)
        obs.correct(so3.exp(true_w * t), t)
        errors.append(float(np.linalg.norm(obs.w - true_w)))
    assert all(b <= a + 1e-12 for a, b in zip(errors, errors[1:])) and errors[-1] < 1e-9
    assert obs.gains(5 * h) == pytest.approx((1.0, 1.0 / (5 * h)))
    assert obs.gains(1e-3) == pytest.approx((min(2e-3 / h, 1.0), 1e-3 / h ** 2))


def test_one_allocation_call_for_the_servo():
    """The servo's allocation is called in one place in the package: the law (issue 24)."""
    from pathlib import Path

    import spherestep

    root = Path(spherestep.__file__).parent
    calls = [(p.relative_to(root).as_posix(), line.strip()) for p in root.rglob("*.py")
             for line in p.read_text(encoding="utf-8").splitlines()
             if "allocate_matrix(" in line and "def allocate_matrix" not in line and p.name != "allocation.py"
             and not line.strip().startswith(("#", ">>>", "``", ":func:"))]
    assert [p for p, _ in calls] == ["control/servo.py"], calls
