"""Commutation: trajectories, the :class:`Plan`, and the planners (Sec. III)."""

from .plan import Plan, Step, default_channel_map

__all__ = ["Plan", "Step", "default_channel_map"]
