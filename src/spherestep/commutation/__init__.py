"""Commutation: trajectories, the :class:`Plan`, and the planners (Sec. III)."""

from ..channels import default_channel_map
from .equilibria import EquilibriumMetrics, equilibrium_metrics, equilibrium_states
from .geometric import plan_geometric
from .iron_planner import plan_iron, rest_pose, supply_coils
from .plan import Plan, PlanSummary, Step, coil_masks
from .potential_planner import plan_potential
from .trajectory import about_axis, steps_for, through
from .turn import turn, turn_targets

__all__ = ["EquilibriumMetrics", "equilibrium_metrics", "equilibrium_states", "Plan", "PlanSummary", "Step", "coil_masks", "about_axis", "default_channel_map", "plan_geometric", "plan_iron", "rest_pose", "supply_coils", "plan_potential", "steps_for", "through",
           "turn", "turn_targets"]
