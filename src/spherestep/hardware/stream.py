"""Streaming a commutation plan: each step driven for one period at a fixed step rate, then all off."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..commutation import Plan, Step
from ..errors import bad_value
from .backend import DeviceInfo
from .driver import CoilDriver
from .limits import ThermalLimits
from .relay_link import RelayLink


@dataclass(frozen=True)
class PlayReport:
    """What a finished run did: steps driven, rate (Hz), elapsed seconds, worst lateness of a step (s)."""

    steps: int
    rate: float
    elapsed: float
    max_lag: float
    device: DeviceInfo


def play(plan: Plan, link: RelayLink, rate: float, limits: ThermalLimits | None = None,
         on_step: Callable[[int, Step], None] | None = None) -> PlayReport:
    """Drive ``plan`` through the relay ``link`` (a :class:`RelayLink` on the plan's channel map, as
    :func:`spherestep.drive.connect` builds it) at ``rate`` steps per second.

    Step ``i`` is applied at ``t0 + i / rate`` and held until ``t0 + (i + 1) / rate`` on the link's clock
    (a late step is held only to its scheduled end, so lateness never accumulates); every coil is off after
    the last step, on any error and on Ctrl-C. The whole plan is checked against ``limits`` before anything is
    switched. ``on_step(i, step)`` is called after step ``i`` is applied (live progress).
    """
    if not plan.steps:
        raise bad_value("plan.steps", "at least one step", [])
    if isinstance(link, RelayLink) and not np.array_equal(link.channel_map, plan.channel_map):
        raise bad_value("link", "a relay link on the plan's channel map", "a link on another map")
    limits = limits if limits is not None else ThermalLimits()
    limits.check_plan(plan, rate)
    period = 1.0 / rate
    with CoilDriver(link, limits) as driver:
        t0 = link.clock()
        max_lag = 0.0
        for i, step in enumerate(plan.steps):
            start, end = t0 + i * period, t0 + (i + 1) * period
            now = link.clock()
            max_lag = max(max_lag, now - start)
            driver.apply(step, duration=max(0.0, end - now))
            if on_step is not None:
                on_step(i, step)
            driver.hold(max(0.0, end - link.clock()))
        elapsed = link.clock() - t0
    return PlayReport(steps=len(plan.steps), rate=rate, elapsed=elapsed, max_lag=max_lag, device=driver.info)
