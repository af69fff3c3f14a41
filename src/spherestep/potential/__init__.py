"""The phenomenological energy of Sec. III-B: eq. (4) for a whole motor, its torque and Hessian, equilibria
and their basins, and the force-curve fit of Fig. 6 (docs/potential.md states every convention).

* :class:`MotorPotential`: ``V(R, c) = ∫ |Σ_j p_j f_r(u·R u_j) − Σ_k c_k f_s(u·v_k)|² du`` by Plancherel with the
  corrected eq. (16) (``energy``), in the equivalent pairwise Funk–Hecke form (``energy_pairwise``), by brute
  force (``energy_quadrature``), over an SO(3) Euler grid by FFT (``energy_grid``); ``torque`` is
  ``τ = −∂V/∂ω`` for ``R → exp(ω̂) R``, in the fixed frame.
* Profiles: :class:`VonMisesFisher` (default, half maximum at the face's rim), :class:`RaisedCosine`;
  :class:`ZonalKernel` tabulates the overlap ``G(t)``.
* Equilibria, basins and stiffness of this (and every) torque model: :mod:`spherestep.statics`.
* :func:`fit_force_curve`, :func:`potential_from_force`, :func:`fit_profile`: Fig. 6.
"""

from .force import (
    ProfileFit,
    example_force_curve,
    fit_force_curve,
    fit_profile,
    load_force_curve,
    pair_potential,
    potential_from_force,
    save_force_curve,
    synthetic_force_curve,
)
from .kernel import ZonalKernel
from .model import MotorPotential, coil_currents
from .profiles import RaisedCosine, VonMisesFisher, ZonalProfile

__all__ = [
    "MotorPotential",
    "ProfileFit",
    "RaisedCosine",
    "VonMisesFisher",
    "ZonalKernel",
    "ZonalProfile",
    "coil_currents",
    "example_force_curve",
    "fit_force_curve",
    "fit_profile",
    "load_force_curve",
    "pair_potential",
    "potential_from_force",
    "save_force_curve",
    "synthetic_force_curve",
]
