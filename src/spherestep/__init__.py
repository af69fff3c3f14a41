"""spherestep: kinematic design and commutation of spherical stepper motors (Chirikjian & Stein, 1999)."""

from __future__ import annotations

from . import errors, so3, units

__all__ = ["errors", "so3", "units"]
__version__ = "0.1.0"
