"""Driving the motor like a servo: current allocation, torque capability over SO(3), trajectories, the controller.

* :mod:`.limits`: :class:`DriveLimits` (supply, coil electrics, per-unit bounds).
* :mod:`.allocation`: :func:`allocate` — least-power coil currents for a torque (exact QP), relay mode.
* :mod:`.capability`: :func:`torque_capability` — the torque available in every direction over SO(3).
* :mod:`.trajectory`: :class:`Trajectory` — rest-to-rest turns on SO(3) with trapezoidal speed profiles.
* :mod:`.controller`: :class:`GeometricPD` and :class:`Observer` — feedback on the log-map error.

The closed-loop simulation (coil electrics, sensor, servo run, ramped relay stepping, the three-way comparison)
is in :mod:`spherestep.dynamics`.
"""

from .allocation import Allocation, allocate, allocate_matrix, allocate_relay, closest_reachable, least_power_box
from .capability import Capability, available_torque, feasible_support, figure_capability, torque_capability
from .controller import GeometricPD, Observer
from .limits import DriveLimits
from .trajectory import Segment, Trajectory, bang_bang_time, path_capability, plan_through, plan_turn

__all__ = ["Allocation", "Capability", "DriveLimits", "GeometricPD", "Observer", "Segment", "Trajectory",
           "bang_bang_time", "path_capability", "plan_through", "plan_turn", "available_torque", "feasible_support", "figure_capability",
           "torque_capability", "allocate", "allocate_matrix", "allocate_relay", "closest_reachable",
           "least_power_box"]
