"""Any design's iron from stored tables: the scaling law of linear magnetostatics (issue 28 §3).

Scale every length of a design by ``s`` (rotor, magnets, gap, shell, cores and their grooves). With linear iron
(the same ``μr``) the magnets' field at corresponding points is unchanged, ``B'(s x) = B(x)`` (it depends on the
remanence and on ratios of lengths only), and the winding's field per ampere-turn goes as ``1/s``. A torque about
the sphere's centre is a volume integral of ``(field) × (field) × length`` over volumes, so

    τ_d' = s³ (B_r'/B_r)² τ_d,    τ_1' = s² (NI'/NI) (B_r'/B_r) τ_1,    X' = s³ (B_r'/B_r)² X

for the detent, the winding's part per nominal current (``NI`` the nominal ampere-turns; at a fixed current
density ``NI ∝ s²`` and ``τ_1 ∝ s⁴``) and the coupling energy of two magnets through a core — at the same angles,
which a scaling leaves alone. These are exact for the solved fields (the FEM and the moment method both scale with
the geometry), so a design whose iron geometry is a scaled copy of one with stored tables (the prototype's FEM
tables) reuses them scaled, at no cost. :func:`shape` is what must match: every length of the pair over the rotor
radius, and the core's ``μr``.
"""

from __future__ import annotations

import hashlib
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

from ..progress import report
from ._iron import IRON_LEVEL, CoreGeometry

SHAPE_RTOL = 1e-9  # shapes equal to this (relative, per ratio): the same geometry up to a scale
SHAPE_FILE = "iron_shape_table.csv"
SHAPE_COUPLING_FILE = "iron_shape_coupling.npz"  # the coupling energy tables on the same grid
SHAPE_GRID = (tuple(round(d / 6.0, 12) for d in (0.7, 1.0, 1.3)), (0.3, 0.5, 0.8))  # d_m/R, l_m/d_m
SHAPE_NAMES = ("magnet_diameter", "magnet_length", "coil_diameter", "coil_length", "air_gap", "rotor_shell",
               "pole_radius", "groove_radius", "groove_depth")


def shape(design, coil) -> tuple[np.ndarray, float]:
    """The pair's shape: ``(ratios, μr)``, the lengths :data:`SHAPE_NAMES` over the rotor radius ``R_s`` (the
    core's outer radius and height are the coil's diameter and length; its pole and groove from ``coil``)."""
    g = CoreGeometry.of(design, coil)
    lengths = np.array([design.magnet_diameter, design.magnet_length, design.coil_diameter, design.coil_length,
                        design.air_gap, design.rotor_shell, g.r_p, g.r_w, g.depth])
    return lengths / design.radius, g.mu_r


@dataclass(frozen=True)
class Scale:
    """How the tables of ``base`` carry over to a design of the same shape: the length ratio ``s`` and the
    factors of the detent (``s³ (B_r/B_r0)²``, also the coupling energy's) and of the winding's part per nominal
    current (``s² (NI/NI0) (B_r/B_r0)``)."""

    s: float
    detent: float
    linear: float

    def to_dict(self, degrees: bool = True) -> dict:
        return {"s": self.s, "detent": self.detent, "linear": self.linear}


def scale_between(design, coil, base, base_coil) -> Scale | None:
    """The :class:`Scale` taking ``base`` (with ``base_coil``) to ``design`` (with ``coil``), or None when their
    shapes differ (a ratio by more than :data:`SHAPE_RTOL`, or ``μr``)."""
    a, mu = shape(design, coil)
    b, mu0 = shape(base, base_coil)
    if mu != mu0 or not np.allclose(a, b, rtol=SHAPE_RTOL, atol=0.0):
        return None
    s = design.radius / base.radius
    br = design.remanence / base.remanence
    ni = CoreGeometry.of(design, coil).NI / CoreGeometry.of(base, base_coil).NI
    return Scale(s, s ** 3 * br ** 2, s ** 2 * ni * br)


def prototype_scale(design, coil, level: int = IRON_LEVEL) -> Scale | None:
    """The :class:`Scale` from the prototype (whose FEM-based tables are stored) to ``design`` with ``coil`` at
    the tables' mesh ``level``, or None (another shape or level)."""
    from ..motor import prototype
    from ..motor.coil import iron_coil

    if level != IRON_LEVEL or coil.core != "iron":
        return None
    return scale_between(design, coil, prototype(), iron_coil())


def scaled_design(design, s: float, name: str | None = None):
    """``design`` with every length ×``s`` (sphere, magnets, coils, gap, rotor shell, the pot's pole, wall and
    back; the wire, the supply and the angles unchanged): a test and a reference of the scaling law."""
    from dataclasses import replace

    from .. import checks

    s = checks.positive(s, "s", "a positive scale factor")
    coil = replace(design.coil, pole_diameter=s * design.coil.pole_diameter,
                   wall_thickness=s * design.coil.wall_thickness, back_thickness=s * design.coil.back_thickness)
    return replace(design, sphere_diameter=s * design.sphere_diameter, magnet_diameter=s * design.magnet_diameter,
                   magnet_length=s * design.magnet_length, coil_diameter=s * design.coil_diameter,
                   coil_length=s * design.coil_length, air_gap=s * design.air_gap,
                   rotor_shell=s * design.rotor_shell, coil=coil,
                   name=f"{design.name} x{s:g}" if name is None else name)


# --- the shape table: the ratios the law leaves --------------------------------------------------------------

FREE = (0, 1)  # the ratios the table spans: d_m / R and (through it) l_m / d_m; the rest must be the prototype's


def _prototype():
    from ..motor import prototype
    from ..motor.coil import iron_coil

    return prototype(), iron_coil()


@lru_cache(maxsize=1)
def _shape_table() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """``(x, aspect, nodes (rad), detent (X, A, n), linear (X, A, n))`` of the stored shape table, or None."""
    from ._ironmap import read_table

    path = resources.files("spherestep.data") / SHAPE_FILE
    if not path.is_file():
        return None
    arr = read_table(path)
    xs, asp, nodes = np.unique(arr[:, 0]), np.unique(arr[:, 1]), np.unique(arr[:, 2])
    shape_ = (len(xs), len(asp), len(nodes))
    order = np.lexsort((arr[:, 2], arr[:, 1], arr[:, 0]))
    return xs, asp, np.radians(nodes), arr[order, 3].reshape(shape_), arr[order, 4].reshape(shape_)


def shape_ratios(design) -> tuple[float, float]:
    """The table's coordinates of ``design``: ``(d_m / R, l_m / d_m)``."""
    return design.magnet_diameter / design.radius, design.magnet_length / design.magnet_diameter


def in_shape_table(design, coil, level: int = IRON_LEVEL) -> str | None:
    """None when the shape table covers ``design`` with ``coil``; else why not (for people)."""
    if level != IRON_LEVEL or coil.core != "iron":
        return "not an iron core at the tables' mesh level"
    table = _shape_table()
    if table is None:
        return f"no shape table stored ({SHAPE_FILE}; python scripts/iron_shape_table.py)"
    p, pc = _prototype()
    a, mu = shape(design, coil)
    b, mu0 = shape(p, pc)
    fixed = [k for k in range(len(a)) if k not in FREE]
    off = [SHAPE_NAMES[k] for k in fixed if not np.isclose(a[k], b[k], rtol=SHAPE_RTOL, atol=0.0)]
    if mu != mu0:
        off.append("relative_permeability")
    if off:
        verb = "differ" if len(off) > 1 else "differs"
        return f"its {', '.join(off)} over the rotor radius {verb} from the prototype's"
    x, asp = shape_ratios(design)
    xs, asps = table[0], table[1]
    if not (xs[0] * (1 - 1e-9) <= x <= xs[-1] * (1 + 1e-9)):
        return f"magnet_diameter / rotor radius {x:.4g} outside the table's {xs[0]:.4g}-{xs[-1]:.4g}"
    if not (asps[0] * (1 - 1e-9) <= asp <= asps[-1] * (1 + 1e-9)):
        return f"magnet_length / magnet_diameter {asp:.4g} outside the table's {asps[0]:.4g}-{asps[-1]:.4g}"
    return None


def _weights(grid: np.ndarray, x: float, quadratic: bool) -> np.ndarray:
    """Interpolation weights on ``grid`` at ``x``: Lagrange through all (three) points, or linear between two."""
    if quadratic:
        return np.array([np.prod([(x - grid[m]) / (grid[n] - grid[m]) for m in range(len(grid)) if m != n])
                         for n in range(len(grid))])
    w = np.zeros(len(grid))
    i = int(np.clip(np.searchsorted(grid, x) - 1, 0, len(grid) - 2))
    t = (x - grid[i]) / (grid[i + 1] - grid[i])
    w[i], w[i + 1] = 1.0 - t, t
    return w


def _face_field(aspect: float) -> float:
    """A cylinder magnet's field on its face centre over ``B_r/2``: ``(l/d) / √((l/d)² + 1/4)``."""
    return aspect / math.sqrt(aspect * aspect + 0.25)


def _landmarks(x: float) -> np.ndarray:
    """The detent's landmarks (rad) for a magnet of ``x = d_m/R``: 0 and the magnet's rim over the groove's rim,
    ``θ_g ∓ θ_m`` (``θ_m = atan(x/2)``, ``θ_g`` the groove's outer radius seen from the centre)."""
    p, pc = _prototype()
    g = CoreGeometry.of(p, pc)
    th_g, th_m = math.atan(g.r_w / (p.radius + p.air_gap)), math.atan(0.5 * x)
    return np.array([0.0, th_g - th_m, th_g + th_m])


def _warp(alpha: np.ndarray, x: float, x_node: float) -> np.ndarray:
    """The angle on the table of magnet ``x_node`` that corresponds to ``alpha`` for magnet ``x``: the landmarks
    (:func:`_landmarks`) matched piecewise linearly, shifted beyond the last."""
    k, k_node = _landmarks(x), _landmarks(x_node)
    return np.where(alpha <= k[-1], np.interp(alpha, k, k_node), alpha + k_node[-1] - k[-1])


def interpolate_shape(table: np.ndarray, xs, asps, nodes, x: float, asp: float, detent: bool) -> np.ndarray:
    """``τ`` at ``(x, asp)`` from the grid ``table (X, A, n)`` at ``nodes`` (rad): ``τ / (x² F(asp))``
    interpolated quadratically through the 3 × 3 grid and multiplied back, ``F`` = 1 for the winding's part and
    :func:`_face_field` for the detent (the detent is quadratic in the magnet's field). The detent's grid tables
    are read at :func:`_warp`'s angles, so that the features where the magnet's rim crosses the groove's rim —
    ``θ_g − θ_m``, moving toward the axis as the magnet grows, and ``θ_g + θ_m``, away — line up."""
    from scipy.interpolate import CubicSpline

    def norm(u: float, a: float) -> float:
        return u * u * (_face_field(a) if detent else 1.0)

    wx, wa = _weights(xs, x, True), _weights(asps, asp, True)
    out = np.zeros(len(nodes))
    for i, xi in enumerate(xs):
        alpha = np.clip(_warp(nodes, x, xi), 0.0, math.pi) if detent else nodes
        for j, aj in enumerate(asps):
            if wx[i] * wa[j] != 0.0:
                out += wx[i] * wa[j] * CubicSpline(nodes, table[i, j] / norm(xi, aj))(alpha)
    return out * norm(x, asp)


def shape_table_tables(design, coil, level: int = IRON_LEVEL):
    """``(nodes (rad), τ_d, τ_1)`` of ``design`` with ``coil`` from the shape table (:func:`interpolate_shape`),
    then scaled by the law (``s = R/R_0``, ``B_r``, ``NI``). None when the table does not cover the design
    (:func:`in_shape_table`)."""
    if in_shape_table(design, coil, level) is not None:
        return None
    xs, asps, nodes, det, lin = _shape_table()
    x, asp = shape_ratios(design)
    x, asp = float(np.clip(x, xs[0], xs[-1])), float(np.clip(asp, asps[0], asps[-1]))
    d = interpolate_shape(det, xs, asps, nodes, x, asp, detent=True)
    li = interpolate_shape(lin, xs, asps, nodes, x, asp, detent=False)
    p, pc = _prototype()
    s = design.radius / p.radius
    br = design.remanence / p.remanence
    ni = CoreGeometry.of(design, coil).NI / CoreGeometry.of(p, pc).NI
    ends = np.isclose(nodes, 0.0) | np.isclose(nodes, np.pi)
    d, li = np.where(ends, 0.0, d), np.where(ends, 0.0, li)
    return nodes, s ** 3 * br ** 2 * d, s ** 2 * ni * br * li


@lru_cache(maxsize=1)
def _shape_coupling() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """``(x, aspect, alpha (rad), dphi (rad), X (X, A, a, a, d))`` of the stored coupling shape table, or None."""
    path = resources.files("spherestep.data") / SHAPE_COUPLING_FILE
    if not path.is_file():
        return None
    with path.open("rb") as fh, np.load(fh) as z:
        return (z["dm_over_R"], z["lm_over_dm"], np.radians(z["alpha_deg"]), np.radians(z["dphi_deg"]),
                z["energy_J"])


def shape_table_coupling(design, coil, level: int = IRON_LEVEL):
    """``(alpha, dphi, X)`` (rad, rad, J) of ``design`` with ``coil`` from the coupling shape table, scaled by the
    law (``X ∝ s³ B_r²``), or None outside the table (:func:`in_shape_table`) or without the file. ``X``
    interpolated quadratically through the 3 × 3 grid at fixed angles: within 4.4 % of the held-out solves' largest
    ``|X|`` and 7.1 % of their largest ``∂X/∂α`` (docs/magnetics.md; a stretched angle or a normalised amplitude
    did no better)."""
    table = _shape_coupling()
    if table is None or in_shape_table(design, coil, level) is not None:
        return None
    xs, asps, alpha, dphi, X = table
    x, asp = shape_ratios(design)
    x, asp = float(np.clip(x, xs[0], xs[-1])), float(np.clip(asp, asps[0], asps[-1]))
    w = np.outer(_weights(xs, x, True), _weights(asps, asp, True))
    p, _ = _prototype()
    s = design.radius / p.radius
    return alpha, dphi, s ** 3 * (design.remanence / p.remanence) ** 2 * np.tensordot(w, X, axes=([0, 1], [0, 1]))


# --- the solve outside the tables: progress and a disk cache ---------------------------------------------------

CACHE_ENV = "SPHERESTEP_CACHE"  # the cache folder (default $XDG_CACHE_HOME/spherestep or ~/.cache/spherestep)


def cache_path(kind: str, key: tuple) -> Path:
    """The disk cache file of solved ``kind`` tables for the geometry ``key`` (a tuple of rounded numbers):
    ``<cache>/iron/<kind>-<sha1 of key>.npz`` under :data:`CACHE_ENV`, else the user's cache folder."""
    root = os.environ.get(CACHE_ENV) or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "spherestep")
    digest = hashlib.sha1(repr((kind, key)).encode()).hexdigest()[:20]
    return Path(root) / "iron" / f"{kind}-{digest}.npz"


def cached(kind: str, key: tuple, solve: Callable[[], tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    """The arrays ``solve()`` returns for the geometry ``key``, read from :func:`cache_path` when a previous run
    stored them, else solved and stored (atomically; an unwritable cache is skipped)."""
    path = cache_path(kind, key)
    try:
        with np.load(path) as z:
            if str(z["key"]) == repr(key):
                return tuple(z[f"a{i}"] for i in range(len(z.files) - 1))
    except (OSError, KeyError, ValueError):
        pass
    out = tuple(np.asarray(a) for a in solve())
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f"tmp-{os.getpid()}-{path.name}")
        np.savez(tmp, key=np.array(repr(key)), **{f"a{i}": a for i, a in enumerate(out)})
        tmp.replace(path)
    except OSError:
        pass
    return out


def solve_pair_tables(design, coil, level: int = IRON_LEVEL, chunks: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """``(τ_d, τ_1)`` at ``_ironmap.TABLE_NODES_DEG`` by the moment method (``_ironmap.pair_table``), the core
    factorised first and the angles in ``chunks``, each step told to :func:`report`."""
    from ._iron import core_solver
    from ._ironmap import TABLE_NODES_DEG, pair_table

    why = in_shape_table(design, coil, level) or "not in the stored tables"
    report(f"iron: factorising the core for the moment method ({why}; about 1-2 min, then cached on disk)")
    core_solver(CoreGeometry.of(design, coil), level)
    parts = np.array_split(TABLE_NODES_DEG, chunks)
    det, lin = [], []
    for i, nodes in enumerate(parts):
        report("iron: the pair tables by the moment method", done=i, total=len(parts))
        d, li = pair_table(design, coil, level, nodes_deg=nodes)
        det.append(d)
        lin.append(li)
    report("iron: the pair tables by the moment method", done=len(parts), total=len(parts))
    return np.concatenate(det), np.concatenate(lin)


def table_label(design, coil, level: int = IRON_LEVEL) -> str:
    """A few words for a model's label: "FEM table (scaled)", "shape table (FEM-based)" or "method-of-moments
    table" (a solve)."""
    if prototype_scale(design, coil, level) is not None:
        return "FEM table (scaled)"
    return "shape table (FEM-based)" if in_shape_table(design, coil, level) is None else "method-of-moments table"


def solve_needed(design, coil, level: int = IRON_LEVEL) -> str | None:
    """None when the iron model of ``design`` with ``coil`` is ready at once from stored tables (the prototype's
    FEM tables scaled by the law, or the shape table); else why its tables need a moment-method solve (for
    people)."""
    if prototype_scale(design, coil, level) is not None:
        return None
    return in_shape_table(design, coil, level)


def iron_source(design, coil, level: int = IRON_LEVEL) -> str:
    """Where the iron model of ``design`` with ``coil`` comes from, for people: the prototype's FEM tables
    (scaled), the shape table, or a solve on first use (and why)."""
    if coil.core != "iron":
        return "air cores: no iron"
    sc = prototype_scale(design, coil, level)
    if sc is not None:
        return f"the prototype's FEM tables scaled by the law (s = {sc.s:.6g}): ready at once"
    why = solve_needed(design, coil, level)
    if why is None:
        x, asp = shape_ratios(design)
        xs, asps = _shape_table()[:2]
        return (f"the shape table (d_m/R {x:.4g} in {xs[0]:.4g}-{xs[-1]:.4g}, l_m/d_m {asp:.4g} in "
                f"{asps[0]:.4g}-{asps[-1]:.4g}; the prototype's FEM table carried over by the moment method's trend, "
                "checked against the FEM at 5 held-out magnets), scaled by the law: ready at once")
    cover = "scaled copies of the prototype"
    if _shape_table() is not None:
        xs, asps = _shape_table()[:2]
        p, pc = _prototype()
        b, _ = shape(p, pc)
        rest = ", ".join(f"{SHAPE_NAMES[k]} {b[k]:.4g}" for k in range(len(b)) if k not in FREE)
        cover += (f" and magnets with d_m/R {xs[0]:.4g}-{xs[-1]:.4g}, l_m/d_m {asps[0]:.4g}-{asps[-1]:.4g} (every "
                  f"other ratio over R the prototype's: {rest})")
    return (f"a moment-method solve on first use (about 1-2 min, with progress; then cached on disk): {why}; "
            f"the stored tables cover {cover}")
