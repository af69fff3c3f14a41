"""Manufacturing exports: where to seat the rotor's magnets and mount the stator's coils.

Tables (CSV and JSON) and a 3-D layout (STL), lengths in the chosen unit (``mm`` or ``in``), angles in degrees.

Rotor magnets (body frame): pole ``j`` at ``u_j = u(φ_j, θ_j)`` is a cylinder of the magnet's diameter and length
whose outer face is centred on the sphere's surface at ``R u_j`` (the table's ``x, y, z``) and whose axis is
``u_j``; its body centre is at ``(R − l_m/2) u_j``. ``polarity`` +1 means north out.

Stator coils (fixed frame): coil ``k`` has axis ``v_k`` (φ, θ and ``axis_x, axis_y, axis_z``) and its face centre
at ``(R + g) v_k`` (``x, y, z``), one air gap ``g`` off the rotor; the coil body reaches out to
``R + g + l_c``. Its *saddle angles* locate the mount in the pedestal: ``tilt`` is the angle between ``v_k``
and the stator axis ``a``, ``atan2(|a × v|, a · v)``, and ``azimuth`` the right-handed angle of ``v_k`` about
``a`` in ``[0°, 360°)``, measured from the reference direction ``e₁`` (the x axis projected onto the plane
normal to ``a``, or the y axis when ``a`` is along x), with ``e₂ = a × e₁``. For the prototype (``a = −z``)
``e₁ = x``, ``e₂ = −y``.

See also :mod:`spherestep.design_file`, :func:`spherestep.cli.export`.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import trimesh

from .atomic import atomic_path, write_text
from .errors import bad_value
from .hardware.sketch_config import HEADER, sketch_config
from .motor import MotorDesign
from .sphere import angles
from .units import METRES_PER_UNIT

UNITS = ("mm", "in")
SECTIONS = 48  # facets around each cylinder of the STL
MAGNET_COLUMNS = ("pole", "polarity", "phi_deg", "theta_deg", "x", "y", "z")
COIL_COLUMNS = ("coil", "enable_channel", "polarity_channel", "failed", "phi_deg", "theta_deg", "tilt_deg",
                "azimuth_deg", "x", "y", "z", "axis_x", "axis_y", "axis_z")


def _check_unit(unit: str) -> float:
    if unit not in UNITS:
        raise bad_value("unit", f"one of {', '.join(UNITS)}", unit)
    return 1.0 / METRES_PER_UNIT[unit]


def azimuth_reference(axis) -> tuple[np.ndarray, np.ndarray]:
    """``(e₁, e₂)``: the x axis (or y when ``axis`` is along x) made normal to ``axis``, and ``axis × e₁``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ a) * a
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _degrees_360(angle: np.ndarray) -> np.ndarray:
    """Radians to degrees in ``[0, 360)`` (a tiny negative angle is 0°, not 360°)."""
    deg = np.mod(np.degrees(angle), 360.0)
    return np.where(deg >= 360.0, 0.0, deg)


def _phi_theta_deg(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    phi, theta = angles(u)
    return _degrees_360(phi), np.degrees(theta)


def magnet_table(design: MotorDesign, unit: str = "mm") -> list[dict]:
    """One row per rotor pole: ``pole, polarity, phi_deg, theta_deg`` and the outer face centre ``x, y, z``."""
    scale = _check_unit(unit)
    u = design.rotor.centers
    phi, theta = _phi_theta_deg(u)
    xyz = design.radius * scale * u
    values = zip(range(len(u)), design.polarity.tolist(), phi.tolist(), theta.tolist(), *xyz.T.tolist())
    return [dict(zip(MAGNET_COLUMNS, row)) for row in values]


def saddle_angles(design: MotorDesign) -> tuple[np.ndarray, np.ndarray]:
    """``(tilt, azimuth)`` of every coil axis about the stator axis, in degrees (see the module docstring)."""
    a = design.stator_axis
    v = design.stator.centers
    e1, e2 = azimuth_reference(a)
    tilt = np.degrees(np.arctan2(np.linalg.norm(np.cross(a, v), axis=1), v @ a))
    azimuth = _degrees_360(np.arctan2(v @ e2, v @ e1))
    return tilt, azimuth


def coil_table(design: MotorDesign, unit: str = "mm") -> list[dict]:
    """One row per coil: channels, failed, direction (φ, θ, axis), saddle angles and the face centre ``x, y, z``."""
    scale = _check_unit(unit)
    v = design.stator.centers
    phi, theta = _phi_theta_deg(v)
    tilt, azimuth = saddle_angles(design)
    xyz = (design.radius + design.air_gap) * scale * v
    failed = np.isin(np.arange(len(v)), design.failed_coils).tolist()
    values = zip(range(len(v)), *design.channel_map.T.tolist(), failed, phi.tolist(), theta.tolist(), tilt.tolist(),
                 azimuth.tolist(), *xyz.T.tolist(), *v.T.tolist())
    return [dict(zip(COIL_COLUMNS, row)) for row in values]


def _frames(axes: np.ndarray) -> np.ndarray:
    """Rotations ``(N, 3, 3)`` taking +z to each unit vector of ``axes``."""
    helper = np.where(np.abs(axes[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    x = np.cross(helper, axes)
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    y = np.cross(axes, x)
    return np.stack([x, y, axes], axis=2)


def _cylinders(axes: np.ndarray, centre_radius: float, radius: float, height: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of one cylinder per axis, centred at ``centre_radius · axis`` and aligned with it."""
    template = trimesh.creation.cylinder(radius=radius, height=height, sections=SECTIONS)
    rot = _frames(axes)
    verts = np.einsum("nij,vj->nvi", rot, template.vertices) + centre_radius * axes[:, None, :]
    faces = template.faces[None, :, :] + len(template.vertices) * np.arange(len(axes))[:, None, None]
    return verts.reshape(-1, 3), faces.reshape(-1, 3)


def layout_mesh(design: MotorDesign, unit: str = "mm", sphere: bool = False) -> trimesh.Trimesh:
    """The motor's parts as one mesh of separate bodies, in ``unit``: a cylinder per magnet (inside the sphere,
    outer face on it), a cylinder per coil (outside, face one air gap off), and with ``sphere`` the rotor ball."""
    scale = _check_unit(unit)
    R, g = design.radius * scale, design.air_gap * scale
    lm, lc = design.magnet_length * scale, design.coil_length * scale
    parts = [
        _cylinders(design.rotor.centers, R - 0.5 * lm, 0.5 * design.magnet_diameter * scale, lm),
        _cylinders(design.stator.centers, R + g + 0.5 * lc, 0.5 * design.coil_diameter * scale, lc),
    ]
    if sphere:
        ball = trimesh.creation.icosphere(subdivisions=4, radius=R)
        parts.append((ball.vertices, ball.faces))
    offsets = np.cumsum([0] + [len(v) for v, _ in parts[:-1]])
    vertices = np.vstack([v for v, _ in parts])
    faces = np.vstack([f + o for (_, f), o in zip(parts, offsets)])
    return trimesh.Trimesh(vertices=vertices, faces=faces, process=False)


def _csv(rows: list[dict], columns: tuple[str, ...], unit: str) -> str:
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([f"{k}_{unit}" if k in ("x", "y", "z") else k for k in columns])
    writer.writerows([[repr(v) if isinstance(v, float) else int(v) if isinstance(v, bool) else v
                       for v in row.values()] for row in rows])
    return buf.getvalue()


def write_exports(design: MotorDesign, out: str | Path, unit: str = "mm", sphere: bool = False) -> list[Path]:
    """Write ``magnets.csv``, ``coils.csv``, ``layout.json``, ``layout.stl`` and the firmware's coil constants
    ``spherestep_config.h`` (:func:`~spherestep.hardware.sketch_config.sketch_config` of the design's drive) into
    folder ``out``, each atomically; returns their paths."""
    scale = _check_unit(unit)
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise bad_value("out", "a folder (it is created if missing)", f"the file {str(out)!r}")
    magnets, coils = magnet_table(design, unit), coil_table(design, unit)
    e1, e2 = azimuth_reference(design.stator_axis)
    layout = {
        "design": design.name, "unit": unit,
        "sphere_radius": design.radius * scale, "air_gap": design.air_gap * scale,
        "magnet": {"diameter": design.magnet_diameter * scale, "length": design.magnet_length * scale},
        "coil": {"diameter": design.coil_diameter * scale, "length": design.coil_length * scale},
        "stator_axis": design.stator_axis.tolist(), "azimuth_reference": e1.tolist(), "azimuth_e2": e2.tolist(),
        "definitions": {
            "magnet x, y, z": "outer face centre R·u on the sphere; the magnet's axis is u",
            "coil x, y, z": "face centre (R + air_gap)·v; the coil's axis is v = (axis_x, axis_y, axis_z)",
            "tilt_deg": "angle between the coil axis and stator_axis",
            "azimuth_deg": "right-handed angle of the coil axis about stator_axis from azimuth_reference",
        },
        "magnets": magnets, "coils": coils,
    }
    written = [write_text(out / "magnets.csv", _csv(magnets, MAGNET_COLUMNS, unit)),
               write_text(out / "coils.csv", _csv(coils, COIL_COLUMNS, unit)),
               write_text(out / "layout.json", json.dumps(layout, indent=1))]
    stl = layout_mesh(design, unit, sphere).export(file_type="stl")
    with atomic_path(out / "layout.stl") as tmp:
        tmp.write_bytes(stl)
    written.append(out / "layout.stl")
    written.append(write_text(out / HEADER, firmware_header(design)))
    return written


def firmware_header(design: MotorDesign) -> str:
    """``spherestep_config.h`` for ``design``: its drive (:func:`~spherestep.magnetics.design_model`'s limits, the
    iron-cored coil's winding for an iron design) as the sketch's constants."""
    from .magnetics import design_model

    return sketch_config(design_model(design).limits, coils=len(design.stator), design=design.name,
                         fingerprint=design.fingerprint)
