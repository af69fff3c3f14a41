"""Recursive refinement: fill every hole with the cap that kisses its whole ring (Sec. II-B-2, II-B-3).

The holes of a packing whose neighbours kiss are the faces of its weighted (power) Delaunay
triangulation, which for caps on the sphere is the convex hull of their *poles* ``c_i / cos r_i`` (the
point whose polar plane cuts the sphere in the cap's circle); the plain hull of the centres would pair
caps that do not touch once radii differ. A hull facet's vertices are caps that ring one uncovered region;
the coplanar facets of a ring of ``k ≥ 4`` caps (which Qhull triangulates) are merged back into one face.
A ring of three gets the cap of eqs. (2)–(3) (:func:`~spherestep.sphere.circle_in_gap`), a symmetric ring of
``k ≥ 4`` the cap on its axis (:func:`~spherestep.sphere.circle_in_ring`). Every hole is filled at every
level, so whole symmetry orbits are filled together and the family's rotation group is kept. After
level 1 every hole is ringed by three caps.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull

from .. import checks
from ..errors import bad_value
from ..sphere import canonical_order, circle_in_gap, circle_in_ring
from .core import Packing

PLANE_TOL = 1e-9


def holes(packing: Packing) -> list[np.ndarray]:
    """The rings of caps around the uncovered regions: a list of index arrays, one per hole, in order
    around it (counter-clockwise seen from outside). The holes come in canonical order of their axes, the
    outward normals of the planes through their rings' poles (:func:`~spherestep.sphere.canonical_order`), not in
    Qhull's facet order, which the last bit of the input (and so the CPU's BLAS kernel) decides."""
    if np.any(packing.radii >= np.pi / 2 - 1e-9):
        raise bad_value("packing", "caps of radius below 90° (a hemisphere has no pole to lift)",
                        f"a cap of {np.degrees(packing.radii.max()):.4g}°")
    hull = ConvexHull(packing.centers / np.cos(packing.radii)[:, None])
    eq = hull.equations  # outward normal (3) and offset (1) of each triangular facet
    # facet i and its neighbour across the edge opposite its vertex j belong to one hole when they are
    # coplanar and that edge joins two caps that do not kiss (a diagonal Qhull drew across the hole)
    n = len(eq)
    i = np.repeat(np.arange(n), 3)
    j = np.tile(np.arange(3), n)
    nb = hull.neighbors[i, j]
    edge = hull.simplices[i][np.arange(3 * n)[:, None], np.array([[1, 2], [0, 2], [0, 1]])[j]]
    a, b = packing.centers[edge[:, 0]], packing.centers[edge[:, 1]]
    arc = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.sum(a * b, axis=1))
    diagonal = arc - packing.radii[edge[:, 0]] - packing.radii[edge[:, 1]] > 1e-8
    coplanar = np.abs(eq[i] - eq[nb]).max(axis=1) < PLANE_TOL
    merge = diagonal & coplanar
    graph = coo_matrix((np.ones(int(merge.sum())), (i[merge], nb[merge])), shape=(n, n))
    count, label = connected_components(graph, directed=False)
    rings, axes = [], []
    order = np.argsort(label, kind="stable")
    bounds = np.searchsorted(label[order], np.arange(count + 1))
    for g in range(count):
        facets = order[bounds[g]:bounds[g + 1]]
        ring = np.unique(hull.simplices[facets])
        normal = eq[facets[0], :3]
        pts = packing.centers[ring]
        e1 = pts[0] - np.dot(pts[0], normal) * normal
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(normal, e1)
        ring = ring[np.argsort(np.arctan2(pts @ e2, pts @ e1))]
        rings.append(ring)
        axes.append(normal)
    return [rings[k] for k in canonical_order(np.array(axes))]


def fill_holes(packing: Packing) -> tuple[np.ndarray, np.ndarray]:
    """Centres ``(H, 3)`` and radii ``(H,)`` of the caps inscribed in every hole of ``packing``, in the order of
    :func:`holes`."""
    rings = holes(packing)
    sizes = np.array([len(r) for r in rings])
    centers = np.zeros((len(rings), 3))
    radii = np.zeros(len(rings))
    for k in np.unique(sizes):
        sel = np.flatnonzero(sizes == k)
        idx = np.array([rings[i] for i in sel])
        if k == 3:
            c, r = circle_in_gap(packing.centers[idx], packing.radii[idx])
        else:
            c, r = circle_in_ring(packing.centers[idx], packing.radii[idx], tol=1e-8)
        centers[sel], radii[sel] = c, r
    return centers, radii


def refine(packing: Packing, levels: int | None = None, target: int | None = None) -> Packing:
    """Fill holes level by level: stop after ``levels`` levels, or at the first level with ``>= target``
    caps (whichever is given; default one level). New caps are appended after the old ones in canonical order
    (:func:`fill_holes`), so the indices of existing caps never change and every machine numbers them alike."""
    levels = None if levels is None else checks.count(levels, "levels", minimum=0, expected="a non-negative integer")
    target = None if target is None else checks.count(target, "target", minimum=0, expected="a non-negative integer")
    if levels is None and target is None:
        levels = 1
    if target is not None and target > 5_000_000:
        raise bad_value("target", "at most 5,000,000 caps", target)
    current = packing
    done = 0
    while (levels is None or done < levels) and (target is None or len(current) < target):
        centers, radii = fill_holes(current)
        current = Packing(np.vstack([current.centers, centers]), np.concatenate([current.radii, radii]),
                          name=packing.name, family=packing.family, level=current.level + 1)
        done += 1
    return current
