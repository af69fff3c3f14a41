"""The five Platonic packings, built as Sec. II-B describes.

Each vertex carries a cap of radius half the nearest-neighbour arc, so neighbouring caps kiss.

* tetrahedron: the north pole and ``(2πk/3, α)``, ``k = 0, 1, 2``, with ``α`` solving
  ``d(u(0,0), u(0,α)) = d(u(2π/3,α), u(0,α))`` (``α = cos⁻¹(−1/3) ≈ 109.4712°``);
* octahedron ``±e_i`` and cube ``(±1, ±1, ±1)/√3`` as printed;
* icosahedron: the two poles, five vertices at ``(2πk/5, β)`` and five at ``((2k+1)π/5, π − β)`` with ``β``
  solving ``d(e3, u(0,β)) = d(u(0,β), u(2π/5,β))`` (``β = tan⁻¹ 2 ≈ 63.4349°``). The printed azimuths
  ``kπ/5`` and ``(2k+1)π/10`` are each half of what a regular icosahedron needs (five points π/5 apart span
  only half a turn); we read them as ``2kπ/5`` and ``(2k+1)π/5``, the only reading that closes the ring;
* dodecahedron: the normalised sums of the icosahedron's triples of mutually nearest vertices (its faces), in
  canonical order (:func:`~spherestep.sphere.canonical_order`); the other four keep the listing order above.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

from ..errors import bad_value
from ..sphere import arc_distance, canonical_order, point
from .core import Packing

PLATONIC = ("tetrahedron", "octahedron", "cube", "icosahedron", "dodecahedron")


def _tetrahedron() -> np.ndarray:
    alpha = brentq(lambda a: arc_distance(point(0, 0), point(0, a)) - arc_distance(point(2 * np.pi / 3, a), point(0, a)),
                   np.pi / 2, np.pi - 1e-9, xtol=1e-15)
    return np.vstack([point(0.0, 0.0), point(2 * np.pi * np.arange(3) / 3, alpha)])


def _icosahedron() -> np.ndarray:
    beta = brentq(lambda b: arc_distance(point(0, 0), point(0, b)) - arc_distance(point(0, b), point(2 * np.pi / 5, b)),
                  0.1, np.pi / 2, xtol=1e-15)
    k = np.arange(5)
    return np.vstack([[0, 0, 1.0], [0, 0, -1.0], point(2 * np.pi * k / 5, beta), point((2 * k + 1) * np.pi / 5, np.pi - beta)])


def icosahedron_faces(vertices: np.ndarray) -> np.ndarray:
    """Index triples of mutually nearest vertices of an icosahedron (its 20 faces)."""
    from scipy.spatial import ConvexHull

    return np.sort(ConvexHull(vertices).simplices, axis=1)


def _dodecahedron() -> np.ndarray:
    ico = _icosahedron()
    centers = ico[icosahedron_faces(ico)].sum(axis=1)
    centers /= np.linalg.norm(centers, axis=1, keepdims=True)
    return centers[canonical_order(centers)]  # not Qhull's facet order, which the last bit of the input decides


def _vertices(name: str) -> np.ndarray:
    if name == "tetrahedron":
        return _tetrahedron()
    if name == "octahedron":
        return np.vstack([np.eye(3), -np.eye(3)])[[2, 5, 0, 3, 1, 4]]
    if name == "cube":
        s = np.array([[1, 1, 1], [-1, 1, 1], [1, -1, 1], [1, 1, -1], [-1, -1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, -1]])
        return s / np.sqrt(3.0)
    if name == "icosahedron":
        return _icosahedron()
    return _dodecahedron()


FAMILY_OF = {"tetrahedron": "T", "octahedron": "O", "cube": "O", "icosahedron": "I", "dodecahedron": "I"}


def congruent_caps(centers: np.ndarray, name: str, family: str | None) -> Packing:
    """Caps of one radius, half the smallest centre-to-centre arc, at ``centers`` (so neighbours kiss)."""
    from .chords import arc_from_chord
    from scipy.spatial import cKDTree

    dist, _ = cKDTree(centers).query(centers, k=2)
    radius = 0.5 * arc_from_chord(dist[:, 1].min())
    return Packing(centers, np.full(len(centers), radius), name=name, family=family)


def platonic(name: str) -> Packing:
    """The Platonic packing ``name`` (one of :data:`PLATONIC`), constructed as in Sec. II-B."""
    if name not in PLATONIC:
        raise bad_value("name", f"one of {', '.join(PLATONIC)}", name)
    return congruent_caps(_vertices(name), name, FAMILY_OF[name])
