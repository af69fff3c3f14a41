"""The rotor's symmetry, which its field cannot see through, and the marker that breaks it.

A rotation ``g`` (body frame) with ``g u_j = u_{π(j)}`` and ``p_{π(j)} = p_j`` for every pole maps the rotor's
magnets onto themselves (each magnet is axisymmetric about its own radius), so the rotor at ``R g`` is the same
object as at ``R`` and every field reading is identical: orientations are determined only up to the group
``{g}``. :func:`symmetry_group` finds it (for the prototype: the 60 rotations of the icosahedron). The fix
offered here, :func:`marked_design`, reverses the polarity of one pole with a trivial stabiliser (a pole of the
primary, 60-member orbit), which leaves no symmetry; tracking from a known start is the other option (the
nearest copy is 72° away for the icosahedral group, so a tracking loop never jumps to it).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import magpylib as magpy
import numpy as np

from .. import checks, so3
from .._fast.threads import single_blas_thread
from ..errors import bad_value
from ..magnetics import equilibrium, state_currents, torque_map
from ..statics import holding_torque


def _frame(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Orthonormal frame (columns) from two non-parallel unit vectors: ``a``, ``(a × b)/|…|``, and their cross."""
    e2 = np.cross(a, b)
    e2 /= np.linalg.norm(e2)
    return np.stack([a, e2, np.cross(a, e2)], axis=1)


def symmetry_group(design, tol: float = 1e-6, polarity: bool = True) -> np.ndarray:
    """Rotations ``g (G, 3, 3)`` (body frame) mapping every pole onto a pole of the same polarity (any pole if
    ``polarity`` is False: the symmetry of the magnets' places, which a marker leaves as a near-symmetry),
    identity first. Candidates map pole 0 and its nearest non-antipodal neighbour onto every pole pair at
    the same angle; a candidate is kept if every pole lands within ``tol`` of a like pole."""
    u = design.rotor.centers
    p = np.asarray(design.polarity) if polarity else np.ones(len(u), int)
    dots = u @ u[0]
    dots[0] = -2.0
    j = int(np.argmax(np.where(np.abs(dots) < 1 - 1e-9, dots, -2.0)))
    F0 = _frame(u[0], u[j])
    found = []
    pair = u @ u.T
    for a in np.nonzero(p == p[0])[0]:
        for b in np.nonzero((np.abs(pair[a] - u[0] @ u[j]) < 1e-9) & (p == p[j]))[0]:
            if a == b:
                continue
            g = _frame(u[a], u[b]) @ F0.T
            image = u @ g.T
            nearest = np.argmax(image @ u.T, axis=1)
            if np.all(np.linalg.norm(image - u[nearest], axis=1) < tol) and np.all(p[nearest] == p):
                if not any(np.abs(g - h).max() < 1e-9 for h in found):
                    found.append(g)
    G = np.stack(found)
    order = np.argsort(np.abs(G - np.eye(3)).max(axis=(1, 2)))
    return G[order]


def marked_design(design, pole: int | None = None):
    """``design`` with the polarity of ``pole`` reversed (default: the first pole whose stabiliser in the
    symmetry group is trivial), named ``<name>-marked``; its symmetry group is then the identity alone."""
    G = symmetry_group(design)
    u = design.rotor.centers
    if pole is None:
        counts = np.zeros(len(u), int)
        for g in G[1:]:
            counts += np.linalg.norm(u @ g.T - u, axis=1) < 1e-6
        free = np.nonzero(counts == 0)[0]
        if not len(free):
            raise bad_value("pole", "a pole to mark (this rotor has no pole with a trivial stabiliser)", None)
        pole = int(free[0])
    pole = checks.count(pole, "pole", 0, len(u) - 1, f"a pole index in [0, {len(u) - 1}]")
    polarity = np.array(design.polarity, copy=True)
    polarity[pole] = -polarity[pole]
    return replace(design, polarity=polarity, name=f"{design.name}-marked")


@dataclass(frozen=True)
class MarkerEffect:
    """What marking costs the motor (torque map of :mod:`spherestep.magnetics`, N·m): holding torque of
    ``states`` stepper states that hold the marked pole and of as many that do not, before and after; the
    share of states that hold it; the marked rotor's net dipole (A·m², the unmarked one's is zero); and the
    RMS change of the torque over random orientations and drives relative to its RMS."""

    marked_pole: int
    states_holding_marker: float
    holding_marker_before_Nm: tuple[float, ...]
    holding_marker_after_Nm: tuple[float, ...]
    holding_other_before_Nm: tuple[float, ...]
    holding_other_after_Nm: tuple[float, ...]
    dipole_before_Am2: float
    dipole_after_Am2: float
    torque_change_rms: float

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@single_blas_thread
def marker_effect(design, marked, states: int = 2, samples: int = 200, seed=0) -> MarkerEffect:
    """Measure :class:`MarkerEffect` for ``marked`` (from :func:`marked_design`) against ``design``."""
    pole = int(np.nonzero(np.asarray(marked.polarity) != np.asarray(design.polarity))[0][0])
    st = design.states()
    holds = np.array([any(j == pole for j, _ in st.held(i)) for i in range(len(st))])
    rng = np.random.default_rng(seed)
    pick_m = rng.choice(np.nonzero(holds)[0], states, replace=False)
    pick_o = rng.choice(np.nonzero(~holds)[0], states, replace=False)
    maps = {id(design): torque_map(design), id(marked): torque_map(marked)}

    def holding(d, picks):
        c = np.array([state_currents(d, int(i)) for i in picks])
        eq = equilibrium(maps[id(d)], st.rotations[picks], c)
        return tuple(float(x) for x in holding_torque(maps[id(d)], eq.rotation, c).torque)

    moment = design.remanence / magpy.mu_0 * np.pi * (0.5 * design.magnet_diameter) ** 2 * design.magnet_length
    dipole = [float(np.linalg.norm(moment * np.asarray(d.polarity) @ d.rotor.centers)) for d in (design, marked)]
    R = so3.random(samples, rng)
    c = rng.choice([-1.0, 0.0, 0.0, 0.0, 1.0], size=(samples, len(design.stator)))
    T0 = maps[id(design)].torque(R, c)
    T1 = maps[id(marked)].torque(R, c)
    change = float(np.sqrt(np.mean((T1 - T0) ** 2) / np.mean(T0 ** 2)))
    return MarkerEffect(pole, float(holds.mean()), holding(design, pick_m), holding(marked, pick_m),
                        holding(design, pick_o), holding(marked, pick_o), dipole[0], dipole[1], change)
