"""Public names of a room loaded from their modules on first use, so importing the room stays cheap.

    __getattr__, __dir__, __all__ = lazy_names(__name__, {"store": ("ResultStore",), ...})

in a package's ``__init__``: ``pkg.ResultStore`` imports ``pkg.store`` the first time it is asked for and keeps the
value in the package's namespace; ``__all__`` is the sorted list of every name, ``dir(pkg)`` shows them all.
"""

from __future__ import annotations

import sys
from importlib import import_module


def lazy_names(package: str, modules: dict[str, tuple[str, ...]]):
    """``(__getattr__, __dir__, __all__)`` for ``package`` whose public names live in ``modules``
    (module name → the names it defines)."""
    home = {name: module for module, names in modules.items() for name in names}
    names = sorted(home)

    def __getattr__(name: str):
        if name not in home:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f".{home[name]}", package), name)
        setattr(sys.modules[package], name, value)
        return value

    def __dir__():
        return sorted(set(vars(sys.modules[package])) | set(names))

    return __getattr__, __dir__, names
