"""The gallery as one JSON-ready table: each entry with its source, assumptions and metrics, then the targets."""

from __future__ import annotations

from .entries import entries, targets
from .stored import stored_metrics


def gallery_table(measurements: dict | None = None) -> dict:
    """``{"entries": [...], "targets": [...]}``: every entry's :meth:`~Entry.to_dict` with ``metrics`` (its
    :class:`~spherestep.gallery.Measurement` ``to_dict()``, angles in degrees; from ``measurements`` by key,
    default the stored ones, None for an entry not measured), then every target with ``metrics`` None (a
    machine of another kind: the PM metrics do not apply)."""
    measured = stored_metrics() if measurements is None else measurements
    rows = []
    for e in entries():
        m = measured.get(e.key)
        rows.append(e.to_dict() | {"metrics": None if m is None else m.to_dict()})
    return {"entries": rows, "targets": [t.to_dict() | {"metrics": None} for t in targets()]}


def write_gallery(out, measurements: dict | None = None) -> list:
    """Write the gallery into the folder ``out``: every entry's design file (``<key>.yaml``, as stored), the
    metrics (``metrics.csv``, :func:`~spherestep.gallery.metrics_csv`) and the whole table (``gallery.json``,
    :func:`gallery_table`), each file atomically; returns the paths written. ``measurements`` default the
    stored ones."""
    import json
    from pathlib import Path

    from ..atomic import write_text
    from .stored import metrics_csv

    measured = stored_metrics() if measurements is None else measurements
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = [write_text(out / f"{e.key}.yaml", e.path.read_text(encoding="utf-8")) for e in entries()]
    written.append(write_text(out / "metrics.csv", metrics_csv([measured[e.key] for e in entries()
                                                                  if e.key in measured])))
    written.append(write_text(out / "gallery.json", json.dumps(gallery_table(measured), indent=1)))
    return written
