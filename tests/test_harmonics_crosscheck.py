"""spherestep.harmonics against SymPy's independent Wigner functions (skipped when SymPy is not installed).

SymPy's ``Rotation.D(j, m, n, α, β, γ)`` is the physicists' ``e^(−imα) d^j_mn(β) e^(−inγ)`` (ZYZ), evaluated
symbolically; ``wigner_d_small(j, β)`` is the matrix ``d^j(β)`` with rows and columns ``m = −j..j``, compared here
through the relation ``P^l_mn(cos β) = (−1)^(m−n) d^l_mn(β)``. Tolerance 1e-13 absolute.
"""

from __future__ import annotations

import numpy as np
import pytest

from spherestep import so3
from spherestep.harmonics import legendre_P_matrix, wigner_D, wigner_U

sympy = pytest.importorskip("sympy")
from sympy.physics.quantum.spin import Rotation  # noqa: E402
from sympy.physics.wigner import wigner_d_small  # noqa: E402


@pytest.mark.slow
def test_wigner_D_and_U_against_sympy_rotation_D():
    alpha, beta, gamma = 0.7, 1.1, -2.0
    R = so3.from_euler_zyz([alpha, beta, gamma])
    for l in range(0, 5):
        idx = np.arange(-l, l + 1)
        reference = np.array([[complex(sympy.N(Rotation.D(l, m, n, alpha, beta, gamma).doit(), 30)) for n in idx]
                              for m in idx])
        assert np.max(np.abs(wigner_D(l, R) - reference)) < 1e-13
        signs = (-1.0) ** (idx[:, None] - idx[None, :])
        assert np.max(np.abs(wigner_U(l, R) - signs * reference)) < 1e-13


def test_legendre_P_matrix_against_sympy_wigner_d_small():
    beta = 1.1
    for l in range(0, 7):
        d = np.array(sympy.N(wigner_d_small(sympy.Integer(l), sympy.Float(beta, 30)), 30), dtype=float)
        idx = np.arange(-l, l + 1)
        assert np.max(np.abs(legendre_P_matrix(l, np.cos(beta)) - (-1.0) ** (idx[:, None] - idx[None, :]) * d)) < 1e-13
