"""The motor: design and its one builder, the built-in prototype, stepper states and design metrics
(Sec. II-B-3, IV)."""

from .design import DEFAULT_TOL, MAX_COILS, MotorDesign, PolarityRule, check_fits, default_channel_map
from .prototype import prototype
from .states import StepperStates, find_states

__all__ = ["DEFAULT_TOL", "MAX_COILS", "MotorDesign", "PolarityRule", "StepperStates", "check_fits",
           "default_channel_map", "find_states", "prototype"]
