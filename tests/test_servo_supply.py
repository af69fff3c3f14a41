"""The servo law within the supply voltage (issue 25 §3) and its scale estimate (§2): the per-coil asymmetric box
of the compiled allocation against the NumPy reference and Clarabel, the box from the back-EMF, the law's commands
within it at speed, and the scales learnt on a plant whose winding and detent differ from the model's."""

import math

import numpy as np
import pytest

from spherestep._fast.allocation import voltage_box
from spherestep.control import DriveLimits, GeometricPD, ServoLaw, Trajectory, allocate_matrix
from spherestep._fast.allocation import solve_box as least_power_box_compiled
from spherestep._fast.allocation import solve_reachable as closest_reachable_compiled
from spherestep.control.allocation import closest_reachable, least_power_box

LIMITS = DriveLimits()


def _boxes(rng, N):
    """Random per-coil boxes: most hold 0, some lie wholly on one side (a coil braking against its back-EMF)."""
    centre = rng.normal(scale=0.5, size=N)
    width = rng.uniform(0.2, 1.0, size=N)
    lower, upper = centre - width, centre + width
    lower[::3] = np.minimum(lower[::3], 0.0)
    upper[::3] = np.maximum(upper[::3], 0.0)
    return np.clip(lower, -1.0, 1.0), np.clip(upper, -1.0, 1.0)


def test_asymmetric_newton_is_the_reference_and_stays_in_the_box():
    rng = np.random.default_rng(11)
    converged = 0
    for _ in range(40):
        K = rng.normal(scale=0.3, size=(3, 16))
        lower, upper = _boxes(rng, 16)
        t = K @ rng.uniform(lower, upper)  # reachable by construction
        for lam0 in (None, rng.normal(size=3)):
            c, lam, ok = least_power_box(K, t, upper, lam0, lower=lower)
            c2, lam2, ok2 = least_power_box_compiled(K, t, upper, lam0, lower=lower)
            assert ok == ok2
            if ok:
                converged += 1
                assert np.abs(c2 - c).max() <= 1e-12
                assert np.all(c2 >= lower) and np.all(c2 <= upper)
                assert np.linalg.norm(K @ c2 - t) <= 1e-9 * (np.linalg.norm(t) + 1)
    assert converged >= 60


def test_asymmetric_closest_reachable_matches_clarabel():
    rng = np.random.default_rng(12)
    solved = 0
    for _ in range(20):
        K = rng.normal(scale=0.3, size=(3, 16))
        lower, upper = _boxes(rng, 16)
        t = 20.0 * rng.normal(size=3)  # out of reach
        c = closest_reachable_compiled(K, t, upper, 3.0, lower)
        if c is None:
            continue
        solved += 1
        ref = closest_reachable(K, t, upper, 3.0, lower)
        assert np.all(c >= lower - 1e-12) and np.all(c <= upper + 1e-12) and c @ c <= 9.0 * (1 + 1e-12)
        assert np.linalg.norm(K @ c - t) <= np.linalg.norm(K @ ref - t) * (1 + 1e-7) + 1e-8
    assert solved >= 15
    # the allocation with the bounds: within them, reachable flagged
    K = rng.normal(scale=0.3, size=(3, 16))
    lower, upper = _boxes(rng, 16)
    a, _ = allocate_matrix(K, K @ (0.5 * (lower + upper)), LIMITS, bounds=(lower, upper))
    assert a.reachable and np.all(a.currents >= lower) and np.all(a.currents <= upper)
    far, _ = allocate_matrix(K, 50.0 * np.ones(3), LIMITS, bounds=(lower, upper))
    assert not far.reachable and np.all(far.currents >= lower - 1e-12) and np.all(far.currents <= upper + 1e-12)


def test_voltage_box_is_the_supply_against_the_back_emf():
    rng = np.random.default_rng(13)
    K = rng.normal(size=(3, 10))
    w = np.array([0.3, -0.2, 0.5])
    e = w @ K
    lower, upper = np.empty(10), np.empty(10)
    voltage_box(K, w, np.zeros(10), 1.0, 1.0, 0.0, lower, upper)
    inside = np.abs(e) <= 2.0
    np.testing.assert_allclose(upper[inside], np.minimum(1.0, 1.0 - e[inside]))
    np.testing.assert_allclose(lower[inside], np.maximum(-1.0, -1.0 - e[inside]))
    braking = inside & (np.abs(e) > 1.0)
    assert np.any(braking) and np.all(np.sign(upper[braking]) == -np.sign(e[braking]))  # no zero: it must brake
    assert np.all(lower[braking] * upper[braking] > 0)
    pinned = ~inside
    np.testing.assert_allclose(lower[pinned], -np.sign(e[pinned]))
    np.testing.assert_allclose(upper[pinned], -np.sign(e[pinned]))
    # the slew from the previous command: a fraction (1 − s) of the way to the ends the full supply drives it to
    prev = rng.uniform(-0.5, 0.5, 10)
    voltage_box(K, 0.1 * w, prev, 1.0, 1.0, 0.8, lower, upper)
    e = 0.1 * e
    np.testing.assert_allclose(upper, np.minimum(1.0, (1.0 - e) + (prev - (1.0 - e)) * 0.8))


def test_law_commands_stay_within_the_supply_at_speed():
    """A fast turn of the air-core map (the law's estimate fed the true orientations): every command within
    ``|R I_n c_k + K_k·ω̂/I_n| ≤ V`` at the law's own estimate, and with the box off some command is not."""
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype

    model = torque_map(prototype())
    limits = DriveLimits(resistance=24.0, supply_voltage=24.0)
    traj = Trajectory.turn(np.eye(3), [1.0, 0.5, 2.0], math.radians(120), acceleration=400.0)
    times = np.arange(0, traj.duration, 1e-3)
    R = traj.sample(times)[0]
    worst = {}
    for voltage in (True, False):
        law = ServoLaw(model, traj, GeometricPD(2e-3), limits=limits, reuse=0.0, voltage=voltage)
        excess = 0.0
        for t, Rt in zip(times, R):
            cmd = law.step(float(t), Rt)
            K = np.asarray(model.torque_matrix(cmd.estimate))
            volts = limits.resistance * limits.nominal_current * cmd.currents + (cmd.velocity @ K) / limits.nominal_current
            excess = max(excess, float(np.abs(volts).max()) - limits.supply_voltage)
        worst[voltage] = excess
    assert worst[True] <= 1e-9 and worst[False] > 1.0


@pytest.mark.slow
def test_scales_learn_the_plants_winding_and_detent(monkeypatch):
    """On a plant with the winding ×0.85 and the detent ×1.2 the law's bias scale grows over a 60° turn (robust
    plan; at rest the coils hold ×1.2/0.85 of the model's detent), tracking within 0.5°; on the exact model it
    stays small; the winding's scale is not learnt by default (``ADAPT_WINDING``)."""
    from spherestep.control.trajectory import MARGIN
    from spherestep.dynamics import Rotor
    from spherestep.dynamics.robustness import turn_run
    from spherestep.magnetics import design_model
    from spherestep.magnetics.mismatch import MismatchCase
    from spherestep.motor import prototype

    design = prototype()
    limits, rotor = design_model(design).limits, Rotor.from_design(design)
    seen = {}
    original = ServoLaw.step

    def step(self, *args, **kwargs):
        out = original(self, *args, **kwargs)
        seen["scales"] = self.scales
        return out

    monkeypatch.setattr(ServoLaw, "step", step)
    for case in (MismatchCase("both", winding=0.85, detent=1.2), MismatchCase("exact")):
        plant, model = case.build(design)
        _, run = turn_run(design, plant, model, limits, rotor, angle=math.radians(60), margin=MARGIN)
        seen[case.name] = (seen["scales"], run.tracking_error.max())
    (tb, tk), err = seen["both"]
    assert tb > 0.05 and tk == 0.0 and err <= math.radians(0.5)
    (eb, ek), err = seen["exact"]
    assert abs(eb) < 0.1 and ek == 0.0 and err <= math.radians(0.5)


def test_the_one_missed_hold_is_beyond_the_plant():
    """The ×0.85 winding × 1.2 detent plant cannot hold the 5th orientation of ``so3.random(20, 0)`` within the
    limits at all (the hold the robustness table misses), and can hold the others: the honest target there is every
    hold the plant can reach. The plant is the table's: the coupled model scaled (MismatchCase's default)."""
    from spherestep import so3
    from spherestep.dynamics.robustness import RobustnessRow, plant_can_hold
    from spherestep.magnetics import design_model
    from spherestep.magnetics.mismatch import MismatchCase
    from spherestep.motor import prototype

    design = prototype()
    limits = design_model(design).limits
    plant, _ = MismatchCase("both", winding=0.85, detent=1.2).build(design)
    reach, unmet = zip(*(plant_can_hold(plant, R, limits) for R in so3.random(20, 0)))
    assert [k for k, r in enumerate(reach) if not r] == [4] and max(unmet[:4] + unmet[5:]) <= 1e-6
    assert 0.7 < unmet[4] < 1.1  # measured 0.918 N·m at the full 100 W (0.518 on the pairwise plant)
    # the row judges the holds the plant can make; the one it cannot is counted and said
    errors = (0.03,) * 4 + (0.8,) + (0.03,) * 15
    row = RobustnessRow("both", tuple(np.radians(errors)), 2.27, 1e-4, 0.005, 25.0, 0.98, None, reach)
    assert row.passed and row.to_dict()["holds_plant_cannot_make"] == 1
    assert not RobustnessRow("both", tuple(np.radians(errors)), 2.27, 1e-4, 0.005, 25.0, 0.98, None).passed


def test_supply_power_ball_bounds_copper_and_back_emf_power():
    """``emf``: Σ R i² + Σ e_k i_k ≤ P (per unit ‖c‖² + ê·c ≤ ρ²), the least-copper currents where that holds;
    with ``previous``/``period`` also the inductance's ``L I_n² (c² − c_prev²)/(2h)``."""
    rng = np.random.default_rng(21)
    rho2 = LIMITS.per_unit_power_radius ** 2
    same = bound = 0
    for _ in range(60):
        K = rng.normal(scale=0.3, size=(3, 12))
        emf = rng.normal(scale=2.0, size=3) @ K  # ê_k = K_k·ω/(R I_n²): ê·c = ω·K c/(R I_n²)
        t = rng.normal(scale=1.0, size=3)
        a, _ = allocate_matrix(K, t, LIMITS, emf=emf)
        c = a.currents
        assert c @ c <= rho2 * (1 + 1e-9) and np.all(np.abs(c) <= LIMITS.per_unit_bound + 1e-12)
        if emf @ c > 0:  # motoring: the supply's power within P (braking: the copper's, the device's bound)
            assert c @ c + emf @ c <= rho2 * (1 + 1e-9)
        plain, _ = allocate_matrix(K, t, LIMITS)
        p = plain.currents
        if plain.reachable and p @ p + emf @ p <= rho2:  # the supply's bound does not bind: the same currents
            same += 1
            assert a.reachable and np.abs(c - p).max() <= 1e-8
        elif plain.reachable:  # within the copper's bound, beyond the supply's: out of reach now
            bound += 1
            assert not a.reachable
        prev = rng.uniform(-1.0, 1.0, size=12)
        q = 0.5 * LIMITS.time_constant / 1e-3
        b, _ = allocate_matrix(K, t, LIMITS, emf=emf, previous=prev, period=1e-3)
        cb = b.currents
        assert cb @ cb <= rho2 * (1 + 1e-9)
        if emf @ cb > 0 and cb @ cb <= rho2 * (1 - 1e-6):
            assert (1 + q) * (cb @ cb) + emf @ cb <= (rho2 + q * (prev @ prev)) * (1 + 1e-9)
    assert same >= 10 and bound >= 1, (same, bound)


def test_iron_coil_limits_carry_its_own_inductance():
    from dataclasses import replace

    from spherestep.electrics import core_key, wheeler_inductance
    from spherestep.magnetics import iron_inductance
    from spherestep.motor import prototype
    from spherestep.motor.coil import iron_coil

    design = prototype()
    spec = iron_coil()
    D, L = design.coil_diameter, design.coil_length
    iron = DriveLimits.from_spec(spec, design)
    assert iron.inductance == pytest.approx(0.6502, rel=1e-3)  # magnetics.coil_inductance, stored (no solve)
    air = DriveLimits.from_spec(replace(spec, core="air"), design)
    r_p, r_w, depth = spec.groove(D, L)
    assert air.inductance == pytest.approx(wheeler_inductance(spec.turns(D, L), r_w, depth, r_p))
    assert iron.inductance > 4 * air.inductance
    thin = iron_coil(fill_factor=0.3)  # the same core, fewer turns: L ∝ N²
    assert core_key(thin, design) == core_key(spec, design)
    assert iron_inductance(thin, design) == pytest.approx(
        iron.inductance * (thin.turns(D, L) / spec.turns(D, L)) ** 2, rel=1e-12)
    assert DriveLimits.from_spec(spec, design, inductance=0.3).inductance == 0.3
