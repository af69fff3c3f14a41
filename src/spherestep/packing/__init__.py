"""Circle packings on the sphere: Platonic, the 21 semiregular ones, recursive refinement (Sec. II-B)."""

import functools

from .. import checks
from ..errors import bad_value
from .congruence import aligning_rotations, congruent, distinct, symmetry_rotations
from .core import Packing
from .platonic import PLATONIC, platonic
from .refine import fill_holes, holes, refine
from .wythoff import CONSTRUCTIONS, NAMES, fundamental_triangle, reflection_group, semiregular, wythoff

__all__ = [
    "CONSTRUCTIONS", "NAMES", "PLATONIC", "Packing", "aligning_rotations", "by_name", "congruent", "distinct",
    "fill_holes", "fundamental_triangle", "holes", "named", "names", "platonic", "reflection_group", "refine",
    "semiregular", "symmetry_rotations", "wythoff",
]


def names() -> list[str]:
    """Names of the 21 base packings, families T, O, I in turn."""
    return [n for f in ("T", "O", "I") for n in NAMES[f]]


def by_name(name: str) -> Packing:
    """One of the 21 base packings by its name (see :func:`names`)."""
    for family, family_names in NAMES.items():
        if name in family_names:
            return wythoff(family, CONSTRUCTIONS[family_names.index(name)])
    raise bad_value("packing name", f"one of {', '.join(names())}", name)


def named(name: str, level: int = 0) -> Packing:
    """The base packing ``name`` refined ``level`` times, ``refine(by_name(name), levels=level)``, computed once
    per process (packings are immutable, so every caller shares the same object)."""
    if not isinstance(name, str) or name not in names():
        raise bad_value("packing name", f"one of {', '.join(names())}", name)
    level = checks.count(level, "level", minimum=0, expected="a non-negative integer number of refinement levels")
    return _named(name, level)


@functools.cache
def _named(name: str, level: int) -> Packing:
    return refine(by_name(name), levels=level)
