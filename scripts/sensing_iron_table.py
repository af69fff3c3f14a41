"""The iron prototype's cores' field at the default sensor array (:mod:`spherestep.sensing.iron`), and the
direct method-of-moments references it is checked against.

``python scripts/sensing_iron_table.py table`` writes ``src/spherestep/data/sensing_iron_cores.npz``: the node
values ``H (181, 360, S, 3)`` of :func:`spherestep.sensing.iron.core_response` on the 1° grid, stored as int16 per
sensor and component with its scale (quantisation step ≤ max|H|/32767, below 2 µT), and the iron coils' field
per unit current ``(29, S, 3)``. About a minute plus the core's factorisation.

``python scripts/sensing_iron_table.py reference`` writes ``src/spherestep/data/sensing_iron_reference.csv``: the
cores' field at the 24 sensors at 3 orientations (``so3.random(3, 26)``) by direct solves with the whole rotor
(92 magnets, magpylib at every cell): (i) every core solved on its own (all 29 cores), (ii) the same with the
cores magnetising each other (the model's physics: each core's polarization, as point dipoles per cell,
magnetises the cores within 50°, to convergence), and (iii) the two cores nearest sensor 8 solved together (one
moment system), beside the same two cores solved one by one and coupled as in (ii). Minutes (one 2-core
factorisation).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from spherestep import so3
from spherestep.atomic import atomic_path
from spherestep.magnetics import CoreGeometry, CoreSolver, core_solver, magnet_face_radius
from spherestep.motor import prototype
from spherestep.sensing import default_array, iron

DATA = Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data"
SEED = 26
CLUSTER_SENSOR = 8


def table() -> None:
    design = prototype()
    p = default_array(design).positions
    t0 = time.perf_counter()
    H = iron.core_response(design, p, progress=lambda i, n: print(f"core {i}/{n} {time.perf_counter() - t0:.0f} s",
                                                                    flush=True))
    coils = iron.IronCoilField.build(design, p).per_coil
    scale = np.abs(H).max(axis=(0, 1)) / 32767.0  # (S, 3)
    Hq = np.round(H / scale).astype(np.int16)
    err = np.abs(Hq * scale - H).max()
    with atomic_path(DATA / iron.DATA_FILE) as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, H=Hq, scale=scale, step_deg=np.array(iron.GRID_STEP_DEG), positions=p,
                                coils=coils, key=np.frombuffer(iron.design_key(design), dtype=np.uint8))
    print(f"wrote {DATA / iron.DATA_FILE}: max |H| {np.abs(H).max() * 1e3:.2f} mT, quantisation ≤ {err * 1e6:.2f} µT,"
          f" {time.perf_counter() - t0:.0f} s")


def rotor_magnets(design, R):
    """The whole rotor at ``R`` as the iron model places its magnets (radius of :func:`magnet_face_radius`)."""
    rc = magnet_face_radius(design) - 0.5 * design.magnet_length
    W = (R @ design.rotor.centers.T).T
    out = []
    for w, pj in zip(W, design.polarity):
        m = magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                  polarization=(0, 0, float(pj) * design.remanence), position=rc * w)
        m.orientation = Rotation.align_vectors([w], [[0.0, 0.0, 1.0]])[0]
        out.append(m)
    return out


def independent(design, R, p, cores) -> np.ndarray:
    """Field ``(S, 3)`` at ``p`` of ``cores`` each solved on its own with the whole rotor at ``R``."""
    solver = core_solver(CoreGeometry.of(design, design.coil), iron.SENSING_LEVEL)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    mags = rotor_magnets(design, R)
    out = np.zeros((len(p), 3))
    for k in cores:
        cells = solver.centroids @ Q[k].T + face * design.stator.centers[k]
        J = solver.polarization(magpy.getB(mags, cells, sumup=True) @ Q[k])
        out += solver.field(J, (p - face * design.stator.centers[k]) @ Q[k]) @ Q[k].T
    return out


def coupled(design, R, p, cores, sweeps: int | None = None) -> np.ndarray:
    """Field ``(K, S, 3)`` at ``p`` of ``cores`` with the whole rotor at each of ``R (K, 3, 3)``: each core solved,
    then the cores magnetising each other through :func:`spherestep.sensing.iron.coupling_matrix` (the model's
    physics, evaluated on the polarizations directly, no table), ``J_l = J0_l + M Σ_k C_lk J_k`` to convergence
    (``sweeps``: that many, 1 = the first order)."""
    solver = core_solver(CoreGeometry.of(design, design.coil), iron.SENSING_LEVEL)
    n = len(solver.cells)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    v = design.stator.centers
    J0 = {k: np.array([solver.polarization(magpy.getB(rotor_magnets(design, Rk), solver.centroids @ Q[k].T
                                                      + face * v[k], sumup=True) @ Q[k]) for Rk in R])
          for k in cores}  # (K, n, 3) in k's frame
    C = {(l, k): iron.coupling_matrix(design, solver, l, k) for l, k in iron.coupled_pairs(design, cores)}
    J = J0
    for _ in range(sweeps or iron.COUPLING_SWEEPS):
        B = {k: np.zeros((len(R), 3 * n)) for k in cores}
        for (l, k), Clk in C.items():
            B[l] += np.swapaxes(J[k], 1, 2).reshape(len(R), 3 * n) @ Clk.T
        new = {k: J0[k] + solver.polarization(np.swapaxes(B[k].reshape(len(R), 3, n), 1, 2)) for k in cores}
        change = max(np.abs(new[k] - J[k]).max() for k in cores) / max(np.abs(J0[k]).max() for k in cores)
        J = new
        if change < 1e-7:
            break
    out = np.zeros((len(R), len(p), 3))
    for k in cores:
        for i in range(len(R)):
            out[i] += solver.field(J[k][i], (p - face * v[k]) @ Q[k]) @ Q[k].T
    return out


def joint(design, R, p, cores) -> np.ndarray:
    """Field ``(S, 3)`` at ``p`` of ``cores`` solved together (one moment system) with the whole rotor at ``R``."""
    geom = CoreGeometry.of(design, design.coil)
    Q = iron.core_frames(design)
    face = design.radius + design.air_gap
    solver = CoreSolver(geom, iron.SENSING_LEVEL, placements=[(Rotation.from_matrix(Q[k]), face * design.stator.centers[k])
                                          for k in cores])
    out = []
    for Rk in R:
        J = solver.polarization(magpy.getB(rotor_magnets(design, Rk), solver.centroids, sumup=True))
        out.append(solver.field(J, p))
    return np.array(out)


def reference() -> None:
    design = prototype()
    p = default_array(design).positions
    R = so3.random(3, SEED)
    t0 = time.perf_counter()
    allc = np.arange(len(design.stator))
    ind = np.array([independent(design, Rk, p, allc) for Rk in R])
    first = coupled(design, R, p, allc)
    print(f"independent and coupled, all cores: {time.perf_counter() - t0:.0f} s", flush=True)
    x = p[CLUSTER_SENSOR] / np.linalg.norm(p[CLUSTER_SENSOR])
    cluster = np.argsort(-(design.stator.centers @ x))[:2]
    ind_c = np.array([independent(design, Rk, p, cluster) for Rk in R])
    first_c = coupled(design, R, p, cluster)
    jnt = joint(design, R, p, cluster)
    print(f"joint, cores {cluster.tolist()}: {time.perf_counter() - t0:.0f} s", flush=True)
    cols = ["independent", "coupled", "cluster_independent", "cluster_coupled", "cluster_joint"]
    lines = [f"# cores' field (T) at the default array's 24 sensors, prototype, R = so3.random(3, {SEED}); "
             "scripts/sensing_iron_table.py reference",
             f"# cluster (cores solved together): {' '.join(map(str, cluster.tolist()))}",
             "k,sensor," + ",".join(f"{c}_{a}" for c in cols for a in "xyz")]
    for k in range(len(R)):
        for s in range(len(p)):
            vals = np.concatenate([ind[k, s], first[k, s], ind_c[k, s], first_c[k, s], jnt[k, s]])
            lines.append(f"{k},{s}," + ",".join(f"{v:.9e}" for v in vals))
    with atomic_path(DATA / "sensing_iron_reference.csv") as tmp:
        Path(tmp).write_text("\n".join(lines) + "\n")
    for name, d in (("coupling left out", jnt - ind_c), ("left by the dipole coupling", jnt - first_c)):
        print(f"{name}: max {np.abs(d).max() * 1e3:.3f} mT, RMS {np.sqrt(np.mean(d ** 2)) * 1e3:.3f} mT; "
              f"cluster field RMS {np.sqrt(np.mean(jnt ** 2)) * 1e3:.3f} mT")


if __name__ == "__main__":
    {"table": table, "reference": reference}[sys.argv[1] if len(sys.argv) > 1 else "table"]()
