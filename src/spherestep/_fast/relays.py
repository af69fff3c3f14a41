"""Compiled (numba) bookkeeping of one step of the potential planner (:mod:`spherestep.commutation.potential_planner`).

The step's arithmetic that decides which candidate comes first stays NumPy's — the closeness of pole–coil
pairs and the products ``R1ᵀ R2`` behind Park's metric — so these loops order ties exactly as the NumPy form
did; what they save is the NumPy form's dozens of small array operations per step. A module apart, loaded
on the planner's first call, so that importing :mod:`spherestep.commutation` does not load numba (as
:mod:`spherestep.statics` loads :mod:`spherestep._fast.descent` only to descend).
"""

from __future__ import annotations

import math

import numpy as np
from .compiling import njit


@njit(cache=True)
def closest_pairs(offsets, pairs, polarity, ids, closeness, max_coils, coil_count):
    """Currents ``(len(ids), coil_count)``: state ``s = ids[g]`` holds the pairs ``(j, k)`` in rows ``offsets[s]``
    to ``offsets[s + 1]`` of ``pairs`` (``closeness`` lists them state after state; it is needed only for a
    state holding more than ``max_coils``); its ``max_coils`` closest, ties in row order, set ``c_k = polarity_j``."""
    out = np.zeros((len(ids), coil_count))
    first = 0
    for g in range(len(ids)):
        lo, hi = offsets[ids[g]], offsets[ids[g] + 1]
        keep = np.arange(lo, hi)
        if hi - lo > max_coils:
            if first + hi - lo > len(closeness):
                raise ValueError("closest_pairs: a state holds more than max_coils pairs and no closeness is given")
            keep = lo + np.argsort(closeness[first:first + hi - lo], kind="mergesort")[:max_coils]
        for r in keep:
            out[g, pairs[r, 1]] = polarity[pairs[r, 0]]
        first += hi - lo
    return out


@njit(cache=True)
def distinct(options):
    """Indices of the distinct rows of ``options (n, N)`` in order of first appearance, each the index of the
    row's last appearance."""
    index = np.arange(len(options))
    seen = np.zeros(len(options), dtype=np.bool_)
    for a in range(len(options)):
        if seen[a]:
            continue
        for b in range(a + 1, len(options)):
            if not seen[b] and np.all(options[a] == options[b]):
                index[a] = b
                seen[b] = True
    return index[~seen]


@njit(cache=True)
def best(from_rest, from_target, H, converged, reach):
    """Index of the equilibrium ``R_b`` nearest the target (the first of equals) among the strict minima —
    converged, Hessian ``H[b]`` positive definite — within Park distance ``reach`` of the previous rest ``R̃``;
    −1 if none. ``from_rest``, ``from_target`` ``(B, 3, 3)``: ``R_bᵀ R̃`` and ``R_bᵀ R_target``. The Hessians are
    checked nearest first, by LAPACK's eigenvalues as :func:`numpy.linalg.eigvalsh` (as
    :attr:`spherestep.statics.Equilibrium.is_minimum`)."""
    error = np.full(len(H), np.inf)
    for b in range(len(H)):
        if converged[b] and angle(from_rest[b]) <= reach:
            error[b] = angle(from_target[b])
    for b in np.argsort(error, kind="mergesort"):
        if error[b] == np.inf:
            break
        if np.isfinite(H[b]).all() and np.linalg.eigvalsh(H[b])[0] > 0:
            return b
    return -1


@njit(cache=True)
def angles(turns):
    """:func:`angle` of each of ``turns (n, 3, 3)``."""
    out = np.empty(len(turns))
    for n in range(len(turns)):
        out[n] = angle(turns[n])
    return out


@njit(cache=True)
def angle(M):
    """Park's metric ``θ`` from ``M = R1ᵀ R2`` as :func:`spherestep.so3.distance` takes it (``sin θ = |vect M|``,
    ``cos θ = (tr M − 1)/2``), bit for bit."""
    x, y, z = M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]
    return math.atan2(0.5 * math.sqrt(x * x + y * y + z * z), 0.5 * (M[0, 0] + M[1, 1] + M[2, 2] - 1.0))
