"""Rigid-rotor dynamics: the integrator, running plans, the closed loop."""

from .rotor import Rotor
from .closed_loop import ClosedLoopRun, run_closed_loop
from .simulate import Integrator, Simulation, currents_of, simulate
from .tuning import Tuning, stiffness, tune

__all__ = ["ClosedLoopRun", "Integrator", "Rotor", "Simulation", "Tuning", "currents_of", "run_closed_loop", "simulate",
           "stiffness", "tune"]
