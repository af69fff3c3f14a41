"""Driving a turn: mode (servo, ramped relays, settled relays) × backend (simulated, emulated motor, a port) →
one result type.

* :func:`drive_turn` (:mod:`.modes`): one turn one way → :class:`DriveResult` (:mod:`.result`: arrays, numbers,
  per-mode details, ``to_dict(degrees=True)``, ``write(out)`` — what ``spherestep move`` writes), one lookup in
  :data:`DRIVE_MODES` (mode → the backends it runs on) of the turn prepared once (:class:`~.turn.Turn`: the
  model, the relay plan by :func:`relay_plan` and its tuning);
* :func:`many_turns` (:mod:`.many_turns`): the many-turn verdict on a relay planner (issue 39 §2);
* :func:`compare_drives` (:mod:`.compare`): the same turn every mode → :class:`DriveComparison` (the demo's table);
* :mod:`.hardware`: the servo on a coil controller or the emulated motor, judged like a simulation;
  :mod:`.session` assembles that session for a design (:func:`servo_session`, :func:`move_on_hardware`,
  :func:`turn_reference`) from the hardware room's links, devices and emulators;
* :func:`connect` (:mod:`.connect`): the one place a backend is chosen and built (``port``, ``lockstep``, ``pty``,
  ``qemu``, ``relay port``, ``dry run``, ``simulated``) → a :class:`Connection`;
* :func:`record_moves` (:mod:`.records`): the servo's moves recorded as ``(t, R, c)`` for the rotor's
  identification (:func:`spherestep.dynamics.fit_rotor`);
* :func:`well_readings` (:mod:`.wells`): the magnetometers' readings at rest in the detent wells, the absolute
  references of :func:`spherestep.sensing.calibrate_array_absolute`;
* :func:`collect_holds` (:mod:`.calibration`): the servo sessions a calibration fits (:class:`Emulated`,
  :class:`Port`, or a torque model: the simulated plant).

The model is the design's own (:func:`spherestep.magnetics.design_model`) unless one is given; every result
names it. The simulation itself (rotor, integrator, coil electrics, the servo and ramped loops) is
:mod:`spherestep.dynamics`.
"""

from .calibration import Emulated, Port, collect_holds
from .connect import KINDS, Connection, connect  # the function shadows its module's name (as design_model)
from .many_turns import TurnOutcome, Verdict, many_turns, verdict_turns
from .compare import DEMO_AXIS, SENSOR_NOISE, DriveComparison, compare_drives
from .records import record_moves
from .wells import WellReadings, well_readings
from .session import Session, move_on_hardware, servo_session, turn_reference
from .result import DriveResult, HardwareDetails, RampedDetails, ServoDetails, SettledDetails, figure_drive
from .modes import BACKENDS, DRIVE_MODES, MODES, SENSORS, DriveMode, check_options, drive_turn
from .turn import FIXED_SERVO_TIME, TOLERANCE, choose_model, fixed_servo_time, relay_plan, relay_planner, relay_tuning

__all__ = ["BACKENDS", "DRIVE_MODES", "DriveMode", "DEMO_AXIS", "FIXED_SERVO_TIME", "MODES", "SENSORS", "SENSOR_NOISE", "TOLERANCE",
           "KINDS", "Connection", "DriveComparison", "DriveResult", "Emulated", "HardwareDetails", "Port",
           "RampedDetails", "ServoDetails", "Session", "SettledDetails", "TurnOutcome", "Verdict", "check_options",
           "choose_model", "collect_holds", "record_moves", "WellReadings", "well_readings", "compare_drives", "connect", "drive_turn", "figure_drive",
           "fixed_servo_time", "many_turns", "move_on_hardware", "relay_plan", "relay_planner", "relay_tuning", "servo_session",
           "turn_reference", "verdict_turns"]
