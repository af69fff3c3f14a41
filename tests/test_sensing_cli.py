"""``spherestep sense``: the layout and its accuracy on disk and as JSON; bad input is one line, exit 2."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherestep import sensing, so3
from spherestep.cli import main
from spherestep.motor import prototype


@pytest.mark.slow
def test_sense_writes_layout_and_accuracy(tmp_path, capsys):
    assert main(["sense", "--sensors", "3", "--samples", "5", "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    saved = json.loads((tmp_path / "sensors.json").read_text())
    assert out["sensors"] == saved["sensors"] == 3 and out["symmetry_group_order"] == 60
    assert np.asarray(saved["positions_m"]).shape == (3, 3)
    acc = saved["accuracy"]
    assert 0 < acc["rms_deg"] < 0.1 and acc["samples"] == 5  # 3 sensors: ≈ 0.016° RMS measured


def test_sense_rejects_bad_counts(tmp_path, capsys):
    assert main(["sense", "--sensors", "0", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--sensors" in err
    assert not (tmp_path / "sensors.json").exists()


DESIGN = prototype()
TABLE = sensing.FieldTable.build(DESIGN, sensing.candidate_positions(DESIGN)[:12])
GROUP = sensing.symmetry_group(DESIGN)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-math.pi, math.pi), min_size=3, max_size=3), st.integers(0, 59))
def test_table_field_is_equivariant_and_invariant(rotvec, k):
    """Properties of the table (not of magpylib): the field at ``R g`` equals the field at ``R`` for every
    symmetry ``g``; a 1e-7-rad turn changes the field by ``J θ`` (first order, to 1e-12 T)."""
    R = so3.exp(np.array(rotvec))
    np.testing.assert_allclose(TABLE.field(R @ GROUP[k]), TABLE.field(R), atol=1e-9)
    B, J = TABLE.field_and_jacobian(R)
    # a small turn of the rotor changes the reading by J θ to first order
    theta = 1e-7 * np.array([0.3, -0.5, 0.8])
    np.testing.assert_allclose(TABLE.field(so3.exp(theta) @ R) - B, J @ theta, atol=1e-12)
