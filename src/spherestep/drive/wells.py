"""Readings of the magnetometers with the rotor at rest in the detent wells, the absolute references of the array's
calibration (:func:`spherestep.sensing.calibrate_array_absolute`): :func:`well_readings`.

For each well ``W`` the servo holds the rotor where the (uncalibrated) estimate says ``W`` is, for ``hold`` s, and
switches every coil off: the detent pulls the rotor into the well, where castor friction stops it somewhere in its
dead band (``f/k``). Each further visit *kicks* it: the currents ``c = K(W)⁺ τ`` (least norm, ``K`` of the model)
for ``kick_time`` s give a torque ``τ`` of ``kick`` N·m about a random axis (``seed``), then zero current; so the
rest points scatter over the dead band and their mean approaches the well. After ``settle`` s the last ``samples``
readings (one every ``READ_EVERY`` s, which also keeps the device's watchdog fed) are averaged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..control import Trajectory
from ..errors import bad_value
from ..interrupts import interrupt_for, last_signal

READ_EVERY = 0.01  # s between readings while the rotor settles
KICK = 0.5  # N·m
KICK_TIME = 0.02  # s: an impulse of 0.01 N·m·s, ~0.14° of swing in the prototype's stiffest wells


@dataclass(frozen=True)
class WellReadings:
    """``readings (V, S, 3)`` T (sensor frame, each the mean of ``samples``), the ``references (V, 3, 3)`` (the
    well of each visit), the emulated rotor's true rest ``truth (V, 3, 3)``."""

    readings: np.ndarray
    references: np.ndarray
    truth: np.ndarray
    samples: int


def well_readings(design, wells, *, visits: int = 4, hold: float = 0.3, settle: float = 0.5, samples: int = 20,
                  kick: float = KICK, kick_time: float = KICK_TIME, seed=0, model=None, limits=None, sensors=None,
                  plant=None, plant_rotor=None, sensor_errors=None, progress=None) -> WellReadings:
    """The readings at rest in each of ``wells`` (``(K, 3, 3)`` or a :class:`~spherestep.sensing.Wells`), ``visits``
    times each (module doc), on the emulated motor in lockstep (``plant``, ``plant_rotor``, ``sensor_errors`` as
    :func:`~spherestep.drive.session.servo_session`; each session starts the emulated rotor at its well, and the
    servo moves it to where the estimate says the well is). ``progress(text, done, total)``. (On a controller the
    rotor would have to be moved from well to well along a path the servo can follow: not built.)"""
    from ..magnetics import design_model
    from ..sensing import Wells
    from .session import servo_session

    W = wells.rotations if isinstance(wells, Wells) else so3.as_rotations(wells, "wells").reshape(-1, 3, 3)
    if len(W) == 0:
        raise bad_value("wells", "at least one detent well (spherestep.sensing.detent_wells)", "none")
    visits = checks.count(visits, "visits")
    samples = checks.count(samples, "samples")
    hold, settle = checks.positive(hold, "hold"), checks.positive(settle, "settle")
    kick, kick_time = checks.non_negative(kick, "kick", "a torque in N·m, ≥ 0"), checks.positive(kick_time, "kick_time")
    if samples * READ_EVERY > settle:
        raise bad_value("samples", f"at most {int(settle / READ_EVERY)} readings within settle = {settle} s", samples)
    if model is None or limits is None:
        own = design_model(design)
        model = own.model if model is None else model
        limits = own.limits if limits is None else limits
    rng = np.random.default_rng(seed)
    readings, references, truth = [], [], []

    def rest(conn, W_k):
        sleep = conn.link.sleep if conn.kind == "lockstep" else time.sleep
        K = np.asarray(model.torque_matrix(W_k), dtype=float)
        out = []
        for v in range(visits):
            if v > 0 and kick > 0:
                axis = rng.standard_normal(3)
                c = np.linalg.pinv(K) @ (kick * axis / np.linalg.norm(axis))
                c /= max(1.0, float(np.abs(c).max()))  # within the nominal current
                conn.link.drive(limits.amperes(c))
                sleep(kick_time)
                conn.link.drive(np.zeros(len(c)))
            fields = []
            for _ in range(int(round(settle / READ_EVERY))):
                sleep(READ_EVERY)
                fields.append(conn.link.read().field)
            out.append((np.mean(fields[-samples:], axis=0), conn.truth().R))
        return out

    for k, W_k in enumerate(W):
        if progress is not None:
            progress(f"well {k + 1} of {len(W)}", k, len(W))
        session = servo_session(design, Trajectory.hold(W_k), hold, emulate=True, lockstep=True, model=model,
                                drive=limits, sensors=sensors, plant=plant, plant_rotor=plant_rotor,
                                sensor_errors=sensor_errors, R0=W_k,
                                after=lambda conn, W_k=W_k: rest(conn, W_k))
        rep = session.report
        if rep.outcome == "INTERRUPT":  # the loop switched every coil off: unwind on
            stop = interrupt_for(last_signal())
            stop.off_acknowledged = bool(rep.off_acknowledged)
            raise stop
        if session.after is None:
            raise bad_value("wells", "wells the servo holds to the end", f"outcome {session.report.outcome} "
                            f"({session.report.message})")
        for m, R in session.after:
            readings.append(m)
            references.append(W_k)
            truth.append(R)
    if progress is not None:
        progress(f"well {len(W)} of {len(W)}", len(W), len(W))
    return WellReadings(np.array(readings), np.array(references), np.array(truth), samples)
