"""Hardware: coil drivers and the serial line protocol to the relay boards (Sec. IV-B).

:class:`CoilDriver` switches stator coils through a :class:`Backend` (:class:`DryRun`, :class:`Serial`,
:class:`Simulated`) within
:class:`ThermalLimits`, and always leaves them off; :func:`play` streams a commutation plan at a step rate.
:mod:`~spherestep.hardware.protocol` is the wire format, :class:`Emulator`/:class:`PtyDevice` a device that
speaks it on a pseudo-terminal. See ``docs/protocol.md``.

Current mode (protocol version 2): :class:`CurrentDevice` is the device (PI current loops, limits, trips) the
firmware's ``drive.cpp`` mirrors; :class:`DriveLink` the host side; :class:`EmulatedMotor`/:class:`MotorPty` the
motor on a pseudo-terminal (:class:`LockstepLink` the same on a simulated clock); :func:`run_servo` the fixed-rate
loop. Links, devices and emulators only: a whole session assembled for a design (``servo_session``) is the drive
room's, :mod:`spherestep.drive.session`. See ``docs/protocol.md`` and ``docs/hardware.md``.
"""

from __future__ import annotations

from . import protocol, protocol2
from .backend import Backend, DeviceInfo, LinkError
from .driver import CoilDriver, coil_masks
from .dryrun import DryRun, Sent
from .emulator import Emulator, Faults, PtyDevice
from .current_device import CurrentDevice
from .drive_link import DeviceTrip, DriveInfo, DriveLink
from .limits import CurrentLimits, ThermalGuard, ThermalLimitError, ThermalLimits, heating_step
from .motor_emulator import EmulatedMotor, LockstepLink, MotorFaults, MotorPty, Truth
from .serialport import NakError, Serial
from .servo import LOOP_RATE, ServoFault, ServoReport, run_servo
from .servo_parts import FieldTracker, wire_limits
from .simulated import Simulated
from .stream import PlayReport, play
from .transcript import Transcript

__all__ = [
    "LOOP_RATE", "Backend", "CoilDriver", "CurrentDevice", "CurrentLimits", "DeviceInfo", "DeviceTrip", "DriveInfo", "DriveLink",
    "DryRun", "EmulatedMotor", "Emulator", "LockstepLink", "Faults", "FieldTracker", "LinkError", "MotorFaults", "MotorPty",
    "NakError", "PlayReport", "PtyDevice", "Sent", "Serial", "ServoFault", "ServoReport",
    "Simulated", "ThermalGuard", "ThermalLimitError", "ThermalLimits", "Transcript", "Truth", "coil_masks",
    "heating_step", "play", "protocol", "protocol2", "run_servo", "wire_limits",
]
