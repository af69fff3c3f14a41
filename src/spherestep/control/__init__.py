"""Driving the motor like a servo: current allocation, torque capability over SO(3), trajectories, the controller.

* :class:`DriveLimits` (supply, coil electrics, per-unit bounds, the unit conversions): :mod:`spherestep.electrics`,
  re-exported here.
* :mod:`.allocation`: :func:`allocate` — least-power coil currents for a torque (exact QP), relay mode.
* :mod:`.capability`: :func:`torque_capability` — the torque available in every direction over SO(3).
* :mod:`.trajectory`: :class:`Trajectory` — rest-to-rest turns on SO(3), trapezoidal or tabulated speed profiles.
* :mod:`.time_optimal`: :func:`fastest_turn` — the time-optimal turn with the detent (phase plane, detours).
* :mod:`.controller`: :class:`GeometricPD` and :class:`Observer` — feedback on the log-map error.
* :mod:`.calibration` (the equations) and :mod:`.identify` (the fit): :func:`calibrate` — the torque model fitted
  to the motor's own holds and moves (the iron model's pair tables, each coil's gain and placement, judged on
  held-out holds), :class:`Calibration` saved beside the design
  (:mod:`spherestep.magnetics.calibrated`); the holds are collected by :func:`spherestep.drive.collect_holds`.
  Loaded on first use: the fit imports the magnetics room.
* :mod:`.servo`: :class:`ServoLaw` — the one servo law (observer, feedback, cached ``K(R)``/bias, allocation) that
  the simulation and the hardware loop call each period; :class:`ModelCache`, :class:`ServoCommand`.

The closed-loop simulation (coil electrics, sensor, servo run, ramped relay stepping, the three-way comparison)
is in :mod:`spherestep.dynamics`. The room is maths only: it imports neither dynamics, drive nor hardware.
"""

from ..electrics import DriveLimits
from ..lazy import lazy_names
from .allocation import Allocation, allocate, allocate_matrix, allocate_relay, closest_reachable, least_power_box
from .capability import Capability, available_torque, feasible_support, figure_capability, torque_capability
from .controller import GeometricPD, Observer
from .servo import ModelCache, ServoCommand, ServoLaw
from .time_optimal import FastestTurn, fastest_time, fastest_turn
from .trajectory import (Segment, TimeLaw, Trajectory, bang_bang_time, path_capability, plan_through, plan_trapezoid,
                         plan_turn, triangle_time, voltage_shortfall)

__getattr__, _lazy_dir, _lazy_all = lazy_names(__name__, {"calibration": (
    "Calibration", "Holds", "calibration_beside", "hold_orientations", "torque_error"), "identify": ("calibrate",)})
__all__ = _lazy_all + [  # noqa: PLE0605  (the one list of names)
           "Allocation", "Capability", "DriveLimits", "GeometricPD", "ModelCache", "Observer", "Segment",
           "ServoCommand", "ServoLaw", "Trajectory", "TimeLaw", "FastestTurn", "fastest_time", "fastest_turn",
           "plan_trapezoid",
           "bang_bang_time", "path_capability", "plan_through", "plan_turn", "available_torque", "feasible_support", "figure_capability",
           "torque_capability", "allocate", "allocate_matrix", "allocate_relay", "closest_reachable",
           "least_power_box", "triangle_time", "voltage_shortfall"]


def __dir__():
    return sorted(set(_lazy_dir()) | set(__all__))
