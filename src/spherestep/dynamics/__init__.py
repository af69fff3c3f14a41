"""Rigid-rotor dynamics: the integrator, running plans, the closed loop."""

from .rotor import Rotor
from .closed_loop import ClosedLoopRun, run_closed_loop
from .simulate import Integrator, Simulation, simulate
from .tuning import Tuning, stiffness, tune
from .electrics import CoilDrive, rl_step
from .servo import NoisySensor, OrientationSensor, ServoRun, hold, simulate_servo
from .ramped import PullOut, RampedRun, pull_out_rate, run_ramped, step_intervals
from .drives import DriveComparison, DriveResult, compare_drives, relay_drives
from .move import Move, drive_turn, figure_drive

__all__ = ["ClosedLoopRun", "Integrator", "Rotor", "Simulation", "Tuning", "run_closed_loop", "simulate",
           "stiffness", "tune", "CoilDrive", "rl_step", "NoisySensor", "OrientationSensor", "ServoRun", "hold",
           "simulate_servo", "PullOut", "RampedRun", "pull_out_rate", "run_ramped", "step_intervals",
           "DriveComparison", "DriveResult", "compare_drives", "relay_drives", "Move", "drive_turn", "figure_drive"]
