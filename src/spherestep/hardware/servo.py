"""The servo loop on hardware: read sensors, estimate, control, allocate, send currents, at a fixed rate.

:func:`run_servo` drives a :class:`~spherestep.hardware.drive_link.DriveLink` (a real board, or
:class:`~spherestep.hardware.motor_emulator.MotorPty`) with two callables:

* ``estimate(state, prior) -> R``: the measured orientation (3×3) from a
  :class:`~spherestep.hardware.protocol2.State` (magnetometers and measured coil currents), searched from
  ``prior``; it raises :class:`ServoFault` on readings it cannot trust
  (:class:`~spherestep.hardware.servo_parts.FieldTracker`);
* ``law``: the control room's :class:`~spherestep.control.ServoLaw`, the same law the simulation runs. Each cycle
  ``law.step(t, R)`` takes the measurement at the reading's time ``t`` and returns per-unit currents, sent as
  ``law.amperes(c)`` A; the estimate and the angular velocity ``ω̂`` (rad/s, fixed frame) logged and shown are
  its observer's, and ``prior`` is the observer's prediction for ``t``, ``exp((t − t̂) ω̂) R̂``.

A first ``READ`` primes the estimate and the currents; then cycle ``k`` starts at ``t_0 + k / rate``: ``DRIVE`` the currents computed in cycle ``k − 1`` and receive the
state, check it (a stale magnetometer, a saturated one → ``SENSOR``), estimate, control, check the currents
against the :class:`~spherestep.hardware.limits.CurrentLimits`, then wait for the next start. A cycle that
starts more than one period late misses deadlines (counted; the ticks that passed are skipped, not caught up
in a burst); one that starts more than ``max_late`` late (default half the device's watchdog period) ends the
run (``SLOW``) — unless the device's watchdog saw the silence first (``WDOG``).
Whatever ends the run — done, a fault seen by the host, a trip reported by the device, a lost link, Ctrl-C —
the loop sends ``OFF`` and reports whether the device acknowledged it (if the link is gone, the device's
watchdog switches the coils off within its period). Each cycle is one line of the log, streamed to
``log + ".part"`` and renamed to ``log`` at the end (a log is whole or marked partial, never half-written in
place).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import checks, so3
from ..errors import ComputationError, bad_value
from .backend import LinkError
from .drive_link import DriveLink
from .limits import CurrentLimits, ThermalLimitError
from .serialport import NakError

LOG_HEADER = "t_s,late_s,rx,ry,rz,wx,wy,wz,power_W,max_abs_current_A,stale\n"


class ServoFault(ComputationError):
    """The host ended the loop for a fault it detected; ``code`` is ``SENSOR``, ``SLOW`` or ``LIMIT``."""

    def __init__(self, message: str, code: str):
        super().__init__(message)
        self.code = code


@dataclass
class ServoReport:
    """What a run did: ``cycles`` completed, ``duration`` s, achieved ``rate`` Hz, ``missed`` deadlines,
    ``outcome`` (``"done"`` or the fault code: a device trip code, ``SENSOR``, ``SLOW``, ``LIMIT``, ``LINK``,
    ``INTERRUPT``), ``message``, ``off_acknowledged`` (the device confirmed all off), ``ended_at`` s (loop time
    of the end), and per-cycle ``times`` (s), ``orientations (T, 3, 3)`` (estimates), ``currents (T, N)`` (A
    commanded)."""

    cycles: int = 0
    duration: float = 0.0
    missed: int = 0
    outcome: str = "done"
    message: str = ""
    off_acknowledged: bool = False
    ended_at: float = 0.0
    log: Path | None = None
    times: list = field(default_factory=list)
    orientations: list = field(default_factory=list)
    currents: list = field(default_factory=list)

    @property
    def rate(self) -> float:
        """Cycles per second between the first and the last cycle."""
        return (self.cycles - 1) / self.duration if self.duration > 0 else 0.0

    def to_dict(self) -> dict:
        return {"cycles": self.cycles, "duration_s": self.duration, "rate_Hz": self.rate, "missed": self.missed,
                "outcome": self.outcome, "message": self.message, "off_acknowledged": self.off_acknowledged,
                "ended_at_s": self.ended_at, "log": None if self.log is None else str(self.log)}


def _check_state(state) -> None:
    if state.stale:
        bad = [s for s in range(state.field.shape[0]) if state.stale >> s & 1]
        raise ServoFault(f"magnetometer {bad[0]} stopped delivering samples (stale)", "SENSOR")
    if np.any(state.saturated):
        raise ServoFault(f"magnetometer {int(np.argmax(state.saturated))} reads full scale", "SENSOR")


def run_servo(link: DriveLink, estimate, law, *, duration: float, rate: float = 200.0,
              limits: CurrentLimits | None = None, log: str | Path | None = None, status=None,
              max_late: float | None = None, clock=time.monotonic, sleep=time.sleep,
              device_time: bool = True) -> ServoReport:
    """Run the loop for ``duration`` s at ``rate`` Hz on an open ``link`` (see the module); returns the
    :class:`ServoReport` (its ``rate`` on the host's clock). ``status(t, R, ω, currents)`` is called every cycle (live display); ``log`` a path
    for the per-cycle log. With ``device_time`` the control law's time ``t`` (and the log's) is the device's
    clock at the reading (``<time>`` of the state), the time the motor lives in; otherwise the host's.
    ``clock``/``sleep`` are the loop's schedule (wall time by default; a simulated clock for
    :class:`~spherestep.hardware.motor_emulator.LockstepLink`). Never raises for a fault of the motor, the sensors, the host or the link: the
    report says what ended the run."""
    if link.info is None:
        raise bad_value("link", "an open DriveLink (call open() or use it in a with block)", link)
    max_late = 0.5 * link.info.watchdog if max_late is None else max_late
    duration, rate = checks.positive(duration, "duration"), checks.positive(rate, "rate")
    max_late = checks.positive(max_late, "max_late")
    limits = limits if limits is not None else CurrentLimits(max_current=link.info.max_current,
                                                             max_power=link.info.max_power)
    report = ServoReport(log=None if log is None else Path(log))
    period = 1.0 / rate
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
    try:
        state = link.read()  # prime: the first estimate and currents come from a reading, before the clock starts
        _check_state(state)
        start_us = state.time_us
        cmd = law.step(0.0, estimate(state, law.predicted(0.0)))
        currents = law.amperes(cmd.currents)
        limits.check_setpoints(currents)
        t0 = clock()
        while k * period < duration:
            start = t0 + k * period
            now = clock()
            if now < start:
                sleep(start - now)
            late = clock() - start
            if late > max_late:
                raise ServoFault(f"cycle {k} started {late * 1e3:.1f} ms late, over max_late = {max_late * 1e3:.0f} "
                                 "ms: the host is too slow for this rate", "SLOW")
            if late > period:  # missed deadlines: skip the ticks that passed, do not burst to catch up
                skipped = int(late // period)
                report.missed += skipped
                k += skipped
            state = link.drive(currents)
            _check_state(state)
            t = (((state.time_us - start_us) & 0xFFFFFFFF) * 1e-6 if device_time else clock() - t0)
            cmd = law.step(t, estimate(state, law.predicted(t)))
            R, w = cmd.estimate, cmd.velocity
            currents = law.amperes(cmd.currents)
            limits.check_setpoints(currents)
            report.times.append(t)
            host.append(clock() - t0)
            report.orientations.append(R)
            report.currents.append(currents)
            report.cycles += 1
            if out is not None:
                rv = so3.log(R)
                out.write(f"{t:.6f},{late:.6f},{rv[0]:.8f},{rv[1]:.8f},{rv[2]:.8f},{w[0]:.6f},{w[1]:.6f},{w[2]:.6f},"
                          f"{limits.resistance * float(currents @ currents):.4f},{np.abs(currents).max():.5f},"
                          f"{state.stale:X}\n")
            if status is not None:
                status(t, R, w, currents)
            k += 1
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
    finally:
        report.ended_at = clock() - t0
        report.duration = host[-1] - host[0] if host else 0.0
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
