"""The self-inductance of one coil, air or iron-cored, from the flux linkage of its winding's loops."""

from __future__ import annotations

import math

import magpylib as magpy
import numpy as np

from ..electrics import core_key, stored_permeance
from ._iron import IRON_LEVEL, WINDING_GRID, CoreGeometry, core_solver, winding_loops

_SOLVED: dict = {}  # L / N² of the cores solved in this process, by core_key


def coil_inductance(design, coil, level: int = IRON_LEVEL, samples: int = 24) -> float:
    """Self-inductance (H) of one coil, rotor absent: ``L = λ / I`` with the flux linkage
    ``λ = Σ_loops (N / n_loops) Φ(r_loop, z_loop)`` of the winding's loops, ``Φ(r, z) = ∫_0^r B_z(ρ, z) 2πρ dρ``
    (Gauss–Legendre, ``samples`` nodes along a radius; the solved core is axisymmetric to its mesh), ``B`` from
    the winding and, for an iron core, the core it magnetises (linear iron, MoM)."""
    geom = CoreGeometry.of(design, coil)
    turns = coil.turns(design.coil_diameter, design.coil_length)
    current = geom.NI / turns
    nr, nz = WINDING_GRID
    loops = winding_loops(geom, geom.NI)
    radii = geom.r_p + (np.arange(nr) + 0.5) / nr * (geom.r_w - geom.r_p)
    heights = (np.arange(nz) + 0.5) / nz * geom.depth
    x, w = np.polynomial.legendre.leggauss(samples)
    lam = 0.0
    for r in radii:
        rho = 0.5 * r * (x + 1.0)
        pts = np.array([[p, 0.0, h] for h in heights for p in rho])
        B = magpy.getB(loops, pts, sumup=True)
        if coil.core == "iron":
            solver = core_solver(geom, level)
            B = B + solver.field(solver.polarization(magpy.getB(loops, solver.centroids, sumup=True)), pts)
        Bz = B[:, 2].reshape(nz, samples)
        phi = (Bz * (0.5 * r * w * 2 * math.pi * rho)[None]).sum(axis=1)
        lam += (turns / (nr * nz)) * phi.sum()
    return float(lam / current)


def iron_inductance(spec, design) -> float:
    """The iron-cored coil's own inductance (H) for ``design`` wound as ``spec``: ``N² ·`` the core's stored
    ``L / N²`` (:func:`spherestep.electrics.stored_permeance`: a stored core or a scaled copy of one), else
    :func:`coil_inductance` solved once per core in the process (~17 s)."""
    key = core_key(spec, design)
    turns = spec.turns(design.coil_diameter, design.coil_length)
    permeance = stored_permeance(key)
    if permeance is None and key not in _SOLVED:
        _SOLVED[key] = coil_inductance(design, spec) / turns ** 2
    return turns ** 2 * (permeance if permeance is not None else _SOLVED[key])
