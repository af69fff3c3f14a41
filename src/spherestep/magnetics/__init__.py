"""Physical forces and torques from the motor's magnet geometry, with magpylib (Sec. IV).

* Model (:mod:`._model`): rotor magnets and coils as magpylib cylinders; a coil is the uniformly magnetised
  cylinder equivalent to its solenoid (``J = μ0 c NI / l_c``). Air core, linear, no saturation or eddy currents.
* Direct (:mod:`._direct`): :func:`force_torque`, :func:`torque`, :func:`force` by ``magpylib.getFT``, batched
  over orientations; :func:`reaction`, the force and torque on the stator (Newton's third law check).
* Fig. 6 (:mod:`._curve`): :func:`force_curve`; calibration of the potential model (:mod:`._calibration`):
  :func:`calibrate`, :func:`compare_models`.
* Torque map (:mod:`._table`): :class:`TorqueMap` from one pole–coil table ``τ(α)``; :func:`torque_function`
  for the dynamics.
* Iron cores (:mod:`._iron` the solve, :mod:`._ironforce`, :mod:`._ironcoupling`, :mod:`._inductance`,
  :mod:`._ironmap`, :mod:`._ironsummary`): pot-core coils solved by the method of moments
  (magpylib-material-response), :func:`iron_pair_torques`, :func:`iron_force_curve`, :func:`coil_inductance`,
  :func:`iron_inductance`;
  the torque model with detent :class:`IronTorqueMap` from :func:`iron_model`
  (``coil=CoilSpec(core="air")`` gives today's map); :func:`iron_summary` (detent, states, polarity, saturation).
* Statics (:mod:`._statics`): :func:`equilibrium` with the map's settings, :func:`state_torques`; holding and
  step torque on any torque model are in :mod:`spherestep.statics`.

Every torque is about the sphere's centre in the fixed frame (N·m), forces in N; currents are per coil,
nominal ±1 (``coil_ampere_turns``), ``+1`` attracting a north-out (``+1``) pole.
"""

from ..lazy import lazy_names
from ._ironforce import fig6_forces as iron_force_curve  # noqa: F401  (renamed; the iron model's module anyway)
from ._ironforce import pair_tables as iron_pair_torques  # noqa: F401
from .design_model import DesignModel, design_model  # noqa: F401  (eager: the function shadows its module's name)

# The other public names load from their modules on first use (spherestep.lazy): a design's model does not import
# matplotlib (the figures), the potential model (the calibration) or the solver's mesher.
_MODULES = {
    "_calibration": ("Calibration", "Comparison", "calibrate", "compare_models", "fit_limit", "random_drives"),
    "_curve": ("ForceCurve", "force_curve"),
    "_figures": ("figure_comparison", "figure_force_curve"),
    "_direct": ("MESHING", "coil_wrenches", "force", "force_torque", "reaction", "torque"),
    "_inductance": ("coil_inductance", "iron_inductance"),
    "_iron": ("IRON_LEVEL", "CoreGeometry", "CoreSolver", "core_solver", "magnet_face_radius"),  # sensing too
    "_ironmap": ("IronTorqueMap", "iron_model"),
    "_ironscale": ("iron_source", "scaled_design", "solve_needed"),
    "_ironsummary": ("IronSummary", "iron_summary"),
    "_model": ("coil_polarization", "model_summary", "rotor_collection", "rotor_magnets", "stator_coils"),
    "_statics": ("StateTorque", "equilibrium", "state_currents", "state_torques"),
    "_table": ("TABLE_MESHING", "TorqueMap", "pair_torque", "table_nodes", "torque_function", "torque_map"),
}
__getattr__, _lazy_dir, _lazy_all = lazy_names(__name__, _MODULES)
_EAGER = ["DesignModel", "design_model", "iron_force_curve", "iron_pair_torques"]
__all__ = sorted(_lazy_all + _EAGER)  # noqa: PLE0605  (the one list of names)


def __dir__():
    return sorted(set(_lazy_dir()) | set(_EAGER))
