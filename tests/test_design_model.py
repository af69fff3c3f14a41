"""The design's own torque model (issue 25 §1): the core the design states, the limits of its coil as built."""

import numpy as np
import pytest

from spherestep import so3
from spherestep.control import DriveLimits
from spherestep.errors import InputError
from spherestep.magnetics import IronTorqueMap, TorqueMap, design_model, torque_map
from spherestep.motor import prototype


def test_prototype_is_iron_with_its_own_winding():
    design = prototype()
    assert design.coil.core == "iron"
    dm = design_model(design)
    assert isinstance(dm.model, IronTorqueMap) and dm.core == "iron"
    assert dm.label == "iron (coupled, FEM table)"
    assert dm.limits == DriveLimits.from_spec(design.coil, design)
    assert dm.limits.nominal_current == pytest.approx(0.2893, abs=1e-4)  # not the 1 A of the air-core default
    R = so3.random(5, 1)
    assert np.abs(dm.model.torque(R, np.zeros((5, len(design.stator))))).max() > 0.1  # the detent is there


def test_air_override_is_the_torque_map_at_the_coils_ampere_turns():
    design = prototype()
    dm = design_model(design, "air")
    assert isinstance(dm.model, TorqueMap) and dm.core == "air" and dm.label.startswith("air")
    ni = design.coil.nominal_ampere_turns(design.coil_diameter, design.coil_length)
    R = so3.random(4, 2)
    c = np.random.default_rng(3).uniform(-1, 1, (4, len(design.stator)))
    expected = torque_map(design).torque(R, c) * ni / design.coil_ampere_turns
    np.testing.assert_allclose(dm.model.torque(R, c), expected, rtol=1e-12, atol=1e-15)
    iron = design_model(design).limits  # same winding, only the core (and so the coil's inductance) differs
    assert dm.limits == iron.replace(inductance=dm.limits.inductance) and dm.limits.inductance < iron.inductance / 4


def test_bad_core_and_coupling_on_air():
    with pytest.raises(InputError, match="^core must be"):
        design_model(prototype(), "steel")
    with pytest.raises(InputError, match="^coupling must be"):
        design_model(prototype(), "air", coupling=True)
