"""Shared fixtures: the prototype is built and its states enumerated once per test session."""

import pytest

from spherestep.motor import prototype


@pytest.fixture(scope="session")
def proto():
    """The built-in prototype with its stepper states and metrics computed."""
    design = prototype()
    design.states()
    return design


@pytest.fixture(scope="session")
def proto_metrics(proto):
    return proto.metrics(samples=20_000, seed=7)
