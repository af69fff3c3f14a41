"""Rigid-rotor dynamics: the integrator, running plans, the closed loop, the servo and ramped loops (driving a
turn mode by mode, with its files, is :mod:`spherestep.drive`), and the rotor identified from its moves
(:mod:`.identify`: :func:`rotor_excitation`, :func:`fit_rotor` → :class:`RotorFit`)."""

from .rotor import Integrator, Rotor
from .closed_loop import ClosedLoopRun, run_closed_loop
from .simulate import Simulation, SimulationSummary, simulate
from .tuning import Tuning, iron_tuning, stiffness, tune
from .electrics import CoilDrive, rl_step
from .servo import ServoRun, ServoSummary, hold, simulate_servo
from .identify import RotorFit, fit_rotor, rotor_excitation, window_equations
from .ramped import PullOut, RampedRun, RampedSummary, pull_out_rate, run_ramped, step_intervals

__all__ = ["ClosedLoopRun", "Integrator", "Rotor", "Simulation", "Tuning", "run_closed_loop", "simulate",
           "stiffness", "tune", "iron_tuning", "CoilDrive", "rl_step", "ServoRun", "ServoSummary", "hold",
           "simulate_servo", "RotorFit", "fit_rotor", "rotor_excitation", "window_equations", "PullOut", "RampedRun", "RampedSummary", "SimulationSummary", "pull_out_rate", "run_ramped", "step_intervals"]
