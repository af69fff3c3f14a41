"""Hardware: coil drivers and the serial line protocol to the relay boards (Sec. IV-B).

:class:`CoilDriver` switches stator coils through a :class:`Backend` (:class:`DryRun`, :class:`Serial`,
:class:`Simulated`) within
:class:`ThermalLimits`, and always leaves them off; :func:`play` streams a commutation plan at a step rate.
:mod:`~spherestep.hardware.protocol` is the wire format, :class:`Emulator`/:class:`PtyDevice` a device that
speaks it on a pseudo-terminal. See ``docs/protocol.md``.
"""

from __future__ import annotations

from . import protocol
from .backend import Backend, DeviceInfo, LinkError
from .driver import CoilDriver, coil_masks
from .dryrun import DryRun, Sent
from .emulator import Emulator, Faults, PtyDevice
from .limits import ThermalGuard, ThermalLimitError, ThermalLimits
from .serialport import NakError, Serial
from .simulated import Simulated
from .stream import PlayReport, play
from .transcript import Transcript

__all__ = [
    "Backend", "CoilDriver", "DeviceInfo", "DryRun", "Emulator", "Faults", "LinkError", "NakError", "PlayReport",
    "PtyDevice", "Sent", "Serial", "Simulated", "ThermalGuard", "ThermalLimitError", "ThermalLimits", "Transcript",
    "coil_masks", "play", "protocol",
]
