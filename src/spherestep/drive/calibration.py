"""Collecting the holds and moves a calibration fits: the servo sessions on the simulated plant, the emulated motor
or a coil controller on a port (:func:`collect_holds`), the maths of each hold's equations and the fit itself in
the control room (:mod:`spherestep.control.calibration`: :func:`~spherestep.control.calibration.series_equations`,
:func:`~spherestep.control.calibrate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .. import checks, so3
from ..control import Trajectory
from ..electrics import DriveLimits
from ..errors import InputError, bad_value
from ..statics import is_torque_model

if TYPE_CHECKING:
    from ..control.calibration import Holds


@dataclass(frozen=True)
class Emulated:
    """The emulated motor as a backend of :func:`collect_holds`: ``plant`` the torque model the emulated rotor
    obeys (it should differ from the controller's), on the lockstep link (``lockstep``, the default) or a
    pseudo-terminal; ``rotor`` the emulated rotor (default the design's, :data:`~.connect.EMULATED_DAMPING`) and
    ``sensor_errors`` its magnetometers' errors (both from a :class:`~spherestep.drive.PlantError`)."""

    plant: object
    lockstep: bool = True
    rotor: object = None
    sensor_errors: object = None


@dataclass(frozen=True)
class Port:
    """A coil controller on a serial ``device`` as a backend of :func:`collect_holds` (the drive room's session)."""

    device: str


HOLD_TOLERANCE = math.radians(0.05)  # rad: a hold farther than this from its target (by the estimate) is held again
RETRIES = 2  # re-commanded holds (each settling twice as long) before a hold is discarded


def collect_holds(design, backend, orientations, *, model=None, limits: DriveLimits | None = None,
                  move_time: float = 0.4, settle: float = 0.5, window: float = 0.25, moves: bool = True,
                  rate: float = 1000.0, quadrature: float = 0.012, progress=None,
                  tolerance: float = HOLD_TOLERANCE, sensor_calibration=None) -> Holds:
    """Drive the servo (controller on ``model``, default the design's own) to each of ``orientations``
    (``(H, 3, 3)``, or a count for :func:`hold_orientations`) in turn and record the holds and moves (module
    docstring). ``backend``: a torque model (the simulated plant, :func:`spherestep.dynamics.simulate_servo` at
    ``rate`` Hz), an :class:`Emulated` motor or a :class:`Port` (the drive room's
    :func:`~spherestep.drive.session.servo_session`, 200 Hz, the magnetometers' estimate as the measurement and
    the commanded currents). Each move takes ``move_time`` s per 20° (at least ``move_time``), then ``settle``
    s at the target; the hold equation is the last ``window`` s; ``moves=False`` keeps only the holds.
    ``quadrature`` s: the move's integral by the midpoint rule on groups of periods this long (fewer samples
    to regress: the per-coil fit's cost is linear in them; 12 ms, 2–3 periods of the emulated motor's 200 Hz loop,
    against a detent period of ~5°, a few ‰ at 1 rad/s). ``progress(text, done, total)`` is told of each hold.

    Holds that are holds: a hold ending farther than ``tolerance`` rad from its target by the measurement is
    commanded again from where it is (the same smooth turn back to it, the servo's disturbance estimate given twice
    the time to settle, up to :data:`RETRIES` times); the hold equation is the last one's window (the move equation
    the first run's: from rest to its end), and a hold still off, or one whose re-run lost the rotor (a target the
    plant cannot be held at: on the demo's plant, detent ×1.2 and winding ×0.85, 2 of the first 6 rest 3° off), is
    discarded (its move kept). ``sensor_calibration``
    (an emulated motor or a port): the array's :class:`~spherestep.sensing.ArrayCalibration` the estimate reads
    through."""
    from ..control.calibration import Holds, hold_orientations, series_equations  # the fit's maths: magnetics
    from ..dynamics import Rotor
    from ..magnetics import design_model

    if isinstance(orientations, (int, np.integer)) and not isinstance(orientations, bool):
        orientations = hold_orientations(int(orientations))
    targets = so3.as_rotations(orientations, "orientations").reshape(-1, 3, 3)
    if len(targets) == 0:
        raise bad_value("orientations", "at least one orientation", "none")
    own = design_model(design)
    model = own.model if model is None else model
    limits = own.limits if limits is None else limits
    if not is_torque_model(model):
        raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
    move_time = checks.positive(move_time, "move_time", "a positive time in seconds")
    settle = checks.positive(settle, "settle", "a positive time in seconds")
    window = checks.positive(window, "window", "a positive time in seconds, shorter than settle")
    if window >= settle:
        raise bad_value("window", f"shorter than settle ({settle} s)", window)
    quadrature = checks.positive(quadrature, "quadrature", "a positive time in seconds")
    if is_torque_model(backend):
        name = "simulated"
        rotor = Rotor.from_design(design)
    elif isinstance(backend, Emulated):
        if not is_torque_model(backend.plant):
            raise bad_value("backend.plant", "a torque model", type(backend.plant).__name__)
        name = "emulated"
        rotor = Rotor.from_design(design, damping=0.01)  # the drive room's emulated rotor
    elif isinstance(backend, Port):
        name = f"port {backend.device}"
        rotor = Rotor.from_design(design, damping=0.01)
    else:
        raise bad_value("backend", "a torque model (the simulated plant), spherestep.drive.Emulated(plant) or "
                        "spherestep.drive.Port(device)", type(backend).__name__)
    rows, rest_R, rest_c, drift, noise, kept = [], [], [], [], [], []
    here = np.eye(3)
    for i, target in enumerate(targets):
        if progress is not None:
            progress(f"holding at orientation {i + 1} of {len(targets)} ({name})", i, len(targets))
        traj, _ = _move(here, target, move_time)
        t, R, c = _session(design, backend, traj, settle, here, model, limits, rate, sensor_calibration)
        every = max(1, round(quadrature / float(np.median(np.diff(t)))))
        eqs, speed = series_equations(t, R, c, window, rotor.inertia, rotor.damping, every)
        move = [e for e in eqs if e[0] == "move"]
        for attempt in range(RETRIES):
            if so3.distance(R[-1], target) <= tolerance:
                break
            if progress is not None:
                progress(f"holding at orientation {i + 1} of {len(targets)} again ({name}: "
                         f"{math.degrees(so3.distance(R[-1], target)):.3f}° off)", i, len(targets))
            again, _ = _move(R[-1], target, move_time)
            try:
                t2, R2, c2 = _session(design, backend, again, settle * 2 ** (attempt + 1), R[-1], model, limits,
                                      rate, sensor_calibration)
            except InputError:  # the servo lost the rotor on the way back (a hold it cannot reach): discarded
                break
            t, R, c = t2, R2, c2
            eqs, speed = series_equations(t, R, c, window, rotor.inertia, rotor.damping, every)
        good = so3.distance(R[-1], target) <= tolerance
        rows.extend([e for e in eqs if e[0] == "hold" and good] + (move if moves else []))
        here = R[-1]
        if good:
            kept.append(i)
            rest_R.append(R[-1])
            sel = t[:-1] >= t[-1] - window
            rest_c.append(c[:-1][sel].mean(axis=0))
            drift.append(speed)
            noise.append(_split_noise(model, eqs[0]))
    if progress is not None:
        progress(f"holding at orientation {len(targets)} of {len(targets)} ({name})", len(targets), len(targets))
    if not kept:
        raise bad_value("backend", f"a motor whose holds end within {math.degrees(tolerance):g}° of their targets",
                        f"none of {len(targets)} did")
    kinds = tuple(r[0] for r in rows)
    sample_eq = np.concatenate([np.full(len(r[4]), k) for k, r in enumerate(rows)])
    return Holds(targets[kept], np.array(rest_R), np.array(rest_c), kinds, np.array([r[1] for r in rows]),
                 np.concatenate([r[2] for r in rows]), np.concatenate([r[3] for r in rows]),
                 np.concatenate([r[4] for r in rows]), sample_eq, rotor.inertia, rotor.damping, name,
                 np.array(drift), np.array(noise).reshape(-1, 3), len(targets) - len(kept))


def _split_noise(model, row) -> np.ndarray:
    """The hold equation ``row`` on the first half of its window minus on the second (N·m, ``(3,)``): the model's
    torque at the same orientation and currents, so its errors cancel and the measurement's noise stays."""
    _, _, Rs, cs, ws = row
    half = np.arange(len(ws)) < len(ws) // 2
    tau = np.asarray(model.torque(Rs, cs), dtype=float)
    mean = [np.sum(ws[m, None] * tau[m], axis=0) / np.sum(ws[m]) for m in (half, ~half)]
    return mean[0] - mean[1]


def _move(start: np.ndarray, target: np.ndarray, move_time: float):
    """The triangular turn from ``start`` to ``target`` (``move_time`` per 20°, at least ``move_time``)."""
    rv = so3.log_single(target @ start.T)
    angle = float(np.linalg.norm(rv))
    if angle < 1e-9:
        return Trajectory.hold(target), 0.0
    T = move_time * max(1.0, math.sqrt(angle / math.radians(20.0)))
    return Trajectory.turn(start, rv / angle, angle, 4.0 * angle / T ** 2), T


def _session(design, backend, traj, settle: float, start, model, limits, rate: float, sensor_calibration=None):
    """``(t, R, c)``: one run of the servo along ``traj`` and ``settle`` s on: times (s), measured orientations
    and the currents per unit over each period."""
    if is_torque_model(backend):
        from ..dynamics import simulate_servo

        run = simulate_servo(design, traj, backend, limits=limits, controller_model=model, settle=settle,
                             start=start, rate=rate)
        return run.times, run.orientations, limits.per_unit(run.currents)
    from .session import current_lag, servo_session, session_series

    port = backend.device if isinstance(backend, Port) else None
    emulate = isinstance(backend, Emulated)
    options = {"plant": backend.plant, "lockstep": backend.lockstep, "plant_rotor": backend.rotor,
               "sensor_errors": backend.sensor_errors} if emulate else {}
    session = servo_session(design, traj, traj.duration + settle, port=port, emulate=emulate, model=model,
                            drive=limits, R0=start, sensor_calibration=sensor_calibration, **options)
    return session_series(session, limits, "backend", "a motor that runs the servo to the end of each hold",
                          current_lag(session.kind))
