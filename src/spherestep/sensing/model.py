"""The field model of a design at its magnetometers, built one way for every user: the simulated sensor, the
emulated motor's readings, the hardware session's estimator, :func:`~spherestep.sensing.accuracy` and
:func:`~spherestep.sensing.calibrate`.

What the sensors at ``x_s`` see, fixed frame, tesla:

    B_s(R, c) = B_rotor,s(R) + B_core,s(R) + Σ_k c_k G_k,s

the rotor's own field (:class:`~spherestep.sensing.field.FieldTable`), on an iron design the cores it magnetises
(:class:`~spherestep.sensing.iron.CoreField`) and the coils at per-unit currents ``c``: on an iron design the
winding plus its own core (:class:`~spherestep.sensing.iron.IronCoilField`), on an air-core one the winding
(:class:`~spherestep.sensing.field.CoilField`). :func:`field_model` with ``cores=False`` on an iron design is the
air-core model of the same motor (rotor alone, bare windings): what an estimator that ignores the iron believes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import bad_value
from .array import SensorArray
from .estimate import Estimator
from .field import CoilField, FieldTable
from .iron import CoreField, IronCoilField, IronFieldTable, iron_fields

ROTOR_AND_CORES = "rotor + cores"  # FieldModel.name on an iron design with the cores modelled
ROTOR_ONLY = "rotor only"  # ... the rotor and the bare windings (an air-core design, or the iron ignored)


@dataclass(frozen=True, eq=False)
class FieldModel:
    """The field at one set of sensor positions (module doc): ``rotor`` (:class:`FieldTable`), ``cores``
    (:class:`CoreField`, ``None`` when not modelled), ``coils`` (per unit current, a known field). ``table`` is
    what an estimator fits the orientation against: the rotor, plus the cores when modelled."""

    rotor: FieldTable
    cores: CoreField | None
    coils: CoilField | IronCoilField

    @property
    def name(self) -> str:
        """``"rotor + cores"`` or ``"rotor only"`` (what results report as their field model)."""
        return ROTOR_ONLY if self.cores is None else ROTOR_AND_CORES

    @property
    def positions(self) -> np.ndarray:
        return self.rotor.positions

    @property
    def table(self) -> FieldTable | IronFieldTable:
        return self.rotor if self.cores is None else IronFieldTable(self.rotor, self.cores)

    def field(self, R, currents=None) -> np.ndarray:
        """``B (..., S, 3)`` (T, fixed frame) for rotations ``R (..., 3, 3)`` and per-unit ``currents`` (``None``:
        coils off)."""
        B = self.rotor.field(R)
        if self.cores is not None:
            B = B + self.cores.field(R)
        if currents is not None:
            B = B + self.coils.field(currents)
        return B

    def estimator(self, array: SensorArray, known=()) -> Estimator:
        """The :class:`Estimator` of ``array`` (at this model's positions) against this model, the coils and
        ``known`` fields subtracted at the currents given."""
        if array.positions.shape != self.positions.shape or np.abs(array.positions - self.positions).max() > 1e-12:
            raise bad_value("array", "the sensor array at this field model's positions", f"{len(array)} sensors "
                            "elsewhere")
        return Estimator(self.table, array.axes, array.part, (self.coils, *known))


def field_model(design, positions, cores: bool | None = None, rotor: FieldTable | None = None) -> FieldModel:
    """The :class:`FieldModel` of ``design`` at ``positions (S, 3)``. ``cores``: model the iron cores' field
    (default: when the design's coil is iron; ``False`` on an iron design gives its air-core model; ``True`` on an
    air-core design is refused). ``rotor``: a :class:`FieldTable` already built at ``positions`` (shared)."""
    iron = design.coil.core == "iron"
    cores = iron if cores is None else cores
    if cores not in (True, False) or (cores and not iron):
        raise bad_value("cores", "True or False (True only for an iron-core design)", cores)
    p = np.asarray(positions, dtype=float).reshape(-1, 3)
    if rotor is None:
        rotor = FieldTable.build(design, p)
    elif rotor.positions.shape != p.shape or np.abs(rotor.positions - p).max() > 1e-12:
        raise bad_value("rotor", "a FieldTable at the same positions", f"one at {len(rotor.positions)} positions")
    if cores:
        core_field, coils = iron_fields(design, p)
        return FieldModel(rotor, core_field, coils)
    return FieldModel(rotor, None, CoilField.build(design, p))


__all__ = ["FieldModel", "ROTOR_AND_CORES", "ROTOR_ONLY", "field_model"]
