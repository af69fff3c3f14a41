"""Shared fixtures: the prototype is built and its states enumerated once per test session.

In CI (``CI`` set) Hypothesis runs derandomized, so a submission's verdict does not depend on the draw;
locally it explores new examples on every run. In CI a skip not listed in tests/skips-allowed.txt fails the run
(:mod:`ci_skips`).
"""

import os

import pytest
from ci_skips import pytest_runtest_logreport, pytest_sessionfinish, pytest_terminal_summary  # noqa: F401 (hooks)
from hypothesis import settings

settings.register_profile("ci", derandomize=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

from spherestep.motor import prototype  # noqa: E402  (after the Hypothesis profile is chosen)


@pytest.fixture(scope="session")
def proto():
    """The built-in prototype with its stepper states and metrics computed."""
    design = prototype()
    design.states()
    return design


@pytest.fixture(scope="session")
def proto_metrics(proto):
    return proto.metrics(samples=20_000, seed=7)


@pytest.fixture(scope="session")
def model(proto):
    """The prototype's potential model (Sec. III-B), built once."""
    from spherestep.potential import MotorPotential

    return MotorPotential(proto)
