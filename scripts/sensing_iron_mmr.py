"""The iron prototype's cores' field at the default sensor array by an independent solve with
magpylib-material-response (issue 26): the check of :func:`spherestep.sensing.iron.iron_fields` against a library
other than the iron room's own method of moments.

The 29 pot cores (:class:`spherestep.magnetics.CoreGeometry`: centre pole, outer wall, back plate, the same shape
the sensing model solves) are meshed with :func:`magpylib_material_response.meshing.mesh_Cylinder` on slabs of
their own grading (first slab ``first`` at the face growing by 1.8 up to ``size``, lateral cells ``size``), placed
as the sensing model places them (:func:`spherestep.sensing.iron.core_frames`, face at ``radius + air_gap``), and
the 92 rotor magnets as magpylib cylinders (radius of :func:`magnetics.magnet_face_radius`) at 3 orientations
``so3.random(3, 26)`` (those of ``sensing_iron_reference.csv``). :func:`magpylib_material_response.demag.apply_demag`
solves all the cores in one moment system (χ = μr − 1, magnets χ = 0: the cores' mutual coupling in full), and
the cores' field at the sensors is the solved cells' field (total minus the magnets' own).

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/sensing_iron_mmr.py [size_mm first_mm] ...`` — each pair
is one mesh (default ``30 8`` and ``20 4``: 45 and 58 cells per core; 1305 cells took 158 s per orientation at load 3); writes ``data/sensing_iron_mmr.csv`` (columns per mesh).
"""

from __future__ import annotations

import datetime
import math
import os
import sys
import time
from pathlib import Path

import magpylib as magpy
import numpy as np
from magpylib_material_response.demag import apply_demag
from magpylib_material_response.meshing import mesh_Cylinder
from scipy.spatial.transform import Rotation

from spherestep import so3
from spherestep.magnetics import CoreGeometry, magnet_face_radius
from spherestep.motor import prototype
from spherestep.sensing import default_array, iron

OUT = Path(__file__).resolve().parents[1] / "data" / "sensing_iron_mmr.csv"
SEED, COUNT = 26, 3
GROWTH = 1.8


def slabs(z0: float, z1: float, first: float, size: float) -> np.ndarray:
    """Slab boundaries on ``[z0, z1]``: thickness ``first`` at ``z = 0`` (the face) growing by :data:`GROWTH` up to
    ``size``."""
    edges, t = [0.0], first
    while edges[-1] < z1 - 1e-12:
        edges.append(min(z1, edges[-1] + t))
        t = min(size, t * GROWTH)
    if len(edges) > 2 and edges[-1] - edges[-2] < 0.3 * (edges[-2] - edges[-3]):
        edges.pop(-2)
    e = np.asarray(edges)
    return np.unique(np.clip(np.concatenate([[z0], e[(e > z0) & (e < z1)], [z1]]), z0, z1))


def core_mesh(geom: CoreGeometry, size: float, first: float) -> list:
    """The core's cells in its own frame (axis ``+z``, face at ``z = 0``)."""
    cells = []
    for r0, r1, z0, z1 in geom.parts():
        nr = max(1, round((r1 - r0) / size))
        nphi = max(6, round(math.pi * (r0 + r1) / size))
        edges = slabs(z0, z1, first, size)
        for a, b in zip(edges[:-1], edges[1:]):
            if r0 == 0.0:
                slab = magpy.magnet.Cylinder(dimension=(2 * r1, b - a), polarization=(0, 0, 0),
                                             position=(0, 0, 0.5 * (a + b)))
            else:
                slab = magpy.magnet.CylinderSegment(dimension=(r0, r1, b - a, 0, 360), polarization=(0, 0, 0),
                                                    position=(0, 0, 0.5 * (a + b)))
            cells.extend(mesh_Cylinder(slab, (nphi, nr, 1)).sources_all)
    for c in cells:
        c.parent = None
    return cells


def stator_cells(design, size: float, first: float) -> list:
    """All 29 cores' cells in the fixed frame, placed as :func:`spherestep.sensing.iron.core_frames`."""
    geom = CoreGeometry.of(design, design.coil)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    out = []
    for k, v in enumerate(design.stator.centers):
        rot = Rotation.from_matrix(Q[k])
        for c in core_mesh(geom, size, first):
            c = c.copy()
            c.orientation = rot * c.orientation
            c.position = Q[k] @ c.position + face * v
            out.append(c)
    return out


def rotor_magnets(design, R) -> list:
    """The whole rotor at ``R``, magnets placed as the iron model places them."""
    rc = magnet_face_radius(design) - 0.5 * design.magnet_length
    out = []
    for w, pj in zip((R @ design.rotor.centers.T).T, design.polarity):
        m = magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                  polarization=(0, 0, float(pj) * design.remanence), position=rc * w)
        m.orientation = Rotation.align_vectors([w], [[0.0, 0.0, 1.0]])[0]
        out.append(m)
    return out


def cores_field(design, positions, R, size: float, first: float) -> tuple[np.ndarray, int]:
    """The cores' field ``(S, 3)`` (T) at ``positions`` with the rotor at ``R``, one apply_demag of all cores."""
    cells = stator_cells(design, size, first)
    chi = float(design.coil.material.relative_permeability) - 1.0
    for c in cells:
        c.susceptibility = chi
    mags = rotor_magnets(design, R)
    for m in mags:
        m.susceptibility = 0.0
    solved = apply_demag(magpy.Collection(*cells, *mags), solver="direct")
    iron_cells = solved.sources_all[:len(cells)]
    return np.asarray(magpy.getB(iron_cells, positions, sumup=True)).reshape(-1, 3), len(cells)


def main(argv) -> None:
    nums = [float(a) for a in argv] or [30.0, 8.0, 20.0, 4.0]
    meshes = list(zip(nums[0::2], nums[1::2]))
    design = prototype()
    p = default_array(design).positions
    Rs = so3.random(COUNT, SEED)
    cols, notes = [], []
    for size, first in meshes:
        B, t0 = [], time.perf_counter()
        for R in Rs:
            b, n = cores_field(design, p, R, size * 1e-3, first * 1e-3)
            B.append(b)
        cols.append(np.array(B))
        notes.append(f"mesh size {size:g} mm first slab {first:g} mm: {n} cells ({n // 29} per core),"
                     f" {time.perf_counter() - t0:.0f} s for {COUNT} solves")
        print(notes[-1], flush=True)
    head = [f"# cores' field (T) at the default array's 24 sensors, prototype, R = so3.random({COUNT}, {SEED}),"
            " magpylib-material-response apply_demag of all 29 cores (coupled) with the whole rotor",
            "# command: OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/sensing_iron_mmr.py "
            + " ".join(f"{a:g}" for m in meshes for a in m),
            f"# {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC, load {os.getloadavg()[0]:.1f}",
            *[f"# mesh {i}: {s}" for i, s in enumerate(notes)],
            "k,sensor," + ",".join(f"mesh{i}_{a}" for i in range(len(meshes)) for a in "xyz")]
    rows = [f"{k},{s}," + ",".join(f"{v:.9e}" for c in cols for v in c[k, s])
            for k in range(COUNT) for s in range(len(p))]
    OUT.write_text("\n".join(head + rows) + "\n")
    d = cols[-1] - cols[0]
    print(f"wrote {OUT}; mesh difference max {np.abs(d).max() * 1e6:.1f} µT RMS {np.sqrt(np.mean(d ** 2)) * 1e6:.1f} µT")


if __name__ == "__main__":
    main(sys.argv[1:])
