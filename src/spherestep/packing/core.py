"""The :class:`Packing` value type and its metrics (Sec. II-B).

A packing is ``N`` caps on the unit sphere: ``centers (N, 3)`` unit vectors and angular ``radii (N,)``.
Pairwise questions (overlaps, contacts) use a KD-tree on the centres, never an ``N × N`` matrix: a pair
that overlaps or touches is within ``2 r_max`` of its larger cap, so each cap queries only its own
neighbourhood of radius ``2 r_i`` and keeps partners no larger than itself.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .. import checks
from ..errors import InputError, bad_value
from ..sphere import as_points, as_radii, cap_area
from .chords import arc_from_chord, chord
from .congruence import symmetry_rotations

CONTACT_TOL = 1e-9


@dataclass(frozen=True, eq=False)
class Packing:
    """Caps on the unit sphere: ``centers (N, 3)``, ``radii (N,)``, a ``name``, symmetry ``family``
    ('T', 'O', 'I' or None) and refinement ``level`` (0 for the 21 base packings)."""

    centers: np.ndarray
    radii: np.ndarray
    name: str = "packing"
    family: str | None = None
    level: int = 0
    _tree: cKDTree = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        centers = as_points(self.centers, "centers", min_ndim=2)
        if centers.ndim != 2:
            raise bad_value("centers", "an array of shape (N, 3)", f"shape {centers.shape}")
        radii = as_radii(np.broadcast_to(self.radii, centers.shape[:1]).copy(), "radii")
        if self.family not in (None, "T", "O", "I"):
            raise bad_value("family", "'T', 'O', 'I' or None", self.family)
        norm = np.linalg.norm(centers, axis=1, keepdims=True)
        centers = np.where(norm == 1.0, centers, centers / norm)  # exact unit vectors are kept bit for bit
        centers.setflags(write=False)
        radii.setflags(write=False)
        object.__setattr__(self, "centers", centers)
        object.__setattr__(self, "radii", radii)
        object.__setattr__(self, "_tree", cKDTree(centers))

    def __len__(self) -> int:
        return len(self.radii)

    def __repr__(self) -> str:
        return f"Packing({self.label!r}, {len(self)} caps, family={self.family!r})"

    @property
    def label(self) -> str:
        """``name`` with the refinement level, e.g. ``truncated-icosahedron/L1``."""
        return self.name if self.level == 0 else f"{self.name}/L{self.level}"

    @property
    def tree(self) -> cKDTree:
        """KD-tree on the centres (built once)."""
        return self._tree

    def subset(self, indices, name: str = "indices") -> Packing:
        """The caps ``indices`` (in that order), keeping name, family and level; InputError naming ``name``
        for an index out of range or repeated (``field`` is ``name[k]``)."""
        idx = np.asarray(indices)
        if idx.ndim != 1 or (idx.size and not np.issubdtype(idx.dtype, np.integer)):
            raise bad_value(name, "a list of cap indices", indices)
        for k, i in enumerate(idx.tolist()):
            if not 0 <= i < len(self):
                raise bad_value(f"{name}[{k}]", f"a cap index 0..{len(self) - 1} of {self.label}", i)
        unique, first = np.unique(idx, return_index=True)
        if len(unique) != len(idx):
            k = int(np.setdiff1d(np.arange(len(idx)), first)[0])
            raise bad_value(f"{name}[{k}]", f"a cap not listed before (cap {int(idx[k])} repeats; list each cap "
                            "once)", int(idx[k]))
        return Packing(self.centers[idx], self.radii[idx], name=self.name, family=self.family, level=self.level)

    def within_cap(self, axis, half_angle: float, min_radius: float = 0.0) -> Packing:
        """The caps whose centres lie within ``half_angle`` (rad) of the unit vector ``axis``
        (``c · axis ≥ cos half_angle − 1e-12``) and whose radius is at least ``min_radius`` (room for a part),
        in this packing's order, keeping name, family and level."""
        axis = as_points(axis, "axis")
        if axis.shape != (3,):
            raise bad_value("axis", "one unit 3-vector", f"shape {axis.shape}")
        axis = axis / np.linalg.norm(axis)
        half_angle = checks.number(half_angle, "half_angle", low=0.0, high=np.pi, expected="an angle in [0, π] radians")
        inside = (self.centers @ axis >= np.cos(half_angle) - 1e-12) & (self.radii >= min_radius)
        return Packing(self.centers[inside], self.radii[inside], name=self.name, family=self.family,
                       level=self.level)

    # --- metrics -------------------------------------------------------------------------------------
    def neighbour_pairs(self, slack: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Pairs ``(i, j)`` with ``d(c_i, c_j) <= r_i + r_j + slack`` and the gap ``d − r_i − r_j`` of each."""
        reach = chord(2.0 * self.radii + slack)
        lists = self.tree.query_ball_point(self.centers, reach)
        counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
        i = np.repeat(np.arange(len(self)), counts)
        j = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists]) if len(i) else np.zeros(0, np.int64)
        keep = (i != j) & ((self.radii[j] < self.radii[i]) | ((self.radii[j] == self.radii[i]) & (j > i)))
        i, j = i[keep], j[keep]
        d = arc_from_chord(np.linalg.norm(self.centers[i] - self.centers[j], axis=1))
        gap = d - self.radii[i] - self.radii[j]
        close = gap <= slack
        pairs = np.sort(np.stack([i[close], j[close]], axis=1), axis=1)
        order = np.lexsort((pairs[:, 1], pairs[:, 0]))
        return pairs[order], gap[close][order]

    def contacts(self, tol: float = CONTACT_TOL) -> np.ndarray:
        """The contact graph: ``(E, 2)`` index pairs of kissing caps (``|d − r_i − r_j| <= tol``)."""
        pairs, gap = self.neighbour_pairs(slack=tol)
        return pairs[np.abs(gap) <= tol]

    def min_separation(self) -> float:
        """Smallest arc distance between two centres (radians), by nearest neighbours in the KD-tree."""
        if len(self) < 2:
            return float("nan")
        dist, _ = self.tree.query(self.centers, k=2)
        return float(arc_from_chord(dist[:, 1].min()))

    def density(self) -> float:
        """Covered fraction of the sphere, ``Σ 2π(1 − cos r_i) / 4π`` (caps do not overlap)."""
        return float(cap_area(self.radii).sum() / (4.0 * np.pi))

    def radius_ratio(self) -> float:
        """Largest over smallest radius (1 for congruent caps)."""
        return float(self.radii.max() / self.radii.min())

    def inertia_isotropy(self) -> float:
        """Largest / smallest principal moment of equal point masses at the centres (1 when balanced).

        The inertia tensor of unit masses at unit vectors is ``Σ (I − c cᵀ)``; the paper needs
        ``I_xx = I_yy = I_zz`` for a rotor with no internal torques (Sec. IV-A).
        """
        tensor = len(self) * np.eye(3) - self.centers.T @ self.centers
        eig = np.linalg.eigvalsh(tensor)
        return float(eig[-1] / eig[0])

    def symmetry_order(self, tol: float = 1e-7) -> int:
        """Number of rotations mapping the packing (centres and radii) onto itself: 12, 24 or 60 for T, O, I."""
        return len(symmetry_rotations(self, tol=tol))

    def problems(self, tol: float = CONTACT_TOL) -> list[str]:
        """What :meth:`validate` objects to: overlapping caps, and caps that kiss no other."""
        out = []
        pairs, gap = self.neighbour_pairs(slack=tol)
        bad = gap < -tol
        if np.any(bad):
            k = np.argmin(gap)
            out.append(f"{int(bad.sum())} pairs of caps overlap (worst: caps {pairs[k, 0]} and {pairs[k, 1]} "
                       f"by {-gap[k]:.3g} rad)")
        touching = np.zeros(len(self), dtype=bool)
        touching[pairs[np.abs(gap) <= tol].ravel()] = True
        if not touching.all():
            lonely = np.flatnonzero(~touching)
            out.append(f"{len(lonely)} caps kiss no other cap (first: cap {lonely[0]})")
        return out

    def validate(self, tol: float = CONTACT_TOL) -> Packing:
        """Raise InputError unless no two caps overlap by more than ``tol`` and every cap kisses another."""
        problems = self.problems(tol)
        if problems:
            raise InputError(f"packing {self.label!r} is not valid: " + "; ".join(problems))
        return self

    def summary(self) -> dict:
        """The metrics as a JSON-ready dict (angles in degrees)."""
        return {
            "name": self.label,
            "family": self.family,
            "caps": len(self),
            "radius_min_deg": float(np.degrees(self.radii.min())),
            "radius_max_deg": float(np.degrees(self.radii.max())),
            "radius_ratio": self.radius_ratio(),
            "density": self.density(),
            "min_separation_deg": float(np.degrees(self.min_separation())),
            "symmetry_order": self.symmetry_order(),
            "inertia_isotropy": self.inertia_isotropy(),
        }
