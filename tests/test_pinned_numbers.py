"""The headline numbers the README quotes, pinned (issue 40 §5): recomputed here on the code path that produced
them, with their seeds, and held to ~1 % of the quoted value (the computations are deterministic; 1 % leaves room
for another BLAS kernel's rounding, issue 35, not for a changed model).

- the torque capability over SO(3) (``spherestep demo``, :func:`spherestep.control.torque_capability`, 400
  orientations, seed 0): median 8.88 N·m on the design's own iron model, 3.11 N·m on the air-core map;
- the robustness row (``spherestep.demo.robustness``): the servo holds 4 of 5 random orientations within 0.05°
  on the plant with the winding ×0.85 and the detent ×1.2, the worst 0.792°;
- the CLI calibration (``spherestep calibrate --emulate``, 60 holds, the default plant error): the torque error
  against the plant falls ≥ 5× (docs/control.md: 0.1699 → 0.0312, 5.4×).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from spherestep.cli import main
from spherestep.control import torque_capability
from spherestep.magnetics import design_model

README_CAPABILITY = {"iron": 8.88, "air": 3.11}  # N·m, the README's "median 8.88 / 3.11 N·m"
README_P5 = {"iron": 4.92, "air": 2.35}  # N·m, "5th percentile 4.92 / 2.35 N·m"


def _capability(design, core):
    own = design_model(design, core)
    return torque_capability(design, own.model, own.limits, samples=400, seed=0)  # as spherestep.demo


def test_air_capability_median_pinned(proto):
    """The air-core map: ~15 s, in ``make check``."""
    cap = _capability(proto, "air")
    assert np.median(cap.radius) == pytest.approx(README_CAPABILITY["air"], rel=0.01)
    assert np.percentile(cap.radius, 5) == pytest.approx(README_P5["air"], rel=0.01)


@pytest.mark.slow
def test_iron_capability_median_pinned(proto):
    """The design's own iron model (coupled, FEM table): ~100 s at load 15, so ``slow``."""
    cap = _capability(proto, "iron")
    assert np.median(cap.radius) == pytest.approx(README_CAPABILITY["iron"], rel=0.01)
    assert np.percentile(cap.radius, 5) == pytest.approx(README_P5["iron"], rel=0.01)


@pytest.mark.slow
def test_robustness_row_pinned(proto):
    """The README's robustness row: 4 of 5 holds within 0.05°, the worst 0.792° (±1 %), the turn's final error
    0.010° (within 0.005°)."""
    from spherestep.demo import robustness

    r = robustness(proto, np.array([1.0, 0.5, 2.0]), math.radians(360.0))  # the demo's default turn
    assert (r["holds_within"], r["holds"]) == (4, 5), r
    assert r["worst_hold_deg"] == pytest.approx(0.792, rel=0.01), r
    assert r["final_error_deg"] == pytest.approx(0.010, abs=0.005), r
    assert r["passed"] is True


@pytest.mark.slow
def test_cli_calibration_factor_pinned(tmp_path, capsys):
    """``spherestep calibrate --emulate`` with its defaults (60 holds, detent ×1.2, winding ×0.85, seed 0; since
    issue 37 also the sensors' wells, the per-coil terms, the held-out verdict — exit 0 only when consistent — and
    the rotor): the torque error against the plant falls ≥ 5× (docs/control.md's control-notes block, measured 5.4×:
    0.1699 → 0.0312 on 2026-11-28 with the tables alone; 7.2×, 0.1699 → 0.0237, with the per-coil terms, 2026-11-28
    15:22, load 7–17), the scales come back near the plant's. The error before the fit is deterministic: 0.1699
    (0.1748 before issue 35 renumbered the coils, which reorders the 200 random currents it is measured at)."""
    out = tmp_path / "calibration.yaml"
    assert main(["calibrate", "--emulate", "--out", str(out), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    before, after = data["torque_error_before"], data["torque_error_after"]
    assert before == pytest.approx(0.1699, rel=0.01), (before, after)
    assert before / after >= 5.0, (before, after)
    cal = data["calibration"]
    assert cal["scale_detent"] == pytest.approx(1.2, abs=0.03) and cal["scale_winding"] == pytest.approx(0.85,
                                                                                                         abs=0.03)
