"""Rigid-rotor dynamics: the integrator, running plans, the closed loop."""

from .rotor import Rotor
from .closed_loop import ClosedLoopRun, run_closed_loop
from .simulate import Integrator, Scaled, Simulation, currents_of, simulate

__all__ = ["ClosedLoopRun", "Integrator", "Rotor", "Scaled", "Simulation", "currents_of", "run_closed_loop", "simulate"]
