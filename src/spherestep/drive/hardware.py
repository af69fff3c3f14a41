"""The servo on a coil controller (a serial ``port``) or the emulated motor, as a
:class:`~spherestep.drive.result.DriveResult`.

The loop itself — estimator, control law, the link with protocol version 2, all off at the end — is
:func:`~spherestep.drive.session.servo_session` (the session assembled for the design, :mod:`.session`). The turn
starts where the rotor is taken to be — the stepper state nearest the identity along the turn, as in simulation —
and its trajectory is the fastest turn, the given ``duration`` or the fixed time where the planner refuses the model,
as in simulation
(:meth:`~spherestep.drive.turn.Turn.servo_trajectory`). The result's rows — what ``trajectory.csv`` holds — are the
loop's cycles: its time, the rotor (the emulated rotor's truth at the cycle's reading time; on a real port the
loop's own estimate) and the target at the trajectory time the loop followed (``report.reference_times``: a
starved loop slows its pace). Every figure is computed from these rows: the tracking error against the target,
the final error and the arrival against the turn's end.

The move ends in a state (``end``, docs/hardware.md "What a move reports, and how it ends"):

* ``"hold"`` (the default, what a servo user expects): the servo holds the turn's end for ``hold`` s; the final
  error is the rotor at the hold's last row, where it rests under the servo. Then every coil goes off, and the
  result *reports* what that release means without judging the run on it: the predicted unpowered rest
  (:func:`park_pose` from the last row: the detent well the rotor falls into) and its distance from the target.
* ``"park"``: the servo moves on from the turn's end into the detent well nearest it (:func:`park_pose`,
  :func:`parked`), holds it ``hold`` s, switches off and watches the rotor until it rests
  (:func:`~spherestep.drive.session.watch_rest`: those rows follow the loop's); the final error is where it rests
  (:func:`_rested`) against the predicted well, and the well's distance from the requested target is reported.

Either way a final error outside ``tolerance`` fails the run with the reason.
"""

from __future__ import annotations

import math

import numpy as np

from .. import so3
from ..errors import bad_value
from .result import HardwareDetails

STATUS_EVERY = 0.25  # s between progress lines from the loop
ENDS = ("hold", "park")
PARK_TIME = 0.5  # s: the move from the turn's end into the detent well it parks in
# the share of each coil's back-EMF the fastest plan keeps off its voltage on a device (control.time_optimal's
# HEADROOM is 0.08 for the simulation): the device's PI loop needs room beyond the feed-forward to slew through
# L di/dt a period late; measured in lockstep at 500 Hz on the demo's iron turn with the emulated back-EMF
# (docs/hardware.md): 0.08 → 0.449° max tracking (arrival 1.518 s), 0.16 → 0.298° (1.680 s), 0.2 → 0.244°
# (1.790 s), 0.24 → 0.237° (1.848 s); held out at 0.2: 0.229° and 0.209° (0.332° and 0.765° at 0.08)
DEVICE_HEADROOM = 0.2


def drive_on_hardware(job, *, duration: float | None, port: str | None, emulate: bool, rate: float, log=None,
                      firmware: str = "python", end: str = "hold", hold: float | None = None, **options):
    """Run the prepared servo turn ``job`` (a :class:`~spherestep.drive.turn.Turn`: its design, model, limits,
    tolerance and progress; ``duration`` checked against the bang-bang bound by
    :func:`~spherestep.drive.drive_turn`) on ``port`` or the emulated motor (module docstring), ending by ``end``
    (:data:`ENDS`: ``"hold"`` or ``"park"``) held ``hold`` s (default :data:`~spherestep.drive.session.SETTLE`, 0.5
    s); ``options`` go to :func:`~spherestep.drive.session.servo_session` (``lockstep``, ``faults``,
    ``watchdog_ms``, ``max_late``: an emulated run on the simulated clock, a starved device)."""
    from .. import checks
    from ..dynamics import Rotor
    from .session import SETTLE, servo_session

    if end not in ENDS:
        raise bad_value("end", "hold or park", end)
    hold = SETTLE if hold is None else checks.positive(hold, "hold", "a positive time in seconds")
    design, chosen, progress, tolerance = job.design, job.chosen, job.say, job.tolerance("servo")
    rotor = Rotor.from_design(design)
    traj, kind, note = job.servo_trajectory(job.start, duration, rotor, headroom=DEVICE_HEADROOM)
    turn_end = traj.end
    if end == "park":
        job.say("finding the detent well to park in: the model's unpowered minimum near the turn's end")
        traj = parked(traj, park_pose(chosen.model, turn_end))
        job.say(f"parking in the well {math.degrees(float(so3.distance(traj.end, turn_end))):.3g}° from the "
                f"turn's end: the predicted rest")
    shown = [-math.inf]

    def status(t, R, w, currents):
        if t - shown[0] >= STATUS_EVERY:
            shown[0] = t
            progress(f"t {t:6.2f} s   turned {math.degrees(float(np.linalg.norm(so3.log(R)))):7.2f}°   "
                     f"|ω| {float(np.linalg.norm(w)):5.2f} rad/s   max |i| {float(np.abs(currents).max()):.3f} A")

    where = port if not emulate else "the emulated motor" + (" (the firmware in QEMU)" if firmware == "qemu" else "")
    job.say(f"servo on {where} at {rate:g} Hz")
    session = servo_session(design, traj, traj.duration + hold, port=port, emulate=emulate, rate=rate, log=log,
                            status=status, model=chosen.model, drive=chosen.limits, firmware=firmware, truth_every=0.0,
                            watch=end == "park", **options)
    if session.step_cost is not None and session.step_cost[0]:
        steps, mean, worst = session.step_cost
        job.say(f"firmware in QEMU: {steps} control steps, {mean:.0f} instructions each (most {worst:.0f}): "
                f"{mean / 600:.1f} µs at 600 MHz and one instruction a cycle")
    report = session.report
    times, rotor, estimates, currents = _samples(session, emulate, chosen.model.coil_count)
    # the trajectory at the time the loop followed it (a starved loop slows its pace: report.reference_times)
    paced = report.reference_times[:len(times)] if report.cycles else [0.0]
    targets = np.array([np.asarray(session.reference(t)[0]) for t in paced])
    cycles = len(times)  # the loop's rows; with park the rows after them watch the rotor with the coils off
    held = float(so3.distance(rotor[-1], traj.end)) if report.cycles else None
    # what releasing the rotor means: where the model says it rests unpowered from the hold's last row
    predicted = traj.end if end == "park" else park_pose(chosen.model, rotor[-1])
    rest_offset = float(so3.distance(predicted, turn_end))
    sensor_error = so3.distance(estimates, rotor) if emulate else np.zeros(len(times))
    rest = session.rest if report.cycles and report.device_start is not None else None
    watched = None  # s from the loop's last cycle to the last look at the rotor after the coils went off
    if rest is not None:  # the rotor after the coils went off, until it rested: rows on the same clock, no currents
        after = np.array([t - report.device_start for t, _ in rest.samples])
        watched = float(after[-1] - times[-1])
        times = np.concatenate([times, after])
        rotor = np.concatenate([rotor, [R for _, R in rest.samples]])
        sensor_error = np.concatenate([sensor_error, np.full(len(after), np.nan)])  # the loop estimates no more
        targets = np.concatenate([targets, np.broadcast_to(traj.end, (len(after), 3, 3))])
        currents = np.concatenate([currents, np.zeros((len(after), currents.shape[1]))])
    # every figure from these rows, the ones trajectory.csv holds: the rotor against the paced target while the
    # loop ran (the first ``cycles`` rows); the final error against what the end holds (the turn's end, or the
    # well parked in): the hold's last row, or where the watched rotor rests
    max_tracking = float(so3.distance(rotor[:cycles], targets[:cycles]).max())
    final = float(so3.distance(rotor[-1], traj.end))
    settled = swing = None
    if rest is not None:
        settled, swing, pose = _rested(chosen.model, rest)
        if settled:  # where it rests; else where it was last seen (final as above: the last row)
            final = float(so3.distance(pose, traj.end))
    if report.outcome != "done":
        time, arrival = math.inf, f"the loop ended with {report.outcome}: {report.message}".rstrip(": ")
    elif settled is False:
        detent = getattr(chosen.model, "has_bias", False)
        how = f"it swung {math.degrees(swing):.3g}° about the well it was last in" if detent else \
            f"coasting at {math.degrees(rest.speed):.3g}°/s"
        time, arrival = math.inf, (f"the rotor had not come to rest {watched:.3g} s after the coils went off ({how}, "
                                   f"{math.degrees(final):.3g}° from the predicted well)")
    elif rest is not None and final > tolerance:
        time, arrival = math.inf, (f"the rotor came to rest {math.degrees(final):.3g}° from the predicted well "
                                   f"after the coils went off, over the {math.degrees(tolerance):.3g}° tolerance")
    else:
        time, arrival = _arrival(times[:cycles], so3.distance(rotor[:cycles], traj.end), tolerance,
                                 "the turn's end" if end == "hold" else "the well")
    details = HardwareDetails(report.outcome, report.message, report.cycles, report.rate, rate, report.missed,
                              report.off_acknowledged, kind, note, float(traj.duration),
                              "" if report.log is None else str(report.log), bool(emulate), report.cpu_mean,
                              report.cpu_max, report.realtime, report.time_scale, report.slowed, report.end_error,
                              session.drift_after_off(), report.late_wakeups, report.late_readings, end, hold, held,
                              rest_offset, watched, settled, swing)
    power = np.einsum("tn,tn->t", currents, currents) * chosen.limits.resistance
    return job.result("servo", "emulated" if emulate else "port", times, rotor, targets, sensor_error,
                      currents, power, time, arrival, final, max_tracking, details)


def _rested(model, rest) -> tuple[bool, float, np.ndarray]:
    """``(settled, swing, pose)`` of a :class:`~spherestep.drive.session.Rest`: ``pose`` where the rotor rests —
    the bottom of the detent well it was last watched in (:func:`park_pose` from the last look: a damped swing
    ends there; the last look itself without a detent) —, ``swing`` rad the farthest it was from there over the
    last ``REST_SPAN`` s, and ``settled`` whether that is within ``REST_BAND`` (a rotor swinging in one well,
    not tumbling from well to well) — without a detent, whether it stood still (:attr:`Rest.at_rest`: a rotor
    that coasts has not come to rest)."""
    from .session import REST_BAND, REST_SPAN

    last_t, last = rest.samples[-1]
    pose = park_pose(model, last)
    recent = np.array([R for t, R in rest.samples if t >= last_t - REST_SPAN - 1e-9])
    swing = float(so3.distance(recent, pose).max())
    detent = getattr(model, "has_bias", False)
    return (swing <= REST_BAND) if detent else rest.at_rest, swing, pose


def park_pose(model, R) -> np.ndarray:
    """Where ``model``'s rotor rests unpowered near ``R``: the detent energy descended from ``R`` at zero current
    (:func:`spherestep.statics.equilibrium`; a saddle left for the lowest strict minimum beside it,
    :func:`spherestep.commutation.rest_pose`); ``R`` itself on a model without a detent (no bias torque)."""
    from ..commutation import rest_pose
    from ..statics import equilibrium

    if not getattr(model, "has_bias", False):
        return np.asarray(R)
    zero = np.zeros(model.coil_count)
    return rest_pose(model, equilibrium(model, R, zero), zero)


def parked(trajectory, pose):
    """``trajectory`` followed by a rest-to-rest turn (triangle profile, :data:`PARK_TIME` s) from its end to
    ``pose`` about the fixed axis ``log(pose endᵀ)``."""
    from ..control import Trajectory
    from ..control.trajectory import segment

    step = so3.log(np.asarray(pose) @ trajectory.end.T)
    angle = float(np.linalg.norm(step))
    if angle < 1e-12:
        return trajectory
    return Trajectory(trajectory.segments + (segment(trajectory.end, step / angle, angle, 4 * angle / PARK_TIME ** 2,
                                                     t0=trajectory.duration),))


def _samples(session, emulate: bool, coils: int):
    """``(times, rotor, estimates, currents)`` per cycle of ``session``: loop time (s), the rotor — the emulated
    rotor at the cycle's reading time, or on a port the loop's estimate —, the loop's estimate and the commanded
    currents (A). The emulated rotor is the device's truth taken in the cycle, stamped on the device's clock
    (``Truth.t``), carried to the reading's time by its angular velocity: ``exp((t − t_s) ω) R`` with
    ``t_s = Truth.t − device_start`` (a few ms at most: the truth is published every 2 ms of emulated time)."""
    report = session.report
    if not report.cycles:  # the loop ended before its first cycle
        first = session.trajectory.start[None]
        return np.zeros(1), first, first, np.zeros((1, coils))
    times = np.asarray(report.times, dtype=float)
    estimates = np.asarray(report.orientations, dtype=float)
    currents = np.asarray(report.currents, dtype=float)
    if not emulate or not session.truth:
        return times, estimates, estimates, currents
    n = min(len(session.truth), len(times))
    times, estimates, currents = times[:n], estimates[:n], currents[:n]
    R = np.array([truth.R for _, truth in session.truth[:n]])
    if report.device_start is None:  # a loop on the host's clock: the truth as taken in the cycle
        return times, R, estimates, currents
    stamped = np.array([truth.t for _, truth in session.truth[:n]]) - report.device_start
    w = np.array([truth.w for _, truth in session.truth[:n]])
    return times, so3.exp((times - stamped)[:, None] * w) @ R, estimates, currents


def _arrival(times, errors, tolerance: float, what: str = "the turn's end") -> tuple[float, str]:
    """First time after which ``errors`` (from ``what``) stay within ``tolerance``, or ``inf`` and why."""
    outside = np.flatnonzero(errors > tolerance)
    if len(outside) == 0:
        return float(times[0]), ""
    if outside[-1] == len(errors) - 1:
        return math.inf, f"not within {math.degrees(tolerance):.3g}° of {what} at the end of the loop"
    return float(times[outside[-1] + 1]), ""
