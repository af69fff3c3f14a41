"""The gallery: published spherical motors rebuilt as design files and measured by the same code (issue 29 §4).

Entries (:func:`entries`, our reading of the paper's prototype first) carry their design file, source and the
assumptions made where the source is silent; :func:`measure` measures one (states, resolution, range, torque
capability on the design's own model, magnet mass, coil power; the servo's fastest turn and the settled relay
plan through :func:`drive_metrics`); :func:`stored_metrics` reads the measurements stored with the package
(``scripts/gallery_metrics.py`` writes them); :func:`targets` lists machines of another kind kept as targets.
docs/gallery.md has the table, the sources and the assumptions.

>>> from spherestep import gallery
>>> [e.key for e in gallery.entries()][:2]
['prototype', 'jhu-as-built']
>>> d = gallery.entry("jhu-as-built").design()
>>> len(d.rotor), len(d.stator)
(80, 16)
"""

from .entries import ENTRIES, TARGETS, Entry, Target, entries, entry, targets
from .measure import DRIVE_ANGLE, DRIVE_AXIS, MAGNET_DENSITY, DriveMetrics, Measurement, drive_metrics, magnet_mass, \
    measure
from .stored import METRICS_FILE, metrics_csv, parse_metrics, stored_metrics
from .table import gallery_table, write_gallery

__all__ = ["DRIVE_ANGLE", "DRIVE_AXIS", "ENTRIES", "MAGNET_DENSITY", "METRICS_FILE", "TARGETS", "DriveMetrics", "Entry",
           "Measurement", "Target", "drive_metrics", "entries", "entry", "gallery_table", "magnet_mass", "measure",
           "metrics_csv", "parse_metrics", "stored_metrics", "targets", "write_gallery"]
