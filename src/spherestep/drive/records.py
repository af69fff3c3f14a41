"""Records of the servo's moves for identification: ``(t, R, c)`` per move on the simulated plant, the emulated
motor or a coil controller on a port (:func:`record_moves`); what :func:`spherestep.dynamics.fit_rotor` consumes.

On the emulated motor and a port, ``R`` is the magnetometers' estimate and ``c`` the commanded currents, each
driven from the next cycle's start (the session's one-period delay), so ``c[n]`` is the current over
``[t_n, t_{n+1}]``; in simulation ``R`` is the rotor's true orientation and ``c`` the coils' mean current over
each period.
"""

from __future__ import annotations

import numpy as np

from ..control import Trajectory
from ..errors import bad_value
from ..statics import is_torque_model

SETTLE = 0.3  # s the servo runs on after each move


def record_moves(design, moves, *, plant=None, model=None, limits=None, plant_rotor=None, sensor_errors=None,
                 sensor_calibration=None, emulate: bool = False, port: str | None = None, rate: float | None = None, settle: float = SETTLE,
                 progress=None) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Run the servo (controller on ``model``, default the design's own, believing the design's rotor) along each
    of ``moves`` (:class:`~spherestep.control.Trajectory`, e.g. :func:`spherestep.dynamics.rotor_excitation`) and
    ``settle`` s on, and return one record ``(t (T,), R (T, 3, 3), c (T, N) per unit)`` per move. Backend: the
    simulated plant (:func:`spherestep.dynamics.simulate_servo` at ``rate``, default 1 kHz; ``plant`` the torque
    model the rotor obeys, ``plant_rotor`` the :class:`~spherestep.dynamics.Rotor` as built), the emulated motor in
    lockstep (``emulate``; also ``sensor_errors``) or a controller on ``port`` (both read through
    ``sensor_calibration``, a :class:`~spherestep.sensing.ArrayCalibration`, when given: calibrate the sensors
    first, as the torque is evaluated at the estimate). ``progress(text, done, total)``."""
    from ..control import GeometricPD
    from ..dynamics import Rotor, simulate_servo
    from ..magnetics import design_model
    from .session import servo_session, session_series

    moves = tuple(moves)
    if not moves or not all(isinstance(m, Trajectory) for m in moves):
        raise bad_value("moves", "one or more spherestep.control.Trajectory", f"{len(moves)} items")
    if emulate and port is not None:
        raise bad_value("port", "a serial device, or emulate=True (not both)", port)
    if plant_rotor is not None and not isinstance(plant_rotor, Rotor):
        raise bad_value("plant_rotor", "a spherestep.dynamics.Rotor (or None)", type(plant_rotor).__name__)
    own = design_model(design) if model is None or limits is None else None
    model = own.model if model is None else model
    limits = own.limits if limits is None else limits
    plant = model if plant is None else plant
    if not is_torque_model(plant):
        raise bad_value("plant", "a torque model (spherestep.statics.TorqueModel)", type(plant).__name__)
    out = []
    for i, traj in enumerate(moves):
        if progress is not None:
            progress(f"move {i + 1} of {len(moves)}", i, len(moves))
        if not emulate and port is None:
            believed = Rotor.from_design(design)
            run = simulate_servo(design, traj, plant, limits=limits, controller_model=model, settle=settle,
                                 rotor=believed if plant_rotor is None else plant_rotor,
                                 controller=GeometricPD(believed.inertia, rate=rate or 1000.0,
                                                        damping=believed.damping), rate=rate or 1000.0)
            out.append((run.times, run.orientations, limits.per_unit(run.currents)))
            continue
        options = {"rate": rate} if rate else {}
        session = servo_session(design, traj, traj.duration + settle, port=port, emulate=emulate, lockstep=emulate,
                                model=model, drive=limits, plant=plant if emulate else None,
                                plant_rotor=plant_rotor if emulate else None,
                                sensor_errors=sensor_errors if emulate else None,
                                sensor_calibration=sensor_calibration, **options)
        # the commanded currents (no lag: fit_rotor fits the current's lag itself)
        out.append(session_series(session, limits, "moves", "moves the servo follows to the end"))
    if progress is not None:
        progress(f"move {len(moves)} of {len(moves)}", len(moves), len(moves))
    return out
