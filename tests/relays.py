"""A relay plan played on a bare protocol-1 back end, as ``spherestep run`` plays it through ``drive.connect``: the
back end behind the one :class:`~spherestep.hardware.RelayLink` on the plan's channel map."""

from __future__ import annotations

from spherestep.hardware import RelayLink, play


def play_relays(plan, backend, *args, **options):
    """:func:`spherestep.hardware.play` of ``plan`` on ``backend`` (a relay :class:`~spherestep.hardware.Backend`)."""
    return play(plan, RelayLink(backend, plan.channel_map), *args, **options)
