"""Harmonic analysis on the sphere and the rotation group (Sec. III-B-1, III-B-2).

Conventions (docs/harmonics.md states them with their derivations and checks):

* ``Y_l^m`` (eq. (5)): Condon–Shortley phase, equal to ``scipy.special.sph_harm_y``; ``θ`` polar, ``φ`` azimuth.
* ``P^l_mn`` (eq. (10), Vilenkin–Klimyk): ``P^l_mn(cos β) = (−1)^(m−n) d^l_mn(β)`` with Wigner's small ``d``.
* ``U^l_mn(R)`` (eq. (8), ZXZ angles of :mod:`spherestep.so3`): ``i^(m−n) e^(−i(mα+nγ)) P^l_mn(cos β)``, a unitary
  homomorphism; the physicists' ``D^l_mn = (−1)^(m−n) U^l_mn``.
* Eq. (16) as printed cannot hold together with the homomorphism; the form that does is
  ``Y_l^n(Rᵀ u) = Σ_m (−1)^(m−n) U^l_mn(R) Y_l^m(u) = Σ_m D^l_mn(R) Y_l^m(u)``.
* SO(3) transform (eqs. (13)–(14)) as printed; the convolution theorem then reads ``(f1 * f2)^ = f̂2 f̂1``.
"""

from ._legendre import half_pi_matrix, legendre_P, legendre_P_matrix
from ._s2 import S2Grid, s2_evaluate, s2_forward, s2_grid, s2_inverse, s2_rotate, sph_harm, sph_harm_u
from ._so3fourier import SO3Grid, so3_convolve, so3_evaluate, so3_forward, so3_grid, so3_inverse
from ._wigner import wigner_D, wigner_U, wigner_U_zxz, wigner_U_zyz

__all__ = [
    "S2Grid",
    "SO3Grid",
    "half_pi_matrix",
    "legendre_P",
    "legendre_P_matrix",
    "s2_evaluate",
    "s2_forward",
    "s2_grid",
    "s2_inverse",
    "s2_rotate",
    "so3_convolve",
    "so3_evaluate",
    "so3_forward",
    "so3_grid",
    "so3_inverse",
    "sph_harm",
    "sph_harm_u",
    "wigner_D",
    "wigner_U",
    "wigner_U_zxz",
    "wigner_U_zyz",
]
