"""The coil driver: stator coil states through a relay link, within thermal limits, always ending all off.

Coil ``k`` is switched by relay channels ``channel_map[k] = (enable, polarity)`` exactly as in
:meth:`spherestep.commutation.Step.masks` (the :class:`~spherestep.hardware.RelayLink` writes the masks of the
amperes it is given: energised coils set their enable bit, coils driven with polarity −1 also set their polarity
bit). Used as a context manager the driver opens the link, which refuses a channel map the device cannot carry,
and on leaving (normally, on an error or on Ctrl-C) switches every coil off before closing.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Mapping
from contextlib import contextmanager

import numpy as np

from .. import checks
from ..commutation.plan import Step
from ..errors import bad_value
from .backend import DeviceInfo, LinkError
from .limits import ThermalGuard, ThermalLimitError, ThermalLimits
from .relay_link import RelayLink


@contextmanager
def _ctrl_c_ignored():
    """Ignore SIGINT and SIGTERM (in the main thread) while the coils are being switched off."""
    main = threading.current_thread() is threading.main_thread()
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)} if main else {}
    for sig in previous:
        signal.signal(sig, signal.SIG_IGN)
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler if handler is not None else signal.SIG_DFL)


class CoilDriver:
    """Drive stator coils through the relay ``link`` (a :class:`~spherestep.hardware.RelayLink`: its back end and
    channel map) under ``limits``.

    ``jitter`` seconds of scheduling slack are allowed on the thermal limits at run time (the plan itself is
    checked exactly by :meth:`ThermalLimits.check_plan`). ``coils`` is the state now driven.

    >>> from spherestep.commutation import default_channel_map
    >>> from spherestep.hardware import CoilDriver, DryRun, RelayLink
    >>> with CoilDriver(RelayLink(DryRun(), default_channel_map(4))) as driver:
    ...     driver.apply({0: +1, 2: -1}, duration=0.1)
    ...     driver.hold(0.1)
    >>> [(s.enable, s.polarity) for s in driver.link.backend.sent]
    [(5, 64), (0, 0)]
    """

    def __init__(self, link: RelayLink, limits: ThermalLimits | None = None, jitter: float = 0.010):
        if not isinstance(link, RelayLink):
            raise bad_value("link", "a spherestep.hardware.RelayLink (spherestep.drive.connect builds one)",
                            type(link).__name__)
        self.link = link
        self.channel_map = link.channel_map
        self.limits = limits if limits is not None else ThermalLimits()
        self.guard = ThermalGuard(self.limits, tolerance=jitter)
        self.coils: dict[int, int] = {}
        self.info: DeviceInfo | None = None

    def __enter__(self) -> CoilDriver:
        self.open()
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        try:
            self.close()
        except LinkError as off_failed:
            if isinstance(exc, LinkError):
                raise LinkError(f"{exc}; {off_failed}") from exc
            if exc is None:
                raise
            exc.add_note(str(off_failed))

    def open(self) -> DeviceInfo:
        """Open the link (all off; it refuses a channel map the device cannot carry)."""
        self.info = self.link.open()
        return self.info

    def close(self) -> None:
        """Switch every coil off, then close the link (even if switching off failed)."""
        try:
            self.all_off()
        finally:
            self.link.close()

    def apply(self, coils: Step | Mapping[int, int], duration: float = 0.0) -> None:
        """Energise exactly ``coils`` (a :class:`Step` or coil → ±1), to be held for ``duration`` seconds.

        Raises :class:`ThermalLimitError` (with every coil switched off) if that would break a limit.
        """
        state = dict(coils.coils if isinstance(coils, Step) else coils)
        expected = f"a map from coil index 0..{len(self.channel_map) - 1} to polarity +1 or -1"
        state = {checks.count(coil, "coils", 0, len(self.channel_map) - 1, expected=expected):
                 checks.sign(sign, "coils", expected) for coil, sign in state.items()}
        self._check(state, duration)
        c = np.zeros(len(self.channel_map))
        for coil, sign in state.items():
            c[coil] = sign
        now = self.link.clock()
        self.link.drive(self.link.limits.amperes(c))
        self.guard.record(state, now)
        self.coils = state

    def hold(self, seconds: float) -> None:
        """Keep the present coils on for ``seconds`` (checked against the limits first)."""
        self._check(self.coils, seconds)
        self.link.sleep(seconds)

    def all_off(self) -> None:
        """Switch every coil off; Ctrl-C cannot interrupt it. A failure raises :class:`LinkError` saying
        that the device's watchdog (if it has one) takes over."""
        with _ctrl_c_ignored():
            self.coils = {}
            self.guard.record({}, self.link.clock())
            try:
                self.link.off()
            except LinkError as exc:
                watchdog = self.info.watchdog if self.info is not None else None
                fallback = (f"the device's watchdog opens every relay within {watchdog:g} s" if watchdog
                            else "check that the coils are unpowered")
                raise LinkError(f"switching the coils off failed too ({exc}); {fallback}") from exc

    def _check(self, coils: Mapping[int, int], duration: float) -> None:
        now = self.link.clock()
        try:
            self.guard.check(coils, now, duration, f"the state applied at t = {now:.3f} s")
        except ThermalLimitError:
            self.all_off()
            raise
