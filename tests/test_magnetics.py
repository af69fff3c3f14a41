"""Physics checks of the magpylib model: signs, Newton's third law, superposition, symmetry, convergence."""

import math
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherestep import magnetics as mg
from spherestep import so3
from spherestep.errors import InputError
from spherestep.potential import load_force_curve


@pytest.fixture(scope="module")
def tmap(proto):
    return mg.torque_map(proto)


def pole_on_coil(design, j, k):
    """A rotation taking body pole ``j`` exactly onto coil ``k``'s axis."""
    R = Rotation.align_vectors([design.stator.centers[k]], [design.rotor.centers[j]])[0].as_matrix()
    assert np.linalg.norm(R @ design.rotor.centers[j] - design.stator.centers[k]) < 1e-12
    return R


def test_geometry_and_polarization(proto):
    mags = mg.rotor_magnets(proto)
    coils = mg.stator_coils(proto, currents=np.where(np.arange(len(proto.stator)) == 3, -1.0, 1.0))
    u, v = proto.rotor.centers, proto.stator.centers
    for j in (0, 61, 91):
        m = mags[j]
        axis = m.orientation.apply([0.0, 0.0, 1.0])
        np.testing.assert_allclose(axis, u[j], atol=1e-12)  # magnet axis radial
        outer_face = np.linalg.norm(m.position) + 0.5 * proto.magnet_length
        assert outer_face == pytest.approx(proto.radius, abs=1e-12)  # outer face on the shell
        np.testing.assert_allclose(m.orientation.apply(m.polarization), proto.remanence * proto.polarity[j] * u[j],
                                   atol=1e-12)
    j0 = 4e-7 * math.pi * proto.coil_ampere_turns / proto.coil_length
    assert mg.coil_polarization(proto) == pytest.approx(j0, rel=1e-9)
    for k in (0, 3):
        c = coils[k]
        inner_face = np.linalg.norm(c.position) - 0.5 * proto.coil_length
        assert inner_face == pytest.approx(proto.radius + proto.air_gap, abs=1e-12)
        sign = -1.0 if k == 3 else 1.0
        np.testing.assert_allclose(c.orientation.apply(c.polarization), sign * j0 * v[k], atol=1e-15)


def test_attracting_coil_pulls_pole_back(proto, tmap):
    # Fig. 6 set-up: attraction along the axis when aligned, restoring sideways
    curve = mg.force_curve(proto, [0.0, 0.005, 0.02], meshing=27)
    assert curve.normal[0] > 3.0  # N, the aligned magnet is pulled towards the coil
    assert curve.lateral[0] == pytest.approx(0.0, abs=1e-9)
    assert np.all(curve.lateral[1:] < -0.1)
    # on the sphere: a +1 pole beside a +1 coil is turned back towards the axis (τ < 0 for small α)
    alpha = np.radians([2.0, 5.0, 8.0])
    assert np.all(tmap.pair(alpha) < -0.05)
    # the rotor as a whole: pole j a few degrees off coil k, only coil k on with the pole's polarity
    j, k = 0, 5
    R = so3.rot(np.cross(proto.stator.centers[k], [1.0, 0.0, 0.0]), math.radians(4.0)) @ pole_on_coil(proto, j, k)
    c = np.zeros(len(proto.stator))
    c[k] = proto.polarity[j]
    T = mg.torque(proto, R, c, meshing=27)
    w = R @ proto.rotor.centers[j]
    back = np.cross(w, proto.stator.centers[k])  # turning about w × v moves the pole towards v
    assert T @ back / np.linalg.norm(back) > 0.2


def test_no_torque_with_coils_off(proto):
    R = so3.random(3, 1)
    F, T = mg.force_torque(proto, R, np.zeros(len(proto.stator)))
    assert np.all(F == 0) and np.all(T == 0)


def test_rotor_exerts_no_net_torque_on_itself(proto):
    # every magnet in the field of every other one: each feels up to ~0.15 N·m, the sum over the rotor vanishes
    # (internal forces), so the torque on the rotor comes from the stator alone
    mags = mg.rotor_magnets(proto)
    F, T = magpy.getFT(mags, mags, pivot=(0.0, 0.0, 0.0), meshing=64, eps=1e-6, squeeze=False)
    F, T = F[:, 0], T[:, 0]  # (source, target, 3)
    own = np.arange(len(mags))
    F[own, own] = 0.0
    T[own, own] = 0.0
    per_magnet = np.linalg.norm(T.sum(axis=0), axis=1).max()
    assert per_magnet > 0.1
    assert np.linalg.norm(T.sum(axis=(0, 1))) < 1e-5 * per_magnet
    assert np.linalg.norm(F.sum(axis=(0, 1))) < 1e-5 * np.linalg.norm(F.sum(axis=0), axis=1).max()


def test_action_equals_minus_reaction(proto):
    # force on the rotor (magnets meshed, coils as cylinders) against force on the stator (coils as current
    # loops, magnets as sources): two independent getFT computations of one interaction
    rng = np.random.default_rng(11)
    R = so3.random(1, rng)[0]
    c = np.zeros(len(proto.stator))
    c[[2, 9, 17, 25]] = [1.0, -1.0, 1.0, -1.0]
    F, T = mg.force_torque(proto, R, c, meshing=216)
    Fr, Tr = mg.reaction(proto, R, c, loops=32, segments=64)
    assert np.linalg.norm(F) > 1.0
    assert np.linalg.norm(F + Fr) < 0.01 * np.linalg.norm(F)
    assert np.linalg.norm(T + Tr) < 0.01 * np.linalg.norm(T)


def test_superposition_and_independent_sum(proto):
    rng = np.random.default_rng(5)
    R = so3.random(2, rng)
    c1 = rng.choice([-1.0, 0.0, 1.0], size=(2, len(proto.stator)))
    c2 = rng.choice([-1.0, 0.0, 1.0], size=(2, len(proto.stator)))
    T1, T2 = mg.torque(proto, R, c1, meshing=8), mg.torque(proto, R, c2, meshing=8)
    T12 = mg.torque(proto, R, c1 + c2, meshing=8)
    np.testing.assert_allclose(T12, T1 + T2, atol=1e-12 * np.abs(T12).max())
    np.testing.assert_allclose(mg.torque(proto, R, 2.5 * c1, meshing=8), 2.5 * T1, rtol=1e-12, atol=1e-14)
    # the same drive as ONE magpylib call with the coils' polarizations set from c1 (no superposition by us)
    coll = magpy.Collection(*mg.rotor_magnets(proto))
    coll.rotate(Rotation.from_matrix(R[0]), anchor=(0.0, 0.0, 0.0))
    stator = magpy.Collection(*mg.stator_coils(proto, currents=c1[0]))
    F_ref, T_ref = magpy.getFT(stator, coll, pivot=(0.0, 0.0, 0.0), meshing=8, eps=1e-6)
    F1, T1_again = mg.force_torque(proto, R[0], c1[0], meshing=8)
    np.testing.assert_allclose(T1_again, T_ref, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(F1, F_ref, rtol=1e-9, atol=1e-12)


def test_symmetric_equilibrium_has_no_torque(proto):
    # a pole on a 5-fold axis of the rotor (rotating the rotor by 72° about it maps poles onto poles of equal
    # polarity; the icosahedral rotor has 12) goes on coil 5's axis, and coil 5 alone is energised: the 5-fold
    # symmetry allows only a torque along the axis, the coil's axisymmetry forbids that one, so none is left
    u, p = proto.rotor.centers, proto.polarity

    def five_fold(j):
        turned = u @ so3.rot(u[j], 2 * math.pi / 5).T
        dist = np.linalg.norm(turned[:, None] - u[None], axis=2)
        return dist.min(axis=1).max() < 1e-9 and np.all(p[dist.argmin(axis=1)] == p)

    axes = [j for j in range(len(u)) if five_fold(j)]
    assert len(axes) == 12
    j, k = axes[0], 5
    c = np.zeros(len(proto.stator))
    c[k] = p[j]
    F, T = mg.force_torque(proto, pole_on_coil(proto, j, k), c, meshing=216)
    assert np.linalg.norm(F) > 1.0  # the coil does pull
    assert np.linalg.norm(T) < 1e-8  # N·m, against ~0.4 N·m for one pole a few degrees off


def test_one_coil_exerts_no_torque_about_its_own_axis(proto):
    R = so3.random(3, 2)
    c = np.zeros(len(proto.stator))
    c[7] = 1.0
    T = mg.torque(proto, R, c, meshing=27)
    assert np.all(np.linalg.norm(T, axis=1) > 0.01)
    np.testing.assert_allclose(T @ proto.stator.centers[7], 0.0, atol=1e-9)


def test_pair_torque_converges_with_meshing(proto):
    # the worst angle: the magnet's rim under the coil's rim
    alpha = np.radians([6.0, 9.0, 11.0])
    ref = mg.pair_torque(proto, alpha, meshing=3000)
    scale = 0.414  # N·m, the peak |τ| at 8°
    errors = [np.abs(mg.pair_torque(proto, alpha, meshing=m) - ref).max() / scale for m in (8, 216, 1000)]
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] < 0.06 and errors[1] < 0.008 and errors[2] < 0.002
    assert np.abs(ref).max() == pytest.approx(scale, rel=0.03)


def test_direct_evaluation_is_batched_like_single_calls(proto):
    R = so3.random(3, 4)
    c = np.zeros((3, len(proto.stator)))
    c[:, [1, 12]] = [1.0, -1.0]
    F, T = mg.force_torque(proto, R, c, meshing=8)
    for i in range(3):
        Fi, Ti = mg.force_torque(proto, R[i], c[i], meshing=8)
        np.testing.assert_allclose(Ti, T[i], rtol=1e-10, atol=1e-14)
        np.testing.assert_allclose(Fi, F[i], rtol=1e-10, atol=1e-14)


def test_force_curve_symmetry(proto):
    x = np.array([-0.03, -0.01, 0.0, 0.01, 0.03])
    c = mg.force_curve(proto, x, meshing=1000)
    # odd and even in x up to the mesh, whose cells are not mirror symmetric (at ±30 mm the magnet's rim
    # crosses the coil's, where the mesh error is largest): 1 % of the peak force at 1000 cells
    tol = 0.01 * np.abs(c.normal).max()
    np.testing.assert_allclose(c.lateral, -c.lateral[::-1], atol=tol)
    np.testing.assert_allclose(c.normal, c.normal[::-1], atol=tol)
    assert abs(c.lateral[1] + c.lateral[3]) < 1e-9  # close to the axis the mesh is symmetric enough
    wider = mg.force_curve(proto, [0.0], meshing=1000, gap=0.002)
    assert 0 < wider.normal[0] < c.normal[2]  # a wider gap pulls less


def test_force_curve_file_reads_back_as_a_fig6_curve(proto, tmp_path):
    c = mg.force_curve(proto, [0.0, 0.01, 0.02], meshing=8)
    c.save(tmp_path / "c.csv", proto.name)
    x, F = load_force_curve(tmp_path / "c.csv")
    np.testing.assert_allclose(F, c.lateral, rtol=1e-6)
    np.testing.assert_allclose(x, c.displacement, rtol=1e-6)
    assert "SIMULATED" in (tmp_path / "c.csv").read_text().splitlines()[0]


@pytest.mark.parametrize("call, field", [
    (lambda d: mg.torque(d, np.ones((3, 3)), np.zeros(29)), "R"),
    (lambda d: mg.torque(d, np.eye(3)[None].repeat(2, 0), np.zeros((3, 29))), "currents"),
    (lambda d: mg.torque(d, np.eye(3), np.full(29, np.nan)), "currents"),
    (lambda d: mg.torque(d, np.eye(3), np.zeros(29), meshing=0), "meshing"),
    (lambda d: mg.torque(d.without_coils([4]), np.eye(3), np.eye(29)[4]), "currents"),
    (lambda d: mg.force_curve(d, []), "displacements"),
    (lambda d: mg.force_curve(d, [0.0], gap=-1.0), "gap"),
    (lambda d: mg.coil_wrenches(d, np.eye(3), coils=[40]), "coils"),
    (lambda d: mg.reaction(d, np.eye(3), np.eye(29)[0], segments=3), "segments"),
])
def test_bad_input_names_the_field(proto, call, field):
    with pytest.raises(InputError, match=rf"^{field} must be"):
        call(proto)


def test_data_file_is_the_simulation(proto):
    x, F = load_force_curve(Path(__file__).resolve().parents[1] / "data" / "force_curve_magpylib.csv")
    assert len(x) == 121 and x[-1] == pytest.approx(0.060)
    rows = [0, 30, 47, 80, 108]  # 0, 15, 23.5 (the peak), 40, 54 mm
    again = mg.force_curve(proto, x[rows])
    np.testing.assert_allclose(F[rows], again.lateral, rtol=1e-5, atol=1e-9)
    assert F.min() == pytest.approx(-2.84, abs=0.01) and x[np.argmin(F)] == pytest.approx(0.0235)
