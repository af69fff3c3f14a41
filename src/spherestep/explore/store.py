"""The results table of a sweep: a folder of Parquet part files, one per batch, each written whole.

A batch of rows is written to a temporary file in the folder and renamed to ``part-<batch>-<8 hex digits>.parquet``
(a sequence number and a random tag), so a reader sees a part whole or not at all, and an interrupted
sweep loses at most the batch it was collecting. Reading concatenates the parts in sequence order; when a
key appears more than once (a design evaluated again after its limits were raised) the latest row wins.
Every part has the same Arrow schema (:data:`SCHEMA`), so the table's columns and types do not depend on
which designs a batch happened to hold.
"""

from __future__ import annotations

import re
import secrets
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from ..atomic import atomic_path
from ..errors import InputError

SCHEMA = pa.schema([
    ("key", pa.string()),
    ("rotor", pa.string()), ("rotor_level", pa.int32()), ("rotor_family", pa.string()), ("rotor_poles", pa.int32()),
    ("stator", pa.string()), ("stator_level", pa.int32()), ("stator_family", pa.string()),
    ("family_rule", pa.string()), ("primary_ratio", pa.float64()),
    ("cap_half_angle_deg", pa.float64()), ("tol_deg", pa.float64()), ("samples", pa.int32()), ("seed", pa.int64()),
    ("core", pa.string()), ("status", pa.string()), ("reason", pa.string()),
    ("motor", pa.string()), ("coils", pa.int32()),
    ("magnet_diameter_mm", pa.float64()), ("coil_diameter_mm", pa.float64()),
    ("max_step_deg", pa.float64()), ("lookup_voxels", pa.int64()), ("candidates", pa.int64()), ("states", pa.int64()),
    ("resolution_median_deg", pa.float64()), ("resolution_p95_deg", pa.float64()),
    ("resolution_max_deg", pa.float64()), ("range_fraction", pa.float64()),
    ("state_graph_components", pa.int64()), ("reaches_all", pa.bool_()), ("escape_violations", pa.int64()),
    ("holding_torque_median_Nm", pa.float64()), ("holding_torque_min_Nm", pa.float64()),
    ("holding_torque_states", pa.int32()),
    ("capability_median_Nm", pa.float64()), ("capability_p5_Nm", pa.float64()), ("model", pa.string()),
    ("inertia_isotropy", pa.float64()), ("seconds", pa.float64()), ("worker", pa.string()), ("params", pa.string()),
])
COLUMNS = SCHEMA.names
MEASURED = [c for c in COLUMNS if c not in ("seconds", "worker")]  # what a rerun reproduces exactly
_NULLABLE = {pa.int32(): pd.Int64Dtype(), pa.int64(): pd.Int64Dtype(), pa.bool_(): pd.BooleanDtype()}
_PART = re.compile(r"^part-(\d{6,})-([0-9a-f]{8})\.parquet$")


class ResultStore:
    """Part files of one sweep's results in ``folder`` (created on the first write); ``schema`` the Arrow schema
    of every part (default :data:`SCHEMA`, the sweep's; :mod:`spherestep.synthesis` stores its own rows)."""

    def __init__(self, folder: str | Path, schema: pa.Schema = SCHEMA):
        self.folder = Path(folder)
        self.schema = schema
        if self.folder.exists() and not self.folder.is_dir():
            raise InputError(f"results folder {str(self.folder)!r} is a file; give a folder")

    def parts(self) -> list[Path]:
        """The part files, in the order they were written."""
        if not self.folder.is_dir():
            return []
        found = [(int(m.group(1)), p) for p in self.folder.iterdir() if (m := _PART.match(p.name))]
        return [p for _, p in sorted(found)]

    def append(self, rows: list[dict]) -> Path | None:
        """Write ``rows`` as the next part file, atomically; returns its path (None for no rows)."""
        if not rows:
            return None
        parts = self.parts()
        seq = int(_PART.match(parts[-1].name).group(1)) + 1 if parts else 1
        table = pa.Table.from_pylist([{c: row.get(c) for c in self.schema.names} for row in rows], schema=self.schema)
        path = self.folder / f"part-{seq:06d}-{secrets.token_hex(4)}.parquet"
        with atomic_path(path) as tmp:
            pq.write_table(table, tmp)
        return path

    def read(self) -> pd.DataFrame:
        """Every stored row (the latest per key), columns as in :data:`SCHEMA`: integers and booleans as pandas'
        nullable types (``<NA>`` where a design was not measured), floats with NaN."""
        tables = []
        for path in self.parts():
            try:
                tables.append(pq.read_table(path, schema=self.schema))
            except (pa.ArrowException, OSError) as exc:
                raise InputError(f"results part {str(path)!r} cannot be read as a sweep's results ({exc}); move "
                                 "it out of the folder") from None
        table = pa.concat_tables(tables) if tables else self.schema.empty_table()
        frame = table.to_pandas(types_mapper=_NULLABLE.get)
        return frame.drop_duplicates("key", keep="last").reset_index(drop=True)
