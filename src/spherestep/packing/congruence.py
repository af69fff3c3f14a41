"""Rotations between packings: symmetry groups and congruence (Sec. II-B-3).

Two packings are congruent when a rotation maps the caps of one onto the caps of the other (centres and
radii, in any order). Candidates come from aligning two caps: a cap ``a`` of the first packing (from its
rarest radius) and a neighbour ``b`` not on ``a``'s axis fix a rotation once their images ``a', b'`` are
chosen with the same radii and the same arc ``d(a, b)``; each candidate is then checked on every cap with a
KD-tree. The number of candidates is at most ``|class(a)| × (#neighbours at that arc)``, not ``N²``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..errors import bad_value
from .chords import chord

if TYPE_CHECKING:  # the packings are only read here (centres, radii, tree): no import of .core at run time
    from .core import Packing


def _frame(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Orthonormal frames ``[a, n, a × n]`` (columns) with ``n`` the unit part of ``b`` orthogonal to ``a``."""
    n = b - np.sum(a * b, axis=-1, keepdims=True) * a
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.stack([a, n, np.cross(a, n)], axis=-1)


def aligning_rotations(src: Packing, dst: Packing, tol: float = 1e-7, first: bool = False) -> np.ndarray:
    """All rotations ``R`` (``(K, 3, 3)``) with ``R src = dst`` as sets of caps (centres within ``tol``).

    With ``first=True`` stop at the first one found (a congruence test).
    """
    if len(src) != len(dst) or not np.allclose(np.sort(src.radii), np.sort(dst.radii), rtol=0.0, atol=tol):
        return np.zeros((0, 3, 3))
    # base cap: one of the rarest radius class
    keys = np.round(src.radii / tol).astype(np.int64)
    values, counts = np.unique(keys, return_counts=True)
    rare = values[np.argmin(counts)]
    a = int(np.flatnonzero(keys == rare)[0])
    # partner: nearest cap not on a's axis
    dist, idx = src.tree.query(src.centers[a], k=min(len(src), 8))
    partners = [int(j) for j in np.atleast_1d(idx)
                if j != a and np.linalg.norm(np.cross(src.centers[a], src.centers[j])) > 1e-6]
    if not partners:
        raise bad_value("packing", "at least three caps not all on one axis", f"{len(src)} caps on one axis")
    b = partners[0]
    d_ab = np.linalg.norm(src.centers[a] - src.centers[b])
    a_images = np.flatnonzero(np.abs(dst.radii - src.radii[a]) <= tol)
    lists = dst.tree.query_ball_point(dst.centers[a_images], d_ab + tol)
    ia, ib = [], []
    for a2, near in zip(a_images, lists):
        for b2 in near:
            if b2 != a2 and abs(dst.radii[b2] - src.radii[b]) <= tol and \
                    abs(np.linalg.norm(dst.centers[a2] - dst.centers[b2]) - d_ab) <= tol:
                ia.append(a2)
                ib.append(b2)
    if not ia:
        return np.zeros((0, 3, 3))
    F_src = _frame(src.centers[a], src.centers[b])
    F_dst = _frame(dst.centers[np.array(ia)], dst.centers[np.array(ib)])
    candidates = F_dst @ F_src.T
    found = []
    for R in candidates:
        moved = src.centers @ R.T
        dist, nearest = dst.tree.query(moved, distance_upper_bound=chord(10 * tol) + tol)
        if np.all(np.isfinite(dist)) and np.allclose(dst.radii[np.minimum(nearest, len(dst) - 1)], src.radii, rtol=0.0, atol=tol) \
                and len(np.unique(nearest)) == len(src):
            found.append(R)
            if first:
                break
    return np.array(found).reshape(-1, 3, 3)


def symmetry_rotations(packing: Packing, tol: float = 1e-7) -> np.ndarray:
    """The rotation group of ``packing``: every ``R`` with ``R packing = packing`` (``(K, 3, 3)``)."""
    return aligning_rotations(packing, packing, tol=tol)


def congruent(a: Packing, b: Packing, tol: float = 1e-7) -> bool:
    """True when some rotation and re-ordering of ``a`` gives ``b`` (centres within ``tol``, equal radii)."""
    return len(aligning_rotations(a, b, tol=tol, first=True)) > 0


def distinct(packings: list[Packing], tol: float = 1e-7) -> list[Packing]:
    """One representative per congruence class, in order of first appearance.

    Of a class, the member kept is the one whose family has the largest rotation group (so the
    octahedron of the tetrahedral family gives way to the octahedral one).
    """
    rank = {None: 0, "T": 1, "O": 2, "I": 3}
    classes: list[list[Packing]] = []
    for p in packings:
        for cls in classes:
            if congruent(cls[0], p, tol):
                cls.append(p)
                break
        else:
            classes.append([p])
    return [max(cls, key=lambda p: rank[p.family]) for cls in classes]
