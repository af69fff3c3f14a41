"""The search's progress line: which stage it is in and an ETA over the whole run left (issue 29 §2).

A run is a list of stages — the ladder (and any local round), the finalists' design files, their verification by
full simulation, the report — each a set of tasks with estimated costs in seconds of one worker, run ``slots`` at a
time. The time left is the current stage's plus every later stage's:

* the current stage's: ``pace × (estimated seconds of the tasks left) / slots``, the pace measured on the fly as
  the finished tasks' measured seconds over their estimated seconds (it absorbs the machine's load and the
  estimates' common error). A task finished without its seconds (:meth:`Progress.advance`) counts as done but not
  in the pace — the search so reports a ladder task stopped at the geometry rung (milliseconds, whatever its size)
  and one that may solve an iron table (another cost altogether). Before a paced task finishes, the estimate less
  the time spent stands;
* a later stage's: its estimate (:meth:`Progress.expect`), revised as the run learns — the search estimates the
  verification and the report from the ladder's measured seconds of the rows that pass (:func:`after_ladder`).

The constants were measured on this 2-core machine (2026-11-26, the camera gimbal's ``normal`` search, 1296 tasks
on 2 workers, load 1–5; docs/synthesis.md, *Progress and its ETA*). A ladder task costs :data:`ALIGNMENT_SECONDS`
× ``(M N)²`` (``M`` rotor poles, ``N`` stator caps within the cap: the enumeration's candidate alignments, as
:func:`~spherestep.synthesis.run.cost_estimate` orders the tasks): 909 s over the 1196 tasks that passed the
geometry rung. Paced by the same weights with the geometry rung's tasks included, as before, the biggest layouts —
too many coils, milliseconds each, finished first — set the pace near zero (the ETA said 64 s with 7 min left,
and counted the ladder alone). A finalist's verification costs its ladder time plus :data:`VERIFY_SECONDS` (the servo
turn and the holds; 2–31 s measured against 0.1–46 s of ladder), the report the shown design's states again
(:data:`REPORT_STATES` of its ladder time: 21 s against 30 s in one run, 14 s against 46 s in another, its ladder
task slowed at the run's start) plus :data:`REPORT_SECONDS`. Three measured runs replay through this ETA
(tests/test_synthesis_eta.py) within 1.8× of the time left from 10 % of the run on.

A relay spec's task also runs the relay rung's many-turn check (:func:`spherestep.drive.many_turns`: 20 random
turns planned and simulated, stopping once 95 % is out of reach), which the enumeration's ``(M N)²`` does not
see: :func:`relay_rung_seconds`, :data:`MANY_TURNS_SECONDS` — a design that passes runs all 20 turns (the 0.25 T
prototype, ``examples/designs/relays-iron.yaml``: 823 steps, 16.6 s CPU, 20 ms a step planned on iron and
integrated over its dwell; 2026-11-28, after issue 39's planner speed-up), one that fails stops after 2–3 (the
prototype as built: 3 turns, 136 steps, 6.8 s, its blocked steps the costly ones). The quick budget's relay
runs measured the rung at 70–90 % of a task's seconds of the rows that reach it (the prototype's 92 × 33
layout: 110 s of a row against the enumeration's 8.5 s estimate, at load 12). A task pruned at a cheaper rung
never runs it: in the ``normal`` relay search 87 of 680 tasks reached it (docs/synthesis.md), so each task of a
relay spec is charged :data:`REACH_RUNG` × :data:`MANY_TURNS_SECONDS` (2.2 s); the pace of the finished tasks
corrects a search whose share differs (the quick budget's five all reach it). So charged, the ``normal`` relay
searches (702 layouts) are estimated at 66 min of one worker (26 min of it the rung), ~33 min on two.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

ALIGNMENT_SECONDS = 6e-7  # s of one worker per (rotor pole × coil in the cap)² (909 s over 1.53e9, 1196 tasks)
SOLVE_SECONDS = 180.0  # s of a task that solves an iron table first (docs/synthesis.md: a minute idle, 4-12 loaded)
BUILD_SECONDS = 0.1  # s to build and write one finalist's design file (4 in under 0.1 s)
VERIFY_SECONDS = 4.0  # s of a finalist's verification beyond its ladder time (3.9-8 s measured)
REPORT_SECONDS = 3.0  # s of the report's figures and tables (the quick budget's report: 3.4 s)
MANY_TURNS_SECONDS = 17.0  # s of one worker: the relay rung's many-turn check of a design that passes it (below)
REACH_RUNG = 0.13  # the share of a relay search's tasks that reach the relay rung (87 of 680, the normal budget's)
REPORT_STATES = 0.45  # the report's states over the shown design's ladder time (21 s of 30 s; 14 s of 46 s)
REFRESH = 10.0  # s: the longest a progress line keeps its ETA within a stage (Progress.line)
CHANGE = 0.2  # the relative change of the ETA that refreshes the line sooner
STAGES = ("ladder", "finalists", "verification", "report")


def after_ladder(row_seconds: Sequence[float], finalists: int, slots: int) -> dict[str, float]:
    """Wall-second estimates of the stages after the ladder, from the ladder's measured seconds of the rows that
    passed (``row_seconds``). The finalists are the preferred best and the best in each other objective: one of
    them, the most torque, is about the costliest row, the others nearer the middle (both measured gimbal runs),
    so the costliest row and ``finalists − 1`` at the median stand for them — building each
    (:data:`BUILD_SECONDS`, one at a time), verifying each (:func:`verify_seconds`, ``slots`` at a time), the
    report on the costliest (:data:`REPORT_STATES` of its ladder time + :data:`REPORT_SECONDS`)."""
    ordered = sorted(float(s) for s in row_seconds)
    picks = [ordered[-1]] + [ordered[(len(ordered) - 1) // 2]] * (finalists - 1) if ordered else []
    picks += [0.0] * (finalists - len(picks))  # nothing passed yet: the fixed parts at least
    return {"finalists": BUILD_SECONDS * finalists,
            "verification": sum(map(verify_seconds, picks)) / min(max(1, int(slots)), max(finalists, 1)),
            "report": REPORT_STATES * max(picks, default=0.0) + REPORT_SECONDS}


def relay_rung_seconds(relays: bool) -> float:
    """Estimated seconds of one worker for the relay rung's many-turn check of a task of a relay spec
    (``relays``; 0 otherwise): the check of a design that passes it, :data:`MANY_TURNS_SECONDS`, times the share
    of tasks that reach the rung, :data:`REACH_RUNG` (module docstring)."""
    return REACH_RUNG * MANY_TURNS_SECONDS if relays else 0.0


def verify_seconds(ladder_seconds: float) -> float:
    """Estimated seconds of one worker to verify a finalist whose ladder task took ``ladder_seconds``."""
    return float(ladder_seconds) + VERIFY_SECONDS


class Progress:
    """Stages, counts and the ETA of the whole run left (module docstring). ``stages``: the planned stage names in
    order; ``clock``: seconds (a fake clock in tests).

    >>> bar = Progress(["ladder", "report"])
    >>> bar.expect("report", 5.0); bar.begin("ladder", [10.0, 10.0], slots=2)
    >>> bar.left()                 # nothing finished: the estimates, 20 s over 2 slots, then the report
    15.0
    """

    def __init__(self, stages: Sequence[str] = STAGES, clock: Callable[[], float] = time.perf_counter):
        self.stages = list(stages)
        self.clock = clock
        self.expected = {s: 0.0 for s in self.stages}  # wall seconds of each stage not yet begun
        self.stage: str | None = None
        self.started = clock()
        self._shown: tuple | None = None

    def expect(self, stage: str, seconds: float) -> None:
        """The estimated wall seconds of a later ``stage``."""
        if stage not in self.stages:
            self.stages.insert(self._next(), stage)
        self.expected[stage] = max(0.0, float(seconds))

    def begin(self, stage: str, costs: Sequence[float] = (), slots: int = 1) -> None:
        """``stage`` begins (a name not planned is inserted here, e.g. a local round): its tasks' estimated
        seconds of one worker (``costs``), run ``slots`` at a time; the stages before it are over."""
        if stage not in self.stages:
            self.stages.insert(self._next(), stage)
        for s in self.stages[:self.stages.index(stage)]:
            self.expected[s] = 0.0
        self.stage, self.slots = stage, max(1, int(slots))
        self.total, self.done = len(costs), 0
        self.cost_total, self.cost_done = float(sum(costs)), 0.0
        self.paced_cost, self.paced_seconds = 0.0, 0.0  # the finished tasks whose seconds were reported
        self.begun = self.clock()
        self.expected[stage] = self.cost_total / self.slots

    def advance(self, cost: float, seconds: float | None = None) -> None:
        """One task of the current stage finished: its estimated ``cost`` and, when known, its measured
        ``seconds`` (of the worker that ran it)."""
        self.done += 1
        self.cost_done += float(cost)
        if seconds is not None:
            self.paced_cost += float(cost)
            self.paced_seconds += float(seconds)

    def stage_left(self) -> float:
        """Wall seconds left in the current stage (module docstring)."""
        if self.stage is None:
            return 0.0
        left = max(self.cost_total - self.cost_done, 0.0)
        spent = self.clock() - self.begun
        if self.paced_cost > 0:
            return self.paced_seconds / self.paced_cost * left / self.slots
        return max(left / self.slots - spent, 0.0)

    def left(self) -> float:
        """Wall seconds left in the whole run: the current stage's and every later stage's estimate."""
        later = self.stages[self._next():]
        return self.stage_left() + sum(self.expected[s] for s in later)

    def eta(self) -> str:
        """``ETA 42 s`` or ``ETA 3.5 min``: :meth:`left` for people."""
        return _eta(self.left())

    def line(self, detail: str) -> str:
        """The progress line: ``stage 1 of 4, ladder: <detail> (ETA …)``. Within one stage and detail the shown
        ETA is kept until it is :data:`REFRESH` s old or off the current one by more than :data:`CHANGE`, so a
        plain line per change of text stays periodic while the ETA stays within that of the current one."""
        now, left = self.clock(), self.left()
        key = (self.stage, detail)
        if self._shown is not None:
            shown_key, at, shown_left, text = self._shown
            if shown_key == key and now - at < REFRESH and abs(left - shown_left) <= CHANGE * max(shown_left, 1.0):
                return text
        n = self.stages.index(self.stage) + 1 if self.stage in self.stages else 0
        text = f"stage {n} of {len(self.stages)}, {self.stage}: {detail} ({_eta(left)})"
        self._shown = (key, now, left, text)
        return text

    def _next(self) -> int:
        """Index of the first stage after the current one."""
        return self.stages.index(self.stage) + 1 if self.stage in self.stages else 0


def _eta(left: float) -> str:
    return f"ETA {left:.0f} s" if left < 120 else f"ETA {left / 60:.1f} min"
