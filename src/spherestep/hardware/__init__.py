"""Hardware: coil drivers and the serial line protocol to the relay boards (Sec. IV-B).

:class:`CoilDriver` switches stator coils through a :class:`RelayLink` (the one :class:`Link` over a relay
:class:`Backend`: :class:`DryRun`, :class:`Serial`, :class:`Simulated`) within :class:`ThermalLimits`, and always
leaves them off; :func:`play` streams a commutation plan at a step rate.
:mod:`~spherestep.hardware.protocol` is the wire format. See ``docs/protocol.md``.

One device, one pseudo-terminal server: :class:`CurrentDevice` is the coil controller — the firmware's
``drive.cpp`` (H-bridges: PI current loops, limits, trips; protocol version 2, and 1 with relay masks as ± the
nominal current) or, as :meth:`CurrentDevice.relay_board`, ``protocol.cpp`` (relays, protocol 1 only);
:class:`PtyDevice` serves one on a pseudo-terminal, with line :class:`Faults` (the relay board by default;
:class:`MotorPty` the device driving an :class:`EmulatedMotor`, :class:`LockstepLink` the same device on a
simulated clock). :class:`DriveLink` is the host side of version 2, :func:`run_servo` the fixed-rate loop. Links, devices and emulators only: a whole session assembled for a design (``servo_session``) is the drive
room's, :mod:`spherestep.drive.session`. See ``docs/protocol.md`` and ``docs/hardware.md``.
"""

from __future__ import annotations

from . import protocol, protocol2
from .backend import Backend, DeviceInfo, Link, LinkError
from ..commutation.plan import coil_masks
from .driver import CoilDriver
from .dryrun import DryRun, Sent
from .current_device import CurrentDevice
from .drive_link import DeviceTrip, DriveInfo, DriveLink
from .limits import CurrentLimits, ThermalGuard, ThermalLimitError, ThermalLimits, heating_step
from .motor_emulator import EmulatedMotor, LockstepLink, MotorFaults, MotorPty
from .pty_device import Faults, PtyDevice, Truth
from .relay_link import RelayLink
from .serialport import NakError, Serial
from .servo import LOOP_RATE, ServoFault, ServoReport, run_servo
from .servo_parts import FieldTracker, wire_limits
from .simulated import Simulated
from .stream import PlayReport, play
from .transcript import Transcript

__all__ = [
    "LOOP_RATE", "Backend", "CoilDriver", "CurrentDevice", "CurrentLimits", "DeviceInfo", "DeviceTrip", "DriveInfo", "DriveLink",
    "DryRun", "EmulatedMotor", "LockstepLink", "Faults", "FieldTracker", "Link", "LinkError", "MotorFaults", "MotorPty",
    "NakError", "PlayReport", "PtyDevice", "RelayLink", "Sent", "Serial", "ServoFault", "ServoReport",
    "Simulated", "ThermalGuard", "ThermalLimitError", "ThermalLimits", "Transcript", "Truth", "coil_masks",
    "heating_step", "play", "protocol", "protocol2", "run_servo", "wire_limits",
]
