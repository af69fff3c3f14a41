"""Shared by the benchmark scripts: ``--json PATH`` stores what a run measured, with its date, the machine and the
load average at its start and end, for ``scripts/docs_numbers.py`` to render the docs' tables from (issue 27 §4).

    RECORD = Record("servo_loop")        # first thing in main(): takes ``--json PATH`` out of sys.argv
    RECORD.put("law", {...})             # plain numbers, strings, lists and dicts (NumPy scalars converted,
                                         # also of what is added to RECORD.values directly)
    RECORD.write()                       # at the end: writes PATH whole (a temporary file renamed), if given

Numbers are stored as measured (seconds, µs, ratios as the key names say); NaN is stored as ``null``.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np


def _plain(value):
    """``value`` as JSON: NumPy scalars and arrays to Python numbers and lists, NaN and inf to None."""
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


class Record:
    """The measurements of one benchmark run (module docstring)."""

    def __init__(self, benchmark: str, argv: list[str] | None = None):
        argv = sys.argv if argv is None else argv
        self.path = None
        if "--json" in argv:
            i = argv.index("--json")
            if i + 1 >= len(argv):
                raise SystemExit("--json needs a file name")
            self.path = Path(argv[i + 1])
            del argv[i:i + 2]
        self.benchmark = benchmark
        self.command = " ".join([Path(sys.argv[0]).name, *sys.argv[1:]])
        self.started = datetime.datetime.now(datetime.UTC)
        self.load_start = os.getloadavg()[0]
        self.values: dict = {}

    def put(self, key: str, value):
        """Store ``value`` under ``key`` and return it."""
        self.values[key] = _plain(value)
        return value

    def write(self) -> None:
        """Write the record to the ``--json`` file (nothing without one)."""
        if self.path is None:
            return
        now = datetime.datetime.now(datetime.UTC)
        data = {"benchmark": self.benchmark, "command": self.command,
                "measured": self.started.strftime("%Y-%m-%d %H:%M UTC"),
                "seconds": round((now - self.started).total_seconds(), 1),
                "load": [round(self.load_start, 1), round(os.getloadavg()[0], 1)],
                "machine": f"{os.cpu_count()} cores ({platform.machine()}, {platform.system()}), Python "
                           f"{platform.python_version()}, NumPy {np.__version__}",
                "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "unset"),
                "values": _plain(self.values)}
        self.path.parent.mkdir(parents=True, exist_ok=True)
        text = json.dumps(data, indent=1, ensure_ascii=False, allow_nan=False) + "\n"
        fd, tmp = tempfile.mkstemp(dir=self.path.parent, suffix=".tmp")
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(text)
            os.chmod(tmp, 0o644)
            os.replace(tmp, self.path)
        except BaseException:
            os.unlink(tmp)
            raise
        print(f"stored {self.path}")
