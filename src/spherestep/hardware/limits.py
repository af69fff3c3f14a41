"""Thermal limits of the stator coils: maximum continuous on-time and maximum duty cycle.

An energised electromagnet heats with I²R whatever its polarity, so both limits count a coil as on while its
enable relay is closed. A coil may stay on for at most ``max_on`` seconds without a break, and be on for at
most ``max_duty × window`` seconds of any sliding window of ``window`` seconds (time before the first step
counts as off). :meth:`ThermalLimits.check_plan` checks a whole plan at a given step rate before anything is
switched; :class:`ThermalGuard` checks each step again as it is driven.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from .. import checks
from ..electrics import DriveLimits
from ..errors import InputError

DRIVE = DriveLimits()  # the default coils and supply: the device's defaults are built from them


class ThermalLimitError(InputError):
    """Driving a coil as asked would exceed its on-time or duty-cycle limit."""


@dataclass(frozen=True)
class ThermalLimits:
    """``max_on`` seconds continuously on, at most ``max_duty`` (0–1] of any ``window`` seconds.

    The defaults (5 s, 0.5 over 30 s) are a cautious start for coils without a datasheet; set them from the
    coil's rated continuous power at the supply voltage (24 V in Sec. IV-B).
    """

    max_on: float = 5.0
    max_duty: float = 0.5
    window: float = 30.0

    def __post_init__(self):
        checks.positive(self.max_on, "max_on", "a positive number of seconds")
        checks.number(self.max_duty, "max_duty", low=0.0, high=1.0, low_open=True, expected="a fraction in (0, 1]")
        checks.positive(self.window, "window", "a positive number of seconds")

    def guard(self, tolerance: float = 1e-9) -> ThermalGuard:
        """A fresh :class:`ThermalGuard` of these limits (nothing on yet)."""
        return ThermalGuard(self, tolerance)

    def check_plan(self, plan, rate: float) -> None:
        """Raise :class:`ThermalLimitError` naming the first step and coil that a run at ``rate`` Hz would
        overheat; step ``i`` is driven from ``i / rate`` to ``(i + 1) / rate`` and all coils are off after."""
        rate = checks.positive(rate, "rate", "a positive step rate in Hz, such as 10")
        guard = self.guard()
        period = 1.0 / rate
        for i, step in enumerate(plan.steps):
            guard.check(step.coils, i * period, period, f"step {step.index}")
            guard.record(step.coils, i * period)


class ThermalGuard:
    """Per-coil on/off history against :class:`ThermalLimits`, on any clock (seconds).

    :meth:`check` tests a coil set about to be held from ``t`` for ``duration`` seconds; :meth:`record`
    notes that the set was switched at ``t``. ``tolerance`` seconds absorb scheduling jitter.
    """

    def __init__(self, limits: ThermalLimits, tolerance: float = 1e-9):
        self.limits = limits
        self.tolerance = tolerance
        self._since: dict[int, float] = {}
        self._history: dict[int, deque[tuple[float, float]]] = {}

    def on_time(self, coil: int, start: float, end: float) -> float:
        """Seconds the coil was on within ``[start, end]`` according to the record."""
        spans = list(self._history.get(coil, ()))
        if coil in self._since:
            spans.append((self._since[coil], end))
        return sum(max(0.0, min(b, end) - max(a, start)) for a, b in spans)

    def check(self, coils: Iterable[int], t: float, duration: float, where: str) -> None:
        """Raise :class:`ThermalLimitError` if holding ``coils`` from ``t`` for ``duration`` s breaks a limit."""
        lim = self.limits
        end = t + duration
        for coil in sorted(coils):
            run = end - self._since.get(coil, t)
            if run > lim.max_on + self.tolerance:
                raise ThermalLimitError(
                    f"coil {coil} would stay on for {run:.3f} s without a break (to the end of {where}), over max_on = "
                    f"{lim.max_on:g} s; use a plan that rests the coil, a higher step rate, or a larger max_on "
                    "if the coil's rating allows")
            used = self.on_time(coil, end - lim.window, t) + duration
            if used > lim.max_duty * lim.window + self.tolerance:
                raise ThermalLimitError(
                    f"coil {coil} would be on for {used:.3f} s of the {lim.window:g} s before the end of {where} "
                    f"(duty {used / lim.window:.3f}), over max_duty = {lim.max_duty:g}; use a plan that "
                    "rests the coil or a larger max_duty if the coil's rating allows")

    def allows(self, coils: Iterable[int], t: float, duration: float) -> bool:
        """Whether holding ``coils`` from ``t`` for ``duration`` s keeps every limit (:meth:`check` without the
        error)."""
        try:
            self.check(coils, t, duration, "a candidate")
        except ThermalLimitError:
            return False
        return True

    def record(self, coils: Iterable[int], t: float) -> None:
        """Note that exactly ``coils`` are on from time ``t``; forget spans older than one window."""
        now_on = set(coils)
        for coil in [c for c in self._since if c not in now_on]:
            self._history.setdefault(coil, deque()).append((self._since.pop(coil), t))
        for coil in now_on:
            self._since.setdefault(coil, t)
        horizon = t - self.limits.window
        for spans in self._history.values():
            while spans and spans[0][1] < horizon:
                spans.popleft()


@dataclass(frozen=True)
class CurrentLimits:
    """Limits of a current-driven stator (protocol version 2), enforced by the device and checked by the host.

    ``max_current`` A: largest setpoint magnitude per coil; a measured current above ``trip_ratio ×
    max_current`` switches everything off. ``max_duty``: largest PWM duty magnitude (0–1]. ``max_power`` W:
    largest ``Σ_k R i_k²`` of a set of setpoints. Heating is the I²t model of :func:`heating_step` with
    ``continuous_current`` A (the current the coil carries forever at its rated temperature rise) and
    ``thermal_time`` s (the winding's thermal time constant). ``resistance`` Ω per coil.

    Defaults: those of :meth:`from_drive` for the default :class:`spherestep.electrics.DriveLimits` (1000-turn
    24 Ω coils, 1 A nominal, 24 V, 100 W); :meth:`from_drive` takes any other.
    """

    max_current: float = DRIVE.max_current
    max_duty: float = 0.95
    max_power: float = DRIVE.supply_power
    continuous_current: float = DRIVE.nominal_current
    thermal_time: float = 60.0
    resistance: float = DRIVE.resistance
    trip_ratio: float = 1.25

    @classmethod
    def from_drive(cls, drive, *, max_duty: float = 0.95, thermal_time: float = 60.0,
                   trip_ratio: float = 1.25) -> CurrentLimits:
        """The device limits for a :class:`spherestep.electrics.DriveLimits`: its current, power and resistance;
        the coil is rated for its nominal current continuously."""
        return cls(max_current=drive.max_current, max_duty=max_duty, max_power=drive.supply_power,
                   continuous_current=drive.nominal_current, thermal_time=thermal_time,
                   resistance=drive.resistance, trip_ratio=trip_ratio)

    def __post_init__(self):
        for name in ("max_current", "max_power", "continuous_current", "thermal_time", "resistance"):
            checks.positive(getattr(self, name), name, "a positive finite number")
        checks.number(self.max_duty, "max_duty", low=0.0, high=1.0, low_open=True, expected="a fraction in (0, 1]")
        checks.number(self.trip_ratio, "trip_ratio", low=1.0, expected="a number >= 1")

    def check_setpoints(self, currents) -> None:
        """Raise :class:`ThermalLimitError` if a setpoint (A) exceeds ``max_current`` or all of them together
        ``max_power`` (the device refuses the same frame with ``NAK,LIMIT``)."""
        worst = max((abs(float(i)) for i in currents), default=0.0)
        if worst > self.max_current:
            raise ThermalLimitError(f"a coil current of {worst:.3f} A was asked, over max_current = "
                                    f"{self.max_current:g} A; lower the gains or the trajectory's speed")
        power = self.resistance * sum(float(i) ** 2 for i in currents)
        if power > self.max_power:
            raise ThermalLimitError(f"the coil currents would dissipate {power:.1f} W, over max_power = "
                                    f"{self.max_power:g} W; lower the gains or the trajectory's speed")


def heating_step(heat: float, current: float, dt: float, limits: CurrentLimits) -> float:
    """One step of the I²t thermal model: ``h ← a h + (1 − a)(i / i_c)²``, ``a = exp(−dt / τ)``.

    ``h`` is the winding's temperature rise over the rise at the continuous current ``i_c`` (the exact
    solution of ``τ ḣ = (i / i_c)² − h`` for a current held over ``dt``); a coil overheats when ``h > 1``.
    The firmware (``firmware/spherestep/drive.cpp``) runs the same update each control period.
    """
    a = math.exp(-dt / limits.thermal_time)
    return a * heat + (1.0 - a) * (current / limits.continuous_current) ** 2
