"""Protocol 1's relay back ends behind the one :class:`~spherestep.hardware.Link`: :class:`RelayLink`.

A relay switches a coil onto the supply or off, either way round, so a relay board can drive a coil at 0 or at
± the coil's nominal current ``I_n`` and nothing between. :class:`RelayLink` takes the link's command in amperes,
``drive(currents)``, checks that each is 0 or ``±I_n`` (to :data:`RELAY_TOL` of ``I_n``), and writes the relay
masks of those coil states (``channel_map[k] = (enable, polarity)``, :func:`~spherestep.commutation.coil_masks`)
to its :class:`~spherestep.hardware.Backend` (:class:`~spherestep.hardware.Serial`,
:class:`~spherestep.hardware.DryRun`, :class:`~spherestep.hardware.Simulated`); ``read()`` is the state those
relays drive (the board measures nothing: no sensors, the currents commanded); ``clock``/``sleep`` are the back
end's clock and hold, the ``timing`` of :func:`spherestep.drive.connect`'s connection. The relay wire format is
unchanged. :func:`spherestep.drive.connect` builds it for the relay kinds; :class:`~spherestep.hardware.CoilDriver`
and :func:`~spherestep.hardware.play` drive it.
"""

from __future__ import annotations

import numpy as np

from ..channels import as_channel_map
from ..commutation.plan import coil_masks
from ..electrics import DriveLimits
from ..errors import InputError, bad_value
from .backend import Backend, DeviceInfo, LinkError
from .protocol2 import State

RELAY_TOL = 1e-6  # of the nominal current: a relay current is 0 or ±I_n, as the per-unit states say


class RelayLink:
    """A :class:`~spherestep.hardware.Link` over the relay ``backend`` for coils on ``channel_map`` (``(N, 2)``:
    enable and polarity channel of each coil) whose relays carry ``drive.nominal_current`` (a
    :class:`~spherestep.electrics.DriveLimits`; default the default coils). See the module."""

    def __init__(self, backend: Backend, channel_map, drive: DriveLimits | None = None):
        cmap = as_channel_map(channel_map)
        if len(cmap) == 0:
            raise bad_value("channel_map", "channels for at least one coil", "an empty map")
        self.backend, self.channel_map = backend, cmap
        self.limits = drive if drive is not None else DriveLimits()
        self.coils: dict[int, int] = {}
        self.info: DeviceInfo | None = None

    def __enter__(self) -> RelayLink:
        self.open()
        return self

    def __exit__(self, *exc) -> None:
        """Every coil off, then close the back end (even if switching off failed)."""
        try:
            self.off()
        finally:
            self.close()

    def close(self) -> None:
        """Release the back end (switch the coils off first: :meth:`off`)."""
        self.backend.close()

    def open(self) -> DeviceInfo:
        """Open the back end (all off) and check that the device has every channel of the map."""
        self.info = self.backend.open()
        top = int(self.channel_map.max())
        if top >= self.info.channels:
            self.close()
            raise InputError(f"the plan's channel map uses relay channel {top}, but device {self.info.name!r} has "
                             f"{self.info.channels} channels (0..{self.info.channels - 1}); use a controller with "
                             "more channels or a plan for fewer coils")
        return self.info

    def states(self, currents) -> dict[int, int]:
        """Coil → ±1 of ``currents`` (A, ``(N,)``), each 0 or ± the nominal current; InputError otherwise."""
        c = self.limits.per_unit(currents)
        if c.shape != (len(self.channel_map),) or not np.all(np.isfinite(c)):
            raise bad_value("currents", f"{len(self.channel_map)} finite coil currents in A", f"shape {c.shape}")
        signs = np.rint(c)
        bad = np.flatnonzero((np.abs(signs) > 1) | (np.abs(c - signs) > RELAY_TOL))
        if len(bad):
            k = int(bad[0])
            raise bad_value("currents", f"0 or ±{self.limits.nominal_current:g} A per coil (a relay switches a coil "
                            "on at its nominal current or off)", f"{self.limits.amperes(c)[k]:g} A on coil {k}")
        return {int(k): int(signs[k]) for k in np.flatnonzero(signs)}

    def drive(self, currents, *, emf=None, within: float | None = None) -> State:
        """Switch the relays to ``currents`` (A per coil: 0 or ``±I_n``) and return :meth:`read` (``within`` does not
        apply: the back end answers before it returns; nor does ``emf``: a relay has no current loop)."""
        if self.info is None:
            raise LinkError("the relay link is not open")
        state = self.states(currents)
        enable, polarity = coil_masks(state, self.channel_map)
        self.backend.write(enable, polarity, state)
        self.coils = state
        return self.read()

    def read(self) -> State:
        """The state the relays drive: the back end's clock (µs), the coils' currents (A), no sensors."""
        i = np.zeros(len(self.channel_map))
        for k, sign in self.coils.items():
            i[k] = sign
        return State(int(round(self.backend.clock() * 1e6)), 0, self.limits.amperes(i), np.zeros((0, 3)),
                     np.zeros(0, dtype=bool))

    def off(self) -> None:
        """Every relay open."""
        self.coils = {}
        self.backend.off()

    def clock(self) -> float:
        """Seconds on the back end's clock (the wall clock on a board, simulated on a dry run or simulation)."""
        return self.backend.clock()

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` pass with the relays unchanged (keep-alives where the device needs them)."""
        self.backend.hold(seconds)
