"""Commutation: trajectories, the :class:`Plan`, and the planners (Sec. III)."""

from ..motor.design import default_channel_map
from .plan import Plan, Step

__all__ = ["Plan", "Step", "default_channel_map"]
