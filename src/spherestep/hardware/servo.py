"""The servo loop on hardware: read sensors, estimate, control, allocate, send currents, at a fixed rate.

:func:`run_servo` drives a :class:`~spherestep.hardware.Link` (a :class:`~spherestep.hardware.DriveLink` to a real
board or :class:`~spherestep.hardware.motor_emulator.MotorPty`, or a :class:`~spherestep.hardware.LockstepLink`)
with two callables:

* ``estimate(state, prior) -> R``: the measured orientation (3×3) from a
  :class:`~spherestep.hardware.protocol2.State` (magnetometers and measured coil currents), searched from
  ``prior``; it raises :class:`ServoFault` on readings it cannot trust
  (:class:`~spherestep.hardware.servo_parts.FieldTracker`);
* ``law``: the control room's :class:`~spherestep.control.ServoLaw`, the same law the simulation runs. Each cycle
  ``law.step(t, R)`` takes the measurement at the reading's time ``t`` and returns per-unit currents, sent as
  ``law.amperes(c)`` A; the estimate and the angular velocity ``ω̂`` (rad/s, fixed frame) logged and shown are
  its observer's, and ``prior`` is the observer's prediction for ``t``, ``exp((t − t̂) ω̂) R̂``.

A first ``READ`` primes the estimate and the currents; then cycle ``k`` starts at ``t_0 + k / rate``: ``DRIVE`` the currents computed in cycle ``k − 1`` (with each coil's back-EMF, ``ServoCommand.emf``, to a device that takes it,
unless the reading they were computed from was answered more than a nominal period, ``1/rate``, after its
``DRIVE``: an estimate from a reading that old may be volts off, and the device's coil's-law check would take it
for a fault; without one the device judges by the rule that holds whatever the back-EMF, docs/protocol.md) and
receive the
state, check it (a stale magnetometer, a saturated one → ``SENSOR``), estimate, control, check the currents
against the :class:`~spherestep.hardware.limits.CurrentLimits`, then wait for the next start. A cycle that
starts more than one period late misses deadlines (counted; the ticks that passed are skipped, not caught up
in a burst); one that starts more than ``max_late`` late (default half the device's watchdog period) ends the
run (``SLOW``) — unless the device's watchdog saw the silence first (``WDOG``).

A loop that keeps missing deadlines (``miss_budget`` late cycles among the last ``MISS_WINDOW``) fails safe by
``on_missed``:
``"slow"`` (default) halves its rate and the trajectory's pace together — the law sees the trajectory at
``τ(t) = τ_k + s (t − t_k)``, with ``(R_d, s ω_d, s² α_d)``, so the motion per cycle stays what it was designed
for, and the run is lengthened so that the whole trajectory is still followed — down to ``MIN_SCALE``, below
which it stops; after ``RECOVER_AFTER`` s without a miss, every cycle done within ``RECOVER_BUSY`` of the faster
period, it doubles them again; ``"stop"`` stops at once. Stopping
is the ``SLOW`` outcome with every coil off, the message saying how many deadlines were missed and where the rotor
stopped (its estimate's distance from the trajectory's end). The report carries what a caller needs to judge the
run: the deadlines missed, the host's CPU per cycle (thread time: mean and max), the pace ``time_scale``, the
trajectory time ``reference_times`` of every cycle, and the last estimate's ``end_error`` from the trajectory's
end.
Whatever ends the run — done, a fault seen by the host, a trip reported by the device, a lost link, Ctrl-C —
the loop sends ``OFF`` and reports whether the device acknowledged it (if the link is gone, the device's
watchdog switches the coils off within its period). A cycle's reading is waited for until ``RESERVE`` of its
period is left; a later one is not used (the law runs that cycle on its own prediction, ``late_readings`` counts
them, and the log's ``stale`` column, otherwise the magnetometers' stale mask in hex, is ``-``), so one late
answer never costs a deadline; not twice in a row, so a link that keeps answering late costs deadlines and meets
the budget above. Each cycle is one line of the log, streamed to
``log + ".part"`` and renamed to ``log`` at the end (a log is whole or marked partial, never half-written in
place).
"""

from __future__ import annotations

import gc
import math
import os
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import checks, so3
from ..errors import ComputationError, bad_value
from ..interrupts import interrupt_of
from .backend import Link, LinkError
from .limits import CurrentLimits, ThermalLimitError
from .serialport import NakError

LOG_HEADER = "t_s,late_s,rx,ry,rz,wx,wy,wz,power_W,max_abs_current_A,stale\n"


class ServoFault(ComputationError):
    """The host ended the loop for a fault it detected; ``code`` is ``SENSOR``, ``SLOW`` or ``LIMIT``."""

    def __init__(self, message: str, code: str):
        super().__init__(message)
        self.code = code


LOOP_RATE = 500.0  # Hz: the loop's default rate (its cost leaves the 2 ms period ~4× headroom: docs/hardware.md)
WARMUP = 0.1  # s of zero-current frames before the schedule starts (on the wall clock)
RT_PRIORITY = 20  # SCHED_FIFO priority the loop asks for (1–99; the kernel's RT throttling still leaves 5 %)
MISS_WINDOW = 25  # cycles: deadlines missed within the last this many count against the budget
MIN_SCALE = 0.125  # the slowest pace a starved loop follows the trajectory at before it stops
RECOVER_AFTER = 2.0  # s without a missed deadline before a slowed loop doubles its pace and rate again ...
RECOVER_BUSY = 0.8  # ... if every cycle since ended within this share of the doubled rate's period
RESERVE = 0.25  # share of the period kept for the estimate and the law: a reading later than that is not waited for
ON_MISSED = ("slow", "stop")


@dataclass
class ServoReport:
    """What a run did: ``cycles`` completed, ``duration`` s, achieved ``rate`` Hz and the ``nominal_rate``,
    ``missed`` deadlines (``late_wakeups`` of them missed while the loop slept, its work done: the OS woke it
    more than a period late), ``late_readings`` (cycles whose reading came too late and ran on the law's
    prediction),
    ``outcome`` (``"done"`` or the fault code: a device trip code, ``SENSOR``, ``SLOW``,
    ``LIMIT``, ``LINK``, ``INTERRUPT``), ``message``, ``off_acknowledged`` (the device confirmed all off),
    ``ended_at`` s (loop time of the end), ``realtime`` whether the loop ran with real-time scheduling,
    ``cpu_mean``/``cpu_p99``/``cpu_max`` s of the host's CPU per cycle (mean, 99th percentile, worst; this
    thread's time from the cycle's start to its end: the link's frames, estimate, law, log), ``time_scale`` the pace the
    trajectory was followed at in the end (1: as planned; see the module), ``slowed`` how often it was halved,
    ``end_error`` rad from the last estimate to the trajectory's end (``None`` before a first cycle),
    ``device_start`` the device's clock (s) at loop time 0 (the priming reading; ``None`` on the host's clock: a
    sample the device stamps at ``t_d`` is at loop time ``t_d − device_start``), and per cycle ``times`` (s), ``reference_times`` (s, the trajectory time the law followed), ``orientations (T, 3,
    3)`` (estimates), ``currents (T, N)`` (A commanded)."""

    cycles: int = 0
    duration: float = 0.0
    missed: int = 0
    outcome: str = "done"
    message: str = ""
    off_acknowledged: bool = False
    ended_at: float = 0.0
    log: Path | None = None
    nominal_rate: float = 0.0
    realtime: bool = False
    cpu_mean: float = 0.0
    cpu_p99: float = 0.0
    cpu_max: float = 0.0
    time_scale: float = 1.0
    slowed: int = 0
    late_readings: int = 0
    late_wakeups: int = 0
    end_error: float | None = None
    device_start: float | None = None
    times: list = field(default_factory=list)
    reference_times: list = field(default_factory=list)
    orientations: list = field(default_factory=list)
    currents: list = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Cycles per second between the first and the last cycle."""
        return (self.cycles - 1) / self.duration if self.duration > 0 else 0.0

    def to_dict(self, degrees: bool = True) -> dict:
        """The summary (no per-cycle lists); ``end_error`` in degrees (``degrees=False``: radians)."""
        unit, f = ("deg", math.degrees) if degrees else ("rad", float)
        return {"cycles": self.cycles, "duration_s": self.duration, "rate_Hz": self.rate,
                "nominal_rate_Hz": self.nominal_rate, "missed": self.missed, "realtime": self.realtime,
                "cpu_mean_ms": 1e3 * self.cpu_mean, "cpu_p99_ms": 1e3 * self.cpu_p99,
                "cpu_max_ms": 1e3 * self.cpu_max, "time_scale": self.time_scale, "slowed": self.slowed,
                "late_readings": self.late_readings, "late_wakeups": self.late_wakeups,
                f"end_error_{unit}": None if self.end_error is None else f(self.end_error),
                "outcome": self.outcome, "message": self.message, "off_acknowledged": self.off_acknowledged,
                "ended_at_s": self.ended_at, "log": None if self.log is None else str(self.log)}


class Paced:
    """``trajectory`` (anything with ``at(t) -> (R, ω, α)``, ``start``, ``end``) followed at a pace ``scale``
    that only falls: trajectory time ``τ(t) = τ_k + s (t − t_k)`` since the last change at ``t_k``, and
    :meth:`at` gives ``(R_d(τ), s ω_d(τ), s² α_d(τ))``. What the servo law follows when the loop slows."""

    def __init__(self, trajectory):
        self.trajectory = trajectory
        self.start, self.end = trajectory.start, trajectory.end
        self.scale, self._t, self._tau = 1.0, 0.0, 0.0

    def tau(self, t: float) -> float:
        return self._tau + self.scale * (t - self._t)

    def slow(self, t: float, factor: float) -> None:
        """From loop time ``t`` on, ``factor`` times the pace."""
        self._tau, self._t = self.tau(t), t
        self.scale *= factor

    def at(self, t: float):
        R, w, a = self.trajectory.at(self.tau(t))
        s = self.scale
        return R, s * np.asarray(w), (s * s) * np.asarray(a)


def _rotvec(R: np.ndarray) -> tuple[float, float, float]:
    """:func:`spherestep.so3.log` of one rotation in Python floats for the log line (a few µs where the array form
    costs ~0.1 ms): the unit quaternion by Shepperd's method (the largest of ``w, x, y, z`` first, accurate at
    every angle), then ``θ = 2 atan2(|v|, w)`` and ``θ v/|v|`` (``w ≥ 0``: ``θ ≤ π``)."""
    (a, b, c), (d, e, f), (g, h, i) = R.tolist()
    trace = a + e + i
    if trace >= a and trace >= e and trace >= i:
        w = 0.5 * math.sqrt(max(1.0 + trace, 0.0))
        x, y, z = (h - f) / (4 * w), (c - g) / (4 * w), (d - b) / (4 * w)
    elif a >= e and a >= i:
        x = 0.5 * math.sqrt(max(1.0 + a - e - i, 0.0))
        w, y, z = (h - f) / (4 * x), (b + d) / (4 * x), (c + g) / (4 * x)
    elif e >= i:
        y = 0.5 * math.sqrt(max(1.0 - a + e - i, 0.0))
        w, x, z = (c - g) / (4 * y), (b + d) / (4 * y), (f + h) / (4 * y)
    else:
        z = 0.5 * math.sqrt(max(1.0 - a - e + i, 0.0))
        w, x, y = (d - b) / (4 * z), (c + g) / (4 * z), (f + h) / (4 * z)
    if w < 0:
        w, x, y, z = -w, -x, -y, -z
    n = math.sqrt(x * x + y * y + z * z)
    if n < 1e-300:
        return 0.0, 0.0, 0.0
    k = 2.0 * math.atan2(n, w) / n
    return k * x, k * y, k * z


def _realtime():
    """Ask for ``SCHED_FIFO`` at ``RT_PRIORITY`` for this thread; the previous ``(policy, priority)``, or ``None``
    when the OS refuses (no permission, another OS)."""
    try:
        before = (os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(RT_PRIORITY))
    except (AttributeError, OSError):
        return None
    return before


def _restore(before) -> None:
    try:
        os.sched_setscheduler(0, before[0], os.sched_param(before[1]))
    except OSError:
        pass


def _where(report: ServoReport, trajectory) -> str:
    """Where the rotor is (the last estimate) against the trajectory's end, for a message."""
    if not report.orientations:
        return "before the first cycle"
    error = math.degrees(float(so3.distance(report.orientations[-1], trajectory.end)))
    turned = math.degrees(float(so3.distance(report.orientations[-1], trajectory.start)))
    return f"the rotor was {turned:.2f}° from the start, {error:.2f}° from the target, when the coils went off"


def _check_state(state) -> None:
    if state.stale:
        bad = [s for s in range(state.field.shape[0]) if state.stale >> s & 1]
        raise ServoFault(f"magnetometer {bad[0]} stopped delivering samples (stale)", "SENSOR")
    if np.any(state.saturated):
        raise ServoFault(f"magnetometer {int(np.argmax(state.saturated))} reads full scale", "SENSOR")


def run_servo(link: Link, estimate, law, *, duration: float, rate: float = LOOP_RATE,
              limits: CurrentLimits | None = None, log: str | Path | None = None, status=None,
              max_late: float | None = None, clock=time.monotonic, sleep=time.sleep,
              device_time: bool = True, on_missed: str = "slow", miss_budget: int = 3,
              cpu_clock=time.thread_time, realtime: bool | None = None, warmup: float | None = None) -> ServoReport:
    """Run the loop for ``duration`` s at ``rate`` Hz on an open ``link`` (see the module); returns the
    :class:`ServoReport` (its ``rate`` on the host's clock). ``status(t, R, ω, currents)`` is called every cycle (live display); ``log`` a path
    for the per-cycle log. With ``device_time`` the control law's time ``t`` (and the log's) is the device's
    clock at the reading (``<time>`` of the state), the time the motor lives in; otherwise the host's.
    ``clock``/``sleep`` are the loop's schedule (wall time by default; a simulated clock for
    :class:`~spherestep.hardware.motor_emulator.LockstepLink`). ``on_missed`` (``"slow"`` or ``"stop"``) and
    ``miss_budget`` (late cycles among the last ``MISS_WINDOW``): what a starved loop does (see the module);
    ``duration`` is in trajectory time (a slowed run lasts longer, at most ``duration / MIN_SCALE``).
    ``cpu_clock`` measures the host's CPU per cycle. With ``realtime`` (default: on the wall clock, not on a
    simulated one, where it would only hog a core) the loop's thread asks the OS for real-time scheduling
    (``SCHED_FIFO`` at ``RT_PRIORITY``, where permitted; the report's ``realtime`` says whether it got it) until
    the loop ends; the garbage collector pauses meanwhile (the loop's objects die young: reference counting frees
    them). ``warmup`` s (default ``WARMUP`` on the wall clock, 0 on another ``clock``) of zero-current ``DRIVE``
    frames at the rate come before the schedule starts, so that first calls on both ends of the link (a forked
    device's first pages, caches) fall outside it. Never raises for a fault of the motor, the sensors, the host
    or the link: the report says what ended the run."""
    if link.info is None:
        raise bad_value("link", "an open Link (call open() or use it in a with block)", link)
    max_late = 0.5 * link.info.watchdog if max_late is None else max_late
    duration, rate = checks.positive(duration, "duration"), checks.positive(rate, "rate")
    max_late = checks.positive(max_late, "max_late")
    if on_missed not in ON_MISSED:
        raise bad_value("on_missed", "'slow' or 'stop'", on_missed)
    miss_budget = checks.count(miss_budget, "miss_budget", 1)
    limits = limits if limits is not None else CurrentLimits(max_current=link.info.max_current,
                                                             max_power=link.info.max_power)
    report = ServoReport(log=None if log is None else Path(log), nominal_rate=rate)
    period = 1.0 / rate
    wall = clock is time.monotonic
    warmup = (WARMUP if wall else 0.0) if warmup is None else checks.non_negative(warmup, "warmup")
    realtime = wall if realtime is None else bool(realtime)
    end = duration  # loop time at which the trajectory time reaches duration
    window = deque(maxlen=MISS_WINDOW)  # deadlines missed before each of the last cycles
    cpu: list[float] = []
    n = link.info.coils
    currents = np.zeros(n)
    part = None if log is None else Path(str(log) + ".part")
    out = None
    if part is not None:
        out = open(part, "w", encoding="utf-8")
        out.write(LOG_HEADER)
    k = 0
    host: list[float] = []  # the host's clock at each cycle, for the achieved rate
    t0 = clock()
    paced = Paced(law.trajectory)  # the law follows the trajectory at the loop's pace until the end of the run
    planned, law.trajectory = law.trajectory, paced
    scheduling = _realtime() if realtime else None
    report.realtime = scheduling is not None
    collecting = gc.isenabled()
    gc.disable()
    try:
        warm_until = clock() + warmup
        while clock() < warm_until:  # every coil at zero, at the loop's rate: first calls on both sides, unscheduled
            _check_state(link.drive(np.zeros(n)))
            sleep(period)
        state = link.read()  # prime: the first estimate and currents come from a reading, before the clock starts
        _check_state(state)
        start_us = state.time_us
        report.device_start = start_us * 1e-6 if device_time else None
        cmd = law.step(0.0, estimate(state, law.predicted(0.0)))
        currents, emf = law.amperes(cmd.currents), cmd.emf
        limits.check_setpoints(currents)
        t0 = clock()
        t = 0.0
        read_at = t0  # the host's clock when the last reading came
        unanswered = False  # the last cycle's reading came too late to be used
        sched = 0.0  # the cycle's start on the schedule, s after t0
        clean = 0.0  # schedule time since which no deadline was missed
        while sched < end:
            start = t0 + sched
            now = clock()
            asleep = now < start  # this cycle's work is done: a miss from here on is the OS waking the loop late
            if asleep:
                sleep(start - now)
            late = clock() - start
            busy = cpu_clock()
            if late > max_late:
                raise ServoFault(f"cycle {k} started {late * 1e3:.1f} ms late, over max_late = {max_late * 1e3:.0f} "
                                 f"ms: the host is too slow for this rate ({_where(report, planned)})", "SLOW")
            if late > period:  # missed deadlines: skip the ticks that passed, do not burst to catch up
                skipped = int(late // period)
                report.missed += skipped
                report.late_wakeups += skipped if asleep else 0
                sched += skipped * period
                late -= skipped * period
                window.append(1)  # one late cycle, however many ticks it skipped
                clean = sched
                if sum(window) >= miss_budget:
                    if on_missed == "stop" or paced.scale * 0.5 < MIN_SCALE:
                        raise ServoFault(f"the loop missed {report.missed} deadlines at {rate * paced.scale:g} Hz "
                                         f"({sum(window)} of its last {len(window)} cycles late, "
                                         f"{report.late_readings} readings late in all"
                                         f"{', at the slowest pace' if on_missed == 'slow' else ''}): stopped "
                                         f"with every coil off; {_where(report, planned)}", "SLOW")
                    end = sched + (end - sched) * 2.0  # the rest of the trajectory at half the pace
                    paced.slow(t, 0.5)
                    period *= 2.0
                    report.slowed += 1
                    window.clear()
            else:
                window.append(0)
                if paced.scale < 1.0 and sched - clean >= RECOVER_AFTER:
                    end = sched + (end - sched) * 0.5  # starved no longer: back up a step
                    paced.slow(t, 2.0)
                    period *= 0.5
                    clean = sched
            # the reading may take until RESERVE of the period is left for the estimate and the law (on the wall
            # clock, and not twice in a row: a silent link is the link's to diagnose, with its own timeout)
            within = None if not wall or unanswered else max(start + (1.0 - RESERVE) * period - clock(),
                                                              RESERVE * period)
            sent = clock()
            state = link.drive(currents, emf=emf, within=within)
            now = clock()
            unanswered = state is None
            stale = unanswered or now - sent > 1.0 / rate  # an estimate from a reading this old may be volts off
            if unanswered:  # a late reading: the law runs on its own prediction for this cycle
                report.late_readings += 1
                t += now - read_at
                cmd = law.step(t, law.predicted(t))
            else:
                _check_state(state)
                t = (((state.time_us - start_us) & 0xFFFFFFFF) * 1e-6 if device_time else clock() - t0)
                cmd = law.step(t, estimate(state, law.predicted(t)))
            read_at = now
            R, w = cmd.estimate, cmd.velocity
            currents, emf = law.amperes(cmd.currents), None if stale else cmd.emf
            limits.check_setpoints(currents)
            report.times.append(t)
            report.reference_times.append(paced.tau(t))
            host.append(clock() - t0)
            report.orientations.append(R)
            report.currents.append(currents)
            report.cycles += 1
            if out is not None:
                rv = _rotvec(R)
                out.write(f"{t:.6f},{late:.6f},{rv[0]:.8f},{rv[1]:.8f},{rv[2]:.8f},{w[0]:.6f},{w[1]:.6f},{w[2]:.6f},"
                          f"{limits.resistance * float(currents @ currents):.4f},{np.abs(currents).max():.5f},"
                          f"{'-' if state is None else format(state.stale, 'X')}\n")
            if status is not None:
                status(t, R, w, currents)
            cpu.append(cpu_clock() - busy)
            if clock() - start > RECOVER_BUSY * 0.5 * period:  # too long a cycle for twice the rate
                clean = sched
            k += 1
            sched += period
    except NakError as exc:  # a device trip (DeviceTrip) or a refused setpoint (LIMIT)
        report.outcome, report.message = exc.code, str(exc)
    except ServoFault as exc:
        report.outcome, report.message = exc.code, str(exc)
    except ThermalLimitError as exc:
        report.outcome, report.message = "LIMIT", str(exc)
    except LinkError as exc:
        report.outcome, report.message = "LINK", str(exc)
    except KeyboardInterrupt:
        report.outcome, report.message = "INTERRUPT", "interrupted"
    except SystemError as exc:  # Ctrl-C or SIGTERM inside a compiled (numba) call surfaces so
        if interrupt_of(exc) is None:
            raise
        report.outcome, report.message = "INTERRUPT", "interrupted"
    finally:
        if collecting:
            gc.enable()
        if scheduling is not None:
            _restore(scheduling)
        law.trajectory = planned
        report.ended_at = clock() - t0
        report.duration = host[-1] - host[0] if host else 0.0
        report.time_scale = paced.scale
        if cpu:
            report.cpu_mean, report.cpu_p99, report.cpu_max = (float(np.mean(cpu)), float(np.percentile(cpu, 99)),
                                                               float(np.max(cpu)))
        if report.orientations:
            report.end_error = float(so3.distance(report.orientations[-1], planned.end))
        try:
            link.off()
            report.off_acknowledged = True
        except LinkError as exc:
            if not report.message:
                report.outcome, report.message = "LINK", str(exc)
            report.message += "; OFF was not acknowledged: the device's watchdog switches the coils off within " \
                              f"{link.info.watchdog * 1e3:.0f} ms"
        if out is not None:
            out.close()
            os.replace(part, report.log)
    return report
