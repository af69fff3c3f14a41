"""User-facing errors.

Every error a user can cause derives from :class:`SpherestepError`, so the CLI can turn it into one line on
stderr and exit status 2. Messages name the argument, what was expected and what was received.
"""

from __future__ import annotations


class SpherestepError(Exception):
    """Base class of the errors a user can cause with bad input; ``field`` names the argument or field at fault
    (set by :func:`bad_value`), so callers map it without parsing the message."""

    field: str | None = None


class InputError(SpherestepError, ValueError):
    """A value is out of its domain: "`name` must be …; instead received …"."""


class ComputationError(SpherestepError, RuntimeError):
    """A computation could not complete on valid input (CLI exit status 1)."""


def bad_value(name: str, expected: str, received: object) -> InputError:
    """Build the standard message: ``name must be expected; instead received received``."""
    text = repr(received)
    if len(text) > 120:
        text = text[:117] + "..."
    error = InputError(f"{name} must be {expected}; instead received {text}")
    error.field = name
    return error
