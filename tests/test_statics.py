"""The torque-model protocol, and equilibria of the prototype's energy next to its stepper states, with their
basins of attraction (issue 5 §1, issue 12 §3)."""

from __future__ import annotations

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.potential import coil_currents
from spherestep.statics import (TorqueModel, TorqueModelBase, equilibrium, finite_difference_hessian, gradient_flow,
                                in_basin)


@pytest.fixture(scope="module")
def sample(proto, model):
    """Equilibria from 300 random stepper states (plus the first five), each with its own coils energised."""
    states = proto.states()
    rng = np.random.default_rng(5)
    idx = np.concatenate([np.arange(5), rng.choice(np.arange(5, len(states)), 300, replace=False)])
    currents = np.stack([coil_currents(proto, states.coils(i)) for i in idx])
    return idx, currents, equilibrium(model, states.rotations[idx], currents)


def test_equilibria_sit_within_two_degrees_of_the_geometric_states(proto, model, sample):
    states = proto.states()
    idx, currents, eq = sample
    assert np.all(eq.converged) and np.all(eq.is_minimum)
    assert np.all(np.linalg.norm(eq.torque, axis=-1) <= 1e-10 * model.torque_reference(currents))
    assert eq.iterations.max() <= 10  # Newton from the geometric state: measured at most 3
    offsets = np.degrees(so3.distance(eq.rotation, states.rotations[idx]))
    # measured: median 0.84°, 90th percentile 1.79°, max 1.82° (docs/potential.md)
    assert np.max(offsets) <= 2.5
    assert 0.3 <= np.median(offsets) <= 1.5
    # lower than the geometric state itself, whose torque is not zero
    assert np.all(eq.energy <= model.energy_pairwise(states.rotations[idx], currents) + 1e-15)


def test_equilibrium_is_a_local_minimum_of_the_harmonic_energy(proto, model, sample):
    """Checked in the paper's form of eq. (4), independently of the pairwise torque that found it."""
    _, currents, eq = sample
    pick = [0, 7, 42]
    R, c = eq.rotation[pick], currents[pick]
    E = model.energy(R, c)
    rng = np.random.default_rng(6)
    for _ in range(2):
        axes = rng.normal(size=(len(pick), 26, 3))
        axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
        nearby = so3.exp(np.radians(0.5) * axes) @ R[:, None]
        assert np.all(model.energy(nearby, c[:, None]) > E[:, None])
    # stationary: the finite-difference gradient of the harmonic energy is ~0 next to the torque 0.5° away
    h = 1e-4
    grad = np.stack([(model.energy(so3.exp(h * e) @ R, c) - model.energy(so3.exp(-h * e) @ R, c)) / (2 * h)
                     for e in np.eye(3)], axis=-1)
    away = np.linalg.norm(model.torque(so3.exp(np.radians(0.5) * np.eye(3)[0]) @ R, c), axis=-1)
    assert np.all(np.linalg.norm(grad, axis=-1) <= 1e-5 * away)


def test_batched_equilibria_match_single_runs(proto, model, sample):
    idx, currents, eq = sample
    states = proto.states()
    for i in (0, 11):
        single = equilibrium(model, states.rotations[idx[i]], currents[i])
        assert single.rotation.shape == (3, 3) and single.energy.shape == ()
        assert so3.distance(single.rotation, eq.rotation[i]) <= 1e-9
        assert single.stiffness == pytest.approx(eq.stiffness[i], rel=1e-6)


@pytest.fixture(scope="module")
def two_minima(proto, model):
    """A state's minimum and a second minimum of the same currents, 38° away, found from a random start."""
    states = proto.states()
    c = coil_currents(proto, states.coils(3))
    first = equilibrium(model, states.rotations[3], c)
    rng = np.random.default_rng(1)
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    starts = so3.exp(axes * np.radians(rng.uniform(10, 30, 200))[:, None]) @ first.rotation
    found = equilibrium(model, starts, c)
    apart = so3.distance(found.rotation, first.rotation)
    others = np.flatnonzero(found.is_minimum & (apart > np.radians(1.0)))
    second = found.rotation[others[np.argmin(apart[others])]]
    return c, first.rotation, second


def test_basin_test_separates_the_two_sides_of_a_saddle(model, two_minima):
    c, first, second = two_minima
    s = np.linspace(0.0, 1.0, 101)
    path = so3.geodesic(first, second, s)
    energy = model.energy_pairwise(path, c)
    top = int(np.argmax(energy))
    assert 10 < top < 90 and energy[top] > max(energy[0], energy[-1])  # a barrier between the minima
    near = so3.exp(np.radians([1.0, -0.5, 0.8])) @ first
    before, after = path[top - 15], path[top + 15]
    starts = np.stack([near, before, after])
    assert list(in_basin(model, starts, c, first)) == [True, True, False]
    assert list(in_basin(model, starts, c, second)) == [False, False, True]
    # the flow's end points are the minima themselves
    end, at_rest = gradient_flow(model, starts, c)
    assert np.all(at_rest)
    assert np.degrees(so3.distance(end[2], second)) <= 0.01
    # the descent from beyond the saddle ends at the second minimum too
    assert so3.distance(equilibrium(model, after, c).rotation, second) <= 1e-8


def test_equilibrium_bad_inputs(proto, model):
    N = len(proto.stator)
    # no current and no detent: every orientation is at rest, and none is a strict minimum
    rest = equilibrium(model, np.eye(3), np.zeros(N))
    assert bool(rest.converged) and not bool(rest.is_minimum) and np.array_equal(rest.rotation, np.eye(3))
    with pytest.raises(InputError, match="^model must be"):
        equilibrium(object(), np.eye(3), np.ones(N))
    with pytest.raises(InputError, match="^R0 must be"):
        equilibrium(model, np.eye(3) * 2, np.ones(N))
    with pytest.raises(InputError, match="^max_step must be"):
        equilibrium(model, np.eye(3), np.ones(N), max_step=-1.0)
    with pytest.raises(InputError, match="^R_eq must be"):
        in_basin(model, np.eye(3), np.ones(N), np.zeros((3, 3)))


# --- the TorqueModel protocol (issue 12 §3) -------------------------------------------------------------------

@pytest.fixture(scope="module")
def tmap(proto):
    from spherestep.magnetics import torque_map

    return torque_map(proto)


def _random_drive(proto, count, seed):
    rng = np.random.default_rng(seed)
    return so3.random(count, rng), rng.uniform(-1, 1, (count, len(proto.stator)))


@pytest.mark.parametrize("which", ["potential", "map"])
def test_both_models_follow_the_protocol(proto, model, tmap, which):
    m = model if which == "potential" else tmap
    assert isinstance(m, TorqueModel) and m.coil_count == len(proto.stator)
    R, c = _random_drive(proto, 20, 1)
    K = m.torque_matrix(R)
    assert K.shape == (20, 3, len(proto.stator))
    tau = m.torque(R, c)
    # linear in the currents: τ = K(R) c (no detent in either model)
    np.testing.assert_allclose(np.einsum("kan,kn->ka", K, c), tau, rtol=1e-10, atol=1e-12 * np.abs(tau).max())
    # the analytic matrix against the protocol's default, central differences in the currents
    fd = TorqueModelBase.torque_matrix(m, R[:4], c[:4])
    np.testing.assert_allclose(fd, K[:4], rtol=1e-6, atol=1e-9 * np.abs(K).max())
    # single orientation: (3, N)
    assert m.torque_matrix(R[0]).shape == (3, len(proto.stator))
    # torque is minus the gradient of the energy (turns about the fixed axes, central differences)
    h = 1e-6
    fd_tau = np.stack([-(m.energy(so3.exp(h * e) @ R[:4], c[:4]) - m.energy(so3.exp(-h * e) @ R[:4], c[:4])) / (2 * h)
                       for e in np.eye(3)], axis=-1)
    np.testing.assert_allclose(fd_tau, tau[:4], rtol=1e-5, atol=1e-7 * np.abs(tau).max())


def test_analytic_hessian_matches_finite_differences_of_the_torque(proto, model):
    R, c = _random_drive(proto, 6, 2)
    H = model.hessian(R, c)
    fd = finite_difference_hessian(model, R, c, 1e-5)
    np.testing.assert_allclose(H, fd, rtol=1e-6, atol=1e-7 * np.abs(H).max())
    E, tau, H2 = model.evaluate(R, c, 2)
    np.testing.assert_allclose(H2, H, rtol=1e-13)
    np.testing.assert_allclose(E, model.energy(R, c), rtol=1e-11)


def test_potential_scale_multiplies_every_output(proto, model):
    from spherestep.potential import MotorPotential

    scaled = MotorPotential(proto, scale=2.5)
    R, c = _random_drive(proto, 5, 3)
    for name in ("energy", "torque", "hessian"):
        expected = 2.5 * getattr(model, name)(R, c)  # the kernel table is rebuilt: its own 1e-12-level error
        np.testing.assert_allclose(getattr(scaled, name)(R, c), expected, rtol=1e-8, atol=1e-9 * np.abs(expected).max())
    np.testing.assert_allclose(scaled.torque_reference(c), 2.5 * model.torque_reference(c), rtol=1e-12)
    with pytest.raises(InputError, match="^scale must be"):
        MotorPotential(proto, scale=0.0)


def test_failed_coils_have_zero_columns_and_refuse_current(proto):
    from spherestep.magnetics import torque_map

    m = torque_map(proto.without_coils([3]))
    R, c = _random_drive(proto, 3, 4)
    assert np.all(m.torque_matrix(R)[..., 3] == 0) and np.any(m.torque_matrix(R)[..., 4] != 0)
    with pytest.raises(InputError, match="^currents must be zero"):
        m.torque(R, c)


def test_descend_is_equilibrium_without_its_checks(proto, model):
    """``statics.descend`` (the planner's loop entry) returns the flat arrays ``equilibrium`` wraps, bit for bit;
    a model must declare ``has_bias`` and ``packed_terms`` to be a TorqueModel."""
    from spherestep.statics import descend, is_torque_model

    states = proto.states()
    c = np.stack([coil_currents(proto, states.coils(i)) for i in range(3)])
    R0 = so3.exp(np.radians([[2.0, 0.0, 1.0]])) @ states.rotations[:3]
    eq = equilibrium(model, R0, c)
    R, E, tau, H, iterations, converged = descend(model, R0.copy(), c)
    assert np.array_equal(R, eq.rotation) and np.array_equal(E, eq.energy) and np.array_equal(tau, eq.torque)
    assert np.array_equal(np.linalg.eigvalsh(H), eq.stiffness) and np.array_equal(iterations, eq.iterations)
    assert np.array_equal(converged, eq.converged)

    class Undeclared:  # the five questions answered, nothing declared
        coil_count, failed = model.coil_count, ()
        energy, torque, torque_matrix = model.energy, model.torque, model.torque_matrix
        hessian, torque_reference, evaluate = model.hessian, model.torque_reference, model.evaluate

    assert is_torque_model(model) and not is_torque_model(Undeclared())
    with pytest.raises(InputError, match="^model must be"):
        equilibrium(Undeclared(), R0, c)
