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
  (magpylib-material-response), :func:`iron_pair_torques`, :func:`iron_force_curve`, :func:`coil_inductance`;
  the torque model with detent :class:`IronTorqueMap` from :func:`iron_model`
  (``coil=CoilSpec(core="air")`` gives today's map); :func:`iron_summary` (detent, states, polarity, saturation).
* Statics (:mod:`._statics`): :func:`equilibrium` with the map's settings, :func:`state_torques`; holding and
  step torque on any torque model are in :mod:`spherestep.statics`.

Every torque is about the sphere's centre in the fixed frame (N·m), forces in N; currents are per coil,
nominal ±1 (``coil_ampere_turns``), ``+1`` attracting a north-out (``+1``) pole.
"""

from ._calibration import Calibration, Comparison, calibrate, compare_models, fit_limit, random_drives
from ._curve import ForceCurve, force_curve
from ._figures import figure_comparison, figure_force_curve
from ._direct import MESHING, coil_wrenches, force, force_torque, reaction, torque
from ._inductance import coil_inductance
from ._iron import IRON_LEVEL, CoreGeometry, CoreSolver, core_solver, magnet_face_radius  # for sensing (the cores' field)
from ._ironforce import fig6_forces as iron_force_curve
from ._ironforce import pair_tables as iron_pair_torques
from ._ironmap import IronTorqueMap, iron_model
from ._ironscale import iron_source, scaled_design, solve_needed
from .design_model import DesignModel, design_model
from ._ironsummary import IronSummary, iron_summary
from ._model import coil_polarization, model_summary, rotor_collection, rotor_magnets, stator_coils
from ._statics import StateTorque, equilibrium, state_currents, state_torques
from ._table import TABLE_MESHING, TorqueMap, pair_torque, table_nodes, torque_function, torque_map

__all__ = [
    "iron_source", "scaled_design", "solve_needed",
    "IRON_LEVEL", "CoreGeometry", "CoreSolver", "core_solver", "magnet_face_radius",
    "DesignModel", "MESHING", "StateTorque", "design_model", "TABLE_MESHING", "Calibration", "Comparison", "ForceCurve", "IronSummary", "IronTorqueMap",
    "coil_inductance", "iron_force_curve", "iron_model", "iron_pair_torques", "iron_summary",
    "TorqueMap", "calibrate", "coil_polarization", "coil_wrenches", "compare_models", "equilibrium",
    "figure_comparison", "figure_force_curve", "fit_limit", "force", "force_curve", "force_torque",
    "model_summary", "pair_torque", "random_drives", "reaction", "rotor_collection",
    "rotor_magnets", "state_currents", "state_torques", "stator_coils", "table_nodes",
    "torque", "torque_function", "torque_map",
]
