"""One judgement of success for every run that moves a rotor: :func:`judge` → :class:`Judgement`.

The rule: a run did what it reports when every pose it is judged on is within ``tolerance`` (rad here, degrees on
the command line's ``--tolerance``) of the pose it was driven to. Each run is judged on what it can reach:

* a relay plan (``simulate``'s open loop, ``run --simulate``): each settled step against the plan's state for it —
  what those commands report is the plan's execution;
* the closed loop (``simulate --noise/--missed``): its end against the state nearest the turn's end, the state it
  steers to (a relay lands only on its states);
* a driven turn (``move`` in every mode, the demo's drives; :func:`judge_drive`): it arrived by its mode's own
  rule, and its end is within the tolerance of the turn's end — the turn asked for;
* a calibration's holds: each rest against its target.

Left out, the tolerance is the run's own: :data:`SERVO_TOLERANCE` 0.05° for the servo and holds (the loop holds
there), :data:`RELAY_TOLERANCE` 0.5° for relay steps (the settling of a tuned rotor in its well). A run that is
not ok ends the command with exit 1 and :attr:`Judgement.reason`, one line naming the first step (or time) that
missed and its error; its files are still written, they show how it failed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SERVO_TOLERANCE = math.radians(0.05)
RELAY_TOLERANCE = math.radians(0.5)
KINDS = {"servo": SERVO_TOLERANCE, "hold": SERVO_TOLERANCE, "relay": RELAY_TOLERANCE}
MODE_TOLERANCE = {"servo": SERVO_TOLERANCE, "ramped": RELAY_TOLERANCE, "settled": RELAY_TOLERANCE}  # a drive's own


def tolerance(degrees: float | None, kind: str) -> float:
    """The tolerance in rad: ``degrees`` when given (``--tolerance``), else the ``kind``'s own (:data:`KINDS`)."""
    if degrees is not None:
        return math.radians(degrees)
    return KINDS[kind]


@dataclass(frozen=True)
class Judgement:
    """``what`` was judged on ``checked`` poses within ``tolerance`` (rad); ``failed`` of them missed, the first
    at index ``first`` (a ``label``: step, hold, end) at time ``first_time`` (s, or None) by ``first_error``
    (rad); ``worst`` the largest error (rad); ``note`` a reason of the run's own (a drive that never arrived)."""

    what: str
    tolerance: float
    checked: int
    failed: int
    first: int | None
    first_time: float | None
    first_error: float
    worst: float
    label: str = "step"
    note: str = ""

    @property
    def ok(self) -> bool:
        """Every judged pose within the tolerance."""
        return self.failed == 0

    @property
    def reason(self) -> str:
        """One line: why the run is not ok ("" when it is)."""
        if self.ok:
            return ""
        if self.note:
            return f"{self.what}: {self.note} (final error {math.degrees(self.worst):.3g}°)"
        at = "" if self.first_time is None else f" (t = {self.first_time:.3g} s)"
        where = f"it ended{at}" if self.label == "end" else f"{self.label} {self.first}{at} ended"
        count = "" if self.checked == 1 else f"; {self.failed} of {self.checked} {self.label}s missed"
        return (f"{self.what}: {where} {math.degrees(self.first_error):.3g}° off, "
                f"more than the tolerance {math.degrees(self.tolerance):.3g}°{count}, worst "
                f"{math.degrees(self.worst):.3g}° (--tolerance to judge it otherwise)")

    def to_dict(self) -> dict:
        """JSON-ready, angles in degrees."""
        return {"ok": self.ok, "reason": self.reason, "tolerance_deg": math.degrees(self.tolerance),
                "checked": self.checked, "failed": self.failed, "first": self.first, "first_time_s": self.first_time,
                "worst_deg": math.degrees(self.worst), "label": self.label}

    def require(self, files: str = "") -> None:
        """Raise :class:`~spherestep.errors.ComputationError` (CLI exit 1) with :attr:`reason` unless ok;
        ``files`` (a folder) is named as where the run's files are."""
        if not self.ok:
            from ..errors import ComputationError

            raise ComputationError(self.reason + (f"; files in {files}" if files else ""))


def judge(errors, tolerance: float, what: str, *, times=None, label: str = "step", first_index: int = 0) -> Judgement:
    """Judge ``errors`` (rad, one per pose, in order; NaN counts as missed) against ``tolerance`` (rad); ``times``
    (s) per pose name when the first miss happened; poses are numbered from ``first_index``."""
    errors = np.atleast_1d(np.asarray(errors, dtype=float))
    if errors.size == 0:
        raise ValueError("judge: no poses to judge")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"judge: the tolerance must be a positive angle in rad; instead received {tolerance!r}")
    missed = np.flatnonzero(~(errors <= tolerance))
    worst = float(np.nanmax(errors)) if np.isfinite(errors).any() else math.inf
    if missed.size == 0:
        return Judgement(what, float(tolerance), errors.size, 0, None, None, 0.0, worst, label)
    k = int(missed[0])
    t = None if times is None else float(np.asarray(times, dtype=float)[k])
    return Judgement(what, float(tolerance), errors.size, int(missed.size), k + first_index, t, float(errors[k]), worst,
                   label)


def judge_drive(result) -> Judgement:
    """A :class:`~spherestep.drive.DriveResult`: it arrived for good (``time`` finite: the servo within its
    tolerance of the turn's end, relay steps within 0.5° of the plan's last state; ``arrival_note`` says why
    not), and its end is within its ``tolerance`` of the turn's end."""
    what = f"{result.mode} on the {result.backend} motor ({result.model})"
    if result.arrived:
        return judge([result.final_error], result.tolerance, what, times=[float(result.times[-1])], label="end")
    return Judgement(what, result.tolerance, 1, 1, 0, float(result.times[-1]), result.final_error,
                   result.final_error, "end", f"it did not arrive: {result.arrival_note}")
