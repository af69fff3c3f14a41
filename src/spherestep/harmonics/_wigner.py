"""Matrix elements ``U^l_mn(R)`` of the irreducible unitary representations of SO(3), eqs. (8)–(9).

Rows and columns run over ``m, n = −l..l`` (row ``m+l``, column ``n+l``). ``U^l(R1 R2) = U^l(R1) U^l(R2)``
holds for eq. (8) with ``P^l_mn`` of eq. (10); in terms of the physicists' Wigner matrix (ZYZ,
``D^l_mn = e^(−imα) d^l_mn(β) e^(−inγ)``) it reads ``U^l_mn(R) = (−1)^(m−n) D^l_mn(R)``.
"""

from __future__ import annotations

import numpy as np
from ..so3 import to_euler_zxz

from . import _checks
from ._legendre import matrix_of_beta


def wigner_U(l, R) -> np.ndarray:
    """``U^l(R)`` of eq. (8) for rotations ``R`` ``(..., 3, 3)``: complex array ``(..., 2l+1, 2l+1)``.

    ``U^l_mn(R) = i^(m−n) e^(−i(mα + nγ)) P^l_mn(cos β)`` with ZXZ angles ``R = R3(α) R1(β) R3(γ)``
    (the convention of :func:`spherestep.so3.to_euler_zxz`, computed here by :func:`euler_zxz`, which stays
    accurate near ``β = 0``). A homomorphism, ``U^l(R1 R2) = U^l(R1) U^l(R2)``, and unitary.

    >>> import numpy as np
    >>> np.allclose(wigner_U(1, np.eye(3)), np.eye(3))
    True

    See also: :func:`wigner_U_zxz`, :func:`wigner_U_zyz`, :func:`wigner_D`.
    """
    l = _checks.degree(l)
    return _zxz(l, *euler_zxz(R))


def wigner_U_zxz(l, alpha, beta, gamma) -> np.ndarray:
    """Eq. (8): ``U^l_mn(R3(α) R1(β) R3(γ)) = i^(m−n) e^(−i(mα + nγ)) P^l_mn(cos β)``.

    The angles broadcast together; the result is ``shape + (2l+1, 2l+1)``. Any real ``β`` is accepted: outside
    ``[0, π]`` the factor ``P^l_mn(cos β)`` is continued in ``β`` (``P^l(cos β)`` is analytic in ``β``), so the
    result is still ``U^l`` of the rotation ``R3(α) R1(β) R3(γ)``.
    """
    l = _checks.degree(l)
    alpha, beta, gamma = np.broadcast_arrays(
        _checks.angles(alpha, "alpha"), _checks.angles(beta, "beta"), _checks.angles(gamma, "gamma"))
    return _zxz(l, alpha, beta, gamma)


def wigner_U_zyz(l, alpha, beta, gamma) -> np.ndarray:
    """Eq. (9): ``U^l_mn(R3(α) R2(β) R3(γ)) = e^(−imα) P^l_mn(cos β) e^(−inγ)``.

    Same matrix function as :func:`wigner_U_zxz`, read through ``R_ZYZ(α, β, γ) = R_ZXZ(α + π/2, β, γ − π/2)``;
    any real angles.
    """
    l = _checks.degree(l)
    alpha, beta, gamma = np.broadcast_arrays(
        _checks.angles(alpha, "alpha"), _checks.angles(beta, "beta"), _checks.angles(gamma, "gamma"))
    return _zyz(l, alpha, beta, gamma)


def wigner_D(l, R) -> np.ndarray:
    """The physicists' Wigner matrix ``D^l_mn(R) = (−1)^(m−n) U^l_mn(R)`` (ZYZ: ``e^(−imα) d^l_mn(β) e^(−inγ)``).

    It carries spherical harmonics with the Condon–Shortley phase (:func:`sph_harm`) under rotation:
    ``Y_l^n(Rᵀ u) = Σ_m D^l_mn(R) Y_l^m(u)``, the corrected form of eq. (16).
    """
    l = _checks.degree(l)
    power = _i_to_the(l)  # (−1)^(m−n) i^(m−n) = (−i)^m i^n
    return _zyz(l, *euler_zxz(R), power.conj(), power)


def euler_zxz(R) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ZXZ angles ``(α, β, γ)`` of ``R = R3(α) R1(β) R3(γ)``, each ``R.shape[:-2]``
    (:func:`spherestep.so3.to_euler_zxz`, exact near ``β = 0``)."""
    angles = to_euler_zxz(R)  # the one rotation contract, naming R
    return angles[..., 0], angles[..., 1], angles[..., 2]


def _zyz(l: int, alpha, beta, gamma, row_phase=1.0, column_phase=1.0) -> np.ndarray:
    idx = np.arange(-l, l + 1)
    left = np.exp(-1j * np.multiply.outer(alpha, idx)) * row_phase
    right = np.exp(-1j * np.multiply.outer(gamma, idx)) * column_phase
    out = left[..., :, None] * right[..., None, :]
    out *= matrix_of_beta(l, beta)
    return out


def _zxz(l: int, alpha, beta, gamma) -> np.ndarray:
    power = _i_to_the(l)
    return _zyz(l, alpha, beta, gamma, power, power.conj())


def i_power(l: int) -> np.ndarray:
    """``i^(m−n)`` for ``m, n = −l..l`` (row ``m+l``, column ``n+l``), exactly."""
    power = _i_to_the(l)
    return power[:, None] * power.conj()[None, :]


def _i_to_the(l: int) -> np.ndarray:
    return np.array([1, 1j, -1, -1j])[np.arange(-l, l + 1) % 4]
