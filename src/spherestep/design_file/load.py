"""Reading a design file: text → document (syntax, then schema) → :class:`~spherestep.motor.MotorDesign`.

:func:`read` and :func:`parse` give a :class:`Document`, a validated spec that knows its source; :func:`build`
hands the document's arguments to ``MotorDesign.from_packings`` (the one motor builder, whose checks are the
only ones) and names the file's field in every error: the builder's errors carry their field as data
(``exc.field``), mapped here by :data:`FILE_FIELDS`.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import ValidationError

from .. import packing as pk
from ..errors import InputError, bad_value
from ..sphere import disc_angle
from .quantities import show
from .schema import MAX_BYTES, DesignFileError, DesignSpec, Direction, translate

# MotorDesign.from_packings argument (or field) → the design file's field path
FILE_FIELDS = {
    "rotor": "rotor", "polarity": "rotor.polarity", "stator": "stator.coils", "coils": "stator.coils",
    "stator_axis": "stator.axis", "cap_half_angle": "stator.cap_half_angle", "tol": "tolerance",
    "max_coils": "overrides.max_coils", "allow_hemisphere": "overrides.allow_hemisphere",
    **{size: f"dimensions.{size}" for size in ("sphere_diameter", "magnet_diameter", "magnet_length",
                                              "coil_diameter", "coil_length", "air_gap", "rotor_shell")},
}
_INDEXED = re.compile(r"^(\w+)(\[\d+\])$")

class _Loader(yaml.SafeLoader):
    """Safe YAML that refuses a key given twice in one mapping (the later one would silently win)."""

    def construct_mapping(self, node, deep=False):
        seen = set()
        for key_node, _ in node.value:
            if isinstance(key_node, yaml.ScalarNode) and key_node.tag != "tag:yaml.org,2002:merge":
                key = (key_node.tag, key_node.value)
                if key in seen:
                    raise yaml.constructor.ConstructorError(None, None, f"duplicate key {key_node.value!r}",
                                                            key_node.start_mark)
                seen.add(key)
        return super().construct_mapping(node, deep=deep)



TOO_DEEP = ("is too deeply nested (lists or tables inside each other hundreds of levels deep); a design file is a "
            "few levels deep, start from `spherestep design new FILE`")


def parse_data(text: str, fmt: str = "yaml", source: str = "<design>") -> Any:
    """Parse the text of a design file (``fmt`` 'yaml' or 'toml') into Python data; DesignFileError on syntax."""
    if "\x00" in text:
        raise DesignFileError(source, None, "is a binary file, not a design file; give a YAML or TOML text file")
    if not text.strip():
        raise DesignFileError(source, None, "is empty; start from `spherestep design new FILE`")
    if fmt == "toml":
        try:
            return tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DesignFileError(source, None, f"TOML syntax error: {exc}; fix the syntax") from None
        except RecursionError:
            raise DesignFileError(source, None, TOO_DEEP) from None
    try:
        data = yaml.load(text, Loader=_Loader)  # noqa: S506 (a SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise DesignFileError(source, None, f"YAML syntax error{where}: {exc.problem or exc.context}; fix the "
                              "syntax") from None
    except RecursionError:
        raise DesignFileError(source, None, TOO_DEEP) from None
    except (yaml.YAMLError, ValueError, TypeError, OverflowError) as exc:
        raise DesignFileError(source, None, f"is not valid YAML ({type(exc).__name__}: {exc}); fix the syntax") \
            from None
    if data is None:
        raise DesignFileError(source, None, "is empty; start from `spherestep design new FILE`")
    return data



def read_text(path: str | Path) -> str:
    """The text of a design file; DesignFileError when it is missing, a folder, too large or not UTF-8."""
    path = Path(path)
    try:
        if path.is_dir():
            raise DesignFileError(str(path), None, "is a folder; give a design file (.yaml, .yml or .toml)")
        if path.stat().st_size > MAX_BYTES:
            raise DesignFileError(str(path), None, f"is larger than {MAX_BYTES // 2 ** 20} MiB; a design file is "
                                  "a short text file")
        raw = path.read_bytes()
    except FileNotFoundError:
        raise DesignFileError(str(path), None, f"does not exist; create it with `spherestep design new {path}`") \
            from None
    except OSError as exc:
        raise DesignFileError(str(path), None, f"could not be read ({exc.strerror or exc})") from None
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise DesignFileError(str(path), None, "is not UTF-8 text (a binary file?); give a YAML or TOML design "
                              "file") from None



@dataclass(frozen=True)
class Document:
    """A design file that passed the schema: ``spec`` and the ``source`` (file name) its errors name."""

    spec: DesignSpec
    source: str = "<design>"

    def arguments(self) -> dict:
        """Keyword arguments of ``MotorDesign.from_packings`` for this document (SI units, radians)."""
        spec, rotor, stator, dims = self.spec, self.spec.rotor, self.spec.stator, self.spec.dimensions
        if rotor.packing is not None:
            rotor_args = dict(rotor=rotor.packing, rotor_refine=rotor.refine or 0)
        else:
            rotor_args = dict(rotor=_explicit(rotor.poles, rotor.name, disc_angle(dims.magnet_diameter,
                                                                                0.5 * dims.sphere_diameter)))
        if stator.packing is not None:
            stator_args = dict(stator=stator.packing, stator_refine=stator.refine or 0, coils=stator.coils)
        else:
            coil_angle = disc_angle(dims.coil_diameter, 0.5 * dims.sphere_diameter + dims.air_gap)
            stator_args = dict(stator=_explicit(stator.coils, stator.name, coil_angle), coils="all")
        polarity = rotor.polarity if isinstance(rotor.polarity, list) else rotor.polarity.model_dump()
        return dict(
            **rotor_args, **stator_args, polarity=polarity, stator_axis=stator.axis.vector,
            cap_half_angle=stator.cap_half_angle, **dims.model_dump(exclude_none=True), tol=spec.tolerance,
            remanence=spec.remanence, coil_ampere_turns=spec.coil_ampere_turns, name=spec.name,
            channel_map=None if spec.channel_map is None else np.array(spec.channel_map, dtype=int).reshape(-1, 2),
            allow_hemisphere=spec.overrides.allow_hemisphere, max_coils=spec.overrides.max_coils,
            failed_coils=tuple(spec.failed_coils),
            # the keys given; CoilSpec fills in the rest (design_file does not import the motor's defaults)
            coil=None if spec.coil is None else spec.coil.model_dump(exclude_none=True),
        )



def _explicit(entries: list[Direction], name: str | None, default_radius: float) -> pk.Packing:
    """The packing of explicitly listed directions; a cap's radius is its own or ``default_radius`` (rad)."""
    centres = np.array([d.vector for d in entries])
    radii = np.array([default_radius if d.radius is None else d.radius for d in entries])
    return pk.Packing(centres, radii, name=name or "custom")


def validate(data: Any, source: str = "<design>") -> Document:
    """The :class:`Document` of parsed data (a mapping); DesignFileError naming the field for every mistake."""
    if not isinstance(data, dict):
        raise DesignFileError(source, None, "must hold a mapping of keys (schema_version, name, rotor, stator, "
                              f"dimensions, ...) at the top level; instead received {type(data).__name__} "
                              f"{show(data)}")
    try:
        return Document(DesignSpec.model_validate(data), source)
    except ValidationError as exc:
        raise DesignFileError(source, *translate(exc)) from None


def parse(text: str, fmt: str = "yaml", source: str = "<design>") -> Document:
    """The :class:`Document` written in ``text`` (``fmt`` 'yaml' or 'toml')."""
    return validate(parse_data(text, fmt, source), source)


SUFFIXES = (".yaml", ".yml", ".toml")  # a design file's name says how it is read; any other suffix is refused


def read(path: str | Path) -> Document:
    """The :class:`Document` of a design file: TOML when its name ends in ``.toml``, YAML for ``.yaml``/``.yml``;
    DesignFileError for any other suffix (a ``.txt`` is refused before it is read)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in SUFFIXES and not path.is_dir():  # a folder is told it is one (read_text)
        raise DesignFileError(str(path), None, f"has suffix {suffix or '(none)'!r}; a design file is named "
                              "*.yaml, *.yml or *.toml (the suffix says how it is read): rename it")
    fmt = "toml" if suffix == ".toml" else "yaml"
    return parse(read_text(path), fmt, str(path))


def file_field(field: str | None) -> str | None:
    """The design file's path of a ``MotorDesign`` field (``coils[3]`` → ``stator.coils[3]``)."""
    if field is None:
        return None
    match = _INDEXED.match(field)
    base, index = match.groups() if match else (field, "")
    return FILE_FIELDS.get(base, base) + index


def build(document: Document, design_type):
    """``design_type.from_packings(**document.arguments())`` (``design_type`` is
    :class:`~spherestep.motor.MotorDesign` or a subclass); its InputErrors become DesignFileErrors that name
    the file and the file's field path."""
    recorded = document.spec.fingerprint
    try:
        design = design_type.from_packings(**document.arguments())
        if recorded is not None and recorded != design.fingerprint:
            raise bad_value("fingerprint", f"{design.fingerprint}, the numbering of the coils and magnets this file "
                            "builds today: the file was written for another numbering (its coil and magnet indices "
                            "would name other caps); write it again from its construction, or remove the "
                            "fingerprint line once its indices are checked", recorded)
        return design
    except InputError as exc:
        message, field = str(exc), file_field(exc.field)
        if exc.field is not None and message.startswith(exc.field + " must be "):
            message = field + message[len(exc.field):]
        elif field is not None:
            message = f"{field}: {message}"
        raise DesignFileError(document.source, field, message) from None


def prototype_text() -> str:
    """The text of the design file shipped with the package, ``spherestep/data/prototype.yaml``."""
    return resources.files("spherestep").joinpath("data/prototype.yaml").read_text(encoding="utf-8")
