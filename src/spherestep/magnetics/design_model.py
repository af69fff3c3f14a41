"""The design's own torque model: what its coils are (``design.coil``), with the drive limits of the coil as built.

:func:`design_model` is the default of every API and subcommand that takes a design. For ``core="iron"`` it is
:func:`~spherestep.magnetics.iron_model` with the coupling through the cores (``coupling=True``: pairwise pole–core
tables — 3-D FEM below 21° for the prototype's coil, the method of moments elsewhere — plus a magnet's energy in
the iron another magnetises, all tabulated and compiled, :mod:`._coupling`; linear iron; the detent
``b(R) = τ(R, 0)`` included; within 3.4 % of the whole-motor patch FEM's largest torque in every linear case,
6.4 % pairwise: docs/magnetics.md); for ``core="air"`` the
magnets' :class:`~spherestep.magnetics.TorqueMap` at the coil's own nominal ampere-turns. Currents are per unit of
the coil's nominal current ``I_n`` in both, and the limits are :meth:`DriveLimits.from_spec` of the coil as built
(its winding's resistance and nominal current, the supply, and the coil's own inductance: for an iron core
:func:`~spherestep.magnetics.coil_inductance`'s value, 4× Wheeler's for the prototype, stored per core by
:func:`~spherestep.magnetics.iron_inductance`).

``core`` overrides the design's choice where a comparison is wanted (``--core air|iron``): the same winding
either way, so the two differ only by the iron.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import bad_value

CORES = ("air", "iron")


@dataclass(frozen=True)
class DesignModel:
    """A design's torque ``model`` (a :class:`~spherestep.statics.TorqueModel`, currents per unit of
    ``limits.nominal_current``), the ``limits`` of its coil as built (a :class:`~spherestep.electrics.DriveLimits`),
    the ``core`` (``"air"`` or ``"iron"``) and ``label``, the one line that says which model it is."""

    model: object
    limits: object
    core: str
    label: str

    def to_dict(self) -> dict:
        return {"model": self.label, "core": self.core, "limits": self.limits.to_dict()}


def design_model(design, core: str | None = None, *, coupling: bool | None = None, calibration=None,
                 accept_inconsistent: bool = False) -> DesignModel:
    """The torque model and drive limits of ``design`` as its file states them (module docstring); ``core``
    ``"air"``/``"iron"`` overrides the design's core (same winding); ``coupling`` (default: with an iron core)
    the iron's coupling term (:func:`~spherestep.magnetics.iron_model`; ``False``: the pairwise model). ``calibration`` (a path, e.g.
    :func:`spherestep.control.calibration_beside` of the design file, or a
    :class:`spherestep.magnetics.calibrated.Calibration`, the control room's fit)
    replaces the iron model by the one fitted to the motor's holds; the label then says "calibrated". A calibration
    whose held-out verdict is inconsistent is refused unless ``accept_inconsistent``."""
    from ..electrics import DriveLimits
    from ._inductance import iron_inductance
    from ._ironmap import iron_model

    coil = design.coil
    if core is not None:
        if core not in CORES:
            raise bad_value("core", "'air' or 'iron'", core)
        if core != coil.core:
            coil = replace(coil, core=core)
    if coupling and coil.core != "iron":
        raise bad_value("coupling", "False for an air-core coil (the coupling is through the iron)", coupling)
    coupling = coil.core == "iron" if coupling is None else bool(coupling)
    model = iron_model(design, coil, coupling=coupling)
    limits = DriveLimits.from_spec(coil, design, iron_inductance(coil, design) if coil.core == "iron" else None)
    if calibration is not None:
        return _calibrated(design, coil, calibration, limits, accept_inconsistent)
    if coil.core == "iron":
        from ._ironscale import table_label

        source = "FEM table" if _has_fem_table(design, coil) else table_label(design, coil)
        label = f"iron ({'coupled' if coupling else 'pairwise'}, {source})"
    else:
        label = "air (magnets' torque map)"
    return DesignModel(model, limits, coil.core, label)


def _calibrated(design, coil, calibration, limits, accept_inconsistent: bool = False) -> DesignModel:
    """The design's model from ``calibration`` (a path or a :class:`~.calibrated.Calibration`)."""
    from .calibrated import Calibration

    if coil.core != "iron":
        raise bad_value("calibration", "used with the iron core (it fits the iron model's tables)", coil.core)
    cal = (calibration.check_usable(accept_inconsistent) if isinstance(calibration, Calibration)
           else Calibration.load(calibration, design, accept_inconsistent))
    if cal.design_fingerprint is not None and cal.design_fingerprint != design.fingerprint:
        from ..motor import check_fingerprint

        check_fingerprint(design, cal.design_fingerprint, "calibration.design_fingerprint",
                          "calibrate this design (spherestep.control.calibrate)")
    label = (f"iron ({'coupled' if cal.coupling else 'pairwise'}), calibrated from {cal.holds} holds "
             f"({cal.backend})")
    return DesignModel(cal.model, limits, coil.core, label)


def _has_fem_table(design, coil) -> bool:
    """Whether the iron model's pair table comes from the stored 3-D FEM (the prototype's coil)."""
    from importlib import resources

    from ..motor import prototype
    from ..motor.coil import iron_coil
    from ._iron import IRON_LEVEL
    from ._ironmap import TABLE_FILE, _key

    return _key(design, coil, IRON_LEVEL) == _key(prototype(), iron_coil(), IRON_LEVEL) and \
        (resources.files("spherestep.data") / TABLE_FILE).is_file()
