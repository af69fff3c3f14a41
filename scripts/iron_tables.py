"""Build the prototype's iron-core tables by the method of moments (magpylib-material-response) and store them;
assemble the pair table the prototype's model reads from the FEM nodes (``scripts/fem_iron.py --table``) below 21°
and the moment method from 21° on (the two agree within 1 % of the peak at 20°, docs/magnetics.md).

    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py              # all of the below at the default level
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py table        # data/iron_pair_table_mom.csv, flux
    python scripts/iron_tables.py fem-table   # src/spherestep/data/iron_pair_table.csv: FEM below 21°, MoM above
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py convergence  # data/iron_convergence.csv
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py multibody    # data/iron_multibody.csv
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py coupling     # data/iron_coupling.csv
    python scripts/iron_tables.py coupling-table  # src/spherestep/data/iron_coupling_table.csv (the model's)
    OPENBLAS_NUM_THREADS=1 python scripts/iron_tables.py coupling-effects  # data/iron_coupling_effects.csv
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py saturation   # data/iron_saturation.csv
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/iron_tables.py fig6         # data/iron_fig6.csv

Each file starts with ``#`` lines saying what produced it; times are wall-clock on the machine that ran it.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

from spherestep.magnetics import _iron as iron
from spherestep.magnetics import _ironcoupling as ironcoupling
from spherestep.magnetics import _ironforce as ironforce
from spherestep.magnetics._ironmap import TABLE_NODES_DEG, pair_table, read_table
from spherestep.motor import prototype
from spherestep.motor.coil import iron_coil

DATA = Path(__file__).resolve().parents[1] / "data"
# The two-core study's cores, by direction: the lowest core and, of the eight at 34.3° round it (equally near, so no
# index order may choose), the one toward this direction (cores 28 and 17; 26 and 17 before issue 35 renumbered them)
STUDY_NEIGHBOUR = (-0.216, -0.521, -0.826)


def study_cores(design) -> list[int]:
    """The stator indices of the two-core study's cores (:data:`STUDY_NEIGHBOUR`)."""
    v = np.array(design.stator.centers)
    return [int(np.argmin(v[:, 2])), int(np.argmax(v @ np.array(STUDY_NEIGHBOUR)))]


def _write(path: Path, header: str, names: list[str], rows: np.ndarray) -> None:
    text = "".join(f"# {line}\n" for line in header.splitlines()) + ",".join(names) + "\n"
    text += "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in rows)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    print("wrote", path, flush=True)


def table(level: int = iron.IRON_LEVEL) -> None:
    design, coil = prototype(), iron_coil()
    t0 = time.perf_counter()
    iron.core_solver(iron.CoreGeometry.of(design, coil), level)
    t1 = time.perf_counter()
    det, lin = pair_table(design, coil, level)
    t2 = time.perf_counter()
    flux(level)
    _write(DATA / "iron_pair_table_mom.csv",
           f"Iron-core pair torques of the prototype (spherestep.magnetics._ironforce.pair_tables), MoM level {level}: "
           f"{len(iron.core_solver(iron.CoreGeometry.of(design, coil), level).cells)} cells.\n"
           f"One +1 rotor magnet at angle alpha from one iron coil's axis; torque about the sphere's centre (N m), "
           f"positive away from the axis; linear per nominal current ({iron.CoreGeometry.of(design, coil).NI:.1f} "
           f"ampere-turns).\nfactorisation {t1 - t0:.1f} s, {len(TABLE_NODES_DEG)} angles {t2 - t1:.1f} s. "
           f"Produced by: python scripts/iron_tables.py table",
           ["alpha_deg", "detent_Nm", "linear_Nm"], np.c_[TABLE_NODES_DEG, det, lin])


def fem_table(switch_deg: float = 21.0) -> None:
    """``src/spherestep/data/iron_pair_table.csv``: 0 at 0° (symmetry), the FEM nodes of data/iron_fem_table.csv
    below ``switch_deg``, the moment-method rows of data/iron_pair_table_mom.csv from it on."""
    fem = read_table(DATA / "iron_fem_table.csv")  # alpha, maxh, elements, detent, linear, mesh_s, solve_s
    mom = read_table(DATA / "iron_pair_table_mom.csv")  # alpha, detent, linear
    fem = fem[fem[:, 0] < switch_deg]
    rows = np.r_[[[0.0, 0.0, 0.0]], fem[:, [0, 3, 4]], mom[mom[:, 0] >= switch_deg]]
    _write(Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data" / "iron_pair_table.csv",
           f"Iron-core pair torques of the prototype: NGSolve 3-D FEM (scripts/fem_iron.py --table, order 2, 2 mm at "
           f"the core's face) at {len(fem)} angles below {switch_deg:g} deg, except the reference angles of "
           f"data/iron_fem.csv, which check it;\nthe moment method (data/iron_pair_table_mom.csv, level 0) from "
           f"{switch_deg:g} deg on; 0 at 0 deg by symmetry.\nOne +1 rotor magnet at angle alpha from one iron coil's "
           f"axis; torque about the sphere's centre (N m), positive away from the axis; linear per nominal current.\n"
           f"Produced by: python scripts/iron_tables.py fem-table",
           ["alpha_deg", "detent_Nm", "linear_Nm"], rows)


def flux(level: int = iron.IRON_LEVEL) -> None:
    """The saturation grid: mean |B| of the pole's face layer over alpha x pc."""
    from spherestep.magnetics import _ironsummary as summ
    design, coil = prototype(), iron_coil()
    aa, pp = np.meshgrid(summ.FLUX_ALPHA_DEG, [-1.0, 0.0, 1.0], indexing="ij")
    path = Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data" / summ.FLUX_FILE
    if path.exists():
        path.unlink()  # compute, do not interpolate the old grid
    B = summ.core_flux_density(design, coil, np.radians(aa.ravel()), pp.ravel(), level)
    _write(path,
           f"Mean |B| (T) in the prototype's centre pole within {1e3 * summ.FACE_LAYER:g} mm of the face (MoM level "
           f"{level}, linear iron) with one pole at alpha from the axis and the coil at pc = polarity x current.\n"
           f"Produced by: python scripts/iron_tables.py flux",
           ["alpha_deg", "pc", "mean_face_B_T"], np.c_[aa.ravel(), pp.ravel(), B])


def convergence(levels=(0, 1)) -> None:
    design, coil = prototype(), iron_coil()
    a = np.array([2.0, 4.0, 6.0, 8.0, 10.0, 12.0, 14.0, 17.0, 20.0, 25.0])
    rows = []
    for level in levels:
        t0 = time.perf_counter()
        s = iron.core_solver(iron.CoreGeometry.of(design, coil), level)
        t1 = time.perf_counter()
        det, lin = ironforce.pair_tables(design, coil, np.radians(a), level)
        t2 = time.perf_counter()
        print(level, len(s.cells), t1 - t0, t2 - t1, flush=True)
        rows += [[level, len(s.cells), t1 - t0, (t2 - t1) / len(a), ai, d, li] for ai, d, li in zip(a, det, lin)]
        iron.core_solver.cache_clear()
    _write(DATA / "iron_convergence.csv",
           "Mesh convergence of the iron pair torques (MoM), prototype. Produced by: "
           "python scripts/iron_tables.py convergence",
           ["level", "cells", "factorise_s", "per_angle_s", "alpha_deg", "detent_Nm", "linear_Nm"], np.array(rows))


def multibody(level: int = 0) -> None:
    """Two neighbouring cores under the whole rotor: full solve against the sum of pair tables (same level)."""
    from spherestep.magnetics._ironmap import IronTorqueMap
    design, coil = prototype(), iron_coil()
    v = np.array(design.stator.centers)
    coils = study_cores(design)
    rng = np.random.default_rng(1)
    from scipy.spatial.transform import Rotation
    # orientations that put a pole 3-10 degrees from each core's axis (where the torques are large)
    R = []
    for i in range(4):
        j = rng.integers(len(design.rotor))
        target = Rotation.from_rotvec(rng.normal(size=3) * np.radians(6.0) / np.sqrt(3)).apply(v[coils[i % 2]])
        base = Rotation.align_vectors(target[None], design.rotor.centers[j][None])[0]
        R.append((Rotation.from_rotvec(target * rng.uniform(0, 2 * np.pi)) * base).as_matrix())
    R = np.array(R)
    if level == iron.IRON_LEVEL:
        from spherestep.magnetics import iron_model
        model = iron_model(design, coil)  # the stored table of this level
    else:
        det, lin = pair_table(design, coil, level, nodes_deg=TABLE_NODES_DEG)
        model = IronTorqueMap.from_tables(design, coil, np.radians(TABLE_NODES_DEG), det, lin, level=level)
    rows = []
    for currents in ([0.0, 0.0], [1.0, 0.0], [1.0, -1.0]):
        t0 = time.perf_counter()
        full = ironforce.rotor_iron_torque(design, coil, coils, R, currents, level)
        t1 = time.perf_counter()
        c = np.zeros(len(design.stator))
        c[coils] = currents
        pair = model.torque_on(R, c, coils)
        for k in range(len(R)):
            rows.append([currents[0], currents[1], k, *full[k], *pair[k], t1 - t0])
        print(currents, np.linalg.norm(full - pair, axis=1) / np.linalg.norm(full, axis=1), flush=True)
    _write(DATA / "iron_multibody.csv",
           f"Full MoM solve of cores {coils} together under all 92 rotor magnets (level {level}) against the sum "
           f"of pair tables of the same level over those cores.\nProduced by: python scripts/iron_tables.py "
           f"multibody. Torques N m, fixed frame, about the centre.",
           ["c0", "c1", "orientation", "full_x", "full_y", "full_z", "pair_x", "pair_y", "pair_z", "solve_s"],
           np.array(rows))
    np.save(DATA / "iron_multibody_R.npy", R)


def coupling(level: int = 0) -> None:
    """The multibody orientations, coils off: the full solve, the pair tables, and the pair tables plus the coupling
    energy's torque (every magnet in the iron every other magnet magnetises, both cores solved together)."""
    design, coil = prototype(), iron_coil()
    mb = read_table(DATA / "iron_multibody.csv")  # c0, c1, orientation, full xyz, pair xyz, solve_s
    R = np.load(DATA / "iron_multibody_R.npy")
    coils = study_cores(design)
    rows = []
    for r in mb[(mb[:, 0] == 0) & (mb[:, 1] == 0)]:
        t0 = time.perf_counter()
        cross = ironcoupling.coupling_torque(design, coil, coils, R[int(r[2])], level)
        full, pair = r[3:6], r[6:9]
        rows.append([r[2], *full, *pair, *cross, time.perf_counter() - t0])
        print(int(r[2]), np.linalg.norm(full - pair) / np.linalg.norm(full),
              np.linalg.norm(full - pair - cross) / np.linalg.norm(full), flush=True)
    _write(DATA / "iron_coupling.csv",
           f"The coupling the pair tables leave out (spherestep.magnetics._ironcoupling.coupling_torque, MoM level {level}, "
           f"cores {coils} solved together, magnets within 40 deg), coils off, at the orientations of "
           f"data/iron_multibody.csv, beside that file's full solve and pair-table sum.\nProduced by: python "
           f"scripts/iron_tables.py coupling. Torques N m, fixed frame, about the centre.",
           ["orientation", "full_x", "full_y", "full_z", "pair_x", "pair_y", "pair_z", "coupling_x", "coupling_y",
            "coupling_z", "solve_s"], np.array(rows))


def coupling_table(level: int = iron.IRON_LEVEL) -> None:
    """``src/spherestep/data/iron_coupling_table.csv``: the coupling energy of two +1 poles over one core
    (``_ironcoupling.cross_energy_table``) on the angles the model reads."""
    from spherestep.magnetics._coupling import COUPLING_ALPHA_DEG, COUPLING_DPHI_DEG
    from spherestep.magnetics._ironmap import COUPLING_FILE

    design, coil = prototype(), iron_coil()
    t0 = time.perf_counter()
    X = ironcoupling.cross_energy_table(design, coil, np.radians(COUPLING_ALPHA_DEG), np.radians(COUPLING_DPHI_DEG), level)
    a, b, d = np.meshgrid(COUPLING_ALPHA_DEG, COUPLING_ALPHA_DEG, COUPLING_DPHI_DEG, indexing="ij")
    _write(Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data" / COUPLING_FILE,
           f"Coupling energy (J) of two +1 rotor poles over one iron core of the prototype (MoM level {level}, coils "
           f"off): -(1/mu0) int J_p . B_q, symmetrised; pole p at alpha_p, pole q at alpha_q from the core's axis, "
           f"dphi apart in azimuth.\nProduced by: python scripts/iron_tables.py coupling-table "
           f"({time.perf_counter() - t0:.0f} s)",
           ["alpha_p_deg", "alpha_q_deg", "dphi_deg", "energy_J"], np.c_[a.ravel(), b.ravel(), d.ravel(), X.ravel()])


def coupling_effects(seed: int = 0, count: int = 12) -> None:
    """What the coupling term changes for the motor: the samples of ``iron_summary`` (seed 0: 12 random unpowered
    starts, 12 stepper states with their coils) brought to rest on the pairwise model and on the coupled one."""
    from spherestep import so3
    from spherestep.magnetics import iron_model, state_currents
    from spherestep.statics import equilibrium

    design = prototype()
    rng = np.random.default_rng(seed)
    R0 = so3.random(count, rng)
    states = design.states()
    idx = np.sort(rng.choice(len(states), count, replace=False))
    starts = {"unpowered": (R0, np.zeros((count, len(design.stator)))),
              "state": (states.rotations[idx], np.array([state_currents(design, i) for i in idx]))}
    rows, rest = [], {}
    for coupled in (False, True):
        model = iron_model(design, coupling=coupled)
        t0 = time.perf_counter()
        for kind, (start, c) in starts.items():
            eq = equilibrium(model, start, c, gtol=1e-9, max_step=np.radians(2.0))
            rest[coupled, kind] = eq.rotation
            apart = so3.distance(eq.rotation, rest[False, kind])
            for n in range(count):
                rows.append([coupled, kind == "state", n, eq.is_minimum[n],
                             np.degrees(so3.distance(eq.rotation[n], start[n])), np.degrees(apart[n]),
                             eq.stiffness[n, 0], time.perf_counter() - t0])
        print("coupled" if coupled else "pairwise", time.perf_counter() - t0, flush=True)
    _write(DATA / "iron_coupling_effects.csv",
           "The samples of iron_summary (seed 0) brought to rest on the prototype's iron model, pairwise and with the "
           "coupling term (iron_model(..., coupling=True)): coupled (0/1), state (0: unpowered random start, 1: "
           "stepper state with its coils), sample, minimum (0/1), rest pose's distance from the start (deg), from "
           "the pairwise model's rest pose (deg), softest stiffness (N m/rad), seconds so far.\nProduced by: "
           "python scripts/iron_tables.py coupling-effects",
           ["coupled", "state", "sample", "minimum", "moved_deg", "from_pairwise_deg", "stiffness_Nm_per_rad",
            "seconds"], np.array(rows, dtype=float))


def saturation(level: int = iron.IRON_LEVEL) -> None:
    """One pole and one coil at the FEM's reference angles, coil off and at ±nominal: the linear solve against the
    saturating one (the linear line up to where it meets the B–H curve, the curve beyond)."""
    design, coil = prototype(), iron_coil()
    angles = np.array([2.0, 5.0, 8.0, 12.0, 20.0])
    det, lin = ironforce.pair_tables(design, coil, np.radians(angles), level)
    rows = []
    for a, d, li in zip(angles, det, lin):
        for c in (0.0, 1.0, -1.0):
            t0 = time.perf_counter()
            tau, peak, iterations = ironforce.saturated_pair_torque(design, coil, np.radians(a), c, level)
            rows.append([a, c, d + c * li, tau, peak, iterations, time.perf_counter() - t0])
            print(rows[-1], flush=True)
    _write(DATA / "iron_saturation.csv",
           f"One +1 pole and one iron coil (MoM level {level}): torque (N m, about the centre, positive away from the "
           f"axis) of the linear solve and of the saturating one (spherestep.magnetics._ironforce.saturated_pair_torque: "
           f"mu_r = {coil.material.relative_permeability:g} up to "
           f"{iron.saturation_onset(coil.material, coil.material.relative_permeability):.0f} A/m, then the B-H curve "
           f"of {coil.material.name}), the largest |B| in a cell, iterations, seconds.\nProduced by: python "
           f"scripts/iron_tables.py saturation",
           ["alpha_deg", "current", "linear_Nm", "saturated_Nm", "max_B_T", "iterations", "solve_s"], np.array(rows))


def fig6(level: int = iron.IRON_LEVEL) -> None:
    design, coil = prototype(), iron_coil()
    x = np.arange(0.0, 0.0605, 0.0025)
    Fd, Fl = ironforce.fig6_forces(design, coil, x, level=level)
    g = design.radius + design.air_gap - iron.magnet_face_radius(design)
    _write(DATA / "iron_fig6.csv",
           f"Fig. 6 with the iron core (MoM level {level}): one +1 magnet translated by x at a {1e3 * g:.3f} mm face "
           f"gap; force on the magnet (N), detent (coil off) and linear (per nominal current).\nProduced by: "
           f"python scripts/iron_tables.py fig6",
           ["x_m", "detent_Fx_N", "detent_Fz_N", "linear_Fx_N", "linear_Fz_N"],
           np.c_[x, Fd[:, 0], Fd[:, 2], Fl[:, 0], Fl[:, 2]])


def everything() -> None:
    """table, fig6 and multibody in one process (the core is factorised once per level)."""
    table()
    fig6()
    multibody(iron.IRON_LEVEL)


if __name__ == "__main__":
    what = sys.argv[1] if len(sys.argv) > 1 else "all"
    {"all": everything, "table": table, "fem-table": fem_table, "convergence": convergence, "multibody": multibody,
     "coupling": coupling, "coupling-table": coupling_table, "coupling-effects": coupling_effects,
     "saturation": saturation, "fig6": fig6,
     "flux": flux}[what]()
