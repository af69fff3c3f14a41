"""The geometry of the Fig. 10 view (Sec. IV-B), shared by the matplotlib figures and the HTML report.

Everything is projected orthographically on the plane normal to the rotation axis, the axis out of the page
(:func:`plane_basis`). Large outlines are the stator coils (the circles bounding the caps their faces cover),
tinted when energised; small ones are the rotor magnets that take part: those held by an energised coil, and
the next pole to be attracted. A line fixed in the rotor, perpendicular to the axis at the plan's start, marks
how far the rotor has turned. :func:`fig10_step` returns these as named outlines in page coordinates; the
drawings only choose colours and styles.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import checks

OUTLINE_POINTS = 48  # points per outline
POLARITY_COLOUR = {1: "#c0392b", -1: "#2c6fbb"}  # red: north out (+1), blue: south out (−1)


def plane_basis(axis) -> np.ndarray:
    """Rows ``e1, e2, n``: an orthonormal frame with ``n`` along ``axis`` (the page is ``e1, e2``)."""
    checks.axis(axis)  # a zero or underflowing axis refused; the frame below normalises it as before
    n = np.asarray(axis, dtype=float)
    n = n / np.linalg.norm(n)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(helper, n)
    e1 /= np.linalg.norm(e1)
    return np.array([e1, np.cross(n, e1), n])


def cap_outline(center, radius: float, points: int = 64) -> np.ndarray:
    """``(points, 3)`` points of the circle bounding the cap of angular ``radius`` about unit ``center``."""
    c = np.asarray(center, dtype=float)
    a = plane_basis(c)
    t = np.linspace(0.0, 2 * np.pi, points, endpoint=False)
    return np.cos(radius) * c + np.sin(radius) * (np.outer(np.cos(t), a[0]) + np.outer(np.sin(t), a[1]))


def cap_outlines(centers, radius: float, points: int = OUTLINE_POINTS) -> np.ndarray:
    """Outlines of the caps about ``centers (K, 3)``, ``(K, points, 3)``."""
    centers = np.asarray(centers, dtype=float).reshape(-1, 3)
    return np.stack([cap_outline(c, radius, points) for c in centers]) if len(centers) else np.zeros((0, points, 3))


def joined(rings: np.ndarray) -> np.ndarray:
    """Closed outlines ``(K, P, d)`` as one polyline ``(K·(P+2) − 1, d)``, NaN between outlines (plotly's
    way of drawing many shapes as one trace)."""
    if not len(rings):
        return np.zeros((0, rings.shape[-1]))
    gap = np.full((len(rings), 1, rings.shape[-1]), np.nan)
    return np.concatenate([rings, rings[:, :1], gap], axis=1).reshape(-1, rings.shape[-1])[:-1]


@dataclass(frozen=True)
class Fig10Step:
    """One plan step in the Fig. 10 view, page coordinates (outlines ``(K, P, 2)``).

    ``coils``: every coil; ``energised``: polarity (±1) → the energised coils' outlines; ``held``: polarity →
    the held poles' outlines; ``next_pole``: its outline ``(0 or 1, P, 2)`` and ``next_polarity`` (0 if none);
    ``marker``: ``(2, 2)`` from the centre to the tip of the rotor-fixed line; ``labels``: energised coil
    numbers and their page positions.
    """

    coils: np.ndarray
    energised: dict[int, np.ndarray]
    held: dict[int, np.ndarray]
    next_pole: np.ndarray
    next_polarity: int
    marker: np.ndarray
    labels: tuple[tuple[int, tuple[float, float]], ...]


def fig10_step(design, plan, i: int, axis, points: int = OUTLINE_POINTS, marker_length: float = 1.15) -> Fig10Step:
    """The outlines of step ``i`` of ``plan`` on ``design`` in the Fig. 10 view about ``axis``."""
    basis = plane_basis(axis)
    page = basis[:2].T
    step = plan.steps[i]
    R = step.achieved
    coils = design.stator.centers
    poles = design.rotor.centers @ R.T
    polarity = design.polarity
    held = [j for j, _ in step.held]
    energised = {s: cap_outlines(coils[[k for k, v in sorted(step.coils.items()) if v == s]], design.coil_angle,
                                 points) @ page for s in (1, -1)}
    held_rings = {s: cap_outlines(poles[[j for j in held if polarity[j] == s]], design.magnet_angle, points) @ page
                  for s in (1, -1)}
    nxt = step.next_pole
    marker_body = plan.steps[0].achieved.T @ basis[0]
    tip = (R @ marker_body) @ page * marker_length
    return Fig10Step(
        coils=cap_outlines(coils, design.coil_angle, points) @ page,
        energised=energised,
        held=held_rings,
        next_pole=cap_outlines(poles[[] if nxt is None else [nxt]], design.magnet_angle, points) @ page,
        next_polarity=0 if nxt is None else int(polarity[nxt]),
        marker=np.array([[0.0, 0.0], tip]),
        labels=tuple((int(k), tuple(float(x) for x in coils[k] @ page)) for k in sorted(step.coils)),
    )
