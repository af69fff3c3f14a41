"""spherestep: kinematic design and commutation of spherical stepper motors (Chirikjian & Stein, 1999)."""

from __future__ import annotations

from . import errors, packing, so3, sphere, units

__all__ = ["errors", "packing", "so3", "sphere", "units"]
__version__ = "0.1.0"
