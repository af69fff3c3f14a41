"""The motor: design and its one builder, the built-in prototype, stepper states and design metrics
(Sec. II-B-3, IV)."""

from .design import (DEFAULT_TOL, MAX_COILS, CoilElectrics, MotorDesign, PolarityRule, check_fingerprint, check_fits,
                     default_channel_map)
from .prototype import prototype
from .metrics import CoilFailure, Coverage, DesignMetrics, design_metrics, single_coil_failures
from .states import StepperStates, coil_currents, find_states

__all__ = ["DEFAULT_TOL", "MAX_COILS", "CoilElectrics", "CoilFailure", "Coverage", "DesignMetrics", "MotorDesign", "PolarityRule",
           "StepperStates", "check_fingerprint", "check_fits", "coil_currents", "default_channel_map", "design_metrics",
           "find_states", "prototype", "single_coil_failures"]
