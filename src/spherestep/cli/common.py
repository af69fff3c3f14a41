"""Shared parsing and printing for the command modules."""

from __future__ import annotations

import json
import sys

import numpy as np
from rich.console import Console

from ..errors import bad_value

console = Console(width=None if sys.stdout.isatty() else 120)


def parse_vector(text: str, name: str) -> np.ndarray:
    """Parse ``"X,Y,Z"`` into a non-zero 3-vector; InputError naming ``name`` otherwise."""
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise bad_value(name, "three comma-separated numbers like 1,0,0.5", text) from None
    vec = np.array(values)
    if vec.shape != (3,) or not np.all(np.isfinite(vec)) or not np.any(vec):
        raise bad_value(name, "three comma-separated numbers, not all zero, like 1,0,0.5", text)
    return vec


def print_json(data) -> None:
    """Write ``data`` as JSON to stdout (for ``--json``)."""
    sys.stdout.write(json.dumps(data, indent=1, default=float) + "\n")
