"""Plants the model does not know exactly: the mismatched motors of the servo's robustness table (issue 25 §2) and
of the calibration (issue 26).

* :func:`scaled_model` — the iron model with the winding's torque ``L(R)``, the pairwise detent ``D(R)`` and the
  coupling through the cores ``Δ(R)`` scaled, ``T = s_d D(R) + s_c Δ(R) + s_w L(R) c``: exact, because the model
  is those maps (the tables scaled node by node, the coupling's series coefficient by coefficient); an air-core
  :class:`TorqueMap` has no detent (``detent`` and ``coupling`` must be 1).
* :func:`shell_model` — the iron model with the rotor's shell (the wall in front of the magnets, hence the gap to
  the cores; :data:`._iron.ROTOR_SHELL` nominally) ``change`` m thicker: the nominal (FEM-based) pair tables plus
  the moment method's change at each node, ``τ(α) = τ_FEM(α) + τ_MoM(α; t + Δt) − τ_MoM(α; t)``. The change is
  added rather than the ratio multiplied because the tables cross zero (the linear table near 12.5°), where a
  ratio is undefined; the two agree to first order elsewhere. The prototype's ±0.3 mm tables are stored
  (``spherestep/data/iron_shell_table.csv``, ``python scripts/iron_shell_tables.py``, a minute); any other shell or
  design is solved on first use (minutes) and cached.
* :class:`CoupledPlant` — the iron model with the coupling through the cores (``iron_model(design,
  coupling=True)``; made when that model cost 0.16 s per orientation, before it was compiled) as a plant: the
  pairwise model plus the coupling's torque ``Δ(R) = T_coupled(R, 0) − T_pairwise(R, 0)`` (independent of the currents: a magnet
  acting on another through a core) expanded to first order about anchors, ``Δ(R) ≈ Δ(A) + J_A log(R Aᵀ)``
  (``J_A`` by central differences of 1e-3 rad), an anchor added wherever the rotor goes farther than ``reach``
  from every anchor so far (7 coupled evaluations each).
* :data:`MISMATCH_CASES` — the named cases, each :meth:`MismatchCase.build` giving ``(plant, controller_model)``:
  the controller the design's own default model (coupled), the coupled plant's case the pairwise one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import lru_cache
from importlib import resources

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..statics import TorqueModelBase
from . import _iron
from ._ironmap import IronTorqueMap, iron_model, read_table
from ._table import TorqueMap
from .calibrated import scaled_coupling

SHELL_FILE = "iron_shell_table.csv"
SHELL_CHANGES = (-0.3e-3, 0.3e-3)  # m: the stored shells of the prototype
COUPLING_REACH = math.radians(1.5)
COUPLING_STEP = 1e-3  # rad: central differences of the coupling's torque


def scaled_model(model, winding: float = 1.0, detent: float = 1.0, coupling: float = 1.0):
    """``model`` (an :class:`IronTorqueMap` or a :class:`TorqueMap`) with its coils' torque ×``winding``, its
    pairwise detent ×``detent`` and its coupling through the cores (a magnet on another through a core, the other
    part of the torque with every coil off; ~12 % of the pairwise detent's rms on the prototype) ×``coupling``
    (module docstring; exact, and the compiled paths kept). ``coupling`` stays 1 for the calibration's plants,
    whose fit has the coupling's own gain; ``coupling=detent`` scales the whole detent."""
    winding = checks.positive(winding, "winding", "a positive scale of the winding's torque")
    detent = checks.non_negative(detent, "detent", "a non-negative scale of the detent")
    coupling = checks.non_negative(coupling, "coupling", "a non-negative scale of the coupling through the cores")
    if isinstance(model, CoupledPlant):
        raise bad_value("model", "an IronTorqueMap or a TorqueMap (scale before coupling)", "a CoupledPlant")
    if isinstance(model, IronTorqueMap):
        if coupling != 1.0 and model.coupling is None:
            raise bad_value("coupling", "1 for an iron model without the coupling through the cores", coupling)
        return replace(model, detent=replace(model.detent, tau=model.detent.tau * detent),
                       linear=replace(model.linear, tau=model.linear.tau * winding),
                       coupling=model.coupling if coupling == 1.0 else scaled_coupling(model.coupling, coupling))
    if isinstance(model, TorqueMap):
        if coupling != 1.0:
            raise bad_value("coupling", "1 for an air-core torque map (it has no cores)", coupling)
        if detent != 1.0:
            raise bad_value("detent", "1 for an air-core torque map (it has no detent)", detent)
        return replace(model, tau=model.tau * winding)
    raise bad_value("model", "a spherestep.magnetics IronTorqueMap or TorqueMap", type(model).__name__)


def shell_model(design, change: float, coil=None) -> IronTorqueMap:
    """The iron model of ``design`` (coil ``coil``, default the design's, iron-cored) whose rotor shell is
    ``change`` m thicker than the design's ``rotor_shell`` (negative: thinner, the magnets nearer the cores); see
    the module docstring."""
    change = checks.number(change, "change", low=-design.rotor_shell, high=0.1 * design.radius, low_open=True,
                           expected=f"a change of the shell's thickness in metres, more than "
                                    f"−{design.rotor_shell:.4g} (no shell) and at most a tenth of the radius")
    nominal = iron_model(design, coil)
    if not isinstance(nominal, IronTorqueMap):
        raise bad_value("coil", "an iron-cored coil (the shell changes the gap to the cores)", "an air core")
    nodes = nominal.detent.nodes
    d_det, d_lin = _shell_change(design, nominal.coil, round(change, 9), tuple(np.round(np.degrees(nodes), 9)))
    return replace(nominal, detent=replace(nominal.detent, tau=nominal.detent.tau + d_det),
                   linear=replace(nominal.linear, tau=nominal.linear.tau + d_lin))


@lru_cache(maxsize=8)
def _shell_change(design, coil, change: float, nodes_deg: tuple) -> tuple[np.ndarray, np.ndarray]:
    """``(Δτ_d, Δτ_1)`` at ``nodes_deg``: the moment method's change of the pair tables with the shell (the
    stored prototype columns, else two solves)."""
    from ..motor import prototype
    from ..motor.coil import iron_coil
    from ._ironforce import pair_tables
    from ._ironmap import _key

    nodes = np.asarray(nodes_deg)
    path = resources.files("spherestep.data") / SHELL_FILE
    if _key(design, coil, _iron.IRON_LEVEL) == _key(prototype(), iron_coil(), _iron.IRON_LEVEL) and path.is_file():
        table = read_table(path)
        for j, stored in enumerate(SHELL_CHANGES):
            if math.isclose(change, stored, abs_tol=1e-9) and table.shape[0] == len(nodes) \
                    and np.allclose(table[:, 0], nodes, atol=1e-9):
                return table[:, 3 + 2 * j] - table[:, 1], table[:, 4 + 2 * j] - table[:, 2]
    inner = (nodes > 0) & (nodes < 180)
    out = [np.zeros(len(nodes)) for _ in range(4)]
    for k, shell in enumerate((design.rotor_shell, design.rotor_shell + change)):
        out[2 * k][inner], out[2 * k + 1][inner] = pair_tables(design, coil, np.radians(nodes[inner]),
                                                                _iron.IRON_LEVEL, shell=shell)
    return out[2] - out[0], out[3] - out[1]


class CoupledPlant(TorqueModelBase):
    """The coupled iron model as a plant one can integrate (module docstring): ``T(R, c) = T_pair(R, c) + Δ_A +
    J_A log(R Aᵀ)`` about the anchor ``A`` nearest ``R`` (``reach`` rad; a new anchor where none is that near).
    ``coupled`` an :class:`IronTorqueMap` with its coupling (``iron_model(design, coupling=True)``);
    ``anchors`` counts the anchors made so far."""

    has_bias = True

    def __init__(self, coupled: IronTorqueMap, reach: float = COUPLING_REACH, step: float = COUPLING_STEP):
        if not isinstance(coupled, IronTorqueMap) or coupled.coupling is None:
            raise bad_value("coupled", "an IronTorqueMap with its coupling (iron_model(design, coupling=True))",
                            type(coupled).__name__)
        self.coupled = coupled
        self.pairwise = replace(coupled, coupling=None)
        self.reach = checks.positive(reach, "reach")
        self.step = checks.positive(step, "step")
        self.coil_count, self.failed = coupled.coil_count, coupled.failed
        self._zeros = np.zeros(self.coil_count)
        self._A: list[np.ndarray] = []
        self._D: list[np.ndarray] = []
        self._J: list[np.ndarray] = []
        self._stack = np.zeros((0, 3, 3))
        self._cos = 1.0 + 2.0 * math.cos(self.reach)

    @property
    def anchors(self) -> int:
        return len(self._A)

    def coupling_torque(self, R) -> np.ndarray:
        """``Δ(R) (3,)`` N·m of the full coupled model at one rotation (0.16 s; the plant's anchors use it)."""
        return np.asarray(self.coupled.torque(R, self._zeros) - self.pairwise.torque(R, self._zeros), dtype=float)

    def _anchor(self, R: np.ndarray) -> int:
        if len(self._A):
            traces = np.einsum("kij,ij->k", self._stack, R)
            k = int(np.argmax(traces))
            if traces[k] >= self._cos:
                return k
        J = np.empty((3, 3))
        for a in range(3):
            turn = so3.exp(self.step * np.eye(3)[a])
            J[:, a] = (self.coupling_torque(turn @ R) - self.coupling_torque(turn.T @ R)) / (2 * self.step)
        self._A.append(np.array(R, dtype=float))
        self._D.append(self.coupling_torque(R))
        self._J.append(J)
        self._stack = np.array(self._A)
        return len(self._A) - 1

    def _delta(self, R) -> np.ndarray:
        R = so3.as_rotations(R)
        flat = R.reshape(-1, 3, 3)
        out = np.empty((len(flat), 3))
        for i, Ri in enumerate(flat):
            k = self._anchor(Ri)
            out[i] = self._D[k] + self._J[k] @ so3.log_single(Ri @ self._A[k].T)
        return out.reshape(R.shape[:-2] + (3,))

    def torque(self, R, currents) -> np.ndarray:
        """``T_pair(R, c) + Δ(R)`` (N·m, fixed frame)."""
        return self.pairwise.torque(R, currents) + self._delta(R)

    def energy(self, R, currents) -> np.ndarray:
        """The pairwise energy (J); the coupling's energy is left out (the plant is integrated by its torque)."""
        return self.pairwise.energy(R, currents)

    def torque_matrix(self, R, currents=None) -> np.ndarray:
        """``L(R)`` (the coupling does not depend on the currents)."""
        return self.pairwise.torque_matrix(R)

    def torque_reference(self, currents) -> np.ndarray:
        return self.pairwise.torque_reference(currents)


@dataclass(frozen=True)
class MismatchCase:
    """A plant ≠ model case: ``name``; the controller's model ``controller``: ``"coupled"`` the design's own
    default model (``iron_model(design, coupling=True)``, :func:`~spherestep.magnetics.design_model`) or
    ``"pairwise"`` its pairwise model (``coupling=False``); the plant that model with the winding's torque
    ×``winding`` and the detent ×``detent`` (:func:`scaled_model`) and/or the shell ``shell`` m thicker
    (:func:`shell_model`, the coupling kept for a coupled controller), or, with ``coupling`` (the pairwise
    controller only), the coupled model (:class:`CoupledPlant`): the motor as built."""

    name: str
    winding: float = 1.0
    detent: float = 1.0
    shell: float = 0.0
    coupling: bool = False
    controller: str = "coupled"

    def __post_init__(self):
        if self.controller not in ("coupled", "pairwise"):
            raise bad_value("controller", "'coupled' or 'pairwise'", self.controller)
        if self.coupling and self.controller != "pairwise":
            raise bad_value("controller", "'pairwise' for the coupled plant (coupling=True)", self.controller)

    def build(self, design) -> tuple[object, object]:
        """``(plant, controller_model)`` for ``design`` (iron-cored coil)."""
        nominal = iron_model(design)
        if not isinstance(nominal, IronTorqueMap):
            raise bad_value("design", "a design with iron-cored coils", design.coil.core)
        model = nominal if self.controller == "pairwise" else iron_model(design, coupling=True)
        if self.coupling:
            plant = CoupledPlant(iron_model(design, coupling=True))
        elif self.shell:
            plant = shell_model(design, self.shell)
            plant = plant if model.coupling is None else replace(plant, coupling=model.coupling)
        else:
            plant = model
        if (self.winding, self.detent) != (1.0, 1.0):
            plant = scaled_model(plant, self.winding, self.detent)
        return plant, model

    def to_dict(self) -> dict:
        return {"name": self.name, "winding": self.winding, "detent": self.detent, "shell_mm": self.shell * 1e3,
                "coupling": self.coupling, "controller": self.controller}


MISMATCH_CASES = (
    MismatchCase("winding ×0.85", winding=0.85),
    MismatchCase("winding ×1.15", winding=1.15),
    MismatchCase("detent ×0.8", detent=0.8),
    MismatchCase("detent ×1.2", detent=1.2),
    MismatchCase("winding ×0.85, detent ×1.2", winding=0.85, detent=1.2),
    MismatchCase("coupled plant, pairwise controller", coupling=True, controller="pairwise"),
    MismatchCase("shell −0.3 mm", shell=-0.3e-3),
    MismatchCase("shell +0.3 mm", shell=0.3e-3),
)
