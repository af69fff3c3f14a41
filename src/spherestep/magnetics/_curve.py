"""The Fig. 6 experiment in simulation: one rotor magnet slid sideways under one energised coil.

Set-up (Sec. III-B, Fig. 6): the coil's axis is ``z``, its flat face in the plane ``z = 0`` and its body in
``z > 0``; the magnet's axis is parallel to it, its face a design gap ``g`` below (``z = −g``), centre at
``(x, 0, −g − l_m/2)``. The magnet is translated along ``x`` in the plane normal to the coil's axis and the
force on it is recorded: ``F_x(x)`` is the lateral (restoring) force, ``F_z(x)`` the normal one (positive
towards the coil: attraction). Magnet polarization ``+B_r ẑ`` (a ``+1`` pole seen by the coil) and coil
current ``+1`` (``coil_ampere_turns``), so the coil attracts: ``F_x`` points back towards ``x = 0``.
On the ball the magnet moves on a sphere instead; ``R_s F_x(R_s α)`` is the paper's translational estimate
of the torque at pole angle ``α`` (``pair_torque`` gives the exact one, see the docs).
"""

from __future__ import annotations

from dataclasses import dataclass

import magpylib as magpy
import numpy as np

from .. import checks
from ..errors import bad_value
from ..potential import save_force_curve
from ._direct import EPS
from ._model import as_meshing, coil_polarization

CURVE_MESHING = 1000  # cells in the sliding magnet (0.1 % of the peak; see _direct's convergence notes)


@dataclass(frozen=True)
class ForceCurve:
    """Lateral and normal force (N) on the magnet at each lateral ``displacement`` (m), with the set-up's
    parameters (SI) and the mesh used."""

    displacement: np.ndarray
    lateral: np.ndarray
    normal: np.ndarray
    gap: float
    meshing: int

    def save(self, path, design_name: str = "design"):
        """Write ``displacement_m,force_N`` (the lateral force) with ``#`` lines saying it is a simulation,
        in the format of :func:`spherestep.potential.save_force_curve` (read back by ``load_force_curve``)."""
        note = (f"SIMULATED with magpylib {magpy.__version__} getFT, not measured: the Fig. 6 experiment for "
                f"design {design_name!r}.\n"
                f"One rotor magnet translated by x in the plane normal to one coil's axis at a {1e3 * self.gap:.4g} mm "
                f"gap; force_N is the lateral force on the magnet along +x (negative: pulled back).\n"
                f"Coil at current +1 as a uniformly magnetised cylinder (air core), magnet +1, "
                f"{self.meshing} mesh cells (spherestep.magnetics.force_curve).")
        return save_force_curve(path, self.displacement, self.lateral, note)


def force_curve(design, displacements, meshing: int = CURVE_MESHING, gap: float | None = None) -> ForceCurve:
    """Force on one rotor magnet translated by ``displacements`` (m, 1-D) in the plane normal to an energised
    coil's axis, at ``gap`` (m, default the design's air gap), by ``magpylib.getFT`` on a target path.

    >>> from spherestep.motor import prototype
    >>> c = force_curve(prototype(), [0.0, 0.01], meshing=8)
    >>> bool(c.lateral[1] < 0 < c.normal[0])   # restoring sideways, attracting along the axis
    True
    """
    x = np.asarray(displacements, dtype=float)
    if x.ndim != 1 or len(x) == 0 or not np.all(np.isfinite(x)):
        raise bad_value("displacements", "a non-empty 1-D array of finite lateral displacements in metres",
                        f"shape {x.shape}" if x.ndim != 1 or len(x) == 0 else "NaN or infinite entries")
    meshing = as_meshing(meshing)
    g = design.air_gap if gap is None else gap
    g = checks.non_negative(g, "gap", "a finite non-negative length in metres")
    coil = magpy.magnet.Cylinder(dimension=(design.coil_diameter, design.coil_length),
                                 polarization=(0.0, 0.0, coil_polarization(design)),
                                 position=(0.0, 0.0, 0.5 * design.coil_length))
    centres = np.zeros((len(x), 3))
    centres[:, 0] = x
    centres[:, 2] = -g - 0.5 * design.magnet_length
    magnet = magpy.magnet.Cylinder(dimension=(design.magnet_diameter, design.magnet_length),
                                   polarization=(0.0, 0.0, design.remanence), position=centres)
    F, _ = magpy.getFT(coil, magnet, meshing=meshing, eps=EPS, squeeze=False)
    F = F[0, :, 0, :]
    return ForceCurve(x.copy(), F[:, 0].copy(), F[:, 2].copy(), float(g), meshing)
