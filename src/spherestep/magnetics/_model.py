"""The motor as magpylib objects: rotor magnets and stator electromagnets (Sec. IV).

Geometry (fixed frame, metres). Rotor pole ``j`` at orientation ``R`` points along ``w_j = R u_j``. Its magnet
is a cylinder of diameter ``d_m`` and length ``l_m`` glued inside the shell, axis radial, outer face on the
sphere: centre ``(R_s − l_m/2) w_j`` with ``R_s`` the rotor radius, polarization ``B_r p_j w_j`` (``B_r`` the
remanence in tesla, ``p_j = ±1``: north out for +1).

Coil ``k`` sits outside the ball on the axis ``v_k``, its flat face a gap ``g`` from the sphere: centre
``(R_s + g + l_c/2) v_k``, a cylinder of diameter ``d_c`` and length ``l_c``.

Coil model (the choice of this module). A solenoid of ``N I`` ampere-turns wound uniformly along a length
``l_c`` is a cylindrical current sheet of density ``K = N I / l_c`` (A/m). A cylinder magnetised uniformly
with ``M = N I / l_c`` along its axis has exactly that surface current (``K = M × n`` on its side, nothing on
its end faces), so outside the cylinder both have the same field. We therefore model coil ``k`` driven with
current ``c_k`` (``±1`` nominal) as a :class:`magpylib.magnet.Cylinder` with polarization

    J_k = μ0 · c_k · NI / l_c   (tesla) along +v_k,

``NI = design.coil_ampere_turns``. The sign makes a coil with ``c_k = +1`` attract a ``+1`` pole: both are
polarised outwards, so the coil's inner face is a south pole facing the magnet's north face.

Limits of the model, stated once:

* Air core. The prototype's electromagnets wind soft-iron cores (Sec. IV); the iron concentrates the field
  and raises the moment by the core's apparent permeability (bounded by its demagnetising factor, a few
  for a core about as long as it is wide). Unsaturated, that is a linear gain: fold it into
  ``coil_ampere_turns``. Not modelled: saturation, hysteresis, eddy currents, and the attraction between the
  rotor magnets and the unenergised iron (detent torque), which is why with all coils off this model gives
  no torque at all.
* The winding is a thin sheet at the coil's outer diameter carrying all the ampere-turns; a thick winding
  of inner radius ``a`` has the smaller moment ``N I π (a² + a b + b²)/3`` (``b = d_c/2``).
* Rigid, ideal magnets: uniform polarization, no demagnetisation by the coils (NdFeB's recoil permeability
  is ≈ 1.05), and each magnet's field ignores the others' material.

Magnet–magnet forces inside the rotor are internal and exert no net torque on it (checked in the tests),
and coils do not move: the torque on the rotor comes from the stator's field alone, which is linear in the
currents. That is what makes the per-coil torque fields and the pair table of :mod:`._table` exact
decompositions of this model.
"""

from __future__ import annotations

import math

import magpylib as magpy
import numpy as np
from scipy.spatial.transform import Rotation

from .. import checks, so3
from ..errors import bad_value

MU0 = float(magpy.mu_0)  # vacuum permeability, T·m/A (magpylib's value, 1.25663706127e-6)


def z_to(directions) -> Rotation:
    """Rotations taking ``+z`` onto each unit vector of ``directions (n, 3)``: about ``z × d`` by ``acos(d_z)``
    (about ``x`` by π for ``d = −z``). A cylinder's local axis is ``z`` in magpylib."""
    d = np.asarray(directions, dtype=float).reshape(-1, 3)
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    axis = np.stack([-d[:, 1], d[:, 0], np.zeros(len(d))], axis=1)
    s = np.linalg.norm(axis, axis=1)
    angle = np.arctan2(s, d[:, 2])
    unit = np.where(s[:, None] > 1e-15, axis / np.where(s > 1e-15, s, 1.0)[:, None], [1.0, 0.0, 0.0])
    return Rotation.from_rotvec(unit * angle[:, None])


def coil_polarization(design) -> float:
    """Polarization (T) of a coil at unit current: ``μ0 · NI / l_c`` (the equivalent-magnetization model)."""
    return MU0 * design.coil_ampere_turns / design.coil_length


def magnet_centre_radius(design) -> float:
    """Distance (m) from the sphere's centre to a rotor magnet's centre: ``R_s − l_m/2``."""
    return design.radius - 0.5 * design.magnet_length


def coil_centre_radius(design) -> float:
    """Distance (m) from the sphere's centre to a coil's centre: ``R_s + g + l_c/2``."""
    return design.radius + design.air_gap + 0.5 * design.coil_length


def rotor_magnets(design, poles=None) -> list:
    """The rotor magnets (at the identity orientation) as magpylib ``Cylinder`` objects, one per pole in
    ``poles`` (default all), polarized ``B_r p_j`` along the outward radius."""
    idx = np.arange(len(design.rotor)) if poles is None else np.asarray(poles, dtype=int)
    u = design.rotor.centers[idx]
    rot = z_to(u)
    r = magnet_centre_radius(design)
    dim = (design.magnet_diameter, design.magnet_length)
    return [magpy.magnet.Cylinder(dimension=dim, polarization=(0.0, 0.0, design.remanence * int(p)),
                                  position=r * uj, orientation=rot[i])
            for i, (uj, p) in enumerate(zip(u, design.polarity[idx]))]


def rotor_collection(design, R=None) -> magpy.Collection:
    """The rotor as one magpylib ``Collection`` about the sphere's centre; with ``R (K, 3, 3)`` its
    orientation is a path of ``K`` rotations (every magnet turns with it about the origin)."""
    rotor = magpy.Collection(*rotor_magnets(design), style_label=f"{design.name} rotor")
    if R is not None:
        rotor.orientation = Rotation.from_matrix(so3.as_rotations(R, "R").reshape(-1, 3, 3))
    return rotor


def stator_coils(design, coils=None, currents=None) -> list:
    """The coils in ``coils`` (default all) as magpylib ``Cylinder`` objects in the fixed frame, each with
    polarization ``μ0 c_k NI / l_c`` along its outward axis (``currents`` default 1 for every coil)."""
    idx = np.arange(len(design.stator)) if coils is None else np.asarray(coils, dtype=int)
    c = np.ones(len(idx)) if currents is None else np.asarray(currents, dtype=float)
    v = design.stator.centers[idx]
    rot = z_to(v)
    r = coil_centre_radius(design)
    j0 = coil_polarization(design)
    dim = (design.coil_diameter, design.coil_length)
    return [magpy.magnet.Cylinder(dimension=dim, polarization=(0.0, 0.0, j0 * float(ck)),
                                  position=r * vk, orientation=rot[i])
            for i, (vk, ck) in enumerate(zip(v, c))]


def as_rotations(R) -> tuple[np.ndarray, tuple[int, ...]]:
    """``R`` through the one rotation contract (:func:`spherestep.so3.as_rotations`: ``(..., 3, 3)`` proper
    rotations, any batch shape, InputError naming ``R``), flattened to ``(K, 3, 3)``, and its batch shape."""
    arr = so3.as_rotations(R, "R")
    return arr.reshape(-1, 3, 3), arr.shape[:-2]


def unflatten(x: np.ndarray, batch: tuple[int, ...]) -> np.ndarray:
    """``x (K, ...)`` computed on flattened rotations, shaped back to ``batch + (...)``."""
    return x.reshape(batch + x.shape[1:])


def currents_for(currents, N: int, failed, batch: tuple[int, ...]) -> np.ndarray:
    """``currents`` through the one currents contract (:func:`spherestep.checks.currents`), broadcast to the
    rotations' batch shape ``batch`` and flattened to ``(K, N)`` (a single ``(N,)`` row serves every rotation);
    InputError naming ``currents`` when they do not broadcast to ``batch + (N,)``."""
    c = checks.currents(currents, N, tuple(failed))
    try:
        return np.broadcast_to(c, batch + (N,)).reshape(-1, N)
    except ValueError:
        raise bad_value("currents", f"one current per coil, shape ({N},) or {batch + (N,)} (nominal ±1, 0 off)",
                        f"shape {c.shape}") from None


def as_meshing(meshing, name: str = "meshing") -> int:
    """A positive integer number of force-mesh cells per magnet."""
    return checks.count(meshing, name, expected="a positive integer (cells per magnet for magpylib.getFT)")


def model_summary(design) -> dict:
    """The model's radii (m), the coil polarization (T) and magnetic moment (A·m²) at unit current."""
    return {"magnet_centre_m": magnet_centre_radius(design), "coil_centre_m": coil_centre_radius(design),
            "face_gap_m": design.air_gap, "coil_polarization_T": coil_polarization(design),
            "coil_moment_Am2": coil_polarization(design) / MU0 * math.pi * (0.5 * design.coil_diameter) ** 2
            * design.coil_length}
