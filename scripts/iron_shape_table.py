"""The iron pair tables over the shape ratios the scaling law leaves (issue 28 §3 c): the FEM near the axis, the
moment method beyond.

    OPENBLAS_NUM_THREADS=1 nohup nice -n 10 python scripts/iron_shape_table.py > shape.log 2>&1 &
        # every grid and held-out point missing from data/iron_shape_solves.csv, appended point by point;
        # then writes src/spherestep/data/iron_shape_table.csv (the grid) and data/iron_shape_heldout.csv
    python scripts/iron_shape_table.py --write     # only assemble the two files from the stored solves
    python scripts/iron_shape_table.py --check     # the table at the held-out magnets against their FEM
    OPENBLAS_NUM_THREADS=1 python scripts/iron_shape_table.py --coupling   # the coupling tables over the grid and
        # held out (data/iron_shape_coupling_solves.npz, resumable), then src/spherestep/data/iron_shape_coupling.npz
        # and its held-out check (3.3 min at load 8: one core factorisation, ~12 s a point)

What varies. By the scaling law (:mod:`spherestep.magnetics._ironscale`) only ratios matter. The table spans the
magnet: its diameter over the rotor radius ``d_m / R`` (0.7 to 1.3 in on the 12-in prototype) and its aspect
``l_m / d_m`` (0.3 to 0.8), with every other ratio the prototype's (the pot core, its groove, the coil's size,
the gap and the shell over ``R``; ``μr``). Each node is the NGSolve FEM below 21° (``scripts/fem_iron.py
--shape-grid``, ``data/iron_fem_shape_grid.csv``: 8 nodes × 18 angles, the prototype's own from its FEM table) and
:func:`spherestep.magnetics._ironmap.pair_table` of the prototype with that magnet beyond (level 0, the moment
method: one core factorisation serves every point, ~0.5–1 min a point here; ``data/iron_shape_solves.csv``; the
prototype's own point is ``data/iron_pair_table_mom.csv``), joined as the prototype's own table (:func:`fem_grid`).
The held-out magnets have their own FEM (``scripts/fem_iron.py --shape``, ``data/iron_fem_shape.csv``), which
``--check`` and ``tests/test_iron_shape.py`` hold the table to.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from spherestep.magnetics import _ironscale
from spherestep.magnetics._ironmap import TABLE_NODES_DEG, pair_table, read_table
from spherestep.motor import prototype

ROOT = Path(__file__).resolve().parents[1]
SOLVES = ROOT / "data" / "iron_shape_solves.csv"
HELD = ROOT / "data" / "iron_shape_heldout.csv"
TABLE = ROOT / "src" / "spherestep" / "data" / _ironscale.SHAPE_FILE
MOM = ROOT / "data" / "iron_pair_table_mom.csv"
INCH = 0.0254
HELD_OUT = ((0.8, 0.625), (0.85, 0.4), (0.9, 0.65), (1.1, 0.4), (1.2, 0.7))  # (d_m in inches, l_m / d_m)
COLUMNS = "dm_over_R,lm_over_dm,alpha_deg,detent_Nm,linear_Nm"


def points() -> list[tuple[float, float, str]]:
    """``(d_m / R, l_m / d_m, "grid" | "held-out")``: the grid of :data:`_ironscale.SHAPE_GRID`, then the held-out
    points."""
    R = prototype().radius
    grid = [(x, a, "grid") for x in _ironscale.SHAPE_GRID[0] for a in _ironscale.SHAPE_GRID[1]]
    return grid + [(round(d * INCH / R, 12), a, "held-out") for d, a in HELD_OUT]


def design_at(x: float, aspect: float):
    """The prototype with a magnet of diameter ``x R`` and length ``aspect`` × that."""
    p = prototype()
    return replace(p, magnet_diameter=x * p.radius, magnet_length=aspect * x * p.radius,
                   name=f"prototype d_m/R {x:g} l_m/d_m {aspect:g}")


def stored() -> dict:
    """``{(d_m/R, l_m/d_m): (detent, linear)}`` at :data:`TABLE_NODES_DEG` from the solves file."""
    out = {}
    if SOLVES.exists():
        arr = read_table(SOLVES)
        for x, a in {(r[0], r[1]) for r in arr}:
            rows = arr[(arr[:, 0] == x) & (arr[:, 1] == a)]
            if len(rows) == len(TABLE_NODES_DEG):
                out[(float(x), float(a))] = (rows[:, 3], rows[:, 4])
    return out


def solve(todo) -> None:
    if not SOLVES.exists():
        SOLVES.write_text("# Moment-method pair tables (level 0) of the prototype with other magnets "
                          "(scripts/iron_shape_table.py); torque about the centre (N m) on one +1 magnet at alpha "
                          "from one core's axis, linear per nominal current.\n" + COLUMNS + "\n")
    for x, a, kind in todo:
        t = time.perf_counter()
        if abs(x - 1.0 / 6.0) < 1e-12 and a == 0.5 and MOM.exists():  # the prototype: its stored moment table
            arr = read_table(MOM)
            det, lin = arr[:, 1], arr[:, 2]
        else:
            d = design_at(x, a)
            det, lin = pair_table(d, d.coil)
        lines = "".join(f"{x:.12g},{a:.12g},{al:g},{dv:.9g},{lv:.9g}\n"
                        for al, dv, lv in zip(TABLE_NODES_DEG, det, lin))
        with open(SOLVES, "a") as fh:
            fh.write(lines)
        print(f"{kind} d_m/R {x:.4f} l_m/d_m {a:.3f}: peak detent {np.abs(det).max():.3f}, linear "
              f"{np.abs(lin).max():.3f} N m, {time.perf_counter() - t:.0f} s", flush=True)


FEM_GRID = ROOT / "data" / "iron_fem_shape_grid.csv"  # scripts/fem_iron.py --shape-grid


def fem_grid(have: dict) -> dict | None:
    """The grid's tables with the FEM below the FEM's last angle + 1° (the moment method beyond, as the
    prototype's own table): ``{(d_m/R, l_m/d_m): (detent, linear)}`` at :data:`TABLE_NODES_DEG`, the prototype's
    node from its FEM table; None unless :data:`FEM_GRID` holds every other node at every angle of
    ``fem_iron.SHAPE_GRID_PROTO_DEG``."""
    from scipy.interpolate import CubicSpline

    from spherestep.magnetics._ironmap import TABLE_FILE

    if not FEM_GRID.exists():
        return None
    fem = read_table(FEM_GRID)
    proto = read_table(ROOT / "src" / "spherestep" / "data" / TABLE_FILE)
    out = {}
    for x, a, kind in points():
        if kind != "grid":
            continue
        if abs(x - 1.0 / 6.0) < 1e-9 and a == 0.5:  # its FEM table's own nodes, read at the grid's
            at = np.radians(proto[:, 0])
            out[(x, a)] = tuple(CubicSpline(at, proto[:, k])(np.radians(TABLE_NODES_DEG)) for k in (1, 2))
            continue
        rows = fem[np.isclose(fem[:, 0], x, rtol=1e-9) & np.isclose(fem[:, 1], a, rtol=1e-9)]
        if len(np.unique(rows[:, 2])) < 18:  # fem_iron.SHAPE_GRID_PROTO_DEG
            return None
        rows = rows[np.argsort(rows[:, 2])]
        cut = rows[-1, 2] + 1.0
        det, lin = have[(x, a)]
        far = TABLE_NODES_DEG >= cut
        al = np.radians(np.r_[0.0, rows[:, 2], TABLE_NODES_DEG[far]])
        near = ~far
        det, lin = det.copy(), lin.copy()
        det[near] = CubicSpline(al, np.r_[0.0, rows[:, 5], det[far]])(np.radians(TABLE_NODES_DEG[near]))
        lin[near] = CubicSpline(al, np.r_[0.0, rows[:, 6], lin[far]])(np.radians(TABLE_NODES_DEG[near]))
        out[(x, a)] = (det, lin)
    return out


def write() -> None:
    """The package's table (the grid: the FEM near the axis when :func:`fem_grid` has it all, else the moment
    method) and the held-out file (moment method), from the solves; atomic."""
    have = stored()
    for path, kind, head in ((TABLE, "grid", "the grid"), (HELD, "held-out", "held-out points (not in the table)")):
        rows = [(x, a) for x, a, k in points() if k == kind]
        missing = [p for p in rows if p not in have]
        if missing:
            print(f"{path.name}: {len(missing)} of {len(rows)} points not solved yet; not written")
            continue
        method = "moment method level 0"
        if kind == "grid" and (fem := fem_grid(have)) is not None:
            have = have | fem
            method = ("NGSolve FEM near the axis (data/iron_fem_shape_grid.csv, the prototype's from its FEM table) "
                      "and the moment method level 0 beyond")
        text = (f"# Iron pair tables over the magnet's shape, {head}: {method} "
                "(scripts/iron_shape_table.py), the prototype with magnet diameter d_m = dm_over_R * R and length "
                "lm_over_dm * d_m, every other ratio the prototype's.\n# Torque (N m) about the centre on one +1 "
                "magnet at alpha_deg from one core's axis, for the prototype's R, B_r and nominal ampere-turns "
                "(scale by the law of spherestep.magnetics._ironscale).\n" + COLUMNS + "\n")
        for x, a in rows:
            det, lin = have[(x, a)]
            text += "".join(f"{x:.12g},{a:.12g},{al:g},{dv:.9g},{lv:.9g}\n"
                            for al, dv, lv in zip(TABLE_NODES_DEG, det, lin))
        tmp = path.with_suffix(".tmp")
        tmp.write_text(text)
        tmp.replace(path)
        print(f"wrote {path} ({len(rows)} points)")


def check() -> None:
    """The package's table interpolated at the held-out magnets against their FEM (``data/iron_fem_shape.csv``),
    as ``tests/test_iron_shape.py`` holds it: max |table − FEM| over the magnet's angles / the FEM's largest |τ|."""
    from scipy.interpolate import CubicSpline

    fem = read_table(ROOT / "data" / "iron_fem_shape.csv")
    for x, a in sorted({(r[0], r[1]) for r in fem}):
        rows = fem[(fem[:, 0] == x) & (fem[:, 1] == a)]
        d = design_at(x, a)
        nodes, det, lin = _ironscale.shape_table_tables(d, d.coil)
        alpha = np.radians(rows[:, 2])
        err = [np.abs(CubicSpline(nodes, tau)(alpha) - rows[:, c]).max() / np.abs(rows[:, c]).max()
               for tau, c in ((det, 5), (lin, 6))]
        print(f"held-out d_m/R {x:.4f} ({x * prototype().radius / INCH:.2f} in) l_m/d_m {a:.3f}, "
              f"{len(rows)} FEM angles {rows[:, 2].min():g}-{rows[:, 2].max():g} deg: table vs FEM, max |d tau| / "
              f"peak: detent {100 * err[0]:.2f} %, winding's part {100 * err[1]:.2f} %")


COUPLING_SOLVES = ROOT / "data" / "iron_shape_coupling_solves.npz"
COUPLING_TABLE = ROOT / "src" / "spherestep" / "data" / _ironscale.SHAPE_COUPLING_FILE


def _key(x: float, a: float) -> str:
    return f"{x:.12g}_{a:.12g}"


def coupling() -> None:
    """The coupling energy tables (``_ironcoupling.cross_energy_table`` on the model's angles) at every grid and
    held-out point missing from :data:`COUPLING_SOLVES` (one core factorisation serves all), then the package's
    grid file (:data:`_ironscale.SHAPE_COUPLING_FILE`, compressed NumPy) and the held-out check."""
    from spherestep.magnetics._coupling import COUPLING_ALPHA_DEG, COUPLING_DPHI_DEG
    from spherestep.magnetics._ironcoupling import cross_energy_table

    have = dict(np.load(COUPLING_SOLVES)) if COUPLING_SOLVES.exists() else {}
    alpha, dphi = np.radians(COUPLING_ALPHA_DEG), np.radians(COUPLING_DPHI_DEG)
    for x, a, kind in points():
        if _key(x, a) in have:
            continue
        t = time.perf_counter()
        d = design_at(x, a)
        have[_key(x, a)] = cross_energy_table(d, d.coil, alpha, dphi)
        tmp = COUPLING_SOLVES.with_name("tmp_" + COUPLING_SOLVES.name)
        np.savez_compressed(tmp, **have)
        tmp.replace(COUPLING_SOLVES)
        print(f"coupling {kind} d_m/R {x:.4f} l_m/d_m {a:.3f}: {time.perf_counter() - t:.0f} s", flush=True)
    xs, asps = _ironscale.SHAPE_GRID
    X = np.array([[have[_key(x, a)] for a in asps] for x in xs])
    tmp = COUPLING_TABLE.with_name("tmp_" + COUPLING_TABLE.name)
    np.savez_compressed(tmp, dm_over_R=np.array(xs), lm_over_dm=np.array(asps), alpha_deg=COUPLING_ALPHA_DEG,
                        dphi_deg=COUPLING_DPHI_DEG, energy_J=X,
                        about=np.array("Coupling energy (J) of two +1 rotor poles over one iron core (MoM level 0, "
                                       "_ironcoupling.cross_energy_table) of the prototype with magnet diameter "
                                       "dm_over_R * R and length lm_over_dm * d_m: energy_J[x, aspect, alpha_p, "
                                       "alpha_q, dphi]. Produced by: python scripts/iron_shape_table.py --coupling"))
    tmp.replace(COUPLING_TABLE)
    print(f"wrote {COUPLING_TABLE}")
    _ironscale._shape_coupling.cache_clear()
    for x, a, kind in points():
        if kind == "held-out":
            d = design_at(x, a)
            got = _ironscale.shape_table_coupling(d, d.coil)[2]
            ref = have[_key(x, a)]
            e = np.abs(got - ref).max() / np.abs(ref).max()
            g_ref, g_got = np.gradient(ref, alpha, axis=0), np.gradient(got, alpha, axis=0)
            e_g = np.abs(g_got - g_ref).max() / np.abs(g_ref).max()
            print(f"coupling held-out d_m/R {x:.4f} l_m/d_m {a:.3f}: table vs solve, max |dX| / max |X| "
                  f"{100 * e:.2f} %, of dX/dalpha {100 * e_g:.2f} %")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--write", action="store_true", help="only assemble the table and held-out files")
    ap.add_argument("--check", action="store_true", help="the table against the held-out solves")
    ap.add_argument("--coupling", action="store_true", help="the coupling tables over the grid (and held out)")
    args = ap.parse_args(argv)
    if args.coupling:
        coupling()
        return
    if args.check:
        check()
        return
    if not args.write:
        have = stored()
        solve([p for p in points() if (p[0], p[1]) not in have])
    write()


if __name__ == "__main__":
    main(sys.argv[1:])
