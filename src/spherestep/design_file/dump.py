"""Writing a design file: a :class:`~spherestep.motor.MotorDesign` → document → YAML, atomically.

Named packings and rules are written where they reproduce the design exactly (centres to 1e-12), explicit
lists otherwise; lengths and angles as the shortest decimal that reads back to the same float; defaults are
left out, except the coil as built, which is always stated. :func:`dumps` checks that the text loads back to a
motor before it is returned.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from .. import packing as pk
from ..atomic import write_text
from ..channels import MAX_COILS, default_channel_map
from .load import build, validate
from .quantities import angle_text, length_text, tesla_text, volts_text, watts_text
from .schema import MATCH_TOL, MAX_REFINE, SCHEMA_VERSION, DesignFileError, Dimensions

if TYPE_CHECKING:
    from ..motor import MotorDesign

_HEADER = "# spherestep design file; every field is described in docs/design-files.md\n"


def _match(packing: pk.Packing, full: pk.Packing) -> np.ndarray | None:
    """Indices of ``packing``'s caps in ``full`` when each agrees with one cap to :data:`MATCH_TOL`, else None."""
    dist, idx = full.tree.query(packing.centers)
    if np.any(dist > MATCH_TOL) or np.any(np.abs(full.radii[idx] - packing.radii) > MATCH_TOL) or \
            len(np.unique(idx)) != len(idx):
        return None
    return idx


def _named_source(packing: pk.Packing) -> pk.Packing | None:
    """The named packing (at ``packing.level``) that ``packing`` was cut from, if it names one."""
    if packing.name in pk.names() and 0 <= packing.level <= MAX_REFINE:
        return pk.named(packing.name, packing.level)
    return None


def _poles(packing: pk.Packing, default_radius: float) -> list:
    """Explicit entries: ``[x, y, z]``, or ``{x, y, z, radius}`` where the radius is not the default."""
    out = []
    for c, r in zip(packing.centers.tolist(), packing.radii.tolist()):
        out.append(c if abs(r - default_radius) <= 1e-15 else dict(zip("xyz", c), radius=angle_text(r)))
    return out


def _rotor_dict(design: MotorDesign) -> dict:
    rotor, polarity = design.rotor, design.polarity.tolist()
    full = _named_source(rotor)
    if full is not None and len(full) == len(rotor) and np.array_equal(_match(rotor, full), np.arange(len(rotor))):
        base = len(pk.named(rotor.name, 0))
        primary, filled = set(polarity[:base]), set(polarity[base:])
        if len(primary) == 1 and len(filled) <= 1:
            rule = {"primary": primary.pop()}
            rule["filled"] = filled.pop() if filled else -rule["primary"]
            return {"packing": rotor.name, "refine": rotor.level, "polarity": rule}
        return {"packing": rotor.name, "refine": rotor.level, "polarity": polarity}
    return {"name": rotor.label, "poles": _poles(rotor, design.magnet_angle), "polarity": polarity}


def _stator_dict(design: MotorDesign) -> dict:
    stator = design.stator
    head = {"axis": design.stator_axis.tolist(), "cap_half_angle": angle_text(design.cap_half_angle)}
    full = _named_source(stator)
    idx = None if full is None else _match(stator, full)
    if idx is None:
        return head | {"name": stator.label, "coils": _poles(stator, design.coil_angle)}
    fit = full.within_cap(design.stator_axis, design.cap_half_angle, min_radius=design.coil_angle)
    fits = len(fit) == len(stator) and np.array_equal(_match(fit, full), idx)
    return {"packing": stator.name, "refine": stator.level} | head | {"coils": "fit" if fits else idx.tolist()}


def _coil_dict(coil) -> dict:
    """The coil section of a ``CoilSpec``: core, pot, winding and supply always; the material's name, μr and knee
    for an iron core, its B–H curve and source where they differ from the default material's (read off
    the dataclass, as this package does not import the motor); an air core's material only if not the default."""
    material = coil.material
    default = {f.name: f.default for f in dataclasses.fields(material)}
    changed = {k: getattr(material, k) for k, v in default.items() if getattr(material, k) != v}
    out = {"core": coil.core}
    if coil.core == "iron" or changed:
        out["material"] = {"name": material.name, "relative_permeability": float(material.relative_permeability),
                           "knee": tesla_text(float(material.knee))}
        if "bh" in changed:
            out["material"]["bh"] = [[float(h), float(b)] for h, b in material.bh]
        if "source" in changed:
            out["material"]["source"] = material.source
    out |= {"pole_diameter": length_text(float(coil.pole_diameter)),
            "wall_thickness": length_text(float(coil.wall_thickness)),
            "back_thickness": length_text(float(coil.back_thickness)),
            "wire_diameter": length_text(float(coil.wire_diameter), units=("um", "mm", "in", "m")),
            "fill_factor": float(coil.fill_factor), "supply_voltage": volts_text(float(coil.supply_voltage)),
            "supply_power": watts_text(float(coil.supply_power)), "coils_on": int(coil.coils_on)}
    if coil.ampere_turns is not None:
        out["ampere_turns"] = float(coil.ampere_turns)
    return out


def to_dict(design: MotorDesign) -> dict:
    """The document of ``design``: named packings and rules where they reproduce it, explicit lists otherwise."""
    data = {
        "schema_version": SCHEMA_VERSION,
        "name": design.name,
        "rotor": _rotor_dict(design),
        "stator": _stator_dict(design),
        "dimensions": {f: length_text(float(getattr(design, f))) for f in Dimensions.model_fields},
    }
    if design.tol is not None:
        data["tolerance"] = angle_text(float(design.tol))
    data["remanence"] = tesla_text(float(design.remanence))
    data["coil_ampere_turns"] = float(design.coil_ampere_turns)
    if not np.array_equal(design.channel_map, default_channel_map(len(design.stator))):
        data["channel_map"] = design.channel_map.tolist()
    overrides = {}
    if design.max_coils != MAX_COILS:
        overrides["max_coils"] = int(design.max_coils)
    if design.allow_hemisphere:
        overrides["allow_hemisphere"] = True
    if overrides:
        data["overrides"] = overrides
    if design.failed_coils:
        data["failed_coils"] = list(design.failed_coils)
    data["coil"] = _coil_dict(design.coil)
    if _names_indices(data):
        data["fingerprint"] = design.fingerprint
    return data


def _names_indices(data: dict) -> bool:
    """Whether a document names caps by index (a coil list, failed coils, a channel map, a polarity list): then it
    records the design's fingerprint, so a machine or version that numbers the caps otherwise refuses it."""
    return (isinstance(data["stator"].get("coils"), list) or isinstance(data["rotor"].get("polarity"), list)
            or "failed_coils" in data or "channel_map" in data)


class _Dumper(yaml.SafeDumper):
    """Block mappings, except short mappings of scalars; lists of scalars on one line."""

    def represent_list(self, data):
        flow = all(not isinstance(v, (list, dict)) for v in data)
        return self.represent_sequence("tag:yaml.org,2002:seq", data, flow_style=flow)

    def represent_dict(self, data):
        flow = len(data) <= 4 and all(not isinstance(v, (list, dict)) for v in data.values())
        return self.represent_mapping("tag:yaml.org,2002:map", data.items(), flow_style=flow)


_Dumper.add_representer(list, _Dumper.represent_list)
_Dumper.add_representer(dict, _Dumper.represent_dict)


def dumps(design: MotorDesign) -> str:
    """``design`` as the YAML text of a design file (checked to load back before it is returned)."""
    data = to_dict(design)
    build(validate(data, source=f"design {design.name!r}"), type(design))
    return _HEADER + yaml.dump(data, Dumper=_Dumper, sort_keys=False, allow_unicode=True, width=110)


def save(design: MotorDesign, path: str | Path) -> Path:
    """Write ``design`` to ``path`` as YAML, atomically; InputError for a TOML name or a design load would refuse."""
    path = Path(path)
    if path.suffix.lower() == ".toml":
        raise DesignFileError(str(path), None, "design files are written as YAML; use a name ending in .yaml")
    return write_text(path, dumps(design))

