"""The motor: prototype, design validation, stepper states and metrics (Sec. II-B-3, IV)."""

import math
from dataclasses import replace

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.motor import check_fits
from spherestep.motor.metrics import largest_empty_cone, orbit_representatives, rotor_symmetries
from spherestep.sphere import arc_distance


def test_prototype_matches_the_paper(proto):
    assert len(proto.rotor) == 92 and len(proto.stator) == 29
    assert proto.cap_half_angle < math.pi / 2
    assert math.isclose(proto.sphere_diameter, 12 * 0.0254, rel_tol=1e-12)
    assert math.isclose(proto.coil_diameter, 2 * 0.0254, rel_tol=1e-12)
    assert math.isclose(proto.coil_length, 1.625 * 0.0254, rel_tol=1e-12)
    assert math.isclose(proto.air_gap, 0.005 * 0.0254, rel_tol=1e-12)
    # every coil inside the cap, the rotor balanced with no net dipole
    assert np.all(proto.stator.centers @ proto.stator_axis >= math.cos(proto.cap_half_angle) - 1e-12)
    assert np.abs(proto.polarity @ proto.rotor.centers).max() < 1e-12
    assert abs(proto.rotor.inertia_isotropy() - 1) < 1e-12
    check_fits(proto)
    # different symmetry families, nearly equal primary circles (Sec. II-B-3)
    assert proto.rotor.family != proto.stator.family
    assert abs(proto.rotor.radii.max() / proto.stator.radii[proto.stator.radii < 0.25].max() - 1) < 0.1


@pytest.mark.parametrize("change, field", [
    (dict(cap_half_angle=math.radians(95)), "cap_half_angle"),
    (dict(max_coils=10), "stator"),
    (dict(polarity=np.zeros(92)), "polarity"),
    (dict(stator_axis=np.array([0, 0, 2.0])), "stator_axis"),
    (dict(air_gap=-1.0), "air_gap"),
    (dict(sphere_diameter=float("nan")), "sphere_diameter"),
    (dict(channel_map=np.zeros((29, 2), dtype=int)), "channel_map"),
    (dict(failed_coils=(99,)), "failed_coils"),
])
def test_design_rejects_bad_values_naming_the_field(proto, change, field):
    with pytest.raises(InputError, match=field):
        replace(proto, **change)


def test_hemisphere_allowed_only_on_request(proto):
    wide = replace(proto, cap_half_angle=math.radians(100), allow_hemisphere=True)
    assert wide.cap_half_angle > math.pi / 2


def test_coil_outside_cap_is_refused(proto):
    with pytest.raises(InputError, match=r"stator\[\d+\] must be a coil within the stator cap") as err:
        replace(proto, cap_half_angle=math.radians(40))
    assert err.value.field.startswith("stator[")


def test_every_state_is_held_by_two_or_more_pairs_within_tol(proto):
    states = proto.states()
    assert len(states) > 1000
    assert states.counts.min() >= 2
    j, k = states.pairs[:, 0], states.pairs[:, 1]
    owner = np.repeat(np.arange(len(states)), states.counts)
    poles = np.einsum("sij,sj->si", states.rotations[owner], proto.rotor.centers[j])
    assert arc_distance(poles, proto.stator.centers[k]).max() <= proto.state_tol + 1e-12
    # no pole or coil used twice in one state
    for i in np.random.default_rng(0).integers(0, len(states), 300):
        held = states.held(i)
        assert len({a for a, _ in held}) == len(held) == len({b for _, b in held})
    # rotations are proper
    assert np.abs(np.linalg.det(states.rotations) - 1).max() < 1e-12


def test_states_are_complete_for_exact_two_pair_matches(proto):
    """Independent construction: align two pole pairs onto two coil pairs of nearly equal arc with
    SciPy's align_vectors; the state set must contain that orientation."""
    from scipy.spatial.transform import Rotation

    states = proto.states()
    u, v = proto.rotor.centers, proto.stator.centers
    rng = np.random.default_rng(3)
    found = 0
    while found < 60:
        k1, k2 = rng.choice(len(v), 2, replace=False)
        s = arc_distance(v[k1], v[k2])
        j1 = rng.integers(len(u))
        a = arc_distance(u[j1], u)
        close = np.flatnonzero(np.abs(a - s) < 0.5 * proto.state_tol)
        if not len(close):
            continue
        j2 = rng.choice(close)
        R = Rotation.align_vectors(v[[k1, k2]], u[[j1, j2]])[0].as_matrix()
        if arc_distance(R @ u[j1], v[k1]) > 0.5 * proto.state_tol or arc_distance(R @ u[j2], v[k2]) > 0.5 * proto.state_tol:
            continue
        found += 1
        dist, idx = states.nearest(R)
        assert dist.ravel()[0] < proto.state_tol  # the refit state differs only by the other held pairs
        held = states.held(int(idx.ravel()[0]))
        assert (j1, k1) in held and (j2, k2) in held


def test_state_set_is_invariant_under_rotor_symmetry(proto):
    states = proto.states()
    group = rotor_symmetries(proto)
    assert len(group) == 60  # the icosahedral group keeps the primary/filled polarity pattern
    rng = np.random.default_rng(5)
    R = states.rotations[rng.integers(0, len(states), 200)] @ group[rng.integers(0, 60, 200)]
    dist, _ = states.nearest(R)
    assert dist.max() < 1e-9


def test_nearest_matches_brute_force(proto):
    states = proto.states()
    R = so3.random(20, 11)
    dist, idx = states.nearest(R)
    brute = so3.distance(R[:, None], states.rotations[None])
    assert np.allclose(dist[:, 0], brute.min(axis=1), atol=1e-9)


def test_metrics(proto, proto_metrics):
    m = proto_metrics
    assert m["states"] == len(proto.states())
    assert 0 < m["resolution_median"] < m["resolution_p95"] <= m["resolution_max"] < m["max_step"]
    assert m["range_fraction"] == 1.0 and m["state_graph_components"] == 1 and m["reaches_all"]
    assert math.isclose(m["max_step"], proto.coil_angle + proto.magnet_angle)
    # resolution against brute force on a subsample
    R = so3.random(40, 99)
    brute = so3.distance(R[:, None], proto.states().rotations[None]).min(axis=1)
    assert np.quantile(brute, 0.5) < m["resolution_p95"]


def test_largest_empty_cone_against_sampling():
    rng = np.random.default_rng(2)
    dirs = rng.normal(size=(200_000, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    for n in (6, 12, 40):
        axes = rng.normal(size=(n, 3))
        axes /= np.linalg.norm(axes, axis=1, keepdims=True)
        exact = largest_empty_cone(axes)
        sampled = np.arccos(np.clip(dirs @ axes.T, -1, 1)).min(axis=1).max()
        assert sampled <= exact + 1e-12 and exact - sampled < math.radians(1.0)
    # six octahedron axes: the empty cone is the cube direction's, acos(1/√3)
    octa = np.vstack([np.eye(3), -np.eye(3)])
    assert math.isclose(largest_empty_cone(octa), math.acos(1 / math.sqrt(3)), abs_tol=1e-12)
    assert largest_empty_cone(np.array([[0, 0, 1.0], [0, 1, 0], [1, 0, 0], [0.6, 0.8, 0]])) > math.pi / 2


def test_escape_violations_agree_with_direct_computation(proto, proto_metrics):
    states = proto.states()
    violators = set(proto_metrics["escape_violations"])
    rng = np.random.default_rng(4)
    for i in rng.integers(0, len(states), 25):
        near = states.within(states.rotations[i], proto.max_step)
        near = near[near != i]
        axes, _ = so3.axis_angle(states.rotations[i].T @ states.rotations[near])
        assert (largest_empty_cone(axes) > math.radians(45)) == (int(i) in violators)


def test_orbit_representatives_group_whole_orbits(proto):
    states = proto.states()
    rep_of, reps = orbit_representatives(states.rotations, rotor_symmetries(proto))
    assert len(reps) * 60 >= len(states) and len(reps) < len(states) / 20
    assert np.all(rep_of[reps] == reps)


def test_failed_coils_are_never_used(proto):
    broken = proto.without_coils([0, 5])
    states = broken.states()
    assert not np.isin(states.pairs[:, 1], [0, 5]).any()
    assert len(states) < len(proto.states())
