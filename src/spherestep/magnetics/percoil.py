"""Per-coil terms of a torque model: each coil's gain, the placement of its field and the windings' saturation
(:class:`PerCoil`).

``τ(R, c) = τ₀(R, k ⊙ σ(c)) + Σ_{j moved} [τ_j(R, k_j σ(c_j); Q_j v_j) − τ_j(R, k_j σ(c_j); v_j)]``

* ``k (N,)`` each coil's gain: a column scale of ``K(R)`` (``τ = b(R) + K(R) diag(k) c``, linear in the holds);
  ``k = 0`` a dead coil, ``k = −1`` a reversed one. Its core's detent stays (the iron is there, powered or not).
* ``turns (N, 3)`` rad, a small rotation ``Q_j = exp(turns_j)`` of coil ``j``'s field about the sphere's centre:
  coil ``j``'s pair terms (detent and winding, ``τ_j``) are moved from its centre ``v_j`` to ``Q_j v_j``. The
  cores' coupling (a whole-stator table) is kept at the nominal places. A turn about ``v_j`` itself changes
  nothing (the pair tables are axisymmetric): two components per coil are seen.
* ``knee`` (per unit current, None: linear): the cores' flux limit, ``σ(c) = knee · tanh(c / knee)``
  (:meth:`PerCoil.winding_currents`): each winding's torque falls below linear as its current nears the knee
  (``σ(c) ≈ c − c³/(3 knee²)``), the detent (zero current) unchanged. A phenomenological stand-in for a core
  driven into saturation: the iron model's own saturating solve (``data/iron_saturation.csv``) finds this
  prototype's winding term within ~2 % of linear at ±1 nominal; ``--plant-error saturation=`` emulates a core that
  saturates sooner.

Exact for the pair terms; the base model's compiled path is kept when no coil is moved and the windings are linear
(the gains only scale the currents: :attr:`affine_in_currents` holds), otherwise the moved coils' correction runs
in NumPy.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..statics import TorqueModelBase


class PerCoil(TorqueModelBase):
    """``base`` (a torque model; turns need an :class:`~spherestep.magnetics.IronTorqueMap`) with per-coil
    ``gains (N,)``, field ``turns (N, 3)`` rad and the windings' saturation ``knee`` (per unit; module
    docstring)."""

    def __init__(self, base, gains=None, turns=None, knee: float | None = None):
        from ._ironmap import IronTorqueMap

        if isinstance(base, PerCoil):
            raise bad_value("base", "a torque model without per-coil terms (give the gains and turns at once)",
                            "a PerCoil")
        N = base.coil_count
        self.base = base
        self.coil_count, self.failed, self.has_bias = N, base.failed, base.has_bias
        self.gains = np.ones(N) if gains is None else np.asarray(gains, dtype=float).reshape(N)
        self.turns = np.zeros((N, 3)) if turns is None else np.asarray(turns, dtype=float).reshape(N, 3)
        if not (np.all(np.isfinite(self.gains)) and np.all(np.isfinite(self.turns))):
            raise bad_value("gains", "finite gains and turns", "a NaN or infinity")
        self.knee = None if knee is None else checks.positive(knee, "knee")
        self.moved = np.nonzero(np.linalg.norm(self.turns, axis=1) > 0)[0]
        self.near = self.far = None
        if len(self.moved):
            if not isinstance(base, IronTorqueMap):
                raise bad_value("turns", "zero unless the base is an iron model (its pair terms are moved)",
                                type(base).__name__)
            pair = replace(base, coupling=None).subset(self.moved)
            Q = so3.exp(self.turns[self.moved])
            moved = np.einsum("kab,kb->ka", Q, pair.linear.coils)
            self.far = pair
            self.near = replace(pair, detent=replace(pair.detent, coils=moved),
                                linear=replace(pair.linear, coils=moved))
        self.affine_in_currents = bool(base.affine_in_currents) and not len(self.moved) and self.knee is None

    def winding_currents(self, currents) -> np.ndarray:
        """``σ(c) = knee · tanh(c / knee)`` (``c`` itself without a knee): what each winding's torque sees."""
        c = np.asarray(currents, dtype=float)
        return c if self.knee is None else self.knee * np.tanh(c / self.knee)

    def _c(self, currents) -> np.ndarray:
        return self.winding_currents(self.as_currents(currents)) * self.gains

    def packed_terms(self, currents):
        """The base model's terms at the scaled currents (none when a coil is moved)."""
        return None if len(self.moved) else self.base.packed_terms(self._c(currents))

    def _delta(self, R, c, what: str):
        if not len(self.moved):
            return 0.0
        cm = c[..., self.moved]
        return getattr(self.near, what)(R, cm) - getattr(self.far, what)(R, cm)

    def torque(self, R, currents) -> np.ndarray:
        c = self._c(currents)
        return self.base.torque(R, c) + self._delta(R, c, "torque")

    def energy(self, R, currents) -> np.ndarray:
        c = self._c(currents)
        return self.base.energy(R, c) + self._delta(R, c, "energy")

    def hessian(self, R, currents) -> np.ndarray:
        if len(self.moved):
            return super().hessian(R, currents)
        return self.base.hessian(R, self._c(currents))

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``K(R) diag(k ⊙ σ'(c))`` with the moved coils' columns from their moved places (``σ' = 1`` at zero
        current or without a knee)."""
        K = np.array(self.base.torque_matrix(R), dtype=float)
        if len(self.moved):
            K[..., self.moved] += self.near.torque_matrix(R) - self.far.torque_matrix(R)
        if currents is None or self.knee is None:
            return K * self.gains
        slope = 1.0 / np.cosh(self.as_currents(currents) / self.knee) ** 2
        return K * (self.gains * slope)[..., None, :]

    def torque_reference(self, currents) -> np.ndarray:
        return self.base.torque_reference(currents)
