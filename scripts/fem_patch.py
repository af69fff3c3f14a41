"""Whole-motor reference (issue 28 §1): a stator patch of four iron cores under the rotor magnets within reach,
3-D FEM with NGSolve, linear iron and the B–H curve; and the package's iron model on the same cases.

    OPENBLAS_NUM_THREADS=1 nice -n 19 python scripts/fem_patch.py --quick     # one coarse case (minutes), printed
    OPENBLAS_NUM_THREADS=1 nohup nice -n 19 python scripts/fem_patch.py > fem_patch.log 2>&1 &
        # every case missing from data/iron_fem_patch.csv, appended row by row (a stopped run keeps its rows)
    ... scripts/fem_patch.py --cases 0 27   and   ... --cases 27 54     # a range of case indices, to share work
    ... scripts/fem_patch.py --cases 30 78 --orientations 0 1 2 3       # or the orientations (a mesh each)
    python scripts/fem_patch.py --list          # the cases
    python scripts/fem_patch.py --compare       # the iron model (pairwise, coupled) against the stored rows
    python scripts/fem_patch.py --scale 1.5     # the scaling law by the FEM (one orientation, printed)

Geometry (the stator frame, sphere's centre at the origin). The patch is coil 0 and its three nearest neighbours
(coils 0, 1, 8, 28 of ``prototype()``; 24.9°–25.6° apart, 1 and 8 43.9°), each a pot core of
``_iron.CoreGeometry.of(design, coil)`` along its axis ``v_k``, face at ``R_s + g``. The rotor magnets included at
an orientation ``R`` are those whose direction ``w_j = R u_j`` lies within :data:`REACH_DEG` of a patch coil's axis
(the coil's angular radius 9.5° + the magnet's 4.8° + 10.7° margin: the pair torque there is < 3 % of its peak),
each a cylinder with its outer face at ``_iron.magnet_face_radius`` (as in the pair tables), magnetisation
``p_j B_r/μ0 w_j``. Outer boundary ψ = 0 on a sphere of 0.3 m about the patch's centre.

Formulation: that of ``scripts/fem_iron.py`` for several cores and magnets — total scalar potential ψ (H1, order 2),
``H = T0 − ∇ψ`` with one current vector potential ``T0_k = c_k NI/d (profile in r_k) v_k`` per energised coil in its
own frame (``0 ≤ z_k ≤ d``). Linear iron (μr of ``design.coil.material``): ``∫ μr ∇ψ·∇v = ∫ μr T0·∇v +
Σ_j ∫_j M_j·∇v``, one factorisation per orientation for the three current cases. B–H: the co-energy
``∫_iron w*(|H|)/μ0 + ∫_rest |H|²/2 + Σ_j ∫_j M_j·H``, ``w*(H) = ∫_0^H B(h) dh``, minimised by Newton with line
search (``ngsolve.solvers.NewtonMinimization``) from the linear solution; ``B(H)`` is the curve ``_iron``'s
saturation check uses (``CoreSolver.saturated_polarization``): the linear line ``μ0 μr H`` up to
``_iron.saturation_onset``, the material's normal curve beyond, so only saturation differs from the linear solve.
Torque on the rotor about the centre: ``Σ_j Σ σ (x × B_ext) dA`` over the included magnets' face charges
(``_iron.magnet_faces``, ``charge_wrench``), ``B_ext`` = the solve minus the same mesh with no iron and no
current (the magnets' own field and its discretisation error cancel; magnet–magnet forces are internal). The
solver is ``scripts/fem_patch_solver.py`` (imported beside this script when a case is solved).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from spherestep.magnetics import _iron as iron
from spherestep.magnetics import TorqueMap, iron_model
from spherestep.motor import prototype

DATA = Path(__file__).resolve().parents[1] / "data"
OUT = DATA / "iron_fem_patch.csv"
SEED = 28
REACH_DEG = 25.0  # magnets within this of a patch coil's axis are meshed
STATES = 4  # stepper states in the patch; as many intermediate orientations
TILT_DEG = 8.0  # an intermediate orientation: a state turned by this about a random axis
MAXH = 2.5e-3  # m: the face mesh of every case
MAXH_FINE = 2.0e-3  # m: the convergence check's face mesh (1.8 mm would need ~18 GB)
OUTER = 0.3  # m: radius of the ψ = 0 sphere about the patch's centre
MAXH_BH = 4.0e-3  # m: the face mesh of the B–H cases and of their linear twins (1.6 GB, ~1 min a case)
OUTER_BH = 0.15  # m: their ψ = 0 sphere (the 2.5 mm mesh in the 0.3 m box took ~7 GB per B–H solve)
COLUMNS = ("case", "orientation", "kind", "qx", "qy", "qz", "qw", "coils", "currents", "magnets", "material",
           "maxh_face_m", "elements", "torque_x_Nm", "torque_y_Nm", "torque_z_Nm", "newton_steps", "mesh_s",
           "solve_s")
HEADER = ("# NGSolve 3-D FEM (total scalar potential, order 2) of a stator patch of four iron-cored coils of the "
          "prototype under the rotor magnets within 25 deg of them (scripts/fem_patch.py).\n"
          "# Torque on the rotor about the sphere's centre (N m, stator frame); orientation R as a quaternion "
          "(x, y, z, w; scipy); coils: stator indices; currents per nominal (nominal_ampere_turns); magnets: rotor "
          "indices included; material linear (mu_r) or bh (B-H curve); maxh_face the mesh at the core faces (m); "
          "times wall-clock (s): mesh (with the air solve) and this case's solve.\n" + ",".join(COLUMNS) + "\n")


@dataclass(frozen=True)
class Case:
    """One FEM case: orientation ``R`` (label ``orientation``, ``kind`` state/intermediate), ``currents`` on the
    patch ``coils`` (per nominal), ``material`` ("linear" or "bh"), face mesh ``maxh`` (m)."""

    index: int
    orientation: int
    kind: str
    R: np.ndarray
    coils: tuple
    currents: tuple
    material: str
    maxh: float


def patch_coils(design) -> tuple:
    """Coil 0 and its three nearest neighbours (stator indices, sorted by angle from coil 0)."""
    v = design.stator.centers
    return tuple(int(k) for k in np.argsort(-(v @ v[0]))[:4])


# The eight orientations of the stored solves as scipy quaternions (x, y, z, w): four stepper states holding only
# patch coils, drawn at random (seed SEED) on 2026-11-25, then each turned by TILT_DEG about a random axis. Frozen
# here because that draw named the states by their index, which the CPU's BLAS kernel decided then (issue 35); each
# state is found again among ``design.states()`` by its rotation, which no numbering changes.
STATE_QUATERNIONS = (
    (0.122140152603, 0.884396556799, -0.361091825166, 0.269327323608),
    (-0.0747214466668, 0.984688349294, -0.10024439424, -0.121476835637),
    (-0.514451857489, -0.115443110477, 0.53584083058, 0.659459459598),
    (-0.0403614303491, 0.784752649358, 0.612314369607, 0.0872086408436),
)
TILTED_QUATERNIONS = (
    (0.10411869227, 0.907613629008, -0.350078234286, 0.206983159312),
    (-0.0454266919988, 0.975287690648, -0.156362407552, -0.149335640856),
    (-0.482435628882, -0.176776922086, 0.544298459179, 0.66313269497),
    (0.00932666635933, 0.810918240547, 0.582122564704, 0.0588042524445),
)


def orientations(design, coils):
    """The ``STATES`` stored stepper states (:data:`STATE_QUATERNIONS`, each a state of ``design`` holding ≥ 2 coils,
    all in the patch) and their intermediate orientations (:data:`TILTED_QUATERNIONS`, the state turned by
    ``TILT_DEG``): a list of ``(R, kind, currents on the patch)`` — the intermediate one carries its state's
    currents."""
    states = design.states()
    patch = set(coils)
    out, tilted = [], []
    for q, q_tilt in zip(STATE_QUATERNIONS, TILTED_QUATERNIONS):
        R = Rotation.from_quat(q).as_matrix()
        i = int(np.argmin(np.abs(states.rotations - R).max(axis=(1, 2))))
        held = states.coils(i)
        if np.abs(states.rotations[i] - R).max() > 1e-9 or len(held) < 2 or not set(held) <= patch:
            raise ValueError(f"orientation {q} is not a state of the design holding only patch coils {coils}")
        c = tuple(float(held.get(k, 0)) for k in coils)
        out.append((R, "state", c))
        turned = Rotation.from_quat(q_tilt).as_matrix()
        if not math.isclose(math.degrees(Rotation.from_matrix(turned @ R.T).magnitude()), TILT_DEG, abs_tol=1e-6):
            raise ValueError(f"intermediate orientation {q_tilt} is not its state turned by {TILT_DEG} deg")
        tilted.append((turned, "intermediate", c))
    return out + tilted


def current_cases(c):
    """Coils off, the state's coils, the state's coils with the first energised one reversed."""
    c = np.asarray(c, dtype=float)
    rev = c.copy()
    rev[np.flatnonzero(c)[0]] *= -1.0
    return [tuple(float(v) + 0.0 for v in a) for a in (0.0 * c, c, rev)]  # + 0.0: no −0


def outer_radius(maxh: float) -> float:
    """The ψ = 0 sphere's radius (m) of the cases at face mesh ``maxh``: ``OUTER_BH`` for ``MAXH_BH``, else
    ``OUTER``."""
    return OUTER_BH if math.isclose(maxh, MAXH_BH) else OUTER


def all_cases(design=None) -> list[Case]:
    """Linear iron at ``MAXH`` (8 orientations × 3 currents), the convergence check (linear, ``MAXH_FINE``, at
    orientations 0 and 4: a state and an intermediate one), the B–H curve at ``MAXH_BH`` in the ``OUTER_BH`` box
    (8 × 3), and the linear iron on that same mesh (8 × 3; the B–H rows' mesh check against the ``MAXH`` rows and
    their linear twins): 78 cases; the B–H case and its linear twin share a mesh."""
    design = prototype() if design is None else design
    coils = patch_coils(design)
    orient = orientations(design, coils)
    runs = [(o, "linear", MAXH) for o in range(len(orient))] + [(o, "linear", MAXH_FINE) for o in (0, STATES)]
    runs += [(o, "bh", MAXH_BH) for o in range(len(orient))]
    runs += [(o, "linear", MAXH_BH) for o in range(len(orient))]
    out = []
    for o, material, h in runs:
        R, kind, c = orient[o]
        for cur in current_cases(c):
            out.append(Case(len(out), o, kind, R, coils, cur, material, h))
    return out


def included_magnets(design, R, coils) -> np.ndarray:
    """Rotor indices of the magnets within ``REACH_DEG`` of a patch coil's axis at ``R``."""
    w = design.rotor.centers @ np.asarray(R).T
    v = design.stator.centers[list(coils)]
    return np.flatnonzero(np.max(w @ v.T, axis=1) >= math.cos(math.radians(REACH_DEG)))


def scale_check(s: float) -> None:
    """The scaling law by the FEM (issue 28 §3): case 0's orientation (coils off, the state's currents) of the
    prototype and of the prototype with every length ×``s`` (``_ironscale.scaled_design``), each on the mesh of
    ``MAXH_BH`` × its scale in the ``OUTER_BH`` box × its scale; prints the torque ratios (the law: ``s³`` coils
    off; ``s² NI'/NI`` for the winding's part)."""
    from ngsolve import SetNumThreads

    from spherestep.magnetics import scaled_design

    SetNumThreads(1)
    base = prototype()
    case = all_cases(base)[1]
    out = []
    for k, d in enumerate((base, scaled_design(base, s))):
        k_s = 1.0 if k == 0 else s
        mags = included_magnets(d, case.R, case.coils)
        from fem_patch_solver import PatchSolver  # beside this script: NGSolve loads only here

        solver = PatchSolver(d, case.R, case.coils, mags, MAXH_BH * k_s, OUTER_BH * k_s, k_s)
        (T0, _, _), (T1, _, _) = solver.solve_linear([np.zeros(len(case.coils)), case.currents])
        ni = iron.CoreGeometry.of(d, d.coil).NI
        out.append((T0, T1 - T0, ni))
        print(f"scale {k_s:g}: {solver.mesh.ne} tetrahedra, coils off {np.round(T0, 5)} N m, winding's part "
              f"{np.round(T1 - T0, 5)} N m, NI {ni:.2f}", flush=True)
    (a0, w0, n0), (a1, w1, n1) = out
    law_w = s * s * n1 / n0
    print(f"coils off: T(s) / T(1) = {np.linalg.norm(a1) / np.linalg.norm(a0):.5f} (law s^3 = {s ** 3:.5f}), "
          f"|T(s) - s^3 T(1)| / |s^3 T(1)| = {np.linalg.norm(a1 - s ** 3 * a0) / np.linalg.norm(s ** 3 * a0):.2%}; "
          f"winding's part: ratio {np.linalg.norm(w1) / np.linalg.norm(w0):.5f} (law s^2 NI'/NI = {law_w:.5f}), "
          f"off by {np.linalg.norm(w1 - law_w * w0) / np.linalg.norm(law_w * w0):.2%}")


def _fmt(values) -> str:
    return ";".join(f"{v:g}" for v in values)


def run(cases, out: Path | None = OUT) -> list[str]:
    """Solve ``cases`` (consecutive ones sharing a mesh are solved on it), appending a row per case to ``out``
    (one ``write`` per complete line) and returning the rows."""
    from ngsolve import SetNumThreads

    SetNumThreads(1)
    design = prototype()
    material = design.coil.material
    rows = []
    groups = {}
    for c in sorted(cases, key=lambda c: c.material != "linear"):  # on a mesh, the linear cases first
        groups.setdefault((c.orientation, c.maxh), []).append(c)
    if out is not None and not out.exists():
        out.write_text(HEADER)
    for (o, h), group in groups.items():
        mags = included_magnets(design, group[0].R, group[0].coils)
        from fem_patch_solver import PatchSolver  # beside this script: NGSolve loads only here

        solver = PatchSolver(design, group[0].R, group[0].coils, mags, h, outer_radius(h))
        print(f"orientation {o} ({group[0].kind}), {len(mags)} magnets, maxh {h * 1e3:g} mm: "
              f"{solver.mesh.ne} tetrahedra, {solver.mesh_s:.0f} s", flush=True)
        lin = [c for c in group if c.material == "linear"]
        for c, result in zip(lin, solver.solve_linear([c.currents for c in lin])):
            _store(c, mags, solver, result, rows, out)
        for c in group:
            if c.material == "bh":
                _store(c, mags, solver, solver.solve_bh(c.currents, material), rows, out)
    return rows


def _store(c: Case, mags, solver,  result, rows: list, out: Path | None) -> None:
    """Print the row of case ``c`` and append it to ``out`` (one ``write`` of a complete line, synced)."""
    T, steps, dt = result
    q = Rotation.from_matrix(c.R).as_quat()
    row = [str(c.index), str(c.orientation), c.kind, *(f"{v:.12g}" for v in q), _fmt(c.coils),
           _fmt(c.currents), _fmt(mags), c.material, f"{c.maxh:g}", str(solver.mesh.ne),
           *(f"{v:.9g}" for v in T), str(steps), f"{solver.mesh_s:.1f}", f"{dt:.1f}"]
    line = ",".join(row) + "\n"
    print(line, end="", flush=True)
    rows.append(line)
    if out is not None:
        with open(out, "a") as fh:
            fh.write(line)
            fh.flush()
            os.fsync(fh.fileno())


# ---------------------------------------------------------------------------------------------------- the model


def read_rows(path: Path = OUT) -> list[dict]:
    """The stored rows (dicts of the columns; arrays for coils, currents, magnets, the torque); the last row of
    a case index wins."""
    if not path.exists():
        return []
    lines = [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")]
    if not lines:
        return []
    rows = {}
    for ln in lines[1:]:
        r = dict(zip(COLUMNS, ln.split(",")))
        if len(r) != len(COLUMNS):
            continue  # an incomplete line
        r["R"] = Rotation.from_quat([float(r[k]) for k in ("qx", "qy", "qz", "qw")]).as_matrix()
        for k in ("coils", "magnets"):
            r[k] = np.array([int(float(v)) for v in r[k].split(";")])
        r["currents"] = np.array([float(v) for v in r["currents"].split(";")])
        r["torque"] = np.array([float(r[k]) for k in ("torque_x_Nm", "torque_y_Nm", "torque_z_Nm")])
        r["maxh"] = float(r["maxh_face_m"])
        rows[int(r["case"])] = r
    return [rows[k] for k in sorted(rows)]


def model_torque(model, R, coils, currents, magnets) -> np.ndarray:
    """The iron model's torque (N·m) restricted to the rotor poles ``magnets`` and the cores ``coils`` (the same
    pair tables, polarities and — if the model has it — coupling terms, over these poles and cores only)."""
    mags = np.asarray(magnets, dtype=int)
    idx = np.asarray(coils, dtype=int)

    def cut(m: TorqueMap, polarity):
        return TorqueMap(m.poles[mags], polarity, m.coils[idx], (), m.nodes, m.tau, m.meshing)

    coupling = model.coupling
    if coupling is not None:
        where = -np.ones(len(coupling.poles), dtype=int)
        where[mags] = np.arange(len(mags))
        keep = (where[coupling.pairs] >= 0).all(axis=1)
        coupling = replace(coupling, poles=coupling.poles[mags], polarity=coupling.polarity[mags],
                           coils=coupling.coils[idx], pairs=where[coupling.pairs[keep]])
    sub = type(model)(cut(model.detent, model.detent.polarity[mags]), cut(model.linear, model.linear.polarity[mags]),
                      model.coil, coupling)
    return sub.exact_torque(R, np.asarray(currents, dtype=float))  # the sums (the tables are for every pole)


@dataclass(frozen=True)
class Comparison:
    """The model against the FEM rows: per row ``|T_model − T_fem| / max_rows |T_fem|`` (vector norms), pairwise
    and coupled; ``peak`` the FEM's largest torque (N·m) over the rows compared."""

    rows: list
    pairwise: np.ndarray
    coupled: np.ndarray
    fem: np.ndarray
    model_pairwise: np.ndarray
    model_coupled: np.ndarray
    peak: float

    def to_dict(self, degrees: bool = True) -> dict:
        return {"cases": [int(r["case"]) for r in self.rows], "peak_Nm": self.peak,
                "pairwise_max": float(self.pairwise.max()), "pairwise_median": float(np.median(self.pairwise)),
                "coupled_max": float(self.coupled.max()), "coupled_median": float(np.median(self.coupled))}


def compare(rows, material: str = "linear", maxh: float | None = None, design=None) -> Comparison | None:
    """The iron model (pairwise and with coupling) against the stored rows of ``material`` at face mesh ``maxh``
    (default ``MAXH``; for the B–H curve by default its rows carried to the ``MAXH`` mesh,
    :func:`saturated_reference`); the error of each row as a fraction of the FEM's largest torque over those
    rows."""
    if material == "bh" and maxh is None:
        pairs = saturated_reference(rows)
        rows, fem = [r for r, _ in pairs], np.array([T for _, T in pairs])
    else:
        maxh = MAXH if maxh is None else maxh
        rows = [r for r in rows if r["material"] == material and math.isclose(r["maxh"], maxh)]
        fem = np.array([r["torque"] for r in rows])
    if not rows:
        return None
    design = prototype() if design is None else design
    models = iron_model(design), iron_model(design, coupling=True)
    got = [np.array([model_torque(m, r["R"], r["coils"], r["currents"], r["magnets"]) for r in rows])
           for m in models]
    peak = float(np.linalg.norm(fem, axis=1).max())
    err = [np.linalg.norm(g - fem, axis=1) / peak for g in got]
    return Comparison(rows, err[0], err[1], fem, got[0], got[1], peak)


def report(rows) -> None:
    """Print the comparison table for both materials and the mesh-convergence rows."""
    for material, maxh in (("linear", MAXH), ("linear", MAXH_BH), ("bh", MAXH_BH), ("bh", None)):
        cmp_ = compare(rows, material, maxh)
        if cmp_ is None:
            continue
        mesh = f"face mesh {maxh * 1e3:g} mm" if maxh else f"carried to the {MAXH * 1e3:g} mm rows"
        print(f"\n{material} iron, {mesh}: FEM peak |T| = {cmp_.peak:.3f} N m")
        print("case orient kind         currents       |T_fem|  T_fem (x, y, z)           "
              "pairwise |dT|/peak (N m)  coupled |dT|/peak (N m)")
        for r, f, e1, e2 in zip(cmp_.rows, cmp_.fem, cmp_.pairwise, cmp_.coupled):
            print(f"{r['case']:>4} {r['orientation']:>6} {r['kind']:<12} {_fmt(r['currents']):<14} "
                  f"{np.linalg.norm(f):7.3f}  ({f[0]:+.3f}, {f[1]:+.3f}, {f[2]:+.3f})   {100 * e1:5.1f} % "
                  f"({e1 * cmp_.peak:.3f})      {100 * e2:5.1f} % ({e2 * cmp_.peak:.3f})")
        print(f"error / peak: pairwise max {100 * cmp_.pairwise.max():.1f} %, median "
              f"{100 * np.median(cmp_.pairwise):.1f} %; coupled max {100 * cmp_.coupled.max():.1f} %, median "
              f"{100 * np.median(cmp_.coupled):.1f} %")
    def by_case(material, maxh):
        return {(r["orientation"], _fmt(r["currents"])): r for r in rows
                if r["material"] == material and math.isclose(r["maxh"], maxh)}

    base = by_case("linear", MAXH)
    peak = max((np.linalg.norm(r["torque"]) for r in base.values()), default=0.0)
    for other, label in ((by_case("linear", MAXH_FINE), "finer"), (by_case("linear", MAXH_BH), "the B-H rows'")):
        both = sorted(set(other) & set(base))
        if not both:
            continue
        h = other[both[0]]["maxh"]
        d = [np.linalg.norm(other[k]["torque"] - base[k]["torque"]) / peak for k in both]
        print(f"\nmesh check, {label} mesh ({MAXH * 1e3:g} -> {h * 1e3:g} mm, box {outer_radius(h):g} m), "
              f"|dT| / peak: max {100 * max(d):.2f} %, median {100 * np.median(d):.2f} % over {len(both)} cases")
        for k, dk in zip(both, d):
            print(f"  orientation {k[0]}, currents {k[1]}: {base[k]['elements']} -> {other[k]['elements']} "
                  f"tetrahedra, {100 * dk:.2f} %")
    sat, twin = by_case("bh", MAXH_BH), by_case("linear", MAXH_BH)
    both = sorted(set(sat) & set(twin))
    if both:
        d = [np.linalg.norm(sat[k]["torque"] - twin[k]["torque"]) / peak for k in both]
        print(f"\nB-H against linear (same {MAXH_BH * 1e3:g} mm mesh), |dT| / peak: max {100 * max(d):.2f} %, "
              f"median {100 * np.median(d):.2f} % over {len(both)} cases")
        for k, dk in zip(both, d):
            print(f"  orientation {k[0]}, currents {k[1]}: |T_lin| {np.linalg.norm(twin[k]['torque']):.3f}, "
                  f"|T_bh| {np.linalg.norm(sat[k]['torque']):.3f} N m, {100 * dk:.2f} %")
    ref = saturated_reference(rows)
    if ref:
        design = prototype()
        models = iron_model(design), iron_model(design, coupling=True)
        errs = {name: [np.linalg.norm(model_torque(m, r["R"], r["coils"], r["currents"], r["magnets"]) - T) / peak
                       for r, T in ref] for name, m in zip(("pairwise", "coupled"), models)}
        print(f"\nthe model against the B-H reference on the {MAXH * 1e3:g} mm rows (T_lin({MAXH * 1e3:g} mm) + "
              f"T_bh - T_lin on the B-H mesh), |dT| / {peak:.2f} N m: " + "; ".join(
                  f"{k} max {100 * max(v):.1f} %, median {100 * np.median(v):.1f} %" for k, v in errs.items())
              + f" over {len(ref)} cases")


def saturated_reference(rows) -> list:
    """``[(row, T)]``: each B–H row with its torque carried to the ``MAXH`` mesh, ``T = T_lin(MAXH) + T_bh −
    T_lin(MAXH_BH)`` (the saturation's change on the fine linear solve: the coarse mesh's error cancels in the
    difference), for the cases whose three rows are stored."""
    def key(r):
        return r["orientation"], _fmt(r["currents"])

    fine = {key(r): r for r in rows if r["material"] == "linear" and math.isclose(r["maxh"], MAXH)}
    twin = {key(r): r for r in rows if r["material"] == "linear" and math.isclose(r["maxh"], MAXH_BH)}
    return [(r, fine[key(r)]["torque"] + r["torque"] - twin[key(r)]["torque"]) for r in rows
            if r["material"] == "bh" and key(r) in fine and key(r) in twin]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one coarse case (4 mm face mesh), printed, not stored")
    ap.add_argument("--cases", nargs=2, type=int, metavar=("FIRST", "STOP"), help="case indices FIRST..STOP-1")
    ap.add_argument("--orientations", nargs="+", type=int, metavar="O", help="only the cases at these orientations")
    ap.add_argument("--scale", type=float, metavar="S", help="the scaling law by the FEM: the prototype x S")
    ap.add_argument("--list", action="store_true", help="print the cases")
    ap.add_argument("--compare", action="store_true", help="the iron model against the stored rows")
    ap.add_argument("--redo", action="store_true", help="solve cases already stored too")
    args = ap.parse_args(argv)
    if args.compare:
        report(read_rows())
        return
    if args.scale:
        scale_check(args.scale)
        return
    cases = all_cases()
    if args.list:
        for c in cases:
            q = Rotation.from_matrix(c.R).as_quat()
            print(c.index, c.orientation, c.kind, np.round(q, 4), c.coils, c.currents, c.material, c.maxh)
        return
    if args.quick:
        run([replace(cases[1], maxh=4e-3)], out=None)
        return
    if args.cases:
        cases = cases[args.cases[0]:args.cases[1]]
    if args.orientations:
        cases = [c for c in cases if c.orientation in args.orientations]
    if not args.redo:
        done = {int(r["case"]) for r in read_rows()}
        cases = [c for c in cases if c.index not in done]
    run(cases)


if __name__ == "__main__":
    main(sys.argv[1:])
