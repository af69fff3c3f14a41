"""The gallery's metrics, measured offline and stored with the package (``spherestep/data/gallery/metrics.csv``).

``scripts/gallery_metrics.py`` measures every entry (:func:`~spherestep.gallery.measure`, escape check included,
about a minute on two cores) and writes the file with :func:`metrics_csv`; :func:`stored_metrics` reads it back
as :class:`~spherestep.gallery.Measurement` values. Angles are stored in degrees; an empty cell is None.
"""

from __future__ import annotations

import csv
import dataclasses
import io
import math
from importlib import resources

from ..errors import ComputationError
from .measure import Measurement

METRICS_FILE = "gallery/metrics.csv"

_FIELDS = [f for f in dataclasses.fields(Measurement)]


def _column(name: str) -> str:
    return name.removesuffix("_rad") + "_deg" if name.endswith("_rad") else name


def metrics_csv(measurements) -> str:
    """CSV text of ``measurements``: one row each, the :class:`Measurement` fields in order, angles in degrees
    (``*_deg``), floats at 10 significant digits, None as an empty cell."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow([_column(f.name) for f in _FIELDS])
    for m in measurements:
        row = []
        for f in _FIELDS:
            value = getattr(m, f.name)
            if value is None:
                row.append("")
            elif f.name.endswith("_rad"):
                row.append(f"{math.degrees(value):.10g}")
            elif isinstance(value, float):
                row.append(f"{value:.10g}")
            else:
                row.append(str(value))
        writer.writerow(row)
    return out.getvalue()


def _value(field: dataclasses.Field, text: str):
    if text == "":
        return None
    kind = str(field.type)
    if kind.startswith("bool"):
        return text == "True"
    if kind.startswith("int"):
        return int(text)
    if kind.startswith("float"):
        value = float(text)
        return math.radians(value) if field.name.endswith("_rad") else value
    return text


def parse_metrics(text: str) -> dict[str, Measurement]:
    """The measurements in CSV ``text`` (as :func:`metrics_csv` writes it), by entry key."""
    rows = list(csv.DictReader(io.StringIO(text)))
    header = [_column(f.name) for f in _FIELDS]
    if not rows or list(rows[0]) != header:
        raise ComputationError(f"the gallery's stored metrics do not have the columns {header}; re-run "
                               "scripts/gallery_metrics.py")
    return {row["key"]: Measurement(**{f.name: _value(f, row[_column(f.name)]) for f in _FIELDS}) for row in rows}


def stored_metrics() -> dict[str, Measurement]:
    """The stored measurements of the gallery's entries, by key (``spherestep/data/gallery/metrics.csv``)."""
    path = resources.files("spherestep.data").joinpath(METRICS_FILE)
    return parse_metrics(path.read_text(encoding="utf-8"))
