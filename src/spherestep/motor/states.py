"""Stepper states: orientations at which at least two rotor poles sit on stator coils (Sec. II-B-3, III-A).

Enumeration. Two poles on two coils fix the rotor (footnote 2). For every pair of working coils
``(k1, k2)`` at arc ``s`` and every ordered pair of rotor poles ``(j1, j2)`` at arc ``a`` with
``|a − s| <= 2 tol``, the rotation that aligns the pair symmetrically (the pole pair's bisector onto the
coil pair's, and their difference directions likewise: the least-squares fit of two equal-weight pairs)
leaves each pole within ``|a − s|/2 <= tol`` of its coil. Each candidate's full set of held pairs — every
``(j, k)`` with ``d(R u_j, v_k) <= tol`` — is found by one batched product, candidates with the same set
are merged, and the rotation is refitted to all of its pairs (Kabsch). Everything is vectorised over
candidates in chunks.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy.spatial import cKDTree

from .. import checks
from ..errors import bad_value
from ..so3 import as_rotations, to_quaternion
from ..sphere import NearestPointGrid, tolerant_ranks

CHUNK = 2048
MAX_REFITS = 6
NEAREST = 16  # neighbours per state in StepperStates.components' first pass


def _pair_frames(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Frames (columns) ``[m, n, m × n]`` with ``m ∝ a + b`` and ``n ∝ a − b`` for unit ``a ≠ ±b``."""
    m = a + b
    m /= np.linalg.norm(m, axis=-1, keepdims=True)
    n = a - b
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    return np.stack([m, n, np.cross(m, n)], axis=-1)


def kabsch(state: np.ndarray, pole: np.ndarray, coil: np.ndarray, count: int, u: np.ndarray,
           v: np.ndarray) -> np.ndarray:
    """Rotations ``(count, 3, 3)`` minimising ``Σ |R u_j − v_k|²`` over each state's pairs.

    ``state``, ``pole``, ``coil`` list the pairs; ``H_s = Σ v_k u_jᵀ``, ``R = U diag(1, 1, det) Vᵀ`` from the SVD.
    """
    outer = (v[coil][:, :, None] * u[pole][:, None, :]).reshape(-1, 9)
    H = np.stack([np.bincount(state, weights=outer[:, c], minlength=count) for c in range(9)], axis=1)
    U, _, Vt = np.linalg.svd(H.reshape(-1, 3, 3))
    D = np.ones((count, 3))
    D[:, 2] = np.sign(np.linalg.det(U @ Vt))
    return (U * D[:, None, :]) @ Vt


def quaternion_tree(rotations: np.ndarray) -> tuple[cKDTree, int]:
    """KD-tree on ``±q`` of each rotation: the nearest point in chord distance is the nearest rotation in
    Park's metric, since ``θ = 2 acos|q1·q2|`` and ``|q1 ∓ q2|² = 2 ∓ 2 q1·q2``."""
    q = to_quaternion(rotations)
    return cKDTree(np.vstack([q, -q])), len(q)


def chord_of_park(theta) -> np.ndarray:
    """Quaternion chord ``|q1 − q2|`` at Park distance ``θ``: ``2 sin(θ/4)``."""
    return 2.0 * np.sin(0.25 * np.asarray(theta))


def park_of_chord(chord) -> np.ndarray:
    """Inverse of :func:`chord_of_park`."""
    return 4.0 * np.arcsin(np.clip(0.5 * np.asarray(chord), 0.0, 1.0))


def coil_currents(coils, coil_count: int, failed=(), name: str = "coils") -> np.ndarray:
    """The current vector ``(coil_count,)`` of a mapping ``coil index → current`` (per unit of the nominal
    current, e.g. :meth:`StepperStates.coils`; coils not listed carry 0): the one "coils → currents" helper.
    InputError naming ``name`` for an index outside ``0..coil_count−1``, a non-finite current, or a current
    on one of the ``failed`` coils."""
    try:
        items = dict(coils).items()
    except (TypeError, ValueError):
        raise bad_value(name, "a mapping from coil index to current", coils) from None
    out = np.zeros(coil_count)
    for k, value in items:
        k = checks.count(k, name, 0, coil_count - 1, expected=f"coil indices 0..{coil_count - 1}")
        try:
            out[k] = float(value)
        except (TypeError, ValueError):
            raise bad_value(f"{name}[{int(k)}]", "a real current", value) from None
    if not np.all(np.isfinite(out)):
        raise bad_value(name, "finite currents", "NaN or infinite currents")
    bad = [int(k) for k in failed if out[int(k)] != 0]
    if bad:
        raise bad_value(name, f"no current on the failed coils {sorted(int(k) for k in failed)}",
                        f"current on coil {bad[0]}")
    return out


@dataclass(frozen=True, eq=False)
class StepperStates:
    """``rotations (K, 3, 3)`` with their held pairs: ``pairs[offsets[i]:offsets[i+1]]`` are the
    ``(rotor pole, coil)`` pairs of state ``i``; ``polarity`` is the rotor's, to give each coil its sign."""

    rotations: np.ndarray
    pairs: np.ndarray
    offsets: np.ndarray
    polarity: np.ndarray
    tol: float

    def __len__(self) -> int:
        return len(self.rotations)

    def held(self, i: int) -> list[tuple[int, int]]:
        """``(rotor pole, coil)`` pairs holding state ``i``."""
        return [(int(j), int(k)) for j, k in self.pairs[self.offsets[i]:self.offsets[i + 1]]]

    def coils(self, i: int) -> dict[int, int]:
        """Coils to energise for state ``i``, each with the polarity of the pole it holds."""
        return {k: int(self.polarity[j]) for j, k in self.held(i)}

    @cached_property
    def counts(self) -> np.ndarray:
        """Number of held pairs per state."""
        return np.diff(self.offsets)

    @cached_property
    def _tree(self) -> tuple[cKDTree, int]:
        return quaternion_tree(self.rotations)

    def nearest(self, R, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """Park distances ``(..., k)`` and indices of the ``k`` states nearest to each rotation ``R (..., 3, 3)``."""
        R = as_rotations(R, "R")
        k = checks.count(k, "k", expected="a positive integer")
        if len(self) == 0:
            raise bad_value("design", "a design with at least one stepper state", "none")
        tree, n = self._tree
        q = to_quaternion(R.reshape(-1, 3, 3))
        k_eff = min(k, n)
        if k_eff == 1:
            chord, idx = tree.query(q)
            return park_of_chord(chord).reshape(R.shape[:-2] + (1,)), (idx % n).reshape(R.shape[:-2] + (1,))
        chord, idx = tree.query(q, k=2 * k_eff)  # a state can appear as +q and −q; keep distinct ones
        out_d = np.empty((len(q), k_eff))
        out_i = np.empty((len(q), k_eff), dtype=np.int64)
        for row in range(len(q)):
            _, first = np.unique(idx[row] % n, return_index=True)
            first = np.sort(first)[:k_eff]
            out_d[row], out_i[row] = park_of_chord(chord[row, first]), idx[row, first] % n
        shape = R.shape[:-2] + (k_eff,)
        return out_d.reshape(shape), out_i.reshape(shape)

    def within(self, R, radius: float):
        """Indices of the states within Park distance ``radius`` (rad) of ``R``: an int array for one rotation
        ``(3, 3)``; for a batch ``(..., 3, 3)`` an object array of shape ``(...)`` holding one int array per
        rotation (as :meth:`scipy.spatial.cKDTree.query_ball_point`)."""
        R = as_rotations(R, "R")
        radius = checks.number(radius, "radius", low=0.0, high=np.pi, expected="a Park distance in [0, π] radians")
        if len(self) == 0:
            found = [np.zeros(0, dtype=np.int64) for _ in range(int(np.prod(R.shape[:-2])))]
        else:
            tree, n = self._tree
            q, chord = to_quaternion(R.reshape(-1, 3, 3)), chord_of_park(radius)
            hits = [tree.query_ball_point(q[0], chord)] if R.ndim == 2 else tree.query_ball_point(q, chord)
            # a state is +q and −q in the tree; both lie within a chord below 1 (Park distance 120°) of no point
            distinct = np.sort if chord < 1.0 else np.unique
            found = [distinct(np.asarray(h, dtype=np.int64) % n) for h in hits]
        if R.ndim == 2:
            return found[0]
        out = np.empty(len(found), dtype=object)
        out[:] = found
        return out.reshape(R.shape[:-2])

    def neighbour_pairs(self, radius: float) -> np.ndarray:
        """All pairs ``(a, b)``, ``a < b``, of states within Park distance ``radius`` of each other.

        The tree holds ``+q`` (indices ``< n``) and ``−q``; a pair of states shows up as ``(a, b)`` among the
        ``+q`` or as both ``(a, b + n)`` and ``(b, a + n)``, so one of each is kept.
        """
        tree, n = self._tree
        raw = tree.query_pairs(chord_of_park(radius), output_type="ndarray")
        i, j = raw[:, 0], raw[:, 1]
        keep = (i < n) & ((j < n) | (i < j - n))
        pairs = np.stack([i[keep], j[keep] % n], axis=1)
        return np.sort(pairs, axis=1)

    def components(self, radius: float) -> int:
        """Connected components of the graph joining the states within Park distance ``radius`` (the state
        graph). First pass: each state to its :data:`NEAREST` nearest within ``radius``, a subgraph of the state
        graph, so if it is connected so is the graph (the count is 1, exactly); otherwise the components of all
        pairs (:meth:`neighbour_pairs`). The first pass costs ~``n·NEAREST`` pairs where the graph may hold ~100×
        more (the states' step graph: ~40 s of a 300 000-state layout's 73 s)."""
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        n = len(self)
        if n <= 1:
            return n
        tree, _ = self._tree
        q = to_quaternion(self.rotations)
        _, idx = tree.query(q, k=min(NEAREST + 1, 2 * n), distance_upper_bound=float(chord_of_park(radius)))
        found = idx < 2 * n  # a missing neighbour is reported as index 2n
        a = np.broadcast_to(np.arange(n)[:, None], idx.shape)[found]
        graph = coo_matrix((np.ones(len(a)), (a, idx[found] % n)), shape=(n, n))
        if connected_components(graph, directed=False)[0] == 1:
            return 1
        pairs = self.neighbour_pairs(radius)
        graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
        return int(connected_components(graph, directed=False)[0])


def held_pairs(R: np.ndarray, u: np.ndarray, v: np.ndarray, tol: float,
               grid: NearestPointGrid | None = None) -> tuple[np.ndarray, ...]:
    """Triples ``(state, pole, coil)`` with ``d(R_s u_j, v_k) <= tol``.

    Each coil is taken into the body frame (``R_sᵀ v_k``) and the rotor pole within ``tol`` of it, if any, is
    read from a :class:`~spherestep.sphere.NearestPointGrid` on the poles: ``O(K N)`` work, not ``O(K M N)``.
    """
    grid = NearestPointGrid(u, tol) if grid is None else grid
    out = []
    for start in range(0, len(R), CHUNK):
        Rc = R[start:start + CHUNK]
        # coils in the body frame, R_sᵀ v_k, as one matrix product: (N, 3) @ (3, c·3)
        body = (v @ np.transpose(Rc, (1, 0, 2)).reshape(3, -1)).reshape(len(v), len(Rc), 3).transpose(1, 0, 2)
        pole = grid.match(body)
        s_idx, k_idx = np.nonzero(pole >= 0)
        out.append(np.stack([start + s_idx, pole[s_idx, k_idx], k_idx]))
    state, pole, coil = np.hstack(out) if out else np.zeros((3, 0), dtype=np.int64)
    return state, pole, coil


def _pair_weights(M: int, N: int) -> np.ndarray:
    """Random 64-bit weights per (pole, coil) pair; a state's key is the sum of its pairs' weights
    (wrapping mod 2⁶⁴), equal for equal sets of pairs and, with probability ~1 − K²/2⁶⁴, only for them."""
    return np.random.default_rng(12345).integers(0, 2**63, size=M * N, dtype=np.uint64)


def _arc_matches(u: np.ndarray, v: np.ndarray, tol: float):
    """Coil pairs ``(k1, k2)``, ordered pole pairs ``(j1, j2)`` (antipodal pairs left out: they fix no
    rotation), the order sorting the pole pairs by arc, and per coil pair the range ``[lo, hi)`` of sorted pole
    pairs whose arc is within ``2 tol`` of the coil pair's."""
    k1, k2 = np.triu_indices(len(v), 1)
    s = np.arccos(np.clip(np.sum(v[k1] * v[k2], axis=1), -1, 1))
    j1, j2 = np.nonzero(~np.eye(len(u), dtype=bool))
    a = np.arccos(np.clip(np.sum(u[j1] * u[j2], axis=1), -1, 1))
    framed = a < np.pi - 1e-9
    j1, j2, a = j1[framed], j2[framed], a[framed]
    order = np.argsort(a)
    lo = np.searchsorted(a[order], s - 2 * tol, "left")
    hi = np.searchsorted(a[order], s + 2 * tol, "right")
    return k1, k2, j1, j2, order, lo, hi


def candidate_count(design, tol: float | None = None) -> int:
    """How many (coil pair, ordered pole pair) alignments the enumeration starts from (its cost)."""
    tol = design.state_tol if tol is None else tol
    *_, lo, hi = _arc_matches(design.rotor.centers, design.stator.centers[design.active_coils], tol)
    return int((hi - lo).sum())


def find_states(design, tol: float) -> StepperStates:
    """Enumerate the stepper states of ``design`` at tolerance ``tol`` (radians); see the module docstring."""
    u = design.rotor.centers
    coils = design.active_coils
    v = design.stator.centers[coils]
    M, N = len(u), len(v)
    empty = StepperStates(np.zeros((0, 3, 3)), np.zeros((0, 2), int), np.zeros(1, int), design.polarity, tol)
    if N < 2:
        return empty
    k1, k2, j1, j2, order, lo, hi = _arc_matches(u, v, tol)
    counts = hi - lo
    if counts.sum() == 0:
        return empty
    coil_pair = np.repeat(np.arange(len(k1)), counts)
    pole_pair = order[np.arange(counts.sum()) + np.repeat(lo - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts)]
    R = _pair_frames(v[k1], v[k2])[coil_pair] @ np.swapaxes(_pair_frames(u[j1], u[j2])[pole_pair], -1, -2)
    grid = NearestPointGrid(u, tol)
    weights = _pair_weights(M, N)
    # each candidate is the least-squares fit of the two pairs it was built from; refit to the pairs it
    # actually holds until the two agree, so every state is the Kabsch fit of its own held set (which
    # makes the set of states independent of the order of discovery, and symmetric)
    fitted = weights[j1[pole_pair] * N + k1[coil_pair]] + weights[j2[pole_pair] * N + k2[coil_pair]]
    for attempt in range(MAX_REFITS + 1):
        state, pole, coil = held_pairs(R, u, v, tol, grid)
        keys = np.zeros(len(R), dtype=np.uint64)
        np.add.at(keys, state, weights[pole * N + coil])
        n_pairs = np.bincount(state, minlength=len(R))
        _, first = np.unique(keys, return_index=True)
        keep = first[n_pairs[first] >= 2]  # one candidate per held set, holding at least two pairs
        R, fitted, keys = R[keep], fitted[keep], keys[keep]
        stale = keys != fitted
        if not stale.any():
            break
        if attempt == MAX_REFITS:  # held set still changing: not a clean equilibrium of its pairs
            R = R[~stale]
            break
        remap = np.full(len(n_pairs), -1)
        remap[keep[stale]] = np.arange(int(stale.sum()))
        mine = remap[state] >= 0
        R[stale] = kabsch(remap[state[mine]], pole[mine], coil[mine], int(stale.sum()), u, v)
        fitted = keys
    state, pole, coil = held_pairs(R, u, v, tol, grid)
    n_pairs = np.bincount(state, minlength=len(R))
    ok = n_pairs >= 2
    for item, count in ((pole, M), (coil, N)):  # one pole per coil and one coil per pole
        pair_id, uses = np.unique(state * count + item, return_counts=True)
        ok[pair_id[uses > 1] // count] = False
    keys = np.zeros(len(R), dtype=np.uint64)
    np.add.at(keys, state, weights[pole * N + coil])
    _, first = np.unique(keys, return_index=True)
    unique = np.zeros(len(R), dtype=bool)
    unique[first] = True
    good = ok & unique
    R, n_pairs = R[good], n_pairs[good]
    R, n_pairs = _merge_close(R, n_pairs, 0.05 * tol)
    angle = np.arccos(np.clip((np.trace(R, axis1=1, axis2=2) - 1) / 2, -1, 1))
    # canonical order: most pairs first, then by rotation angle (equal angles within ORDER_TOL, as symmetric states
    # have, keep the order of their held sets' integer keys rather than their last bits)
    order = np.lexsort((tolerant_ranks(angle), -n_pairs))
    R = R[order]
    state, pole, coil = held_pairs(R, u, v, tol, grid)
    pairs = np.stack([pole, coils[coil]], axis=1)
    offsets = np.concatenate([[0], np.cumsum(np.bincount(state, minlength=len(R)))])
    return StepperStates(R, pairs, offsets, design.polarity, tol)


def _merge_close(R: np.ndarray, strength: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Drop states within Park distance ``radius`` of a state holding at least as many pairs."""
    if len(R) < 2:
        return R, strength
    tree, n = quaternion_tree(R)
    pairs = tree.query_pairs(chord_of_park(radius), output_type="ndarray") % n
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    if not len(pairs):
        return R, strength
    a, b = pairs[:, 0], pairs[:, 1]
    loser = np.where((strength[a] > strength[b]) | ((strength[a] == strength[b]) & (a < b)), b, a)
    keep = np.ones(len(R), dtype=bool)
    keep[loser] = False
    return R[keep], strength[keep]
