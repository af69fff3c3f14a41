"""The cores' field table (spherestep.sensing.iron) against an independent magpylib-material-response solve of all
29 cores with the whole rotor (data/sensing_iron_mmr.csv, scripts/sensing_iron_mmr.py), at the stored
orientations ``so3.random(3, 26)``."""

from pathlib import Path

import numpy as np
import pytest

from spherestep import so3
from spherestep.motor import prototype
from spherestep.sensing import default_array, iron

CSV = Path(__file__).resolve().parents[1] / "data" / "sensing_iron_mmr.csv"


def stored():
    lines = [ln for ln in CSV.read_text().splitlines() if ln and not ln.startswith("#")]
    rows = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    return rows[:, 2:].reshape(3, 24, -1, 3)  # (orientation, sensor, mesh, xyz)


@pytest.mark.xfail(strict=True, reason="the stored mmr solve is not mesh-converged: its two meshes (45 and 58 cells per "
                   "core) differ by 46 mT RMS, more than either differs from the table (28, 43 mT); issue 26")
def test_table_against_mmr():
    design = prototype()
    core, _ = iron.iron_fields(design, default_array(design).positions)
    model = core.field(so3.random(3, 26))
    ref = stored()
    fine = ref[:, :, -1]
    mesh = np.sqrt(np.mean((ref[:, :, -1] - ref[:, :, 0]) ** 2)) if ref.shape[2] > 1 else 0.0
    err = model - fine
    rms = np.sqrt(np.mean(err ** 2))
    scale = np.sqrt(np.mean(fine ** 2))
    # the reference first: two meshes within 10 % of its field (else it judges nothing); then the table within its
    # stated accuracy against the MoM (4.5 µT RMS) plus the reference's measured mesh difference
    assert ref.shape[2] > 1 and mesh < 0.1 * scale, ("mmr reference not converged", mesh, scale)
    assert rms < 4.5e-6 + mesh, (rms, mesh, scale)
