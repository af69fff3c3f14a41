"""The cores' field table (spherestep.sensing.iron) against direct magpylib-material-response solves on successively
finer meshes (data/sensing_iron_mmr.csv, scripts/sensing_iron_mmr.py: every core solved on its own with the whole
rotor, the iron room's mesh at levels 0-4, 317-1198 cells per core) at the stored orientations ``so3.random(3, 26)``:
the reference converges, at the table's own mesh (level 2) it is the model's solve, and against the finest mesh the
table is off by its mesh error alone (2.4 % RMS; docs/sensing.md, "The mesh")."""

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from spherestep import so3
from spherestep.motor import prototype
from spherestep.sensing import default_array, iron

CSV = Path(__file__).resolve().parents[1] / "data" / "sensing_iron_mmr.csv"
NOISE = 100e-6  # T, the array part's noise (TMAG5273A2)


def rms(x) -> float:
    return float(np.sqrt(np.mean(np.square(x))))


def rows(text):
    lines = [ln for ln in text.splitlines() if ln and not ln.startswith("#")]
    return lines[0].split(","), np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])


@pytest.fixture(scope="module")
def mmr():
    """``{level: (3, 24, 3)}`` (T): every core solved on its own at each mesh level."""
    head, data = rows(CSV.read_text())
    levels = [int(c[len("level"):-2]) for c in head[2::3]]
    return {lv: data[:, 2 + 3 * i:5 + 3 * i].reshape(3, 24, 3) for i, lv in enumerate(levels)}


@pytest.fixture(scope="module")
def model():
    """The model's own direct solves at its mesh (level 2; sensing_iron_reference.csv): ``(each core alone,
    coupled)``, each ``(3, 24, 3)``."""
    _, data = rows((resources.files("spherestep.data") / "sensing_iron_reference.csv").read_text())
    return data[:, 2:5].reshape(3, 24, 3), data[:, 5:8].reshape(3, 24, 3)


@pytest.fixture(scope="module")
def gap(mmr, model):
    """``(table − reference, reference, level-2 mesh error)``: the stored table against the finest mmr solve plus
    the cores' coupling (the model's, level 2)."""
    design = prototype()
    core, _ = iron.iron_fields(design, default_array(design).positions)
    finest = max(mmr)
    reference = mmr[finest] + (model[1] - model[0])
    return core.field(so3.random(3, 26)) - reference, reference, rms(mmr[iron.SENSING_LEVEL] - mmr[finest])


def test_at_the_tables_mesh_the_mmr_solve_is_the_models(mmr, model):
    """Same mesh (level 2), same physics: the mmr column is the model's own per-core solve (to 1e-12 T)."""
    assert np.abs(mmr[iron.SENSING_LEVEL] - model[0]).max() < 1e-9


def test_the_mmr_reference_converges(mmr):
    """Each refinement changes the cores' field less than the one before (measured 0.97, 0.50, 0.38, 0.19 mT
    RMS), the last (level 3 → 4) by under 1.5 % of it (measured 1.05 %)."""
    levels = sorted(mmr)
    assert len(levels) >= 4 and levels[-1] >= iron.SENSING_LEVEL + 2
    steps = [rms(mmr[b] - mmr[a]) for a, b in zip(levels[:-1], levels[1:])]
    assert all(b < a for a, b in zip(steps[:-1], steps[1:])), steps
    assert steps[-1] < 0.015 * rms(mmr[levels[-1]]), (steps, rms(mmr[levels[-1]]))


def test_table_against_the_converged_mmr_solve(gap):
    """The gap is the table's error against its own model (4.5 µT RMS) plus the level-2 mesh's (measured 431 µT
    RMS of 432, max 3.6 mT at the sensor 2.3 mm from its core's wall): under 3 % of the cores' field (measured
    2.4 %)."""
    err, reference, mesh = gap
    assert rms(err) < 4.5e-6 + 1.02 * mesh, (rms(err), mesh)
    assert rms(err) < 0.03 * rms(reference), (rms(err), rms(reference))
    assert rms(reference) > 10e-3  # the cores' field is real: 18 mT RMS at the sensors


@pytest.mark.xfail(strict=True, reason="the table's level-2 mesh is 432 µT RMS (2.4 %, max 3.6 mT) off the level-4 "
                   "solve, 4.3x the part's 100 µT noise (3.0 % extrapolated; 0.004-0.018 deg of orientation): "
                   "a finer mesh at the cores' walls is left to do, issue 26")
def test_table_within_the_noise_of_the_converged_solve(gap):
    err, _, _ = gap
    assert rms(err) < NOISE
