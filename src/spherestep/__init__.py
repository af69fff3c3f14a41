"""spherestep: kinematic design, commutation and control of spherical stepper motors (Chirikjian & Stein, 1999).

Every room a user works with is advertised here (``__all__``, ``dir``) and imported on first use through the module
``__getattr__`` (even the light ones: the ``spherestep`` command imports this package, and its ``--help`` must not
wait for SciPy); the plumbing (:data:`PLUMBING`: atomic writes, input checks, lazy names, output folders, signals,
relay channels, the rotor function's sums) is reached by its module path and not advertised::

    >>> import spherestep as ss
    >>> design = ss.motor.prototype()
    >>> len(design.stator)
    29
"""

from __future__ import annotations

import importlib

ROOMS = ("commutation", "control", "demo", "design_file", "drive", "dynamics", "electrics", "errors", "explore",
         "export", "fig10", "gallery", "hardware", "harmonics", "magnetics", "motor", "packing", "plots", "potential",
         "report", "sensing", "so3", "sphere", "statics", "synthesis", "units")
PLUMBING = ("atomic", "channels", "checks", "interrupts", "lazy", "outputs", "progress", "rotor_field")
_LAZY = ROOMS + PLUMBING
# every room loads on first use: `spherestep --help` must not wait for SciPy

__all__ = list(ROOMS)  # noqa: PLE0605  (the one list of rooms)
__version__ = "0.1.0"


def __getattr__(name: str):
    """Import a heavy room on first access (``spherestep.magnetics`` …)."""
    if name in _LAZY:
        module = importlib.import_module(f".{name}", __name__)
        globals()[name] = module
        return module
    raise AttributeError(f"module 'spherestep' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted((set(globals()) - set(PLUMBING)) | set(ROOMS))
