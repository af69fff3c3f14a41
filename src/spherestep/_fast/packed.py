"""How a torque model hands its energy to the compiled code: :class:`Packed` (no numba is loaded here)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Packed(NamedTuple):
    """A model's energy as compiled zonal terms: ``params`` (the kernels, concatenated, :func:`.kernels.kernel_params`),
    ``offsets (T + 1,)`` (term ``i``'s kernel is ``params[offsets[i]:offsets[i+1]]``), ``coils (N, 3)`` the ``v_k``,
    ``C (..., T, N)`` each term's currents, ``poles (3, M)`` the ``u_j`` (shared by the terms), ``P (T, M)`` each
    term's pole weights, ``signs (T,)`` and ``constant (...)`` the energy's part that does not depend on ``R``
    (J; it sets the rounding level of the descent's line search)."""

    params: np.ndarray
    offsets: np.ndarray
    coils: np.ndarray
    C: np.ndarray
    poles: np.ndarray
    P: np.ndarray
    signs: np.ndarray
    constant: np.ndarray | float = 0.0
