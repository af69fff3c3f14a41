"""The README's prototype table is generated from one stored demo run (``scripts/readme_numbers.py``,
``data/demo_summary.json``), so its numbers cannot drift from the run, and the stored run's cheap numbers are held
against the live code (issue 27 §4)."""

import importlib.util
import math
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _script():
    spec = importlib.util.spec_from_file_location("readme_numbers", ROOT / "scripts" / "readme_numbers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_readme_table_is_the_stored_run_rendered():
    script = _script()
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    assert script.readme_block(text) == script.render(script.stored()), \
        "README's prototype table differs from data/demo_summary.json: run `make demo` and scripts/readme_numbers.py"


def test_the_stored_run_agrees_with_the_code(proto, proto_metrics):
    """States exactly; the resolution within its sampling noise (the stored run used seed 0, the fixture seed 7);
    the plan's step count; the coil as built."""
    from spherestep.commutation import turn
    from spherestep.magnetics import design_model

    s = _script().stored()
    assert s["states"] == proto_metrics.states == 101_640
    assert s["resolution_median_deg"] == pytest.approx(math.degrees(proto_metrics.resolution_median_rad), abs=0.03)
    assert s["plan"]["steps"] == len(turn(proto, s["plan"]["axis"], math.radians(s["plan"]["angle_deg"])).steps) - 1
    assert s["iron"]["electrics"]["nominal_current_A"] == pytest.approx(design_model(proto).limits.nominal_current,
                                                                        rel=1e-12)
    assert s["torque_model"] == design_model(proto).label
