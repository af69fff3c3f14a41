"""The simulated back end: a plan runs "on hardware" against the rotor dynamics.

Every state written energises the coils it names (``coils``: coil → ±1) on a simulated rotor
(an integrator of :mod:`spherestep.dynamics`, built by the drive room's :func:`spherestep.drive.connect` and passed
in); :meth:`Simulated.hold` integrates the rotor for that long. The clock is the
simulated time, so thermal limits and the schedule follow it and a long plan takes only the integration's
time. ``orientations`` records the orientation at the end of every hold, ``trajectory`` every integrator
sample, for comparison with the plan.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..motor import coil_currents
from .backend import Backend, DeviceInfo
from .protocol import VERSION


class Simulated(Backend):
    """A back end driving a simulated rotor: ``integrator`` (a :class:`spherestep.dynamics.Integrator` of the
    design's rotor under its torque model: ``run(R, ω, c, seconds, record_every)``), ``coil_count`` coils,
    starting orientation ``start`` (3×3, at rest) and ``channels`` (the relay channels it stands in for; default
    two per coil)."""

    def __init__(self, integrator, coil_count: int, start, channels: int | None = None):
        start = so3.as_rotations(start, "start")
        if start.shape != (3, 3):
            raise bad_value("start", "a 3×3 rotation matrix", f"shape {start.shape}")
        self.coil_count = checks.count(coil_count, "coil_count")
        self.channels = 2 * self.coil_count if channels is None else int(channels)
        self.integrator = integrator
        self.R = start.copy()
        self.w = np.zeros(3)
        self.currents = np.zeros(self.coil_count)
        self.now = 0.0
        self.orientations: list[tuple[float, np.ndarray]] = []
        self.trajectory: list[tuple[float, np.ndarray]] = []

    def open(self) -> DeviceInfo:
        """Report the simulated controller (no watchdog: the simulation cannot lose the host)."""
        return DeviceInfo(name="simulated rotor", protocol=VERSION, channels=self.channels, watchdog=None)

    def write(self, enable: int, polarity: int, coils: Mapping[int, int]) -> None:
        """Energise ``coils`` (the masks carry the same state by channel)."""
        self.currents = coil_currents(dict(coils), self.coil_count)

    def hold(self, seconds: float) -> None:
        """Integrate the rotor for ``seconds`` under the current coils."""
        if seconds <= 0:
            return
        self.R, self.w, times, Rs, _, _ = self.integrator.run(self.R, self.w, self.currents, seconds, record_every=4)
        self.trajectory += [(self.now + t, R) for t, R in zip(times, Rs)]
        self.now += seconds
        self.orientations.append((self.now, self.R.copy()))

    def clock(self) -> float:
        """Seconds of simulated time."""
        return self.now
