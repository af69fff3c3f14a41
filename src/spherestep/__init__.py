"""spherestep: kinematic design, commutation and control of spherical stepper motors (Chirikjian & Stein, 1999).

Every room is reachable from here, imported on first use through the module ``__getattr__`` (even the light
ones: the ``spherestep`` command imports this package, and its ``--help`` must not wait for SciPy)::

    >>> import spherestep as ss
    >>> design = ss.motor.prototype()
    >>> len(design.stator)
    29
"""

from __future__ import annotations

import importlib

_LAZY = ("atomic", "channels", "checks", "commutation", "control", "demo", "design_file", "drive", "dynamics", "errors",
         "explore", "export", "fig10", "gallery", "hardware", "harmonics", "lazy", "magnetics", "motor", "outputs",
         "packing", "plots", "potential", "report", "rotor_field", "sensing", "so3", "sphere", "statics", "synthesis",
         "units")
# every room loads on first use: `spherestep --help` must not wait for SciPy

__all__ = list(_LAZY)  # noqa: PLE0605  (the one list of rooms)
__version__ = "0.1.0"


def __getattr__(name: str):
    """Import a heavy room on first access (``spherestep.magnetics`` …)."""
    if name in _LAZY:
        module = importlib.import_module(f".{name}", __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'spherestep' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
