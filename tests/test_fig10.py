"""The Fig. 10 view's geometry (one source for the matplotlib figures and the HTML report)."""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from spherestep import plots
from spherestep.commutation import about_axis, plan_geometric
from spherestep.fig10 import cap_outlines, fig10_step, joined, plane_basis


def test_plane_basis_is_right_handed_with_the_axis_out_of_the_page():
    for axis in ([1, 0.5, 2], [1, 0, 0], [0, 0, -3]):
        b = plane_basis(axis)
        np.testing.assert_allclose(b @ b.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(np.cross(b[0], b[1]), b[2], atol=1e-14)
        np.testing.assert_allclose(b[2], np.asarray(axis) / np.linalg.norm(axis), atol=1e-14)


def test_cap_outlines_lie_on_the_cap_boundary_and_join_with_gaps():
    rng = np.random.default_rng(0)
    c = rng.normal(size=(5, 3))
    c /= np.linalg.norm(c, axis=1, keepdims=True)
    rings = cap_outlines(c, 0.3, 40)
    np.testing.assert_allclose(np.linalg.norm(rings, axis=-1), 1.0, atol=1e-14)
    np.testing.assert_allclose(np.einsum("kpa,ka->kp", rings, c), math.cos(0.3), atol=1e-14)
    line = joined(rings)
    assert line.shape == (5 * 42 - 1, 3) and np.sum(np.isnan(line[:, 0])) == 4


def test_matplotlib_draws_the_shared_geometry(proto):
    targets = about_axis([1, 0.5, 2], math.radians(20), 4, start=proto.states().rotations[0])
    plan = plan_geometric(proto, targets)
    i = next(s.index for s in plan.steps[1:] if s.coils)
    view = fig10_step(proto, plan, i, [1, 0.5, 2], points=64)
    assert len(view.coils) == len(proto.stator)
    assert sum(len(r) for r in view.energised.values()) == len(plan.steps[i].coils)
    assert sum(len(r) for r in view.held.values()) == len(plan.steps[i].held)
    # the rotor-fixed marker has the requested length and turns with the rotor
    assert np.linalg.norm(view.marker[1]) <= 1.15 + 1e-12
    ax = Figure().add_subplot()
    plots.draw_step(ax, proto, plan, i, [1, 0.5, 2])
    drawn = [p.get_xy()[:-1] for p in ax.patches if len(p.get_xy()) == 65]  # closed 64-point outlines
    for ring in view.coils:
        assert any(np.allclose(ring, d) for d in drawn)
    for ring in view.held[1].tolist() + view.held[-1].tolist():
        assert any(np.allclose(ring, d) for d in drawn)
