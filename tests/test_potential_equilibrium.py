"""Equilibria of the prototype's energy next to its stepper states, and basins of attraction (issue 5 §1)."""

from __future__ import annotations

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.potential import (
    coil_currents,
    equilibrium,
    gradient_flow,
    in_basin,
    torque_scale,
)


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
    assert np.all(np.linalg.norm(eq.torque, axis=-1) <= 1e-10 * torque_scale(model, currents))
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
    with pytest.raises(InputError, match="^currents must be at least one energised coil"):
        equilibrium(model, np.eye(3), np.zeros(N))
    with pytest.raises(InputError, match="^model must be"):
        equilibrium(object(), np.eye(3), np.ones(N))
    with pytest.raises(InputError, match="^R0 must be"):
        equilibrium(model, np.eye(3) * 2, np.ones(N))
    with pytest.raises(InputError, match="^max_step must be"):
        equilibrium(model, np.eye(3), np.ones(N), max_step=-1.0)
    with pytest.raises(InputError, match="^R_eq must be"):
        in_basin(model, np.eye(3), np.ones(N), np.zeros((3, 3)))
