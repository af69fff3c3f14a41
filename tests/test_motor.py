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
    assert m.states == len(proto.states())
    assert 0 < m.resolution_median_rad < m.resolution_p95_rad <= m.resolution_max_rad < m.max_step_rad
    assert m.range_fraction == 1.0 and m.state_graph_components == 1 and m.reaches_all
    assert math.isclose(m.max_step_rad, proto.coil_angle + proto.magnet_angle)
    # resolution against brute force on a subsample
    R = so3.random(40, 99)
    brute = so3.distance(R[:, None], proto.states().rotations[None]).min(axis=1)
    assert np.quantile(brute, 0.5) < m.resolution_p95_rad
    # one dict for people: the *_rad fields in degrees, named *_deg; the rest as is
    people, raw = m.to_dict(), m.to_dict(degrees=False)
    assert people["resolution_median_deg"] == math.degrees(m.resolution_median_rad)
    assert people["max_step_deg"] == math.degrees(raw["max_step_rad"])
    assert not any(k.endswith("_rad") for k in people) and not any(k.endswith("_deg") for k in raw)
    assert people["held_pairs_histogram"] == list(m.held_pairs_histogram) and sum(m.held_pairs_histogram) == m.states
    with pytest.raises(AttributeError):
        m.states = 0  # frozen


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
    violators = set(proto_metrics.escape_violations)
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


# --- the one builder ---------------------------------------------------------------------------------------

SMALL = dict(rotor="icosidodecahedron", stator="truncated-octahedron", stator_axis=[0, 0, -1],
             cap_half_angle=math.radians(70), sphere_diameter="12 in", magnet_diameter="1 in",
             magnet_length="0.5 in", coil_diameter="2 in", coil_length="1.625 in", air_gap="0.005 in")


def test_from_packings_builds_the_prototype_bit_for_bit(proto):
    """Independent construction: refine, select the caps and assign polarities by hand."""
    from spherestep import packing as pk
    from spherestep.motor import MotorDesign

    rotor = pk.refine(pk.by_name("truncated-icosahedron"), levels=1)
    full = pk.refine(pk.by_name("truncated-cuboctahedron"), levels=1)
    R, g, d = 6 * 0.0254, 0.005 * 0.0254, 2 * 0.0254
    coil_angle = math.atan(0.5 * d / (R + g))
    keep = (full.centers @ [0, 0, -1] >= math.cos(math.radians(80)) - 1e-12) & (full.radii >= coil_angle)
    assert np.array_equal(proto.rotor.centers, rotor.centers) and np.array_equal(proto.stator.centers, full.centers[keep])
    assert np.array_equal(proto.polarity, np.where(np.arange(92) < 60, 1, -1))
    assert proto.coil_angle == coil_angle and len(proto.stator) == 29
    # the same design from explicit packings, cap indices and a per-pole polarity list
    again = MotorDesign.from_packings(**(SMALL | dict(rotor=rotor, stator=full, cap_half_angle=math.radians(80),
                                                      magnet_diameter="1 in", polarity=proto.polarity.tolist(),
                                                      coils=np.flatnonzero(keep).tolist())))
    assert np.array_equal(again.stator.centers, proto.stator.centers) and np.array_equal(again.polarity, proto.polarity)
    # the named packings are shared, not rebuilt
    assert MotorDesign.from_packings(**SMALL).rotor is pk.named("icosidodecahedron", 0)


@pytest.mark.parametrize("change, field", [
    (dict(cap_half_angle=math.radians(95)), "cap_half_angle"),
    (dict(cap_half_angle="80 deg"), "cap_half_angle"),
    (dict(stator_axis=[0, 0, 2]), "stator_axis"),
    (dict(rotor="football"), "rotor"),
    (dict(rotor_refine=-1), "rotor_refine"),
    (dict(coils=[0, 99]), "coils[1]"),
    (dict(coils=[3, 3]), "coils[1]"),
    (dict(coils="some"), "coils"),
    (dict(coil_diameter="20 in"), "coil_diameter"),
    (dict(coil_diameter="11 in", cap_half_angle=math.radians(20)), "coils"),
    (dict(magnet_diameter="13 in"), "magnet_diameter"),
    (dict(air_gap="-1 mm"), "air_gap"),
    (dict(sphere_diameter="12 furlongs"), "sphere_diameter"),
    (dict(polarity=[1, -1]), "polarity"),
    (dict(polarity={"primary": 2}), "polarity.primary"),
    (dict(magnet_diameter="5 in"), "rotor"),
    (dict(max_coils=3), "stator"),
    (dict(coils=[0], cap_half_angle=math.radians(10)), "stator[0]"),
    (dict(coil="iron"), "coil"),
    (dict(coil={"core": "copper"}), "coil.core"),
    (dict(coil={"colour": "red"}), "coil"),
    (dict(coil={"fill_factor": 2.0}), "coil.fill_factor"),
    (dict(coil={"material": {"knee": 9.0}}), "coil.material.knee"),
    (dict(coil={"material": {"mu": 9.0}}), "coil.material"),
    (dict(coil={"material": "steel"}), "coil.material"),
])
def test_from_packings_errors_carry_the_field(change, field):
    from spherestep.motor import MotorDesign

    with pytest.raises(InputError) as err:
        MotorDesign.from_packings(**(SMALL | change))
    assert err.value.field == field and "\n" not in str(err.value)


@pytest.mark.slow
def test_the_coil_as_built(proto):
    """Default the prototype's iron coil; a mapping or a CoilSpec; checked by MotorDesign; not part of the
    geometry (stepper states, the air-core table key)."""
    from spherestep.magnetics._table import _geometry_key
    from spherestep.motor import MotorDesign
    from spherestep.motor.coil import CoilSpec, air_coil, iron_coil

    assert proto.coil == iron_coil() and MotorDesign.from_packings(**SMALL).coil == iron_coil()
    mapped = MotorDesign.from_packings(**(SMALL | dict(coil={"core": "air", "fill_factor": 0.5,
                                                             "material": {"relative_permeability": 200.0}})))
    assert mapped.coil == CoilSpec(core="air", fill_factor=0.5, material=replace(iron_coil().material,
                                                                                relative_permeability=200.0))
    with pytest.raises(InputError) as err:
        replace(proto, coil={"core": "air"})  # a mapping is the builder's convenience, the field holds a CoilSpec
    assert err.value.field == "coil" and "CoilSpec" in str(err.value)
    air = replace(proto, coil=air_coil())
    assert air.without_coils([3]).coil == air_coil()
    assert _geometry_key(air) == _geometry_key(proto)
    assert np.array_equal(air.states().rotations, proto.states().rotations)
    assert proto.summary()["coil"]["turns"] == 2824


def test_coil_electrics_is_a_result_with_an_explicit_misfit():
    from spherestep.motor import prototype

    proto = prototype()
    e = proto.coil_electrics()
    assert e.fits and e.misfit is None and e.turns == 2824 and e.core == "iron"
    assert e.power == pytest.approx(e.resistance * e.nominal_current ** 2, rel=1e-12)
    assert e.to_dict() == proto.coil.electrics(proto.coil_diameter, proto.coil_length) == proto.summary()["coil"]
    bad = replace(proto, coil_diameter=0.001).coil_electrics()  # a pole wider than the groove: no winding
    assert not bad.fits and "coil must be" in bad.misfit
    assert (bad.turns, bad.resistance, bad.nominal_current, bad.ampere_turns, bad.power) == (None,) * 5
    assert bad.to_dict() == {"core": "iron", "winding": bad.misfit} and bad.supply_voltage == 24.0


def test_polarity_rule_and_explicit_rotor():
    from spherestep import packing as pk
    from spherestep.motor import MotorDesign, PolarityRule

    design = MotorDesign.from_packings(**(SMALL | dict(rotor_refine=1, polarity={"primary": -1})))
    base = len(pk.named("icosidodecahedron", 0))
    assert np.array_equal(design.polarity, np.where(np.arange(len(design.rotor)) < base, -1, 1))
    assert np.array_equal(PolarityRule(1, 1).signs(5, 2), np.ones(5))
    custom = pk.Packing(pk.named("icosidodecahedron", 0).centers, 0.1, name="custom")
    with pytest.raises(InputError) as err:  # a rule needs a named rotor
        MotorDesign.from_packings(**(SMALL | dict(rotor=custom)))
    assert err.value.field == "polarity"


# --- results and helpers -------------------------------------------------------------------------------------

def test_single_coil_failures_are_the_metrics_without_that_coil():
    from spherestep.motor import MotorDesign, single_coil_failures

    design = MotorDesign.from_packings(**SMALL)
    rows = single_coil_failures(design, samples=300, seed=1)
    assert [r.coil for r in rows] == list(range(len(design.stator)))
    for r in rows[:3]:
        m = design.without_coils([r.coil]).metrics(samples=300, seed=1, escape=False)
        assert (r.states, r.range_fraction, r.reaches_all, r.resolution_median_rad) == \
            (m.states, m.range_fraction, m.reaches_all, m.resolution_median_rad)
        assert m.escape_violations is None
        assert r.to_dict()["resolution_median_deg"] == math.degrees(r.resolution_median_rad)
    assert rows[0].states < design.metrics(samples=300, escape=False).states  # a failed coil loses states


def test_coil_currents_is_the_one_current_vector(proto):
    from spherestep.motor import coil_currents

    states = proto.states()
    c = proto.coil_currents(states.coils(0))
    assert c.shape == (29,) and set(np.flatnonzero(c)) == {k for _, k in states.held(0)}
    assert all(c[k] == proto.polarity[j] for j, k in states.held(0))
    assert np.array_equal(coil_currents({2: 0.5}, 4), [0, 0, 0.5, 0])
    for bad, field in (({29: 1}, "coils"), ({1: float("nan")}, "coils"), ({1: "x"}, "coils[1]"), (5, "coils")):
        with pytest.raises(InputError) as err:
            proto.coil_currents(bad)
        assert err.value.field == field
    with pytest.raises(InputError, match="failed coils"):
        proto.without_coils([3]).coil_currents({3: 1})


def test_within_takes_one_rotation_or_a_batch(proto):
    states = proto.states()
    R = states.rotations[:4].reshape(2, 2, 3, 3)
    batch = states.within(R, proto.max_step)
    assert batch.shape == (2, 2)
    for i in range(4):
        one = states.within(states.rotations[i], proto.max_step)
        assert np.array_equal(batch.reshape(-1)[i], one) and i in one
        brute = np.flatnonzero(so3.distance(states.rotations[i], states.rotations) <= proto.max_step)
        assert np.array_equal(one, brute)
    for call in (lambda: states.within(2 * np.eye(3), 0.1), lambda: states.nearest(np.eye(2)),
                 lambda: states.within(np.eye(3), -1.0)):
        with pytest.raises(InputError):
            call()


def test_result_dict_turns_angles_into_degrees_only():
    from dataclasses import dataclass

    from spherestep.units import result_dict

    @dataclass(frozen=True)
    class Result:
        offset_rad: float
        stiffness_Nm_per_rad: tuple[float, ...]
        missing_rad: float | None
        count: int

    r = Result(math.pi / 2, (1.5, 2.0), None, 3)
    assert result_dict(r) == {"offset_deg": 90.0, "stiffness_Nm_per_rad": [1.5, 2.0], "missing_deg": None, "count": 3}
    assert result_dict(r, degrees=False) == {"offset_rad": math.pi / 2, "stiffness_Nm_per_rad": [1.5, 2.0],
                                             "missing_rad": None, "count": 3}


def test_summaries_convert_their_angles_to_radians():
    import math

    from spherestep.units import in_radians

    out = in_radians({"time_s": 1.5, "final_error_deg": 0.05, "max_tracking_error_deg": None, "mode": "servo"})
    assert out == {"time_s": 1.5, "final_error_rad": math.radians(0.05), "max_tracking_error_rad": None,
                   "mode": "servo"}


@pytest.mark.slow
def test_prototype_headline_numbers(proto, proto_metrics):
    """The numbers the README and the demo quote (issue 27 §5), pinned to their noise: the state count is exact;
    the resolution median of 20,000 uniform samples has a sampling spread of about 0.01°."""
    m = proto_metrics
    assert m.states == 101_640
    assert math.degrees(m.resolution_median_rad) == pytest.approx(3.52, abs=0.03)
    assert math.degrees(m.resolution_p95_rad) == pytest.approx(6.22, abs=0.06)
    # the reported median against brute force over every state (no k-d tree) at 300 other orientations:
    # the median of 300 samples spreads by about 0.1°
    R = so3.random(300, 2024)
    states = proto.states().rotations
    brute = np.concatenate([so3.distance(R[i:i + 20, None], states[None]).min(axis=1) for i in range(0, 300, 20)])
    assert math.degrees(np.median(brute)) == pytest.approx(math.degrees(m.resolution_median_rad), abs=0.25)



@pytest.mark.parametrize("rotor, level, cap", [("truncated-icosahedron", 0, 60.0), ("icosidodecahedron", 0, 60.0),
                                               ("rhombicuboctahedron", 1, 70.0)])
def test_components_of_the_state_graph_against_all_pairs(rotor, level, cap):
    """The state graph's components (the nearest-neighbour pass, else all pairs) against a union-find over every
    pair within the radius, on layouts with one component and with hundreds, and at a radius that splits one."""
    from pathlib import Path

    from spherestep.synthesis import Candidate, load_spec
    from spherestep.synthesis.ladder import build

    spec = load_spec(Path(__file__).resolve().parents[1] / "examples" / "specs" / "prototype-relays-iron.yaml")
    design = build(Candidate(rotor, 0, "truncated-cuboctahedron", level, cap, 0.3048), "iron", spec)
    states = design.states()
    for radius in (design.max_step, 0.3 * design.max_step):
        parent = list(range(len(states)))

        def find(a):
            while parent[a] != a:
                parent[a] = parent[parent[a]]
                a = parent[a]
            return a

        for a, b in states.neighbour_pairs(radius):
            parent[find(int(a))] = find(int(b))
        assert states.components(radius) == len({find(a) for a in range(len(states))})
