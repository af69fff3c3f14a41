"""The hardware law's delay compensation (issue 38 §4) and the wire's voltage (§1), each against an independent
check: the lead's prediction against the closed form of a constant acceleration about a fixed axis, the
current-lag pre-emphasis against a fine integration of the first-order response, the box and the power ball it
is kept in, and ``wire_limits``' voltage bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.control import DriveLimits, GeometricPD, ServoLaw, Trajectory


@pytest.fixture(scope="module")
def model():
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype

    return torque_map(prototype())


def law(model, **options):
    traj = Trajectory.hold(np.eye(3))
    return ServoLaw(model, traj, GeometricPD(2e-3, rate=500.0), limits=DriveLimits(), **options)


def test_the_lead_carries_the_state_on_under_the_torque_already_commanded(model):
    """ω and the torque about one axis: the rotation is exp(θ(t) n) with θ = |ω| t + ½ α t², exactly (the
    trapezoid of ``_ahead`` is exact for a constant acceleration about a fixed axis)."""
    s = law(model, lead=3e-3)
    obs = s.observer
    n = np.array([1.0, 0.5, 2.0]) / np.linalg.norm([1.0, 0.5, 2.0])
    obs.R, obs.w, obs.d = so3.exp(0.3 * n), 2.0 * n, 0.01 * n
    s._promised.append(0.05 * n)  # the newest promise: what the drive applies until the next command acts
    R, w = s._ahead(3e-3)
    alpha = (0.05 + 0.01 - s.controller.damping * 2.0) / obs.inertia  # along n
    assert np.allclose(w, (2.0 + alpha * 3e-3) * n, atol=1e-12)
    theta = 2.0 * 3e-3 + 0.5 * alpha * 3e-3 ** 2
    assert np.allclose(R, so3.exp(theta * n) @ so3.exp(0.3 * n), atol=1e-12)
    # the observer itself is not moved
    assert np.allclose(obs.R, so3.exp(0.3 * n)) and np.allclose(obs.w, 2.0 * n)


def test_the_setpoint_sent_has_the_allocations_current_as_its_mean_over_the_period(model):
    """c' = c + β/(1 − β)(c − c'_prev): the first-order response from c'_prev toward c' with τ, averaged over the
    period by a fine integration (10⁵ exact sub-steps), is c — within the box and the power ball."""
    tau, h = 5e-4, 1 / 500
    s = law(model, current_lag=tau)
    n = model.coil_count
    rng = np.random.default_rng(1)
    s._box[0][:], s._box[1][:] = -1.0, 1.0
    s._sent = rng.uniform(-0.3, 0.3, n)
    c = s._sent + rng.uniform(-0.1, 0.1, n)
    previous = s._sent.copy()
    out = s._emphasised(c)
    steps = 100_000
    dt = h / steps
    i, total = previous.copy(), np.zeros(n)
    for _ in range(steps):  # exact per sub-step, trapezoidal mean
        nxt = out + (i - out) * math.exp(-dt / tau)
        total += 0.5 * (i + nxt) * dt
        i = nxt
    np.testing.assert_allclose(total / h, c, atol=1e-9)
    assert np.array_equal(s._sent, out)


def test_the_pre_emphasis_stays_within_the_box_and_the_power_ball(model):
    s = law(model, current_lag=5e-4)
    n = model.coil_count
    rho = s.limits.per_unit_power_radius
    top = 0.8 * rho / math.sqrt(n)  # a box whose corner is inside the ball
    s._box[0][:], s._box[1][:] = -top, top
    s._sent = np.zeros(n)
    c = np.full(n, 0.9 * top)  # near the box: the emphasis is cut at its face
    out = s._emphasised(c)
    assert np.all(out <= top + 1e-12) and np.all(out >= c) and np.linalg.norm(out) < rho
    s._sent = np.zeros(n)
    s._box[0][:], s._box[1][:] = -1.0, 1.0
    c = np.full(n, 0.98 * rho / math.sqrt(n))  # inside the ball; the emphasis would leave it: cut at its surface
    out = s._emphasised(c)
    assert np.linalg.norm(c) < rho and np.linalg.norm(out) == pytest.approx(rho, rel=1e-12)
    assert np.all(out >= c) and np.all(out <= 1.0)


def test_no_lag_no_lead_is_the_simulations_law(model):
    s = law(model)
    assert s.lead == 0 and s._emphasis == 0


def test_the_sessions_current_lag_is_the_devices_loop_and_none_on_a_board():
    from spherestep.drive.session import current_lag

    assert current_lag("port") == 0.0
    assert current_lag("pty") == pytest.approx(1 / 2000) and current_lag("lockstep") == pytest.approx(1 / 2000)
    assert current_lag("qemu") == pytest.approx(1 / 500)


def test_the_wire_gives_the_law_the_bridges_voltage():
    from spherestep.hardware import wire_limits

    d = DriveLimits()
    w = wire_limits(d)
    assert w.supply_voltage == pytest.approx(0.95 * d.supply_voltage)
    assert w.voltage_bound == pytest.approx(0.95 * d.supply_voltage / (d.resistance * d.nominal_current))
    assert w.max_current == pytest.approx(0.99 * d.max_current)


def test_the_period_means_of_a_lagging_current_are_a_fine_integrations():
    """``electrics.period_means`` (what calibration regresses on) against 10⁴ exact sub-steps per period of the
    first-order response to random setpoints (τ = 0.5 ms, h = 2 ms), from rest: within 1e-12 relative."""
    from spherestep.electrics import period_means

    rng = np.random.default_rng(3)
    c = rng.normal(size=(6, 4))
    tau, h, n = 5e-4, 2e-3, 10_000
    i, means = np.zeros(4), []
    a = np.exp(-h / n / tau)
    for setpoint in c:  # exact step of di/dt = (c − i)/τ; the mean of each sub-step's exact integral
        total = np.zeros(4)
        for _ in range(n):
            total += setpoint + (i - setpoint) * tau / (h / n) * (1 - a)
            i = setpoint + (i - setpoint) * a
        means.append(total / n)
    assert np.allclose(period_means(c, tau, h), means, rtol=0, atol=1e-12 * np.abs(c).max())
