"""The torque map against direct magpylib, equilibria, holding and step torques, the calibration."""

import math

import numpy as np
import pytest

from spherestep import magnetics as mg
from spherestep import so3, statics
from spherestep.errors import InputError


@pytest.fixture(scope="module")
def tmap(proto):
    return mg.torque_map(proto)


@pytest.fixture(scope="module")
def sample(proto):
    rng = np.random.default_rng(21)
    R = so3.random(3, rng)
    return R, mg.random_drives(len(proto.stator), 3, rng)


def test_map_is_the_exact_decomposition_of_direct_getft(proto, sample):
    # same mesh on both sides: what is left is the table's interpolation and the mesh's orientation about
    # each magnet's axis (not the same in the table and in the motor)
    R, c = sample
    direct = mg.torque(proto, R, c, meshing=216)
    same_mesh = mg.torque_map(proto, meshing=216).torque(R, c)
    scale = np.abs(direct).max()
    assert scale > 0.2
    assert np.abs(same_mesh - direct).max() < 1e-3 * scale
    # the default map (1000 cells) against direct at 216 cells: the direct mesh's own error, 0.3 %
    assert np.abs(mg.torque_map(proto).torque(R, c) - direct).max() < 0.01 * scale


def test_table_interpolation_error(proto, tmap):
    nodes = mg.table_nodes()
    mid = 0.5 * (nodes[1:] + nodes[:-1])[::4]
    exact = mg.pair_torque(proto, mid, meshing=tmap.meshing)
    peak = np.abs(tmap.tau).max()
    assert np.abs(tmap.pair(mid) - exact).max() < 3e-4 * peak
    assert abs(tmap.pair(0.0)) < 1e-12 and abs(tmap.pair(math.pi)) < 1e-12


def test_energy_is_the_potential_of_the_torque(proto, tmap, sample):
    R, c = sample
    T = tmap.torque(R, c)
    h = 1e-5
    for w in np.eye(3):
        dE = (tmap.energy(so3.exp(h * w) @ R, c) - tmap.energy(so3.exp(-h * w) @ R, c)) / (2 * h)
        np.testing.assert_allclose(dE, -T @ w, atol=1e-6 * np.abs(T).max())


def test_torque_function_for_dynamics(proto, tmap, sample):
    R, c = sample
    f = mg.torque_function(proto)
    out = f(R, c)
    assert out.shape == (3, 3)
    np.testing.assert_array_equal(out, tmap.torque(R, c))
    np.testing.assert_allclose(f(R, c + c), 2 * out, rtol=1e-12, atol=1e-15)
    single = np.zeros(len(proto.stator))
    single[4] = 1.0
    np.testing.assert_allclose(f(R, np.tile(single, (3, 1))) @ proto.stator.centers[4], 0.0, atol=1e-12)
    with pytest.raises(InputError, match="^currents must be"):
        f(R, c[:, :5])
    with pytest.raises(InputError, match="^R must be"):
        f(2 * R, c)


@pytest.fixture(scope="module")
def settled(proto, tmap):
    states = proto.states()
    idx = np.random.default_rng(3).choice(len(states), 25, replace=False)
    c = np.array([mg.state_currents(proto, i) for i in idx])
    return idx, c, mg.equilibrium(tmap, states.rotations[idx], c)


def test_equilibria_near_the_geometric_states(proto, tmap, settled):
    idx, c, eq = settled
    assert eq.converged.all() and eq.is_minimum.all()
    assert np.all(np.linalg.norm(eq.torque, axis=1) <= 1e-9 * np.abs(tmap.tau).max() * np.abs(c).sum(axis=1))
    shift = np.degrees(so3.distance(eq.rotation, proto.states().rotations[idx]))
    assert shift.max() < 1.0
    # against direct magpylib at the map's equilibrium: the residual torque over the stiffness bounds how far
    # the direct model's own equilibrium is
    T = mg.torque(proto, eq.rotation[:4], c[:4], meshing=216)
    assert np.all(np.degrees(np.linalg.norm(T, axis=1) / eq.stiffness[:4, 0]) < 0.1)


def test_holding_torque(proto, tmap, settled):
    _, c, eq = settled
    hold = statics.holding_torque(tmap, eq.rotation[:5], c[:5])
    assert hold.per_axis.shape == (5, 32)
    assert np.all(hold.torque > 0.1) and np.all(hold.torque < 2.0)  # N·m
    assert np.all(hold.peak_angle > math.radians(2.0))
    cube_only = statics.holding_torque(tmap, eq.rotation[:5], c[:5], axes=statics.cube_axes())
    assert np.all(hold.torque <= cube_only.torque + 1e-12)  # the eigen-axes can only find a softer direction
    # linear in the currents
    double = statics.holding_torque(tmap, eq.rotation[:5], 2 * c[:5])
    np.testing.assert_allclose(double.per_axis, 2 * hold.per_axis, rtol=1e-9)
    # small turns: restoring torque ≈ stiffness × angle along the weakest eigen-axis
    H = tmap.hessian(eq.rotation[:1], c[:1])[0]
    h, e = np.linalg.eigh(H)
    small = statics.holding_torque(tmap, eq.rotation[:1], c[:1], axes=e[:, :1].T, max_angle=1e-3, samples=2)
    assert small.per_axis[0, 0] == pytest.approx(h[0] * 1e-3, rel=1e-3)


def test_holding_torque_on_a_coarse_grid_finds_the_full_grids_peaks(proto, tmap, settled):
    """``stride``: every 4th angle, then around the two best coarse maxima — the full grid's peak on every axis
    (a subset of its points: never above it); over 90° the restoring curve passes other poles (several peaks)."""
    _, c, eq = settled
    for max_angle, samples in ((math.radians(20.0), 81), (math.radians(90.0), 181)):
        full = statics.holding_torque(tmap, eq.rotation, c, max_angle=max_angle, samples=samples)
        coarse = statics.holding_torque(tmap, eq.rotation, c, max_angle=max_angle, samples=samples, stride=4)
        np.testing.assert_array_equal(coarse.per_axis, full.per_axis)
        np.testing.assert_array_equal(coarse.peak_angle, full.peak_angle)
    wide = np.radians(np.linspace(0.0, 90.0, 181))
    restoring = statics._restoring(tmap, eq.rotation[0], c[0], full.axes[0], np.broadcast_to(wide, (32, 181)))
    assert (np.diff(np.sign(np.diff(restoring, axis=1)), axis=1) < 0).sum(axis=1).max() >= 2  # several peaks
    for bad in (0, 81, 2.0, True):
        with pytest.raises(InputError, match="stride"):
            statics.holding_torque(tmap, eq.rotation[:1], c[:1], stride=bad)


def test_step_torque_drives_to_the_next_state(proto, tmap, settled):
    idx, c, eq = settled
    states = proto.states()
    near = states.within(states.rotations[idx[0]], 0.5 * proto.max_step)
    near = near[near != idx[0]][:4]
    cb = np.array([mg.state_currents(proto, j) for j in near])
    eqb = mg.equilibrium(tmap, states.rotations[near], cb)
    s = statics.step_torque(tmap, np.repeat(eq.rotation[:1], len(near), axis=0), eqb.rotation, cb)
    assert np.all(s.start > 0) and np.all(s.peak >= s.start)
    end = tmap.torque(eqb.rotation, cb)
    assert np.abs(end).max() < 1e-6


def test_state_torques_rows(proto, tmap):
    rows = mg.state_torques(proto, tmap, [0])
    r = rows[0]
    assert isinstance(r, mg.StateTorque) and r.coils == {int(k): int(s) for k, s in proto.states().coils(0).items()}
    assert 0 < r.holding_torque_Nm <= r.strongest_axis_Nm
    assert r.steps > 0 and 0 <= r.downhill_steps <= r.steps
    people = r.to_dict()
    assert people["equilibrium_offset_deg"] == math.degrees(r.equilibrium_offset_rad) and "equilibrium_offset_rad" not in people
    assert people["weakest_axis"] == list(r.weakest_axis)
    with pytest.raises(InputError, match="^indices must be"):
        mg.state_torques(proto, tmap, [len(proto.states())])


@pytest.mark.slow
def test_calibrated_potential_against_magpylib(proto, tmap):
    cal = mg.calibrate(proto)
    assert 0.050 < cal.limit < 0.058  # m: the lateral force turns from pulling back to pushing at ~54 mm
    assert cal.fit.success
    comp = mg.compare_models(proto, cal, tmap, samples=80, states=30, seed=1)
    s = comp.summary()
    assert s["map_vs_direct"]["relative_error"] < 0.05  # the coarse direct mesh (8 cells) costs ~2 %
    assert s["potential_vs_direct"]["correlation"] > 0.95
    assert s["potential_vs_direct"]["relative_error"] < 0.35
    assert s["state_offset_deg"]["max"] < 1.0
    assert s["minima_fraction"] == {"map": 1.0, "potential": 1.0}


def test_map_takes_the_rotation_contract_and_any_batch(proto, tmap):
    """Any batch shape, as in every room; a non-rotation refused naming R (so3.as_rotations)."""
    from spherestep import so3

    R = so3.random(6, 9)
    c = mg.state_currents(proto, 0)
    flat, batch = tmap.torque(R, c), tmap.torque(R.reshape(2, 3, 3, 3), np.tile(c, (2, 3, 1)))
    assert batch.shape == (2, 3, 3) and np.array_equal(batch.reshape(6, 3), flat)
    assert np.array_equal(tmap.energy(R.reshape(3, 2, 3, 3), c).ravel(), tmap.energy(R, c))
    assert tmap.torque_matrix(R.reshape(2, 3, 3, 3)).shape == (2, 3, 3, len(proto.stator))
    assert np.allclose(tmap.torque(R[0], c), flat[0], rtol=1e-12, atol=1e-15)  # one rotation: the single-orientation path
    for bad in (2 * np.eye(3), np.diag([1.0, 1.0, -1.0])):
        with pytest.raises(InputError) as err:
            tmap.torque(bad, c)
        assert err.value.field == "R"
    with pytest.raises(InputError, match="^currents must be"):
        tmap.torque(R.reshape(2, 3, 3, 3), np.tile(c, (3, 2, 1)))
