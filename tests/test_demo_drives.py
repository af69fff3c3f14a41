"""The demo's three drives of its 360° turn about the tilted axis (1, 0.5, 2) on the prototype's own model (iron,
coupled, FEM table), run as ``spherestep demo`` runs them (``compare_drives`` with the iron relay rates, sensor
seed 0) and pinned to their noise (issue 27 §5: "the drives' times and final errors" were pinned nowhere).

To update after a deliberate change of the servo law or the models: run the drive with seeds 0, 1, 2
(``compare_drives(..., seed=s)``), put seed 0's values in :data:`EXPECTED` and keep each tolerance at least 2× the
seeds' spread (state it below)."""

import math

import pytest

from spherestep.demo import IRON_RELAY_RATES
from spherestep.drive import compare_drives
from spherestep.drive.compare import DEMO_AXIS
from spherestep.magnetics import design_model
from spherestep.motor import prototype

# mode: (time in s, or None when the rotor never arrives, ± s), (final error °, ± °)
# Measured 2026-11-26 (load 8-11), seeds 0 / 1 / 2 of the 0.02° sensor noise:
#   servo: time 1.474 / 1.491 / 1.466 s (spread 0.025 s), final error 0.0122 / 0.0116 / 0.0103° (spread 0.002°);
#          the stored demo run (data/demo_summary.json) 1.474 s, 0.0127°; bang-bang bound 1.148 s.
#   settled and ramped (2, 5, 14 steps/s): no sensor, no noise; on iron the detent holds the rotor, no step settles
#          on the plan and the turn ends 27.7185° off (the stored run and today's agree to 1e-9°); the tolerance
#          allows for integrator changes only.
EXPECTED = {
    "servo": ((1.474, 0.05), (0.0122, 0.006)),
    "settled": ((None, None), (27.7185, 0.05)),
    "ramped": ((None, None), (27.7184, 0.05)),
}
BOUND_S = (1.1477, 0.01)  # the bang-bang bound: deterministic


@pytest.fixture(scope="module")
def drives():
    design = prototype()
    own = design_model(design)
    assert own.core == "iron"  # the demo's "own" model; its relay rates are IRON_RELAY_RATES
    return compare_drives(design, DEMO_AXIS, math.radians(360.0), own, rates=IRON_RELAY_RATES)


@pytest.mark.slow
@pytest.mark.parametrize("mode", list(EXPECTED))
def test_the_demo_drives_time_and_final_error_are_pinned(drives, mode):
    (time, dt), (error, de) = EXPECTED[mode]
    r = drives.result(mode).to_dict()
    if time is None:
        assert r["time_s"] is None and r["arrival_note"], r
        assert not r["within_tolerance"]
    else:
        assert r["time_s"] == pytest.approx(time, abs=dt), r
        assert r["within_tolerance"] and r["arrival_note"] == ""
    assert r["final_error_deg"] == pytest.approx(error, abs=de), r


@pytest.mark.slow
def test_the_demo_drives_bound_and_relay_outcome(drives):
    d = drives.to_dict()
    assert d["bang_bang_bound_s"] == pytest.approx(BOUND_S[0], abs=BOUND_S[1])
    settled = drives.result("settled").to_dict()["details"]
    assert settled["steps"] == 73 and settled["steps_settled_on_plan"] == 0
    ramped = drives.result("ramped").to_dict()["details"]
    assert [t["rate_steps_per_s"] for t in ramped["tried"]] == list(IRON_RELAY_RATES)
    assert all(t["lost_a_step"] for t in ramped["tried"]) and ramped["pull_out_rate_steps_per_s"] == 0.0
