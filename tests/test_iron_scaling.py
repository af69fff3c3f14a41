"""Any design's iron (issue 28 §3): the rotor shell as a design dimension, and the scaling law of linear
magnetostatics reusing the prototype's stored (FEM-based) tables for any scaled copy of its geometry."""

from __future__ import annotations

import math
from dataclasses import replace
from importlib import resources

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from spherestep.errors import InputError
from spherestep.magnetics import iron_model
from spherestep.magnetics import _iron
from spherestep.magnetics._ironmap import TABLE_FILE, read_table
from spherestep.magnetics import _ironscale
from spherestep.magnetics._ironscale import prototype_scale, scale_between, scaled_design, shape
from spherestep.motor import MotorDesign, prototype

INCH = 0.0254


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def rotations():
    return Rotation.random(40, random_state=28).as_matrix()


# --- the rotor shell, a design dimension -----------------------------------------------------------------------

def test_shell_default_is_todays(design):
    """The prototype's shell is 1/16 in (the constant it replaces), stated in its file and its summary."""
    assert design.rotor_shell == pytest.approx(INCH / 16, rel=1e-15)
    assert _iron.ROTOR_SHELL == design.rotor_shell
    assert "rotor_shell: 0.0625 in" in design.dumps()
    assert design.summary()["rotor_shell_mm"] == pytest.approx(1.5875, abs=1e-12)


def test_shell_from_a_design_file_reaches_the_iron(design):
    text = design.dumps().replace("rotor_shell: 0.0625 in", "rotor_shell: 2 mm")
    d2 = MotorDesign.loads(text)
    assert d2.rotor_shell == pytest.approx(2e-3, rel=1e-15)
    r_m = 0.5 * d2.magnet_diameter
    assert _iron.magnet_face_radius(d2) == pytest.approx(math.sqrt((d2.radius - 2e-3) ** 2 - r_m ** 2), rel=1e-15)
    assert _iron.magnet_face_radius(design) == pytest.approx(math.sqrt((design.radius - INCH / 16) ** 2 - r_m ** 2),
                                                             rel=1e-15)
    assert prototype_scale(d2, d2.coil) is None  # another shape: not the prototype's tables
    # a file without the key keeps the default
    d3 = MotorDesign.loads(design.dumps().replace("  rotor_shell: 0.0625 in\n", ""))
    assert d3.rotor_shell == design.rotor_shell


@pytest.mark.parametrize("value", [-1e-3, 0.2, float("nan")])
def test_bad_shell_is_refused(design, value):
    with pytest.raises(InputError) as err:
        replace(design, rotor_shell=value)
    assert err.value.field == "rotor_shell"


def test_bad_shell_in_a_file_names_the_field(design):
    from spherestep.design_file import DesignFileError

    with pytest.raises(DesignFileError, match="dimensions.rotor_shell"):
        MotorDesign.loads(design.dumps().replace("rotor_shell: 0.0625 in", "rotor_shell: 7 in"))


# --- the scaling law ---------------------------------------------------------------------------------------------

def test_prototype_tables_unchanged(design):
    """Scale 1: the prototype's model is its stored table, bit for bit."""
    arr = read_table(resources.files("spherestep.data") / TABLE_FILE)
    m = iron_model(design)
    assert np.array_equal(m.detent.tau, arr[:, 1]) and np.array_equal(m.linear.tau, arr[:, 2])
    sc = prototype_scale(design, design.coil)
    assert (sc.s, sc.detent, sc.linear) == (1.0, 1.0, 1.0)


def test_scaled_prototype_detent_is_s_cubed(design, rotations):
    """Every length ×1.5: the detent torques ×3.375 (to 1e-6 of the peak; the issue's test), the energy too,
    the coupled model's coils-off torque too, and the winding's part ×s²·NI'/NI (the nominal ampere-turns of the
    same wire on the same supply change with the groove)."""
    big = scaled_design(design, 1.5)
    m0, m1 = iron_model(design), iron_model(big)
    d0, d1 = m0.detent_torque(rotations), m1.detent_torque(rotations)
    assert np.max(np.abs(d1 - 3.375 * d0)) <= 1e-6 * np.max(np.abs(d0))
    off = np.zeros(len(design.stator))
    e0, e1 = m0.energy(rotations, off), m1.energy(rotations, off)
    assert np.max(np.abs(e1 - 3.375 * e0)) <= 1e-6 * np.max(np.abs(e0))
    ni = (_iron.CoreGeometry.of(big, big.coil).NI / _iron.CoreGeometry.of(design, design.coil).NI)
    K0, K1 = m0.torque_matrix(rotations), m1.torque_matrix(rotations)
    assert np.max(np.abs(K1 - 2.25 * ni * K0)) <= 1e-6 * np.max(np.abs(K0))
    c0, c1 = iron_model(design, coupling=True), iron_model(big, coupling=True)
    t0, t1 = c0.torque(rotations[:8], off), c1.torque(rotations[:8], off)
    assert np.max(np.abs(t1 - 3.375 * t0)) <= 1e-6 * np.max(np.abs(t0))


def test_scaled_design_is_ready_at_once(design, rotations):
    """A scaled copy (a scale not used before, so nothing is cached) needs no solve: no moment-method stage is
    reported, pairwise or coupled (the cold time is measured in docs/magnetics.md, not asserted)."""
    from spherestep.progress import listening

    seen = []
    with listening(lambda text, done=None, total=None: seen.append(text)):
        for coupling in (False, True):
            m = iron_model(scaled_design(design, 0.731), coupling=coupling)
            m.torque(rotations[:4], np.zeros(len(design.stator)))
    assert seen == []


def test_remanence_scales_the_tables(design, rotations):
    """Linear iron: the detent goes as B_r², the winding's part as B_r."""
    weak = replace(design, remanence=0.5 * design.remanence)
    sc = scale_between(weak, weak.coil, design, design.coil)
    assert (sc.s, sc.detent, sc.linear) == pytest.approx((1.0, 0.25, 0.5), rel=1e-15)
    d0, d1 = iron_model(design).detent_torque(rotations), iron_model(weak).detent_torque(rotations)
    assert np.max(np.abs(d1 - 0.25 * d0)) <= 1e-12 * np.max(np.abs(d0))


def test_shape_is_scale_free(design):
    a, mu = shape(design, design.coil)
    b, mu_b = shape(scaled_design(design, 2.0), scaled_design(design, 2.0).coil)
    assert mu == mu_b and np.allclose(a, b, rtol=1e-14, atol=0)
    other = replace(design, air_gap=2 * design.air_gap)
    assert scale_between(other, other.coil, design, design.coil) is None


# --- the shape table: other magnets, interpolated ----------------------------------------------------------------

# The shape table's interpolation (``_ironscale.interpolate_shape``) applied to the moment method's own grid
# (data/iron_shape_solves.csv) against its solves at the five held-out magnets, max over the angles / the solve's
# peak. Measured 2026-11-26: from 10° on (where the package table is this method's beyond the FEM's 21°, and the
# level-0 face cells no longer jag) the detent 0.5–2.6 %, the winding's part at every angle 1.0–3.5 %; nearer the
# axis the level-0 detent jags ±20 % between neighbouring angles (the FEM grid carries that part: test_iron_shape).
# The bounds are those rounded up.
HELD_OUT_BOUND = {"detent": 0.03, "linear": 0.04}


def _mom(path: str):
    """``{(d_m/R, l_m/d_m): (alpha_deg, detent, linear)}`` of a moment-method file under ``data/``."""
    from pathlib import Path

    arr = read_table(Path(__file__).resolve().parents[1] / "data" / path)
    out = {}
    for x, a in sorted({(r[0], r[1]) for r in arr}):
        rows = arr[(arr[:, 0] == x) & (arr[:, 1] == a)]
        rows = rows[np.argsort(rows[:, 2])]
        out[(x, a)] = (rows[:, 2], rows[:, 3], rows[:, 4])
    return out


def _with_magnet(design, x, aspect):
    return replace(design, magnet_diameter=x * design.radius, magnet_length=aspect * x * design.radius)


def test_interpolation_on_the_moment_method_grid(design):
    """Five magnets not in the grid: the interpolation of the moment method's grid against their own solves."""
    solves, held = _mom("iron_shape_solves.csv"), _mom("iron_shape_heldout.csv")
    xs, asps = (np.array(v) for v in _ironscale.SHAPE_GRID)
    alpha = solves[(xs[0], asps[0])][0]
    grid = {k: np.array([[solves[(x, a)][k] for a in asps] for x in xs]) for k in (1, 2)}
    assert len(held) == 5
    for (x, a), (al, det, lin) in held.items():
        assert np.array_equal(al, alpha)
        got_d = _ironscale.interpolate_shape(grid[1], xs, asps, np.radians(alpha), x, a, detent=True)
        got_l = _ironscale.interpolate_shape(grid[2], xs, asps, np.radians(alpha), x, a, detent=False)
        far = alpha >= 10.0
        assert np.abs(got_d - det)[far].max() <= HELD_OUT_BOUND["detent"] * np.abs(det).max()
        assert np.abs(got_l - lin).max() <= HELD_OUT_BOUND["linear"] * np.abs(lin).max()


def test_a_new_magnet_is_ready_at_once_and_said(design, rotations):
    """0.8-in magnets (the issue's 45-s case) on a scaled ball: from the tables (pairs and coupling), scaled, no
    solve reported; ``iron_source`` says so; outside the table's range it says why and that it solves."""
    from spherestep.progress import listening

    d = scaled_design(_with_magnet(design, 0.8 / 6.0, 0.625), 1.3)
    assert "shape table" in _ironscale.iron_source(d, d.coil)
    seen = []
    with listening(lambda text, done=None, total=None: seen.append(text)):
        for coupling in (False, True):
            m = iron_model(d, coupling=coupling)
            m.torque(rotations[:4], np.zeros(len(d.stator)))
    assert seen == []
    far = _with_magnet(design, 0.4 / 6.0, 0.5)
    assert _ironscale.shape_table_tables(far, far.coil) is None
    said = _ironscale.iron_source(far, far.coil)
    assert "solve on first use" in said and "magnet_diameter / rotor radius" in said
    other = replace(design, coil_length=1.1 * design.coil_length)
    assert "coil_length" in _ironscale.iron_source(other, other.coil)


def test_table_at_the_prototype_is_its_fem_table(design):
    """The table at the prototype's own ratios is the FEM-based table (the grid's prototype node is that table
    read at the grid's angles through its spline, stored to 9 significant digits)."""
    from scipy.interpolate import CubicSpline

    nodes, det, lin = _ironscale.shape_table_tables(design, design.coil)
    fem = read_table(resources.files("spherestep.data") / TABLE_FILE)
    a = np.radians(fem[:, 0])
    for got, ref in ((det, CubicSpline(a, fem[:, 1])(nodes)), (lin, CubicSpline(a, fem[:, 2])(nodes))):
        assert np.abs(got - ref).max() <= 1e-8 * np.abs(ref).max()
