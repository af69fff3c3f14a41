"""The two interfaces a motor is reached by: :class:`Link` (coil currents, protocol 2) and :class:`Backend` (relay
states, protocol 1).

:class:`Link` is what the servo loop (:func:`~spherestep.hardware.run_servo`) drives: ``info`` (a
:class:`~spherestep.hardware.DriveInfo`), ``drive(currents)`` (A per coil) and ``read()`` → the device's
:class:`~spherestep.hardware.protocol2.State`, ``off()``, and a context manager that leaves every coil off. The
serial :class:`~spherestep.hardware.DriveLink` (a board, or the emulated motor's pseudo-terminal) and the in-process
:class:`~spherestep.hardware.LockstepLink` implement it; :func:`spherestep.drive.connect` is the one place either
is built.

A back end is one class implementing :class:`Backend`: :meth:`~Backend.open` returns a :class:`DeviceInfo`,
:meth:`~Backend.write` drives relay masks, :meth:`~Backend.hold` lets time pass with the outputs unchanged and
:meth:`~Backend.clock` tells the time on the back end's own clock (real or simulated), so that the thermal
limits and the schedule follow the back end's time. :class:`~spherestep.hardware.DryRun` and
:class:`~spherestep.hardware.Serial` are the two in this package; a simulator that integrates rotor dynamics
during :meth:`~Backend.hold` fits the same interface.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from ..errors import ComputationError


class LinkError(ComputationError):
    """The link to the coil controller failed (no answer, refused command, lost device); a one-line message."""


@dataclass(frozen=True)
class DeviceInfo:
    """What a back end reports on opening: name, protocol version, relay channel count, watchdog (s or None)."""

    name: str
    protocol: int
    channels: int
    watchdog: float | None


@runtime_checkable
class Link(Protocol):
    """A current-mode coil controller as the servo loop sees it (module docstring)."""

    info: object

    def drive(self, currents, *, emf=None, within: float | None = None):
        """Set every coil's current (A) and return the device's state (None: no answer ``within`` s); ``emf``
        each coil's back-EMF estimate (V), sent to a device that takes it (``info.takes_emf``)."""

    def read(self):
        """The device's state, the currents unchanged."""

    def off(self) -> None:
        """Every coil off."""

    def __enter__(self): ...

    def __exit__(self, *exc) -> None: ...


class Backend(ABC):
    """Destination of relay states. Masks follow :meth:`spherestep.commutation.Step.masks`: bit ``b`` is
    channel ``b``; an enable bit energises a coil, a polarity bit reverses its current.
    """

    @abstractmethod
    def open(self) -> DeviceInfo:
        """Connect, leave every output off, and report the device."""

    @abstractmethod
    def write(self, enable: int, polarity: int, coils: Mapping[int, int]) -> None:
        """Drive the masks; ``coils`` (stator coil → ±1) is the same state by coil, for model back ends."""

    @abstractmethod
    def hold(self, seconds: float) -> None:
        """Let ``seconds`` pass with the outputs unchanged (sending keep-alives where the device needs them)."""

    def off(self) -> None:
        """Switch every output off."""
        self.write(0, 0, {})

    def close(self) -> None:  # noqa: B027  (an optional hook: most back ends hold nothing to release)
        """Release the connection (outputs are already off: the driver calls :meth:`off` first)."""

    def clock(self) -> float:
        """Seconds on this back end's clock (monotonic wall time unless overridden)."""
        return time.monotonic()
