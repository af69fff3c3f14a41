"""The iron prototype's cores' field at the default sensor array against direct magpylib-material-response solves
on successively finer meshes (issue 26): the mesh convergence of :func:`spherestep.sensing.iron.iron_fields`.

What is solved. Each of the 29 pot cores with the whole rotor (92 magnets, magpylib cylinders at the iron model's
radius, :func:`magnetics.magnet_face_radius`) at 3 orientations ``so3.random(3, 26)`` (those of
``sensing_iron_reference.csv``), meshed by the iron room's mesher (``_iron.core_cells``: slabs graded from the face,
level ``L`` divides every size by ``2^(L/4)``) and solved on its own by magpylib-material-response's point-matched
moment system ``(I − χT) J = χ B_src`` (its ``demag_tensor``, factorised once per level by
:class:`magnetics.CoreSolver`, then one back-substitution per core and orientation: what ``apply_demag(solver=
"direct")`` solves, without rebuilding ``T`` 87 times; checked equal below). The cores' field at the sensors is the
solved cells' field. The cores' mutual coupling is not re-solved per level (a system of all 29 cores is 19 GB at
level 2): each level's column is the cores solved each on its own, and the coupling is the model's (dipole
coupling within 50°, its own check against one moment system is in docs/sensing.md) taken from
``sensing_iron_reference.csv`` (level 2).

``apply_demag`` itself (``apply-demag``): the two cores nearest sensor 8 (28 and 22, 1124 cells at level 2) and the
92 magnets as χ = 0 cells in one ``apply_demag(solver="direct")`` at orientation 0, against the factorised joint
solve of the same two cores in ``sensing_iron_reference.csv`` (``cluster_joint``); writes
``data/sensing_iron_mmr_apply_demag.csv``.

Run: ``OPENBLAS_NUM_THREADS=1 nice -n 5 .venv/bin/python scripts/sensing_iron_mmr.py [level ...]`` (default
``0 1 2 3 4 5``); writes ``data/sensing_iron_mmr.csv`` after each level (one column triple per level), keeping
the levels already stored. ``... scripts/sensing_iron_mmr.py apply-demag``: the check above.
"""

from __future__ import annotations

import datetime
import os
import sys
import time
from pathlib import Path

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from spherestep import so3
from spherestep.magnetics import CoreGeometry, CoreSolver, magnet_face_radius
from spherestep.motor import prototype
from spherestep.sensing import default_array, iron

OUT = Path(__file__).resolve().parents[1] / "data" / "sensing_iron_mmr.csv"
SEED, COUNT = 26, 3


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


def independent(design, positions, Rs, level: int) -> tuple[np.ndarray, int]:
    """The cores' field ``(K, S, 3)`` (T) at ``positions`` for each ``R`` of ``Rs``, every core solved on its own
    at mesh ``level``; and the cells per core."""
    solver = CoreSolver(CoreGeometry.of(design, design.coil), level)
    n = len(solver.cells)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    v = design.stator.centers
    Y = np.einsum("kji,ksj->ksi", Q, positions[None] - face * v[:, None]).reshape(-1, 3)  # sensors, core frames
    G = iron._unit_fields(solver, Y).reshape(len(v), len(positions), 3, 3 * n)  # per unit cell polarization
    out = np.zeros((len(Rs), len(positions), 3))
    for i, R in enumerate(Rs):
        mags = rotor_magnets(design, R)
        cells = np.einsum("kij,nj->kni", Q, solver.centroids) + face * v[:, None]  # (29, n, 3) fixed frame
        B = np.asarray(magpy.getB(mags, cells.reshape(-1, 3), sumup=True)).reshape(len(v), n, 3)
        J = solver.polarization(np.einsum("kni,kij->knj", B, Q))  # core frames
        Jf = np.moveaxis(J, 2, 1).reshape(len(v), 3 * n)  # solver layout x1..xn, y1..yn, z1..zn
        out[i] = np.einsum("kij,ksj->si", Q, np.einsum("ksac,kc->ksa", G, Jf))
    return out, n


def apply_demag_check(cores=(28, 22), level: int = 2, k: int = 0) -> None:
    """``apply_demag`` of ``cores`` (one moment system) with the whole rotor at orientation ``k``, written beside
    the factorised solve of ``sensing_iron_reference.csv`` (``cluster_joint``, the same cores at level 2)."""
    from magpylib_material_response.demag import apply_demag

    from spherestep.magnetics import _iron

    design = prototype()
    p = default_array(design).positions
    R = so3.random(COUNT, SEED)[k]
    geom = CoreGeometry.of(design, design.coil)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    cells = []
    for c in cores:
        rot = Rotation.from_matrix(Q[c])
        for cell in _iron.core_cells(geom, level):
            cell.orientation = rot * cell.orientation
            cell.position = Q[c] @ cell.position + face * design.stator.centers[c]
            cell.susceptibility = geom.mu_r - 1.0
            cells.append(cell)
    mags = rotor_magnets(design, R)
    for m in mags:
        m.susceptibility = 0.0
    t0 = time.perf_counter()
    solved = apply_demag(magpy.Collection(*cells, *mags), solver="direct")
    B = np.asarray(magpy.getB(solved.sources_all[:len(cells)], p, sumup=True)).reshape(-1, 3)
    took = time.perf_counter() - t0
    ref_path = Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data" / "sensing_iron_reference.csv"
    lines = [ln for ln in ref_path.read_text().splitlines() if ln and not ln.startswith("#")]
    data = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    joint = data[data[:, 0] == k][:, 14:17]
    d = B - joint
    note = (f"cores {' '.join(map(str, cores))}, level {level} ({len(cells)} cells), orientation {k}: {took:.0f} s"
            f" (load {os.getloadavg()[0]:.1f}, {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC);"
            f" apply_demag − factorised: max {np.abs(d).max():.2e} T, RMS {np.sqrt(np.mean(d ** 2)):.2e} T"
            f" of {np.sqrt(np.mean(joint ** 2)):.4e} T")
    print(note, flush=True)
    out = OUT.with_name("sensing_iron_mmr_apply_demag.csv")
    head = ["# cores' field (T) at the default array's 24 sensors, prototype, R = so3.random(3, 26)[k]: one"
            " magpylib-material-response apply_demag(solver='direct') of the cores with the 92 magnets (chi = 0)"
            " against the factorised joint solve (sensing_iron_reference.csv cluster_joint)",
            "# command: OPENBLAS_NUM_THREADS=1 nice -n 5 .venv/bin/python scripts/sensing_iron_mmr.py apply-demag",
            f"# {note}", "sensor,apply_demag_x,apply_demag_y,apply_demag_z,factorised_x,factorised_y,factorised_z"]
    out.write_text("\n".join(head + [f"{s}," + ",".join(f"{v:.12e}" for v in (*B[s], *joint[s]))
                                      for s in range(len(p))]) + "\n")


def main(argv) -> None:
    if argv[:1] == ["apply-demag"]:
        apply_demag_check()
        return
    levels = [int(a) for a in argv] or [0, 1, 2, 3, 4, 5]
    design = prototype()
    p = default_array(design).positions
    Rs = so3.random(COUNT, SEED)
    cols, notes, commands = stored()  # levels already stored are kept unless recomputed
    for level in levels:
        t0 = time.perf_counter()
        B, n = independent(design, p, Rs, level)
        cols[level] = B
        notes[level] = (f"level {level}: {n} cells per core, {time.perf_counter() - t0:.0f} s"
                        f" (load {os.getloadavg()[0]:.1f}, {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC)")
        print(notes[level], f"RMS {np.sqrt(np.mean(B ** 2)) * 1e3:.4f} mT", flush=True)
        done = sorted(cols)
        for a, b in zip(done[:-1], done[1:]):
            d = cols[b] - cols[a]
            print(f"  level {b} − level {a}: RMS {np.sqrt(np.mean(d ** 2)) * 1e6:.1f} µT, max"
                  f" {np.abs(d).max() * 1e6:.1f} µT", flush=True)
        cmd = "OPENBLAS_NUM_THREADS=1 nice -n 5 .venv/bin/python scripts/sensing_iron_mmr.py " + " ".join(map(str, levels))
        head = [f"# cores' field (T) at the default array's 24 sensors, prototype, R = so3.random({COUNT}, {SEED}),"
                " every core solved on its own (magpylib-material-response demag_tensor, point matching) with the"
                " whole rotor, mesh _iron.core_cells at each level",
                *[f"# command: {c}" for c in dict.fromkeys([*commands, cmd])],
                *[f"# {notes[lv]}" for lv in done],
                "k,sensor," + ",".join(f"level{lv}_{a}" for lv in done for a in "xyz")]
        rows = [f"{k},{s}," + ",".join(f"{v:.9e}" for lv in done for v in cols[lv][k, s])
                for k in range(COUNT) for s in range(len(p))]
        OUT.write_text("\n".join(head + rows) + "\n")


def stored() -> tuple[dict, dict, list]:
    """The levels already in :data:`OUT`: ``({level: (K, S, 3)}, {level: note}, [commands])``."""
    if not OUT.is_file() or "level" not in OUT.read_text().split("k,sensor,", 1)[-1].split("\n", 1)[0]:
        return {}, {}, []
    lines = OUT.read_text().splitlines()
    comments = [ln[2:] for ln in lines if ln.startswith("# ")]
    head = next(ln for ln in lines if ln.startswith("k,sensor,"))
    levels = [int(c[5:-2]) for c in head.split(",")[2::3]]
    data = np.array([[float(v) for v in ln.split(",")[2:]] for ln in lines if ln and ln[0].isdigit()])
    data = data.reshape(COUNT, -1, len(levels), 3)
    notes = {int(c.split()[1].rstrip(":")): c for c in comments if c.startswith("level ")}
    commands = [c[len("command: "):] for c in comments if c.startswith("command: ")]
    return {lv: data[:, :, i] for i, lv in enumerate(levels)}, notes, commands


if __name__ == "__main__":
    main(sys.argv[1:])
