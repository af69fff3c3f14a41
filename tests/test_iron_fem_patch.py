"""The iron model against the whole-motor patch FEM (issue 28 §1, §2's measurement): four neighbouring iron cores
of the prototype under the rotor magnets within reach, NGSolve 3-D (``scripts/fem_patch.py``, stored rows in
``data/iron_fem_patch.csv``; docs/magnetics.md, "Whole-motor patch FEM").

The model is evaluated live on the stored cases (the same magnets, cores, polarities and currents) and held at
the error measured today, as a regression bound; the issue's target, 5 % of the FEM's largest torque in every
linear case, is met by the design's own model (coupled, tabulated: ``design_model``), evaluated as the drives use
it — every rotor pole, the patch's cores."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from spherestep.magnetics import design_model, iron_model
from spherestep.motor import prototype

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("fem_patch", ROOT / "scripts" / "fem_patch.py")
fem_patch = importlib.util.module_from_spec(_spec)
sys.modules.setdefault("fem_patch", fem_patch)  # its dataclasses look their module up
_spec.loader.exec_module(fem_patch)  # the script imports NGSolve only inside its solver

# Measured 2026-11-25 on the 24 linear rows at 2.5 mm (error = |T_model − T_FEM| / the FEM's largest |T| over the
# rows, 7.86 N m; vector norms): pairwise max 6.4 % (median 2.5 %), coupled max 3.2 % (median 1.5 %), 3.3 % (1.5 %)
# with the reach's taper (the sums over the meshed magnets); the bounds are those rounded up. The design's own model
# (coupled, its tables, every pole): max 3.4 %, median 1.25 %. The B–H rows were not solved yet when this was written: they are held to the same bounds
# (the model is linear), provisionally — a failure there says saturation matters (docs/magnetics.md).
BOUND = {("linear", "pairwise"): 0.07, ("linear", "coupled"): 0.035, ("bh", "pairwise"): 0.07,
         ("bh", "coupled"): 0.035}
TARGET = 0.05  # issue 28 §2: every case within 5 % of the FEM's largest torque
CONVERGENCE = 0.015  # |T(2.5 mm) − T(2.0 mm)| / peak, measured 0.98 % (orientations 0 and 4, linear)


@pytest.fixture(scope="module")
def rows():
    out = fem_patch.read_rows()
    if not out:
        pytest.skip("data/iron_fem_patch.csv has no rows yet: python scripts/fem_patch.py (docs/magnetics.md)")
    return out


@pytest.fixture(scope="module")
def design():
    return prototype()


def test_cases_are_the_scripts(rows, design):
    """Every stored row is the script's case of its index: orientation, coils, currents, material, mesh; and the
    magnets meshed are those within reach of the patch at that orientation."""
    cases = fem_patch.all_cases(design)
    for r in rows:
        c = cases[int(r["case"])]
        assert np.allclose(r["R"], c.R, atol=1e-9)
        assert tuple(r["coils"]) == c.coils
        assert np.array_equal(r["currents"], c.currents)
        assert (r["material"], r["maxh"]) == (c.material, c.maxh)
        assert np.array_equal(r["magnets"], fem_patch.included_magnets(design, c.R, c.coils))


def test_restriction_is_the_models(design):
    """The model restricted to every pole and the patch's cores is the full model's sums over those cores
    (pairwise and coupled), so the comparison uses the model's own pairs and polarities; the coupled model's tables
    (what ``torque_on`` evaluates) agree with those sums to 0.5 % of the pair table's peak torque."""
    c = fem_patch.all_cases(design)[1]
    full = np.zeros(design.stator.centers.shape[0])
    full[list(c.coils)] = c.currents
    for coupling in (False, True):
        m = iron_model(design, coupling=coupling)
        got = fem_patch.model_torque(m, c.R, c.coils, c.currents, np.arange(len(design.rotor.centers)))
        assert np.allclose(got, m.subset(c.coils).exact_torque(c.R, full[list(c.coils)]), rtol=0, atol=1e-12)
        tol = 1e-12 if not coupling else 5e-3 * np.max(np.abs(m.detent.tau))
        assert np.allclose(got, m.torque_on(c.R, full, c.coils), rtol=0, atol=tol)


@pytest.mark.parametrize("material", ["linear", "bh"])
def test_model_against_patch_fem(rows, design, material):
    """Pairwise and coupled model within today's measured error of the FEM (regression bound), as a share of the
    FEM's largest torque over the linear cases (the issue's measure: the B–H rows are few and small, 1.2 N m, and
    their own largest torque would make a 0.1 N m miss read as 9 %)."""
    cmp_ = fem_patch.compare(rows, material, design=design)
    if cmp_ is None:
        pytest.skip(f"no {material} rows stored yet")
    peak = fem_patch.compare(rows, "linear", design=design).peak
    for model, got in (("pairwise", cmp_.model_pairwise), ("coupled", cmp_.model_coupled)):
        assert np.linalg.norm(got - cmp_.fem, axis=1).max() <= BOUND[material, model] * peak


def test_default_model_within_target(rows, design):
    """Issue 28 §2: the design's own model (coupled, tabulated, compiled; every rotor pole, the patch's cores on,
    as the drives evaluate it) within 5 % of the FEM's largest torque in every linear case; the pairwise model
    (its opt-out, ``coupling=False``) is not."""
    cmp_ = fem_patch.compare(rows, "linear", design=design)
    if cmp_ is None:
        pytest.skip("no linear rows stored yet")
    own = design_model(design)
    assert own.label == "iron (coupled, FEM table)"
    got = []
    for r in cmp_.rows:
        full = np.zeros(len(design.stator.centers))
        full[list(r["coils"])] = r["currents"]
        got.append(own.model.torque_on(r["R"], full, r["coils"]))
    err = np.linalg.norm(np.array(got) - cmp_.fem, axis=1) / cmp_.peak
    assert err.max() <= TARGET
    assert cmp_.pairwise.max() > TARGET  # what the coupling buys: 6.4 % pairwise


def test_coupled_model_within_target_linear(rows, design):
    """With the coupling the model meets 5 % on the linear cases (not yet shown for the B–H cases, nor fast)."""
    cmp_ = fem_patch.compare(rows, "linear", design=design)
    if cmp_ is None:
        pytest.skip("no linear rows stored yet")
    assert cmp_.coupled.max() <= TARGET


def test_mesh_convergence(rows):
    """The FEM at the face mesh of the cases against the finer mesh, at the same orientations and currents."""
    fine = {(r["orientation"], tuple(r["currents"])): r["torque"] for r in rows
            if r["material"] == "linear" and math.isclose(r["maxh"], fem_patch.MAXH_FINE)}
    coarse = {(r["orientation"], tuple(r["currents"])): r["torque"] for r in rows
              if r["material"] == "linear" and math.isclose(r["maxh"], fem_patch.MAXH)}
    both = set(fine) & set(coarse)
    if not both:
        pytest.skip("no convergence rows stored yet")
    peak = max(np.linalg.norm(t) for t in coarse.values())
    assert max(np.linalg.norm(fine[k] - coarse[k]) for k in both) <= CONVERGENCE * peak


# The B–H rows (issue 28 §1): at the MAXH_BH face mesh in the OUTER_BH box (the 2.5-mm mesh in the 0.3-m box needed
# ~7 GB a B–H solve), each with its linear twin on the same mesh, which checks that mesh against the 2.5-mm rows.
BH_MESH_CHECK = 0.035  # |T_lin(4 mm, 0.15 m box) − T_lin(2.5 mm, 0.3 m)| / peak: measured max 3.3 % (median 1.4 %)
SATURATION = 0.01  # |T_bh − T_lin| / peak on the same mesh: measured max 0.66 %, median 0.03 % (docs/magnetics.md)


def _by_case(rows, material, maxh):
    return {(r["orientation"], tuple(r["currents"])): r["torque"] for r in rows
            if r["material"] == material and math.isclose(r["maxh"], maxh)}


def test_bh_rows_are_stored(rows, design):
    """All 24 B–H cases and their 24 linear twins are stored (no skip: the reference is complete)."""
    cases = fem_patch.all_cases(design)
    want = {c.index for c in cases if math.isclose(c.maxh, fem_patch.MAXH_BH)}
    assert len(want) == 48
    assert want <= {int(r["case"]) for r in rows}


def test_bh_mesh_against_the_fine_linear_rows(rows):
    """The B–H rows' mesh: its linear solve against the 2.5-mm rows, every orientation and current."""
    twin, base = _by_case(rows, "linear", fem_patch.MAXH_BH), _by_case(rows, "linear", fem_patch.MAXH)
    assert set(twin) == set(base) and len(base) == 24
    peak = max(np.linalg.norm(t) for t in base.values())
    assert max(np.linalg.norm(twin[k] - base[k]) for k in base) <= BH_MESH_CHECK * peak


def test_saturation_is_negligible(rows):
    """The B–H curve against the linear iron on the same mesh, every stored B–H case: the torque moves by less
    than 1 % of the peak (the face saturates in a thin layer; the torque is set by the air gap's reluctance)."""
    sat, twin = _by_case(rows, "bh", fem_patch.MAXH_BH), _by_case(rows, "linear", fem_patch.MAXH_BH)
    peak = max(np.linalg.norm(t) for t in _by_case(rows, "linear", fem_patch.MAXH).values())
    assert sat and set(sat) <= set(twin)
    assert max(np.linalg.norm(sat[k] - twin[k]) for k in sat) <= SATURATION * peak
