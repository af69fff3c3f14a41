"""The motor: design, the built-in prototype, stepper states and design metrics (Sec. II-B-3, IV)."""

from .design import MAX_COILS, MotorDesign, check_fits, default_channel_map
from .prototype import prototype, stator_in_cap
from .states import StepperStates, find_states

__all__ = ["MAX_COILS", "MotorDesign", "StepperStates", "check_fits", "default_channel_map", "find_states",
           "prototype", "stator_in_cap"]
