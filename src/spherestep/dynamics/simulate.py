"""Running a plan on the simulated rotor: energise each step's coils for a dwell time and watch it settle.

The rotor starts at rest in the plan's first state. For step ``i`` the currents are ``c_k = ±1`` for the
step's coils (0 elsewhere) for ``dwell`` seconds; the orientation at the end of the dwell is the step's
*settled* orientation. The plan is *executed* when every settled orientation is within ``tolerance``
(default 0.5°) of the planned ``R̃_i``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..motor import coil_currents
from .rotor import Integrator, Rotor
from .._fast.threads import single_blas_thread

EXECUTED_TOL = math.radians(0.5)


@dataclass(frozen=True)
class SimulationSummary:
    """What a settled run did (:meth:`Simulation.summary`): ``steps``, whether every step was ``executed``, the
    settling errors ``settled_error_median`` and ``settled_error_max`` against the ``tolerance`` (rad), the
    ``missed_steps`` (indices) and the ``simulated`` time (s)."""

    steps: int
    executed: bool
    settled_error_median: float
    settled_error_max: float
    tolerance: float
    missed_steps: tuple[int, ...]
    simulated: float

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready; angles in degrees (``*_deg``), or radians (``*_rad``) with ``degrees=False``."""
        unit, conv = ("deg", math.degrees) if degrees else ("rad", float)
        return {"steps": self.steps, "executed": self.executed,
                f"settled_error_median_{unit}": conv(self.settled_error_median),
                f"settled_error_max_{unit}": conv(self.settled_error_max), f"tolerance_{unit}": conv(self.tolerance),
                "missed_steps": list(self.missed_steps), "simulated_s": self.simulated}


@dataclass
class Simulation:
    """A simulated run: ``times (T,)`` s, ``orientations (T, 3, 3)``, ``angular_velocity (T, 3)`` rad/s,
    ``active_coils (T, N)`` currents, ``settled (n+1, 3, 3)`` one per plan step, ``planned (n+1, 3, 3)``,
    ``energy (T,)`` J (kinetic + potential) and ``tolerance`` (rad)."""

    times: np.ndarray
    orientations: np.ndarray
    angular_velocity: np.ndarray
    active_coils: np.ndarray
    settled: np.ndarray
    planned: np.ndarray
    energy: np.ndarray
    tolerance: float = EXECUTED_TOL

    @property
    def step_errors(self) -> np.ndarray:
        """Park distance (rad) between settled and planned orientation, per plan step."""
        return so3.distance(self.settled, self.planned)

    @property
    def executed(self) -> bool:
        """Every step settled within ``tolerance`` of the plan."""
        return bool(np.all(self.step_errors <= self.tolerance))

    @property
    def missed_steps(self) -> np.ndarray:
        """Indices of the steps that did not settle within ``tolerance``."""
        return np.flatnonzero(self.step_errors > self.tolerance)

    def summary(self) -> SimulationSummary:
        """Steps, execution, settling errors (rad), the steps that missed the tolerance and the simulated time
        (:class:`SimulationSummary`; ``.to_dict()`` for people)."""
        err = self.step_errors
        return SimulationSummary(len(self.planned) - 1, self.executed, float(np.median(err)), float(err.max()),
                                 float(self.tolerance), tuple(int(k) for k in self.missed_steps),
                                 float(self.times[-1]))

    def to_csv(self, path=None, axis=None) -> str:
        """One row per recorded sample: ``t_s``, unit quaternion ``qw, qx, qy, qz`` (scalar first), angular
        velocity (rad/s, fixed frame), the angle turned about ``axis`` (degrees, :func:`so3.turned_angle`; the
        column is left out without ``axis``) and the energised coils (``k:+1;…``). Written atomically to
        ``path`` when given; returns the text."""
        import csv
        import io

        q = so3.quaternion_rows(self.orientations)
        turned = None if axis is None else np.degrees(so3.turned_angle(self.orientations, axis))
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(["t_s", *so3.QUATERNION_COLUMNS, "wx_rad_s", "wy_rad_s", "wz_rad_s"]
                   + ([] if axis is None else ["turned_deg"]) + ["coils"])
        for i, (t, qq, om, c) in enumerate(zip(self.times, q, self.angular_velocity, self.active_coils)):
            coils = ";".join(f"{k}:{int(c[k]):+d}" for k in np.flatnonzero(c))
            w.writerow([f"{t:.6f}", *(f"{x:.12f}" for x in qq), *(f"{x:.9f}" for x in om)]
                       + ([] if turned is None else [f"{turned[i]:.6f}"]) + [coils])
        text = buf.getvalue()
        if path is not None:
            from ..atomic import write_text

            write_text(path, text)
        return text


@single_blas_thread
def simulate(design, plan, model, dwell: float | None = None, *, rotor: Rotor | None = None,
             dt: float | None = None, record_every: int = 5, tolerance: float = EXECUTED_TOL) -> Simulation:
    """Run ``plan`` on ``design``'s rotor under the torque ``model`` (a :class:`~spherestep.statics.TorqueModel`
    in SI units; see the module docstring).

    ``dwell`` (s), ``rotor`` (inertia and damping) and ``dt`` (s) default to :func:`~spherestep.dynamics.tune`'s
    choice for this design and model (damping critical on the softest wells, dwell 8 decay times, the step
    resolving the stiffest well); give all three to skip the tuning. ``record_every``: keep every k-th
    integration step in the trajectory.
    """
    from ..commutation import Plan

    if not isinstance(plan, Plan):
        raise bad_value("plan", "a spherestep.commutation.Plan (commutation.turn, plan_geometric, Plan.from_json)",
                        type(plan).__name__)
    if not all(callable(getattr(model, name, None)) for name in ("torque", "energy")):
        raise bad_value("model", "a torque model with torque(R, c) and energy(R, c) (spherestep.statics.TorqueModel)",
                        type(model).__name__)
    if plan.coil_count != len(design.stator):
        raise bad_value("plan", f"a plan for this design's {len(design.stator)} coils", f"{plan.coil_count} coils")
    if plan.design_fingerprint is not None:  # a plan made for a design names its numbering (a hand-built one may not)
        plan.check_design(design)
    if dwell is None or rotor is None or dt is None:
        from .tuning import tune

        tuning = tune(design, model)
        dwell = tuning.dwell if dwell is None else dwell
        rotor = tuning.rotor if rotor is None else rotor
        dt = tuning.dt if dt is None else dt
    dwell = checks.positive(dwell, "dwell", "a positive time in seconds")
    integrator = Integrator(model, rotor, dt)
    N = plan.coil_count
    R = plan.steps[0].achieved.copy()
    w = np.zeros(3)
    times, Rs, ws, coils, energy = [np.zeros(1)], [R[None]], [w[None]], [coil_currents(plan.steps[0].coils, N)[None]], []
    energy.append(model.energy(R[None], coils[0]))
    settled = [R.copy()]
    t0 = 0.0
    for step in plan.steps[1:]:
        c = coil_currents(step.coils, N)
        R, w, t, r, v, e = integrator.run(R, w, c, dwell, record_every)
        times.append(t0 + t)
        Rs.append(r)
        ws.append(v)
        coils.append(np.repeat(c[None], len(t), axis=0))
        energy.append(e)
        settled.append(R.copy())
        t0 += dwell
    return Simulation(np.concatenate(times), np.concatenate(Rs), np.concatenate(ws), np.concatenate(coils),
                      np.array(settled), plan.achieved, np.concatenate(energy), tolerance)
