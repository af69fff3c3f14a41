"""One field list for "how a set of states covers SO(3)" (issue 36): the geometric states' ``DesignMetrics`` and the
equilibria's ``EquilibriumMetrics`` are both ``motor.Coverage`` with their own extras, and turn to dicts alike."""

import dataclasses
import math

from spherestep.commutation import EquilibriumMetrics
from spherestep.motor import Coverage, DesignMetrics

COMMON = [f.name for f in dataclasses.fields(Coverage)]


def test_both_metrics_share_the_coverage_fields_in_order():
    for cls, extra in ((DesignMetrics, ["held_pairs_histogram", "escape_violations"]),
                       (EquilibriumMetrics, ["minima", "distinct", "offset_median_rad", "offset_max_rad"])):
        assert issubclass(cls, Coverage)
        assert [f.name for f in dataclasses.fields(cls)] == COMMON + extra


def test_both_turn_their_angles_to_degrees():
    common = dict(states=12, samples=500, max_step_rad=0.2, resolution_median_rad=0.05, resolution_p95_rad=0.1,
                  resolution_max_rad=0.15, range_fraction=1.0, state_graph_components=1, reaches_all=True)
    d = DesignMetrics(**common, held_pairs_histogram=(0, 12), escape_violations=None).to_dict()
    assert d["resolution_median_deg"] == math.degrees(0.05) and d["escape_violations"] is None
    assert d["held_pairs_histogram"] == [0, 12]
    e = EquilibriumMetrics(**common, minima=3, distinct=2, offset_median_rad=0.01, offset_max_rad=0.02)
    assert e.to_dict(degrees=False) == {**Coverage(**common).to_dict(degrees=False), "minima": 3, "distinct": 2,
                                        "offset_median_rad": 0.01, "offset_max_rad": 0.02}
    assert e.to_dict()["offset_max_deg"] == math.degrees(0.02)
