"""A new design's iron model without a solve (issue 28 §3: ready in seconds cold): the prototype with another magnet
(the shape table) and scaled by 1.5 (the scaling law) get the design's own coupled model and its drive limits with
no moment-method solve, no inductance solve and no disk cache; the compiled tables' builders split over threads give
the same numbers. The time itself is measured by ``benchmarks/bench_iron.py`` (cold rows), not asserted here."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

import spherestep.magnetics as magnetics
from spherestep import so3
from spherestep._fast import coupling as fast_coupling
from spherestep import electrics
from spherestep.magnetics import _coupling, _inductance, _ironcoupling, _ironmap, _ironscale, design_model, scaled_design
from spherestep.motor import prototype

INCH = 0.0254


def _no_solve(*args, **kwargs):
    raise AssertionError("a solve (or a per-design disk cache) was used for a new design")


@pytest.fixture
def no_solve(monkeypatch):
    """Every path to a solve or a per-design cache raises; the in-process tables are emptied (a new process)."""
    for module, name in ((_ironscale, "solve_pair_tables"), (_ironscale, "cached"),
                         (_ironcoupling, "cross_energy_table"), (magnetics, "coil_inductance"),
                         (_inductance, "coil_inductance")):
        monkeypatch.setattr(module, name, _no_solve)
    monkeypatch.setattr(_inductance, "_SOLVED", {})
    _ironmap._tables.cache_clear()
    _ironmap._coupling_table.cache_clear()
    monkeypatch.setattr(_coupling, "_TABLES", {})
    yield
    _ironmap._tables.cache_clear()
    _ironmap._coupling_table.cache_clear()


@pytest.mark.parametrize("which", ["magnet 0.95 in", "x1.5"])
def test_new_design_model_builds_without_a_solve(no_solve, which):
    p = prototype()
    design = replace(p, magnet_diameter=0.95 * INCH) if which == "magnet 0.95 in" else scaled_design(p, 1.5)
    own = design_model(design)
    assert "coupled" in own.label and ("shape table" in own.label or "scaled" in own.label)
    c = np.zeros(len(design.stator))
    c[0] = 1.0
    R = so3.random(3, np.random.default_rng(28))
    E, tau = own.model.evaluate(R, c, 1)
    assert np.all(np.isfinite(E)) and np.all(np.isfinite(tau)) and np.max(np.abs(tau)) > 0.0
    assert own.limits.inductance > 0.0


def test_scaled_core_inductance_follows_the_law():
    """``L / N²`` of a core ×s is ``s ×`` the stored core's (no solve); another core is not found."""
    p = prototype()
    key = electrics.core_key(p.coil, p)
    base = electrics.IRON_PERMEANCE[key]
    for s in (0.5, 1.5, 2.0):
        d = scaled_design(p, s)
        assert electrics.stored_permeance(electrics.core_key(d.coil, d)) == pytest.approx(s * base, rel=1e-12)
        turns = d.coil.turns(d.coil_diameter, d.coil_length)
        assert magnetics.iron_inductance(d.coil, d) == pytest.approx(turns ** 2 * s * base, rel=1e-12)
    other = replace(p, coil_length=1.1 * p.coil_length)
    assert electrics.stored_permeance(electrics.core_key(other.coil, other)) is None
    wider = replace(p.coil, material=replace(p.coil.material, relative_permeability=2000.0))
    assert electrics.stored_permeance(electrics.core_key(wider, p)) is None


def test_table_builders_do_not_depend_on_the_thread_split(monkeypatch):
    """The compiled table builders over 1 and 3 threads: the same numbers, bit for bit."""
    from spherestep._fast.spheretable import face_nodes

    model = design_model(prototype()).model
    x = np.ascontiguousarray(face_nodes(24).reshape(-1, 3))  # 6 × 41² points: three slices of 4096 or more
    knots, C = model.coupling.spline_coefficients()
    det, lin = model.detent, model.linear
    args_g = (np.ascontiguousarray(model.coupling.poles.T), np.ascontiguousarray(model.coupling.polarity),
              float(model.coupling.alpha[-1]), math.radians(_coupling.TAPER_DEG), np.ascontiguousarray(knots),
              np.ascontiguousarray(C))
    args_z = (np.ascontiguousarray(det.poles.T), np.ascontiguousarray(np.stack([det.polarity, lin.polarity])),
              np.ascontiguousarray(det._e.x),
              np.ascontiguousarray(np.stack([np.asarray(det._e.c).T, np.asarray(lin._e.c).T])))
    results = []
    for threads in ("1", "3"):
        monkeypatch.setenv("SPHERESTEP_TABLE_THREADS", threads)
        g, z = np.empty(len(x)), np.empty((2, len(x)))
        fast_coupling.in_threads(fast_coupling.coupling_energies, x, *args_g, out=g)
        fast_coupling.in_threads(fast_coupling.zonal_energies, x, *args_z, out=z)
        results.append((g, z))
    assert fast_coupling.table_threads() == 3
    assert np.array_equal(results[0][0], results[1][0]) and np.array_equal(results[0][1], results[1][1])
    assert np.ptp(results[0][0]) > 0.0


def test_zonal_sums_are_the_pair_splines():
    """``_fast.coupling.zonal_energies`` (the interval by look-up) is ``−Σ_j P_j e(acos x·u_j)`` of the pair maps'
    energy splines, to rounding, also at points whose angle to a pole is a spline break."""
    model = design_model(prototype()).model
    det, lin = model.detent, model.linear
    breaks = np.asarray(det._e.x)
    rng = np.random.default_rng(5)
    u = det.poles[0]
    side = np.cross(u, [0.0, 0.0, 1.0] if abs(u[2]) < 0.9 else [1.0, 0.0, 0.0])
    side /= np.linalg.norm(side)
    on_breaks = np.cos(breaks)[:, None] * u + np.sin(breaks)[:, None] * side  # pole 0 at every break angle
    x = np.vstack([on_breaks, so3.random(200, rng)[:, :, 0]])
    x = np.ascontiguousarray(x / np.linalg.norm(x, axis=1, keepdims=True))
    P = np.stack([det.polarity, lin.polarity])
    out = np.empty((2, len(x)))
    fast_coupling.zonal_energies(x, np.ascontiguousarray(det.poles.T), np.ascontiguousarray(P),
                                 np.ascontiguousarray(breaks),
                                 np.ascontiguousarray(np.stack([np.asarray(det._e.c).T, np.asarray(lin._e.c).T])),
                                 out)
    alpha = np.arccos(np.clip(x @ det.poles.T, -1.0, 1.0))  # (Q, M)
    for t, spline in enumerate((det._e, lin._e)):
        ref = -(spline(alpha) * P[t]).sum(axis=1)
        np.testing.assert_allclose(out[t], ref, rtol=0, atol=1e-12 * np.abs(ref).max())
