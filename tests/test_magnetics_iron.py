"""Iron-cored coils (issue 14): the coil spec, the method-of-moments core solve, the iron torque model, and the
fast model against the stored full solves and finite elements."""

from __future__ import annotations

import math
from pathlib import Path

import magpylib as magpy
import numpy as np
import pytest
from magpylib_material_response.demag import apply_demag

from spherestep import so3
from spherestep.errors import InputError
from spherestep.magnetics import _iron as iron
from spherestep.magnetics import _ironcoupling as ironcoupling
from spherestep.magnetics import _ironforce as ironforce
from spherestep.magnetics import TorqueMap, iron_model
from spherestep.magnetics._coupling import COUPLING_ALPHA_DEG
from spherestep.magnetics._ironmap import IronTorqueMap
from spherestep.motor import prototype
from spherestep.motor.coil import INCH, RHO_COPPER, CoilSpec, IronMaterial, air_coil, iron_coil

DATA = Path(__file__).resolve().parents[1] / "data"


def study_cores(design) -> list[int]:
    """The two-core study's cores (``scripts/iron_tables.py``: the lowest core and, of the eight equally near it,
    the one toward ``STUDY_NEIGHBOUR`` — chosen by direction, not by index order), checked to be neighbours."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("iron_tables", DATA.parent / "scripts" / "iron_tables.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    cores = module.study_cores(design)
    v = design.stator.centers
    assert cores == [28, 17] and v[cores[1]] @ v[cores[0]] == pytest.approx(np.sort(v @ v[cores[0]])[-2])
    return cores


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def model(design):
    return iron_model(design)


# --- the coil as built -------------------------------------------------------------------------------------------

def test_winding_formulas_by_hand():
    c = iron_coil()
    D, L = 2 * INCH, 1.625 * INCH
    r_p, r_w, depth = 0.5 * INCH, 1.0 * INCH - 0.125 * INCH, 1.625 * INCH - 0.375 * INCH
    area = math.pi * 0.286e-3 ** 2 / 4
    n = int(0.6 * (r_w - r_p) * depth / area)
    R = RHO_COPPER * n * math.pi * (r_p + r_w) / area
    assert c.turns(D, L) == n
    assert c.resistance(D, L) == pytest.approx(R, rel=1e-12)
    assert c.nominal_current(D, L) == pytest.approx(min(24.0 / R, 100.0 / (24.0 * 4)), rel=1e-12)
    assert c.power(D, L) == pytest.approx(c.nominal_current(D, L) ** 2 * R, rel=1e-12)
    # a thicker wire: fewer turns, less resistance, the supply's share becomes the limit
    thick = iron_coil(wire_diameter=1.0e-3)
    assert thick.nominal_current(D, L) == pytest.approx(100.0 / 96.0)
    assert air_coil(1000).nominal_ampere_turns(D, L) == 1000.0


def test_bh_curve_is_invertible_and_odd():
    m = IronMaterial()
    H = np.array([-5e4, -100.0, 0.0, 300.0, 2000.0, 4e5])
    assert np.allclose(m.field_strength(m.flux_density(H)), H, rtol=1e-9, atol=1e-9)
    assert m.flux_density(-300.0) == -m.flux_density(300.0)


@pytest.mark.parametrize("kw, name", [({"core": "steel"}, "core"), ({"fill_factor": 1.2}, "fill_factor"),
                                      ({"wire_diameter": -1.0}, "wire_diameter"), ({"coils_on": 0}, "coils_on")])
def test_bad_coil_names_the_field(kw, name):
    with pytest.raises(InputError, match=name):
        CoilSpec(**kw)


def test_groove_must_fit(design):
    with pytest.raises(InputError, match="coil"):
        iron_coil(pole_diameter=2.5 * INCH).turns(design.coil_diameter, design.coil_length)


# --- the method of moments ---------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def rod():
    """A small iron rod (r = 6 mm, 12 mm long) at level 0: a few dozen cells, fast to factorise."""
    geom = iron.CoreGeometry(R=6e-3, L=12e-3, r_p=6e-3 - 1e-12, r_w=6e-3, depth=12e-3, NI=200.0, mu_r=1000.0)
    return iron.CoreSolver(geom, level=0)


@pytest.mark.slow
def test_factorised_solve_equals_apply_demag(rod):
    """One back-substitution of the factorised system reproduces magpylib-material-response's own apply_demag."""
    magnet = magpy.magnet.Cylinder(dimension=(0.01, 0.005), polarization=(0, 0, 1.3), position=(0.003, 0, -0.004))
    cells = [c.copy() for c in rod.cells]
    coll = magpy.Collection(*cells, magnet)
    for c in cells:
        c.susceptibility = rod.chi
    magnet.susceptibility = 0.0
    solved = apply_demag(coll, solver="direct")
    ref = np.array([s.orientation.apply(s.polarization) for s in solved.sources_all[:len(cells)]])
    mine = rod.polarization(magnet.getB(rod.centroids))
    assert np.abs(mine - ref).max() < 1e-9 * np.abs(ref).max()


@pytest.mark.slow
def test_reaction_equals_direct_force_on_the_magnet(rod):
    """Newton's third law across two computations: the force on the magnet from the solved rod's field (charges on
    the magnet's faces) against minus the magnet's force on the rod's cells (what magnet_wrenches uses)."""
    centre = np.array([[0.004, 0.0, -0.0045]])
    axis = np.array([[0.0, 0.0, 1.0]])
    magnet = iron.rotor_magnet(type("D", (), {"magnet_diameter": 0.01, "magnet_length": 0.005, "remanence": 1.3})(),
                          centre, axis)
    J = rod.polarization(magnet.getB(rod.centroids))
    pts, q = iron.magnet_faces(centre[0], axis[0], 0.01, 0.005, 1.3, n_r=8, n_phi=16)
    F_direct, T_direct = iron.charge_wrench(pts, q, rod.field(J, pts), pivot=(0, 0, -0.1))
    F_react, T_react = ironforce._reaction(rod, J, magnet, (0, 0, -0.1), order=4)
    assert F_direct[2] > 1.0  # pulled towards the iron
    assert np.linalg.norm(F_direct + F_react[0]) < 0.02 * np.linalg.norm(F_direct)
    assert np.linalg.norm(T_direct + T_react[0]) < 0.02 * np.linalg.norm(T_direct)


def test_face_charges_reproduce_getFT():
    """F = ∮σB dA on the magnet's faces against magpylib.getFT's volume mesh, in a coil's field."""
    loops = [magpy.current.Circle(diameter=0.04, current=100.0, position=(0, 0, z)) for z in (0.002, 0.01, 0.02)]
    magnet = magpy.magnet.Cylinder(dimension=(0.0254, 0.0127), polarization=(0, 0, 1.32),
                                   position=(0.008, 0.001, -0.009))
    F_ref, T_ref = magpy.getFT(loops, magnet, pivot=(0, 0, -0.15), meshing=3000)
    pts, q = iron.magnet_faces(magnet.position, (0, 0, 1), 0.0254, 0.0127, 1.32)
    F, T = iron.charge_wrench(pts, q, magpy.getB(loops, pts, sumup=True), pivot=(0, 0, -0.15))
    assert np.allclose(F, F_ref.sum(axis=0), atol=2e-3 * np.abs(F_ref.sum(axis=0)).max())
    assert np.allclose(T, T_ref.sum(axis=0), atol=2e-3 * np.abs(T_ref.sum(axis=0)).max())


def test_bad_mesh_level():
    with pytest.raises(InputError, match="level"):
        iron.mesh_parameters(9)


# --- the torque model --------------------------------------------------------------------------------------------

def test_air_core_reproduces_todays_map(design):
    R = so3.random(5, 3)
    c = np.random.default_rng(3).choice([-1.0, 0.0, 1.0], size=(5, len(design.stator)))
    today = TorqueMap.build(design)
    air = iron_model(design, air_coil(design.coil_ampere_turns))
    assert np.array_equal(air.torque(R, c), today.torque(R, c))
    assert np.array_equal(air.energy(R, c), today.energy(R, c))


def test_the_design_states_its_coil(model, design):
    """iron_model reads design.coil: a thinner fill of the same wire (half the turns, twice the current, the same
    N I) keeps the stored tables; an air coil is the air map at the winding's N I; iron_summary needs iron."""
    from dataclasses import replace

    from spherestep.control import DriveLimits
    from spherestep.magnetics import iron_summary

    thin = replace(design, coil=iron_coil(fill_factor=0.3))
    m = iron_model(thin)
    assert isinstance(m, IronTorqueMap) and m.coil is thin.coil and model.coil == iron_coil()
    assert np.array_equal(m.linear.tau, model.linear.tau) and np.array_equal(m.detent.tau, model.detent.tau)
    D, L = design.coil_diameter, design.coil_length
    assert DriveLimits.from_spec(m.coil, thin).nominal_current == pytest.approx(
        2 * DriveLimits.from_spec(model.coil, design).nominal_current, rel=1e-3)
    assert iron_model(thin, iron_coil()).coil == iron_coil()  # the explicit argument wins
    air = replace(design, coil=replace(iron_coil(), core="air"))
    ni = air.coil.nominal_ampere_turns(D, L)
    R = so3.random(3, 9)
    c = np.random.default_rng(9).choice([-1.0, 0.0, 1.0], size=(3, len(design.stator)))
    np.testing.assert_allclose(iron_model(air).torque(R, c),
                               TorqueMap.build(design).torque(R, c) * ni / design.coil_ampere_turns, rtol=1e-12)
    with pytest.raises(InputError, match="iron-cored"):
        iron_summary(design, air_coil())
    with pytest.raises(InputError, match="model"):  # the whole motor's model: a TorqueModel of its coils
        iron_summary(design, model=design)


def test_iron_model_is_a_torque_model_with_a_detent(model, design):
    from spherestep.statics import TorqueModel
    assert isinstance(model, IronTorqueMap) and isinstance(model, TorqueModel)
    R = so3.random(4, 5)
    T0 = model.torque(R, np.zeros(len(design.stator)))
    assert np.all(np.linalg.norm(T0, axis=1) > 1e-3)  # the iron pulls with every coil off
    # linear in the currents: T(c) = T(0) + K c
    c = np.random.default_rng(5).uniform(-1, 1, (4, len(design.stator)))
    K = model.torque_matrix(R)
    assert np.allclose(model.torque(R, c), T0 + np.einsum("kin,kn->ki", K, c), atol=1e-12, rtol=1e-10)


def test_torque_is_minus_the_energy_gradient(model, design):
    """τ·e = −dE/dθ along a turn exp(θ e) R, by central differences of the energy (to 1e-6 relative)."""
    rng = np.random.default_rng(7)
    R = so3.random(6, rng)
    c = rng.choice([-1.0, 0.0, 1.0], size=(6, len(design.stator)))
    e = rng.normal(size=(6, 3))
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    h = 1e-6
    Ep = model.energy(so3.exp(h * e) @ R, c)
    Em = model.energy(so3.exp(-h * e) @ R, c)
    dE = (Ep - Em) / (2 * h)
    tau = np.einsum("ki,ki->k", model.torque(R, c), e)
    scale = np.linalg.norm(model.torque(R, c), axis=1)
    assert np.all(np.abs(tau + dE) <= 1e-6 * scale)


# --- the fast model against stored full solves ------------------------------------------------------------------

def _csv(name):
    """Columns of a stored ``#``-commented CSV (header line of names) as a dict of arrays."""
    path = DATA / name
    if not path.exists():
        pytest.fail(f"{path} missing: run the script named in docs/magnetics.md")
    lines = [line for line in path.read_text().splitlines() if line and not line.startswith("#")]
    names = lines[0].split(",")
    values = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    return {n: values[:, i] for i, n in enumerate(names)}


def _fem_rows():
    fem = _csv("iron_fem.csv")
    sizes, counts = np.unique(fem["maxh_face_m"], return_counts=True)
    keep = fem["maxh_face_m"] == sizes[np.argmax(counts)]  # the mesh every angle was solved on
    return {k: v[keep] for k, v in fem.items()}


def test_fast_model_against_fem(model):
    """The issue's target: the prototype's fast model within 5 % of the FEM's peak pair torque at every reference
    angle of data/iron_fem.csv (2°, 5°, 8°, 12°, 20°), none of which is a node of its table (held out: the check
    covers the table's interpolation too)."""
    fem = _fem_rows()
    a = np.radians(fem["alpha_deg"])
    assert not np.any(np.isclose(model.detent.nodes[:, None], a[None, :]))  # held out
    peak = max(np.abs(fem["detent_Nm"]).max(), np.abs(fem["linear_Nm"]).max())
    assert np.abs(model.detent.pair(a) - fem["detent_Nm"]).max() <= 0.05 * peak
    assert np.abs(model.linear.pair(a) - fem["linear_Nm"]).max() <= 0.05 * peak


def test_moment_method_against_fem(design):
    """The moment method (data/iron_pair_table_mom.csv, level 0) meets the FEM within 5 % of its peak only where
    its mesh resolves the geometry (detent at α ≥ 8°, coil at α ≥ 12°); near the axis it misses by 20–31 %, which is
    why the prototype's table takes the FEM below 21° (docs/magnetics.md)."""
    fem = _fem_rows()
    mom = _csv("iron_pair_table_mom.csv")
    m = IronTorqueMap.from_tables(design, iron_coil(), np.radians(mom["alpha_deg"]), mom["detent_Nm"],
                                  mom["linear_Nm"])
    a = fem["alpha_deg"]
    peak = max(np.abs(fem["detent_Nm"]).max(), np.abs(fem["linear_Nm"]).max())
    err_d = np.abs(m.detent.pair(np.radians(a)) - fem["detent_Nm"]) / peak
    err_l = np.abs(m.linear.pair(np.radians(a)) - fem["linear_Nm"]) / peak
    assert np.all(err_d[a >= 8.0] <= 0.05) and np.all(err_l[a >= 12.0] <= 0.05)
    assert max(err_d.max(), err_l.max()) > 0.2  # the near-axis miss the FEM table replaces


def _multibody(design):
    """The two-core study's orientations, coil drives, cores and full-solve torques (data/iron_multibody.csv)."""
    mb = _csv("iron_multibody.csv")
    R = np.load(DATA / "iron_multibody_R.npy")[mb["orientation"].astype(int)]
    v = design.stator.centers
    cores = study_cores(design)
    c = np.zeros((len(R), len(v)))
    c[:, cores] = np.c_[mb["c0"], mb["c1"]]
    return mb, R, c, cores, np.c_[mb["full_x"], mb["full_y"], mb["full_z"]]


def _mom_model(design, coupling=None):
    """The live superposition on the moment method's own pair table (the full solve's mesh level)."""
    from spherestep.magnetics._ironmap import read_table

    mom = read_table(DATA / "iron_pair_table_mom.csv")
    return IronTorqueMap.from_tables(design, iron_coil(), np.radians(mom[:, 0]), mom[:, 1], mom[:, 2],
                                     coupling=coupling)


def test_pairwise_against_full_multibody_solve(design):
    """The live pairwise superposition (``IronTorqueMap.torque_on`` on the moment method's table, the full solve's
    mesh level) against the full solve of two cores under the whole rotor (data/iron_multibody.csv, 4 orientations
    × 3 drives): it reproduces the file's pair sums (1e-6 N·m: the study used this code) and misses the full solve by
    a median 32 % (0.25–0.40 allowed), up to 155 % (< 1.7): the issue's 5 % target is not met by superposition, and
    the coupling term narrows the gap (test_coupled_model_against_the_full_solve)."""
    mb, R, c, cores, full = _multibody(design)
    got = _mom_model(design).torque_on(R, c, cores)
    assert np.abs(got - np.c_[mb["pair_x"], mb["pair_y"], mb["pair_z"]]).max() <= 1e-6
    err = np.linalg.norm(full - got, axis=1) / np.linalg.norm(full, axis=1)
    assert 0.25 < np.median(err) < 0.40 and err.max() < 1.7


@pytest.mark.slow
def test_coupling_energy_is_the_joint_solve_less_the_self_terms(design):
    """``_ironcoupling.coupling_energy`` by an independent route: one solve with every near magnet's field at once, its
    energy ``−(1/2μ0) ∫ J·B``, less each magnet's energy alone, equals the cross terms (linearity), to 1e-9."""
    from spherestep.magnetics._model import MU0

    coil = iron_coil()
    v = design.stator.centers
    k = int(np.argmin(v[:, 2]))
    R = np.load(DATA / "iron_multibody_R.npy")[3]
    got = ironcoupling.coupling_energy(design, coil, [k], R)
    solver = ironcoupling._placed_solver(iron.CoreGeometry.of(design, coil), 0, (tuple(v[k]),),
                                 design.radius + design.air_gap)
    w = R @ design.rotor.centers.T
    near = np.flatnonzero(v[k] @ w > np.cos(ironcoupling.COUPLING_REACH))
    assert len(near) >= 2
    r_c = iron.magnet_face_radius(design) - 0.5 * design.magnet_length
    rotor = [iron.rotor_magnet(design, r_c * w[:, j][None], w[:, j][None], float(design.polarity[j])) for j in near]
    pts, wts, owner = iron.cell_quadrature(solver.cells, 3, near=solver.near)

    def energy(magnets):
        J = solver.polarization(magpy.getB(magnets, solver.centroids, sumup=True))
        B = np.zeros_like(J)
        np.add.at(B, owner, magpy.getB(magnets, pts, sumup=True) * wts[:, None])
        return -0.5 * np.sum(J * B) / MU0

    want = energy(rotor) - sum(energy([m]) for m in rotor)
    assert abs(got - want) <= 1e-9 * abs(want) and abs(want) > 0


def test_coupling_brings_pairwise_toward_the_full_solve(design):
    """The live coupling term (``iron_model(design, coupling=True)``, its table of the core's coupling energy) on the
    two cores of the coupling study, coils off, against the direct coupling solve stored there
    (data/iron_coupling.csv, ``scripts/iron_tables.py coupling``): within 0.08 N·m at every orientation (the table's
    interpolation in three angles, differentiated; measured 0.023–0.063 N·m, up to 13 % of the largest coupling
    torque, 0.47 N·m); and the live pair
    superposition plus that term is closer to the stored full solve than the pair tables alone at every
    orientation — the coupling is most of the gap."""
    cp = _csv("iron_coupling.csv")
    R = np.load(DATA / "iron_multibody_R.npy")[cp["orientation"].astype(int)]
    _, _, _, cores, _ = _multibody(design)
    coupled = iron_model(design, coupling=True).coupling
    live = iron_model(design, coupling=True).subset(cores).coupling.torque(R)
    stored = np.c_[cp["coupling_x"], cp["coupling_y"], cp["coupling_z"]]
    assert len(R) == 4 and np.linalg.norm(live - stored, axis=1).max() <= 0.08
    full = np.c_[cp["full_x"], cp["full_y"], cp["full_z"]]
    off = np.zeros((len(R), len(design.stator)))
    pair = _mom_model(design).torque_on(R, off, cores)
    with_term = _mom_model(design, coupled).torque_on(R, off, cores)
    before = np.linalg.norm(full - pair, axis=1) / np.linalg.norm(full, axis=1)
    after = np.linalg.norm(full - with_term, axis=1) / np.linalg.norm(full, axis=1)
    assert np.all(after < before) and np.median(before) > 0.35


@pytest.mark.slow
def test_saturating_solve_without_saturation_is_the_linear_one(design):
    """With a B–H curve that is the linear solve's own line (μr = 1000 all the way), the saturating solve never
    leaves it: one iteration, and the pair torque at 8° with the coil at +nominal equals the linear tables'
    detent + linear to 1e-9 of the peak."""
    import dataclasses

    from spherestep.magnetics._model import MU0

    coil = iron_coil()
    line = IronMaterial(bh=((0.0, 0.0), (1e6, MU0 * 1000.0 * 1e6)), knee=1.5)
    straight = dataclasses.replace(coil, material=line)
    tau, _, iterations = ironforce.saturated_pair_torque(design, straight, math.radians(8.0), 1.0)
    det, lin = ironforce.pair_tables(design, coil, np.radians([8.0]))
    assert iterations == 1 and abs(tau - (det[0] + lin[0])) <= 1e-9 * abs(det[0] + lin[0])


@pytest.mark.slow
def test_saturation_study(design):
    """The live saturating solve (``_ironforce.saturated_pair_torque``, MoM level 0, one pole and one coil) against
    the stored study (data/iron_saturation.csv, ``scripts/iron_tables.py saturation``): at the detent's peak (12°,
    coil off) and near the axis with the coil on (2°, +1) it reproduces the stored torque, largest |B| and iteration
    count (the iteration is deterministic: 1e-6 relative; measured equal to the file's 9 digits), and the live
    linear tables (``pair_tables``) the file's linear column; at 20° no cell saturates (one iteration, the linear
    torque). What the study shows, on the live numbers: saturation weakens the detent at its peak by more than 5 %
    and keeps every cell below 2.1 T (the linear solve reaches 2.9 T at the motor's rest poses); and over the
    stored angles the torque per unit current ``(τ(+1) − τ(−1))/2`` moves by under 3 % of the linear peak —
    saturation acts on the detent, not on the winding."""
    s = _csv("iron_saturation.csv")
    at = {(a, c): row for row in zip(*(s[k] for k in ("alpha_deg", "current", "linear_Nm", "saturated_Nm", "max_B_T",
                                                          "iterations"))) for a, c in [row[:2]]}
    coil = iron_coil()
    for a, c in ((12.0, 0.0), (2.0, 1.0), (20.0, 1.0)):
        tau, b_max, iterations = ironforce.saturated_pair_torque(design, coil, math.radians(a), c)
        _, _, lin, sat, b_stored, it_stored = at[(a, c)]
        assert tau == pytest.approx(sat, rel=1e-6) and b_max == pytest.approx(b_stored, rel=1e-6)
        assert iterations == it_stored and b_max < 2.1
    det, lin = ironforce.pair_tables(design, coil, np.radians([2.0, 12.0, 20.0]))
    for k, a in enumerate((2.0, 12.0, 20.0)):
        assert det[k] == pytest.approx(at[(a, 0.0)][2], rel=1e-6)
        assert det[k] + lin[k] == pytest.approx(at[(a, 1.0)][2], rel=1e-6, abs=1e-9)
    assert at[(20.0, 1.0)][5] == 1 and at[(20.0, 1.0)][3] == at[(20.0, 1.0)][2]
    assert abs(at[(12.0, 0.0)][3]) < 0.95 * abs(det[1])
    peak = max(abs(v[2]) for v in at.values())
    for a in np.unique(s["alpha_deg"]):
        per_current = [0.5 * (at[(a, 1.0)][i] - at[(a, -1.0)][i]) for i in (2, 3)]
        assert abs(per_current[1] - per_current[0]) <= 0.03 * peak


@pytest.fixture(scope="module")
def coupled(design):
    return iron_model(design, coupling=True)


@pytest.mark.slow
def test_coupled_model_is_a_torque_model(coupled, design):
    """With the coupling the iron model is still a torque model: torque = −∂E/∂θ (central differences, 1e-6 of
    the largest torque), compiled terms (its tables), equilibria by the compiled descent."""
    from spherestep.statics import equilibrium

    R = so3.random(6, np.random.default_rng(2))
    c = np.zeros((6, len(design.stator)))
    c[:, [3, 11]] = [1.0, -1.0]
    h = 1e-6
    fd = np.stack([-(coupled.energy(so3.exp(h * e) @ R, c) - coupled.energy(so3.exp(-h * e) @ R, c)) / (2 * h)
                   for e in np.eye(3)], axis=1)
    tau = coupled.torque(R, c)
    assert np.max(np.abs(fd - tau)) <= 1e-6 * np.max(np.abs(tau))
    assert coupled.packed_terms(c[0]) is not None  # its tables: the compiled paths take it (issue 28 §2)
    assert np.max(np.abs(coupled.coupling.torque(R))) > 0.05  # N·m: not negligible
    states = design.states()
    eq = equilibrium(coupled, states.rotations[0], design.coil_currents(states.coils(0)))
    assert eq.converged and eq.is_minimum


def test_coupling_table_against_the_direct_energy(coupled, design):
    """The table's coupling energy for one core (``CoreCoupling``, splines in the two angles, a cosine series in the
    azimuth) against the direct sum ``_ironcoupling.coupling_energy`` of the same core at the multibody orientations: within
    5 % of the direct value (the table's interpolation; 2° and 15° nodes)."""
    v = design.stator.centers
    k = int(np.argmin(v[:, 2]))
    one = coupled.subset([k]).coupling
    for R in np.load(DATA / "iron_multibody_R.npy")[2:4]:
        want = ironcoupling.coupling_energy(design, iron_coil(), [k], R, reach=np.radians(COUPLING_ALPHA_DEG[-1]))
        assert abs(one.energy(R[None])[0] - want) <= 0.05 * abs(want)


def test_coupled_model_against_the_full_solve(design):
    """The moment method's pair tables plus the coupling term against the full two-core solve (data/iron_multibody.csv,
    same mesh level; 4 orientations × coils off, one on, one on and one reversed): closer in every case than the
    pair tables alone (median 32 %, up to 155 %), median under 10 % and at most 36 % — the rest is the cores'
    coupling to each other, which the term leaves out."""
    from spherestep.magnetics._ironmap import read_table

    mom = read_table(DATA / "iron_pair_table_mom.csv")
    coupled = iron_model(design, coupling=True)
    model = IronTorqueMap.from_tables(design, iron_coil(), np.radians(mom[:, 0]), mom[:, 1], mom[:, 2],
                                      coupling=coupled.coupling)
    mb = _csv("iron_multibody.csv")
    R = np.load(DATA / "iron_multibody_R.npy")[mb["orientation"].astype(int)]
    full = np.c_[mb["full_x"], mb["full_y"], mb["full_z"]]
    pair = np.c_[mb["pair_x"], mb["pair_y"], mb["pair_z"]]
    v = design.stator.centers
    cores = study_cores(design)
    c = np.zeros((len(R), len(v)))
    c[:, cores] = np.c_[mb["c0"], mb["c1"]]
    got = model.torque_on(R, c, cores)
    assert np.allclose(model.subset(cores).detent.torque(R, np.ones((len(R), 2))) + model.subset(cores).linear.torque(
        R, c[:, cores]), pair, atol=1e-6)  # the file's pair sum is these tables'
    before = np.linalg.norm(full - pair, axis=1) / np.linalg.norm(full, axis=1)
    after = np.linalg.norm(full - got, axis=1) / np.linalg.norm(full, axis=1)
    # max 0.356 before the reach's taper (issue 28 §2: the coupling fades out over 50–60°, which its tables need),
    # 0.369 with it (the case of 0.36 N m; the median 0.082 → 0.093)
    assert np.all(after < before) and after.max() < 0.375 and np.median(after) < 0.10


def test_coupling_effects_study(model, design):
    """The stored study of what the coupling changes (data/iron_coupling_effects.csv, ``scripts/iron_tables.py
    coupling-effects``) against the live pairwise model: iron_summary's samples (seed 0: 12 random unpowered starts,
    12 stepper states with their coils) brought to rest by ``statics.equilibrium`` on ``iron_model(design)`` are
    the file's pairwise rows — every one a minimum, the rest pose's distance from its start to 1e-5° and the
    softest stiffness to 1e-5 relative (measured 5e-8° and 4e-7: the descent's tolerance) — and the coupled model's
    unpowered rest poses stored beside them stay within 2° of those (a fraction of a degree)."""
    from spherestep.magnetics import state_currents
    from spherestep.statics import equilibrium

    t = _csv("iron_coupling_effects.csv")
    rng = np.random.default_rng(0)
    starts = so3.random(12, rng)
    states = design.states()
    idx = np.sort(rng.choice(len(states), 12, replace=False))
    runs = {0: (starts, np.zeros((12, len(design.stator)))),
            1: (states.rotations[idx], np.array([state_currents(design, i) for i in idx]))}
    for kind, (start, c) in runs.items():
        rows = (t["coupled"] == 0) & (t["state"] == kind)
        eq = equilibrium(model, start, c, gtol=1e-9, max_step=np.radians(2.0))
        assert np.all(eq.is_minimum) and np.all(t["minimum"][rows] == 1)
        assert np.degrees(so3.distance(eq.rotation, start)) == pytest.approx(t["moved_deg"][rows], abs=1e-5)
        assert eq.stiffness[:, 0] == pytest.approx(t["stiffness_Nm_per_rad"][rows], rel=1e-5)
    unpowered = (t["coupled"] == 1) & (t["state"] == 0) & (t["minimum"] == 1)
    assert np.count_nonzero(unpowered) >= 9 and np.all(t["from_pairwise_deg"][unpowered] < 2.0)


def test_fem_mesh_convergence(model):
    """The FEM reference converges and the live model meets its finest mesh: at 2°, 8° and 12° the pair torques on
    successively finer face meshes (2 mm, 1.4 mm) change by less than 1 % of the peak pair torque (measured ≤ 0.7 %;
    data/iron_fem.csv, ``scripts/fem_iron.py --quick`` and ``--maxh 0.0014 --angles 12 2``), and the live model
    (``iron_model(prototype())``, its table built from the 2-mm FEM nodes, none at a reference angle) is within
    1.5 % of the peak of the finest solve at every reference angle (measured ≤ 1.1 %, at 5°): the model's error is
    of the order of the FEM's own mesh error, not the 5 % the issue allowed."""
    fem = _csv("iron_fem.csv")
    peak = max(np.abs(fem["detent_Nm"]).max(), np.abs(fem["linear_Nm"]).max())
    refined = [a for a in np.unique(fem["alpha_deg"]) if np.count_nonzero(fem["alpha_deg"] == a) >= 2]
    assert {2.0, 8.0, 12.0} <= set(refined)  # near the axis, mid-way, the detent's peak
    for a in np.unique(fem["alpha_deg"]):
        at = np.flatnonzero(fem["alpha_deg"] == a)
        at = at[np.argsort(-fem["maxh_face_m"][at])]  # coarse to fine
        live = {"detent_Nm": model.detent.pair(np.radians([a]))[0], "linear_Nm": model.linear.pair(np.radians([a]))[0]}
        for column in ("detent_Nm", "linear_Nm"):
            assert abs(live[column] - fem[column][at[-1]]) <= 0.015 * peak, (a, column)
            if a in refined:
                assert fem["elements"][at[-1]] > 2 * fem["elements"][at[0]]
                assert abs(fem[column][at[-1]] - fem[column][at[-2]]) <= 0.01 * peak
