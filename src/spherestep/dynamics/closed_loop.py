"""Closed-loop stepping: measure, re-plan from the measurement, step; with noise and missed steps.

At each step ``i`` of the desired motion the controller measures the orientation (the true one turned by
a random rotation vector with independent N(0, σ²) components), takes the stepper state nearest the
measurement as where the rotor is, chooses the next state towards ``R_i`` with the geometric planner's
rule (:func:`~spherestep.commutation.geometric.next_state`) and energises its coils for the dwell. A
*missed* step (drawn with probability ``missed``) energises nothing new, so the rotor stays where it was;
the next measurement shows it and the controller plans from there. After the last target it keeps
stepping (at most ``extra_steps`` times) until the measured state is the one nearest the final target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import so3
from ..commutation.geometric import DEFAULT_CANDIDATES, next_state
from ..errors import bad_value
from ..motor import coil_currents
from .rotor import Integrator, Rotor
from ..commutation.trajectory import check_targets
from .._fast.threads import single_blas_thread


@dataclass
class ClosedLoopRun:
    """Per controller step: ``targets``, ``true`` and ``measured`` orientations (``(S, 3, 3)``), the
    ``commanded`` state indices, whether the step was ``missed``; ``final_error`` (rad) = D(true, R_n); ``goal``
    the stepper state nearest ``R_n``, the one the loop steers to, and ``dwell`` (s) per controller step."""

    targets: np.ndarray
    true: np.ndarray
    measured: np.ndarray
    commanded: np.ndarray
    missed: np.ndarray
    final_error: float
    goal: np.ndarray
    dwell: float

    @property
    def end_error(self) -> float:
        """Park distance (rad) from where the rotor ends to :attr:`goal`: what the closed loop is judged on (a
        relay can land only on its states; the goal may be a few degrees from ``R_n``)."""
        return float(so3.distance(self.true[-1], self.goal))

    @property
    def errors(self) -> np.ndarray:
        """Park distance (rad) between the true orientation and the target, per controller step."""
        return so3.distance(self.true, self.targets)

    def to_csv(self, path=None, axis=None) -> str:
        """One row per controller step: ``step``, ``missed`` (0/1), ``error_deg`` (D(true, target)) and, with
        ``axis``, the desired and true angles turned about it (degrees, :func:`so3.turned_angle`). Written
        atomically to ``path`` when given; returns the text."""
        import csv
        import io

        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["step", "missed", "error_deg"] + ([] if axis is None else ["turned_desired_deg",
                                                                               "turned_true_deg"]))
        angles = [] if axis is None else [np.degrees(so3.turned_angle(self.targets, axis)),
                                          np.degrees(so3.turned_angle(self.true, axis))]
        for i, (m, e) in enumerate(zip(self.missed, np.degrees(self.errors))):
            w.writerow([i, int(m), f"{e:.6f}"] + [f"{a[i]:.6f}" for a in angles])
        text = buf.getvalue()
        if path is not None:
            from ..atomic import write_text

            write_text(path, text)
        return text


@single_blas_thread
def run_closed_loop(design, targets, model, *, dwell: float = 0.5, noise: float = 0.0, missed: float = 0.0,
                    rotor: Rotor | None = None, dt: float = 1e-3, extra_steps: int = 10,
                    rng: np.random.Generator | int | None = None) -> ClosedLoopRun:
    """Follow ``targets (n+1, 3, 3)`` in closed loop (see the module docstring); ``noise`` is σ in radians."""
    targets = check_targets(targets)
    if not (math.isfinite(noise) and noise >= 0):
        raise bad_value("noise", "a non-negative angle in radians", noise)
    if not (math.isfinite(missed) and 0 <= missed < 1):
        raise bad_value("missed", "a fraction in [0, 1)", missed)
    rng = np.random.default_rng(rng)
    states = design.states()
    rotor = Rotor.from_design(design) if rotor is None else rotor
    integrator = Integrator(model, rotor, dt)
    N = len(design.stator)
    _, near = states.nearest(targets, k=DEFAULT_CANDIDATES)
    R = states.rotations[int(near[0, 0])].copy()
    w = np.zeros(3)
    coils = states.coils(int(near[0, 0]))
    log_t, log_true, log_meas, log_cmd, log_missed = [], [], [], [], []

    def measure(R_true):
        return so3.exp(rng.normal(0.0, noise, 3)) @ R_true if noise else R_true

    n = len(targets) - 1
    plan_targets = list(range(1, n + 1)) + [n] * extra_steps
    for count, i in enumerate(plan_targets):
        R_meas = measure(R)
        here = int(states.nearest(R_meas)[1].ravel()[0])
        if count >= n and here == int(near[n, 0]):
            break
        goal, _ = next_state(states, here, targets[i], near[i], design.max_step, last=i == n)
        skip = rng.random() < missed
        if not skip:
            coils = states.coils(goal)
        R, w, *_ = integrator.run(R, w, coil_currents(coils, N), dwell, record_every=10**9)
        log_t.append(targets[i])
        log_true.append(R.copy())
        log_meas.append(R_meas)
        log_cmd.append(goal)
        log_missed.append(skip)
    return ClosedLoopRun(np.array(log_t), np.array(log_true), np.array(log_meas), np.array(log_cmd),
                         np.array(log_missed), float(so3.distance(R, targets[-1])),
                         states.rotations[int(near[n, 0])].copy(), float(dwell))
