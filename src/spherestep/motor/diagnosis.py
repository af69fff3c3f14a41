"""Why a design cannot step, in words a designer can act on.

A stepper state needs two rotor poles on two working coils (:mod:`spherestep.motor.states`): a coil pair at
arc ``s`` and a pole pair at arc ``a`` with ``|a − s| ≤ 2 tol``. :func:`unusable_reasons` lists what rules
that out, each with the field to change: fewer than two working coils in the cap (``cap_half_angle``,
``failed_coils``); a tolerance over half the smallest pole spacing, where one coil would hold two poles
(``tol``); and, when no state is found, the smallest mismatch ``min |a − s|`` between pole and coil
spacings, with the tolerance that would admit it.
"""

from __future__ import annotations

import math

import numpy as np


def _arcs(points: np.ndarray) -> np.ndarray:
    """Sorted great-circle distances (rad) of all pairs of unit vectors ``points (n, 3)``."""
    i, j = np.triu_indices(len(points), k=1)
    return np.sort(np.arccos(np.clip(np.einsum("ij,ij->i", points[i], points[j]), -1.0, 1.0)))


def unusable_reasons(design, field=str) -> list[str]:
    """Reasons ``design`` has no (or ambiguous) stepper states, each naming the field to change (``field``
    maps the design's field names ``tol``, ``cap_half_angle``, ``failed_coils`` to the caller's, e.g. a design
    file's); empty when the design can step."""
    tol_name, cap_name, failed_name = field("tol"), field("cap_half_angle"), field("failed_coils")
    reasons = []
    working = design.active_coils
    total = len(design.stator)
    tol = design.state_tol
    if len(working) < 2:
        failed = f", {len(design.failed_coils)} failed" if len(design.failed_coils) else ""
        reasons.append(f"the stator has {len(working)} working coil{'s' if len(working) != 1 else ''} ({total} in "
                       f"the cap of half-angle {math.degrees(design.cap_half_angle):.1f}°{failed}) and a state "
                       f"needs two: widen {cap_name}, choose a denser stator packing or shorten {failed_name}")
        return reasons
    poles = _arcs(design.rotor.centers)
    spacing = float(poles[0]) if len(poles) else math.pi
    if tol > spacing / 2:
        reasons.append(f"{tol_name} {math.degrees(tol):.3g}° is over half the rotor's pole spacing "
                       f"({math.degrees(spacing):.3g}°), so one coil can hold two poles: make {tol_name} smaller "
                       f"than {math.degrees(spacing) / 2:.3g}°")
        return reasons
    if len(design.states()) == 0:
        coils = _arcs(design.stator.centers[working])
        k = np.clip(np.searchsorted(poles, coils), 1, len(poles) - 1)
        gap = float(np.min(np.minimum(np.abs(poles[k] - coils), np.abs(poles[k - 1] - coils))))
        if gap <= 2 * tol:
            reasons.append(f"pole and coil spacings match within twice {tol_name} ({math.degrees(tol):.3g}°) but "
                           f"no alignment keeps two poles on two coils once refitted: raise {tol_name} a little or "
                           "choose other packings")
            return reasons
        reasons.append(f"no two poles are as far apart as any two working coils within twice {tol_name} "
                       f"({math.degrees(tol):.3g}°; the closest spacings differ by {math.degrees(gap):.3g}°): raise "
                       f"{tol_name} to at least {math.degrees(gap) / 2:.3g}° or choose rotor and stator packings "
                       "whose spacings match")
    return reasons
