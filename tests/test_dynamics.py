"""Rotor dynamics: the integrator's accuracy, plan execution and the closed loop.

The torque model here is a small analytic one (each energised coil pulls each pole with energy
``−A p_j c_k exp(κ((R u_j)·v_k − 1))``), with its torque checked against finite differences of its energy,
so these tests exercise the integrator on its own; the motor's potential model is tested in its room.
"""

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.commutation import about_axis, plan_geometric
from spherestep.dynamics import Rotor, run_closed_loop, simulate
from spherestep.dynamics import Integrator
from spherestep.errors import InputError
from spherestep.statics import TorqueModelBase


class PoleCoilWells(TorqueModelBase):
    """``V(R, c) = −A Σ_jk p_j c_k e^{κ((R u_j)·v_k − 1)}``; ``τ = A κ Σ p_j c_k e^{…} (R u_j × v_k)``: a torque
    model written independently of the package's (finite-difference Hessian from ``TorqueModelBase``)."""

    def __init__(self, design, amplitude=2.0, kappa=16.0):
        self.u, self.p, self.v = design.rotor.centers, design.polarity, design.stator.centers
        self.A, self.k = amplitude, kappa
        self.coil_count, self.failed = len(self.v), ()

    def torque_reference(self, c):
        return self.A * self.k * np.abs(np.asarray(c, dtype=float)).sum(axis=-1)

    def energy(self, R, c):
        on = np.flatnonzero(np.any(c != 0, axis=0))  # only energised coils contribute
        t = np.einsum("kij,mj,ni->kmn", R, self.u, self.v[on])
        return -self.A * np.einsum("m,kn,kmn->k", self.p, c[:, on], np.exp(self.k * (t - 1)))

    def torque(self, R, c):
        on = np.flatnonzero(np.any(c != 0, axis=0))
        Ru = np.einsum("kij,mj->kmi", R, self.u)
        t = Ru @ self.v[on].T
        w = self.A * self.k * np.exp(self.k * (t - 1)) * self.p[None, :, None] * c[:, None, on]
        # Σ_mn w (Ru_m × v_n) = Σ_m Ru_m × (Σ_n w_mn v_n)
        return np.cross(Ru, w @ self.v[on]).sum(axis=1)


@pytest.fixture(scope="module")
def wells(proto):
    return PoleCoilWells(proto)


def test_model_torque_is_minus_the_energy_gradient(proto, wells):
    R = so3.random(3, 1)
    c = np.zeros((3, len(proto.stator)))
    c[:, :6] = 1
    c[:, 6:10] = -1
    eps = 1e-6
    fd = np.stack([-(wells.energy(so3.exp(eps * e) @ R, c) - wells.energy(so3.exp(-eps * e) @ R, c)) / (2 * eps)
                   for e in np.eye(3)], axis=1)
    assert np.allclose(wells.torque(R, c), fd, rtol=1e-6, atol=1e-8)


def _drift(proto, wells, dt):
    rotor = Rotor.from_design(proto)
    c = np.zeros(len(proto.stator))
    c[:6], c[6:10] = 1, -1
    R0 = proto.states().rotations[0]
    *_, ws, E = Integrator(wells, rotor, dt).run(R0, np.array([0.3, -0.2, 0.5]), c, 10.0, record_every=1)
    scale = max(abs(E[0]), rotor.kinetic_energy(ws).max())
    return np.abs(E - E[0]).max() / scale


@pytest.mark.slow
def test_energy_drift_below_1e6_over_10_s(proto, wells):
    """Zero damping, fixed currents: |E(t) − E(0)| / energy scale < 1e-6 over 10 s at dt = 1 ms, and the
    error falls as dt⁴ (fourth-order composition)."""
    fine = _drift(proto, wells, 1e-3)
    coarse = _drift(proto, wells, 2e-3)
    assert fine < 1e-6
    assert 8 < coarse / fine < 32


def test_damping_and_friction_are_exact_and_stop_the_rotor():
    rotor = Rotor(inertia=2.0, damping=0.5, friction=0.1)
    w = np.array([[3.0, 0.0, 4.0]])
    out = rotor.dissipate(w, 1.0)
    speed = 5 * math.exp(-0.25) - 0.05
    assert np.allclose(out, w / 5 * speed, rtol=1e-14)
    assert np.all(rotor.dissipate(w, 1000.0) == 0)


def test_static_friction_holds_and_slips_at_the_friction_torque():
    """A rotor at rest stays put under a torque below castor friction (the splitting alone crept 0.022°/s at 0.9 f),
    and above it accelerates at (τ − f)/I: the exact solution of I ω̇ = τ − f ω̂ from rest."""
    rotor = Rotor(inertia=0.094, damping=0.0, friction=0.04)
    for ratio, h in ((0.9, 2e-3), (0.999, 1e-3)):
        tau = np.array([[ratio * 0.04, 0.0, 0.0]])
        R, w = np.eye(3)[None], np.zeros((1, 3))
        for _ in range(500):
            R, w, _ = rotor.step(R, w, lambda R, tau=tau: tau, h, tau)
        assert np.array_equal(R[0], np.eye(3)) and np.all(w == 0)
    tau = np.array([[0.06, 0.0, 0.0]])
    R, w = np.eye(3)[None], np.zeros((1, 3))
    for _ in range(500):
        R, w, _ = rotor.step(R, w, lambda R: tau, 2e-3, tau)
    # within the splitting's start-up offset f h / 2I (the first half step of friction acts on a rotor at rest)
    assert w[0, 0] == pytest.approx(0.02 / 0.094, abs=0.04 * 2e-3 / (2 * 0.094) * 1.01)
    assert so3.distance(R[0], np.eye(3)) == pytest.approx(0.5 * 0.02 / 0.094, abs=0.04 * 2e-3 / (2 * 0.094))


def test_free_rotor_turns_uniformly(proto):
    class Free:
        def torque(self, R, c):
            return np.zeros((len(R), 3))

        def energy(self, R, c):
            return np.zeros(len(R))

    w = np.array([0.2, -0.1, 0.4])
    R, wf, *_ = Integrator(Free(), Rotor(inertia=0.07), 1e-2).run(np.eye(3), w, np.zeros(3), 2.0)
    assert so3.distance(R, so3.exp(2.0 * w)) < 1e-12 and np.allclose(wf, w)


def test_a_settled_step_lands_in_the_wells_minimum(proto, wells):
    """Energise one state's coils from a nearby orientation with damping: the rotor settles where the
    torque vanishes, within a degree of the geometric state."""
    states = proto.states()
    i = 0
    target = states.rotations[i]
    c = np.zeros(len(proto.stator))
    for k, s in states.coils(i).items():
        c[k] = s
    start = so3.exp(np.radians([2.0, -1.5, 1.0])) @ target
    rotor = Rotor.from_design(proto, damping=0.6)
    R, w, *_ = Integrator(wells, rotor, 1e-3).run(start, np.zeros(3), c, 3.0, record_every=100)
    assert np.linalg.norm(wells.torque(R[None], c[None])) < 1e-3
    assert np.linalg.norm(w) < 1e-3
    assert so3.distance(R, target) < math.radians(1.0)


def test_simulate_records_a_plan(proto, wells):
    states = proto.states()
    plan = plan_geometric(proto, about_axis([1, 0.5, 2], math.radians(40), 5, start=states.rotations[0]))
    sim = simulate(proto, plan, wells, dwell=0.8, rotor=Rotor.from_design(proto, damping=0.6), dt=1e-3, record_every=20)
    assert sim.settled.shape == (len(plan.steps), 3, 3)
    assert len(sim.times) == len(sim.orientations) == len(sim.angular_velocity) == len(sim.active_coils)
    assert np.all(np.diff(sim.times) > 0)
    # the currents recorded are the plan's coils
    last = sim.active_coils[-1]
    assert {k for k in np.flatnonzero(last)} == set(plan.steps[-1].coils)
    # every step ends near its geometric state: a two-pole well's minimum lies within a couple of degrees
    assert np.degrees(sim.step_errors).max() < 3.0


@pytest.mark.slow
def test_closed_loop_recovers_missed_steps(proto, wells):
    """360° with 10 % missed steps and 0.2° measurement noise ends within the design's resolution."""
    states = proto.states()
    targets = about_axis([0.3, -0.5, 1.0], 2 * math.pi, 36, start=states.rotations[5])
    run = run_closed_loop(proto, targets, wells, dwell=0.6, noise=math.radians(0.2), missed=0.1,
                          rotor=Rotor.from_design(proto, damping=0.6), dt=2e-3, rng=11)
    assert run.missed.sum() >= 2
    assert run.final_error < proto.metrics(samples=5000).resolution_p95_rad


@pytest.mark.parametrize("kwargs, field", [(dict(noise=-1.0), "noise"), (dict(missed=1.0), "missed")])
def test_closed_loop_rejects_bad_settings(proto, wells, kwargs, field):
    T = about_axis([0, 0, 1], 0.5, 3, start=proto.states().rotations[0])
    with pytest.raises(InputError, match=field):
        run_closed_loop(proto, T, wells, **kwargs)


def test_rotor_rejects_bad_parameters():
    with pytest.raises(InputError, match="inertia"):
        Rotor(inertia=0.0)
    with pytest.raises(InputError, match="damping"):
        Rotor(inertia=1.0, damping=-1.0)


def test_tuning_matches_an_independent_stiffness(proto, wells):
    """``tune``: stiffness against the model's Hessian by a coarser central difference of the energy
    (second differences, an independent route), damping 2ζ√(kI), dwell 8/(ζω) for ζ < 1."""
    from spherestep.dynamics import stiffness, tune

    states = proto.states()
    c = np.zeros(len(proto.stator))
    for k, s in states.coils(0).items():
        c[k] = s
    R = states.rotations[0]
    h = 1e-3
    H = np.empty((3, 3))
    E = lambda v: wells.energy((so3.exp(v) @ R)[None], c[None])[0]  # noqa: E731
    for a in range(3):
        for b in range(3):
            ea, eb = h * np.eye(3)[a], h * np.eye(3)[b]
            H[a, b] = (E(ea + eb) - E(ea - eb) - E(-ea + eb) + E(-ea - eb)) / (4 * h * h)
    # the second differences of V(exp(v) R) carry the Lie-bracket term symmetrically; compare eigenvalues
    assert np.allclose(stiffness(wells, R, c), np.linalg.eigvalsh(0.5 * (H + H.T)), rtol=2e-3, atol=1e-4)
    t = tune(proto, wells, zeta=0.8, samples=5)
    assert math.isclose(t.rotor.damping, 2 * 0.8 * math.sqrt(t.stiffness * t.rotor.inertia), rel_tol=1e-12)
    assert math.isclose(t.dwell, 8 / (0.8 * t.omega), rel_tol=1e-12) and t.stiffness > 0


def test_a_potential_plan_is_executed_on_its_model(proto):
    """The potential planner's equilibria are where the rotor comes to rest: simulated on the same model
    (in SI at 1 J per model unit) with tuned damping and dwell, every step settles within 0.5° of the plan."""
    from spherestep.commutation import plan_potential
    from spherestep.dynamics import tune
    from spherestep.potential import MotorPotential

    potential = MotorPotential(proto)
    T = about_axis([1, 0.5, 2], math.radians(45), 6, start=proto.states().rotations[0])
    plan = plan_potential(proto, T, potential)
    model = potential
    t = tune(proto, model, samples=8)
    sim = simulate(proto, plan, model, dwell=t.dwell, rotor=t.rotor, dt=5e-3, record_every=10)
    assert sim.executed, np.degrees(sim.step_errors)
    assert so3.distance(sim.settled[-1], T[-1]) < math.radians(6)


def test_tuning_measures_the_wells_at_the_rest_poses(proto):
    """On the iron-cored model the detent moves the rest poses degrees from the geometric states, where the
    Hessian can be indefinite: ``tune`` measures the wells at the equilibria the states' coils reach, and finds them
    stable and stiff (the air core's softest well is 0.23 N·m/rad)."""
    from spherestep.dynamics import stiffness, tune
    from spherestep.magnetics import iron_model
    from spherestep.statics import equilibrium

    model = iron_model(proto)
    states = proto.states()
    rng = np.random.default_rng(0)
    picks = rng.choice(len(states), size=40, replace=False)
    c = np.array([proto.coil_currents(states.coils(int(i))) for i in picks])
    at_states = np.array([stiffness(model, states.rotations[i], c[n])[0] for n, i in enumerate(picks)])
    assert np.quantile(at_states, 0.1) < 0  # the geometric states are not wells on iron
    rest = equilibrium(model, states.rotations[picks], c)
    assert np.median(np.degrees(so3.distance(rest.rotation, states.rotations[picks]))) > 1.0
    t = tune(proto, model)
    assert t.stiffness > 1.0 and math.isclose(t.dwell, 8 / t.omega, rel_tol=1e-12)
