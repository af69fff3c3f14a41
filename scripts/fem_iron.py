"""Independent 3-D finite-element check of the iron pair torques with NGSolve (total scalar potential).

    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/fem_iron.py            # data/iron_fem.csv (~10-20 min)
    OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/fem_iron.py --quick    # 8° at 2, 1.4, 1 mm: data/iron_fem_8.csv
    ... scripts/fem_iron.py --angles 12 20   then   scripts/fem_iron.py --merge   # a share of the angles in parallel
    ... scripts/fem_iron.py --maxh 0.0014 --angles 12 2; scripts/fem_iron.py --merge  # convergence at more angles
    ... scripts/fem_iron.py --table 0 2 & scripts/fem_iron.py --table 1 2; scripts/fem_iron.py --merge
        # the pair tables' FEM nodes (1°…20° and 1.5°, 2.5°, 3.5°, but not the reference angles) in 2 shares:
        # data/iron_fem_table.csv; --table-angles A B ... solves the given angles only
    ... scripts/fem_iron.py --shape        # the shape table's 5 held-out magnets: data/iron_fem_shape.csv
        # (the prototype's 5°, 12.5°, 3°, ... stretched to each magnet, one pass per angle, resumable;
        # 2.6-7 min a point at load 8-12, ~1 min on a quiet core)
    ... scripts/fem_iron.py --shape-grid   # the shape table's 8 other grid nodes at 18 angles up to 20° (stretched):
        # data/iron_fem_shape_grid.csv, for scripts/iron_shape_table.py --write (144 points)

Formulation (coil frame: axis z, core face at z = 0, body z > 0). The field is ``H = T0 − ∇ψ`` with a
total scalar potential ψ (H1, order 2, ψ = 0 on a sphere of 0.2 m) and two sources that need no field from
outside: the rotor magnet as a uniform magnetisation ``M = B_r/μ0`` in its own meshed cylinder, and the winding
as a current vector potential ``T0`` (curl T0 = J, uniform J in the groove): ``T0 = ẑ NI/d`` inside the groove's
inner radius, falling linearly to 0 across the groove, for ``0 ≤ z ≤ d``. Weak form, with μ = μ0 μr in the iron:

    ∫ μ ∇ψ·∇v = ∫ μ T0·∇v + ∫_magnet μ0 M·∇v.

Force on the magnet: its end faces carry magnetic charge ``σ = ±M`` and ``F = ∮ σ B_ext dA``,
``T = ∮ σ (x − x0) × B_ext dA`` with ``B_ext`` the field of everything but the magnet: the iron solve minus the
same mesh solved without iron and coil (the magnet's self-field and its discretisation error cancel). The linear
part is the coil-on solve minus the coil-off solve. The MoM model (``spherestep.magnetics._iron``) shares only
the geometry with this.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
from netgen.occ import Cylinder, Dir, Glue, OCCGeometry, Pnt, Sphere
from ngsolve import (BilinearForm, CoefficientFunction, GridFunction, H1, IfPos, LinearForm, Mesh, TaskManager,
                     dx, grad, sqrt, x, y, z)

from spherestep.magnetics import _iron as iron
from spherestep.motor import prototype
from spherestep.motor.coil import iron_coil

MU0 = 4e-7 * math.pi
DATA = Path(__file__).resolve().parents[1] / "data"


def build_mesh(design, coil, alpha: float, maxh_face: float):
    g = iron.CoreGeometry.of(design, coil)
    face = design.radius + design.air_gap
    pole_lo = Cylinder(Pnt(0, 0, 0), Dir(0, 0, 1), g.r_p, g.depth)
    pole_hi = Cylinder(Pnt(0, 0, g.depth), Dir(0, 0, 1), g.r_p, g.L - g.depth)
    wall = Cylinder(Pnt(0, 0, 0), Dir(0, 0, 1), g.R, g.depth) - Cylinder(Pnt(0, 0, 0), Dir(0, 0, 1), g.r_w, g.depth)
    back = Cylinder(Pnt(0, 0, g.depth), Dir(0, 0, 1), g.R, g.L - g.depth) - pole_hi
    groove = Cylinder(Pnt(0, 0, 0), Dir(0, 0, 1), g.r_w, g.depth) - pole_lo
    w = np.array([math.sin(alpha), 0.0, math.cos(alpha)])
    r_face = iron.magnet_face_radius(design)
    base = (r_face - design.magnet_length) * w - [0.0, 0.0, face]
    magnet = Cylinder(Pnt(*base), Dir(*w), 0.5 * design.magnet_diameter, design.magnet_length)
    parts = [pole_lo, pole_hi, wall, back]
    for p in parts:
        p.mat("iron")
        p.maxh = 2.5 * maxh_face
    for f in pole_lo.faces + wall.faces:
        f.maxh = maxh_face
    groove.mat("winding")
    magnet.mat("magnet")
    magnet.maxh = 1.5 * maxh_face
    outer = Sphere(Pnt(0, 0, 0), 0.2)
    outer.faces.name = "outer"
    air = outer - pole_lo - pole_hi - wall - back - groove - magnet
    air.mat("air")
    shape = Glue([air, *parts, groove, magnet])
    mesh = Mesh(OCCGeometry(shape).GenerateMesh(maxh=0.04, grading=0.25))
    return mesh, g, base, w


def solve(mesh, g, w, design, mu_r: float, sources=("magnet", "coil"), order: int = 2):
    """ψ for each of ``sources`` alone ("magnet": the rotor magnet; "coil": the winding at its nominal current)
    with iron of ``mu_r``: one assembly and factorisation, one back-substitution per source."""
    fes = H1(mesh, order=order, dirichlet="outer")
    psi, v = fes.TnT()
    mu = mesh.MaterialCF({"iron": mu_r}, default=1.0)
    a = BilinearForm(fes, symmetric=True)
    a += mu * grad(psi) * grad(v) * dx
    a.Assemble()
    with TaskManager():
        inv = a.mat.Inverse(fes.FreeDofs(), inverse="sparsecholesky")
    out = []
    for source in sources:
        f = LinearForm(fes)
        if source == "magnet":
            M = design.remanence / MU0 * CoefficientFunction(tuple(w))
            f += M * grad(v) * dx(definedon=mesh.Materials("magnet"))
        else:
            r = sqrt(x * x + y * y)
            t0 = g.NI / g.depth * IfPos(g.r_p - r, 1.0, IfPos(g.r_w - r, (g.r_w - r) / (g.r_w - g.r_p), 0.0))
            T0 = CoefficientFunction((0.0, 0.0, t0 * IfPos(z, IfPos(g.depth - z, 1.0, 0.0), 0.0)))
            f += mu * T0 * grad(v) * dx(definedon=mesh.Materials("iron|winding"))
        f.Assemble()
        gfu = GridFunction(fes)
        with TaskManager():
            gfu.vec.data = inv * f.vec
        out.append(gfu)
    return out


def field_at(mesh, gfu, pts):
    """μ0 (−∇ψ) at points (the T0 and M terms cancel in the differences taken below)."""
    G = grad(gfu)(mesh(pts[:, 0], pts[:, 1], pts[:, 2]))
    return -MU0 * np.asarray(G).reshape(-1, 3)


def pair(design, coil, alpha: float, maxh_face: float):
    t0 = time.perf_counter()
    mesh, g, base, w = build_mesh(design, coil, alpha, maxh_face)
    t1 = time.perf_counter()
    face = design.radius + design.air_gap
    centre = base + 0.5 * design.magnet_length * w
    pts, q = iron.magnet_faces(centre, w, design.magnet_diameter, design.magnet_length, design.remanence)
    inward = np.where(q > 0, -1.0, 1.0)[:, None] * w * 1e-7  # a hair inside the magnet, same element side
    pts = pts + inward
    pivot = np.array([0.0, 0.0, -face])
    iron_magnet, iron_coil_ = solve(mesh, g, w, design, g.mu_r, ("magnet", "coil"))
    (air_magnet,) = solve(mesh, g, w, design, 1.0, ("magnet",))
    B = {key: field_at(mesh, gfu, pts) for key, gfu in
         (("iron", iron_magnet), ("coil", iron_coil_), ("air", air_magnet))}
    t2 = time.perf_counter()
    det = iron.charge_wrench(pts, q, B["iron"] - B["air"], pivot)[1][1]
    lin = iron.charge_wrench(pts, q, B["coil"], pivot)[1][1]
    return det, lin, mesh.ne, t1 - t0, (t2 - t1) / 2


REFERENCE_DEG = (2.0, 5.0, 8.0, 12.0, 20.0)  # data/iron_fem.csv: held out of the tables, they check them
TABLE_DEG = tuple(sorted({1.5, 2.5, 3.5} | {float(a) for a in range(1, 21)} - set(REFERENCE_DEG)))  # the FEM nodes
HEADER = ("# NGSolve 3-D FEM (total scalar potential, order 2) of one +1 rotor magnet and one iron-cored coil of the "
          "prototype (scripts/fem_iron.py).\n# Torque about the sphere's centre (N m), positive away from the axis; "
          "linear per nominal current (the -nominal case is detent - linear: the problem is linear); maxh_face the "
          "mesh size at the core's face (m); times wall-clock (s) per mesh and per solve.\n"
          "alpha_deg,maxh_face_m,elements,detent_Nm,linear_Nm,mesh_s,solve_s\n")


def main(quick: bool = False, angles=None, maxh: float | None = None):
    if quick:  # the mesh convergence alone, merged into data/iron_fem.csv with --merge
        angles, sizes = [8.0], (2.0e-3, 1.4e-3, 1.0e-3)
    else:
        sizes = (maxh,) if maxh else (2.0e-3,) if angles else (2.0e-3, 1.4e-3, 1.0e-3)
    if angles:  # a share of the angles, for running in parallel: data/iron_fem_<angles>.csv, merge with --merge
        runs = [(a, h) for a in angles for h in sizes]
        out = DATA / ("iron_fem_" + "_".join(f"{a:g}" for a in angles) + ".csv")
    else:
        runs = [(a, 2.0e-3) for a in (8.0, 2.0, 5.0, 12.0, 20.0)] + [(8.0, h) for h in sizes[1:]]
        out = DATA / "iron_fem.csv"
    solve_pairs(runs, out)


def table(angles):
    """FEM pair torques at ``angles`` (degrees; 2 mm face mesh): data/iron_fem_table_<first angle>.csv, merged
    into data/iron_fem_table.csv by ``--merge``."""
    solve_pairs([(a, 2.0e-3) for a in angles], DATA / f"iron_fem_table_{angles[0]:g}.csv")


def solve_pairs(runs, out: Path) -> None:
    """Pair torques at each ``(angle in degrees, face mesh size in m)`` of ``runs``, written to ``out`` (CSV,
    rewritten after every solve, so a stopped run keeps what it finished)."""
    design, coil = prototype(), iron_coil()
    rows = []
    for a, h in runs:
        det, lin, ne, tm, ts = pair(design, coil, math.radians(a), h)
        print(a, h, ne, det, lin, tm, ts, flush=True)
        rows.append([a, h, ne, det, lin, tm, ts])
        tmp = out.with_suffix(".tmp")
        tmp.write_text(HEADER + "".join(",".join(f"{v:.9g}" for v in r) + "\n" for r in rows))
        tmp.replace(out)
    print("wrote", out)


SHAPE_OUT = DATA / "iron_fem_shape.csv"
SHAPE_PROTO_DEG = (5.0, 12.5, 3.0, 9.0, 14.0, 7.0, 2.0, 11.0)  # the prototype's angles, stretched to each magnet (passes in order)
SHAPE_GRID_OUT = DATA / "iron_fem_shape_grid.csv"
SHAPE_GRID_PROTO_DEG = (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0, 16.0, 18.0, 20.0)
SHAPE_HEADER = ("# NGSolve 3-D FEM (as data/iron_fem.csv) of the shape table's {which}: the prototype with "
                "magnet diameter dm_over_R * R and length lm_over_dm * d_m, every other ratio the prototype's.\n"
                "# OPENBLAS_NUM_THREADS=1 nice -n 5 python scripts/fem_iron.py {flag} [--maxh 0.002]   "
                "(rows appended point by point; a stopped run resumes). The angles are the prototype's {angles} deg "
                "stretched by (theta_m0 + theta_c) / (theta_m + theta_c) (theta_m = atan(d_m / 2R) the magnet's "
                "angular radius, theta_c the core's), one pass over the magnets per angle.\n"
                "# Torque about the centre (N m) on one +1 magnet at alpha_deg from one core's axis, linear per nominal "
                "current; times wall-clock (s): the mesh, and per factorisation (two per point: iron, air).\n"
                "dm_over_R,lm_over_dm,alpha_deg,maxh_face_m,elements,detent_Nm,linear_Nm,mesh_s,solve_s\n")


def shape_angle(design, alpha0_deg: float) -> float:
    """The prototype's angle ``alpha0_deg`` stretched to ``design``'s magnet (degrees, to 0.1°)."""
    p = prototype()
    th_c = math.atan(0.5 * p.coil_diameter / (p.radius + p.air_gap))
    stretch = (math.atan(0.5 * design.magnet_diameter / design.radius) + th_c) / (
        math.atan(0.5 * p.magnet_diameter / p.radius) + th_c)
    return round(alpha0_deg * stretch, 1)


def shape_heldout(maxh: float = 2.0e-3, angles=SHAPE_PROTO_DEG, grid: bool = False) -> None:
    """FEM pair torques of the shape table's held-out magnets (``iron_shape_table.HELD_OUT``; with ``grid`` its
    grid nodes but the prototype's, at :data:`SHAPE_GRID_PROTO_DEG` by default) at ``angles`` (the prototype's,
    stretched), appended to :data:`SHAPE_OUT` (:data:`SHAPE_GRID_OUT`); rows already there are skipped."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from iron_shape_table import points

    out = SHAPE_GRID_OUT if grid else SHAPE_OUT
    angles = SHAPE_GRID_PROTO_DEG if grid and angles is SHAPE_PROTO_DEG else angles
    todo = [(x, a) for x, a, kind in points() if kind == ("grid" if grid else "held-out")
            and not (grid and abs(x - 1.0 / 6.0) < 1e-9 and a == 0.5)]
    done = set()
    if out.exists():
        for line in out.read_text().splitlines():
            if line and line[0].isdigit():
                v = [float(t) for t in line.split(",")[:4]]
                done.add((round(v[0], 9), round(v[1], 9), v[2], v[3]))
    else:
        out.write_text(SHAPE_HEADER.format(which="grid nodes (but the prototype's)" if grid else "held-out magnets",
                                           flag="--shape-grid" if grid else "--shape",
                                           angles=", ".join(f"{a:g}" for a in angles)))
    for a0 in angles:
        for xr, asp in todo:
            design = design_at_ratio(xr, asp)
            a = shape_angle(design, a0)
            if (round(xr, 9), round(asp, 9), a, maxh) in done:
                continue
            det, lin, ne, tm, ts = pair(design, design.coil, math.radians(a), maxh)
            print(f"d_m/R {xr:.4f}, l_m/d_m {asp:g}, alpha {a:g} deg: detent {det:.5g}, linear {lin:.5g} N m; "
                  f"{ne} elements, mesh {tm:.0f} s, {ts:.0f} s per factorisation", flush=True)
            with open(out, "a") as fh:
                fh.write(",".join(f"{v:.9g}" for v in (xr, asp, a, maxh, ne, det, lin, tm, ts)) + "\n")


def design_at_ratio(x: float, aspect: float):
    """The prototype with a magnet of diameter ``x R`` and length ``aspect`` × that (``iron_shape_table``)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from iron_shape_table import design_at

    return design_at(x, aspect)


def merge():
    """Rows of data/iron_fem.csv and every data/iron_fem_<angles>.csv into data/iron_fem.csv, and the table shares
    data/iron_fem_table_<k>.csv into data/iron_fem_table.csv (the parts removed; a later solve at the same angle
    and mesh size replaces an earlier one; rows sorted by angle, then mesh size)."""
    for name, parts in (("iron_fem_table.csv", sorted(DATA.glob("iron_fem_table_*.csv"))),
                        ("iron_fem.csv", sorted(set(DATA.glob("iron_fem_*.csv")) - set(DATA.glob("iron_fem_table*"))))):
        _merge(DATA / name, parts)


def _merge(out: Path, parts: list[Path]) -> None:
    rows = {}
    for p in [out, *parts]:
        if p.exists():
            for line in p.read_text().splitlines():
                if line and line[0].isdigit():
                    alpha, maxh = (float(v) for v in line.split(",")[:2])
                    rows[alpha, maxh] = line
    if not rows:
        return
    tmp = out.with_suffix(".tmp")
    tmp.write_text(HEADER + "\n".join(line for _, line in sorted(rows.items(), key=lambda kv: (kv[0][0], -kv[0][1])))
                   + "\n")
    tmp.replace(out)
    for p in parts:
        p.unlink()


if __name__ == "__main__":
    if "--merge" in sys.argv:
        merge()
    elif "--shape" in sys.argv or "--shape-grid" in sys.argv:  # [--maxh H (m)]: the shape table's held-out
        # magnets (data/iron_fem_shape.csv) or its grid nodes near the axis (data/iron_fem_shape_grid.csv)
        shape_heldout(float(sys.argv[sys.argv.index("--maxh") + 1]) if "--maxh" in sys.argv else 2.0e-3,
                      grid="--shape-grid" in sys.argv)
    elif "--table" in sys.argv:
        at = sys.argv.index("--table")
        share, shares = (int(v) for v in sys.argv[at + 1:at + 3]) if len(sys.argv) > at + 2 else (0, 1)
        table(TABLE_DEG[share::shares])
    elif "--table-angles" in sys.argv:
        table([float(a) for a in sys.argv[sys.argv.index("--table-angles") + 1:]])
    elif "--angles" in sys.argv:  # [--maxh H (m)] first: the face mesh size (default 2 mm)
        maxh = float(sys.argv[sys.argv.index("--maxh") + 1]) if "--maxh" in sys.argv else None
        main(angles=[float(a) for a in sys.argv[sys.argv.index("--angles") + 1:]], maxh=maxh)
    else:
        main("--quick" in sys.argv)
