"""The OpenBLAS kernel this process runs and another one this CPU can run (issue 35: the numbering of caps must not
depend on it). ``make test`` runs the numbering-sensitive tests again under ``--other``.

    .venv/bin/python scripts/blas_kernel.py [--other]
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import threadpoolctl


def current() -> str:
    """The kernel NumPy's OpenBLAS chose (or was told by OPENBLAS_CORETYPE)."""
    np.ones((8, 8)) @ np.ones((8, 8))
    names = [i.get("architecture") for i in threadpoolctl.threadpool_info() if i.get("internal_api") == "openblas"]
    return names[0] if names else "unknown"


def other(now: str) -> str:
    """A second kernel of this CPU: Haswell (AVX2) unless that is the one running, then SkylakeX where the CPU has
    AVX-512, else Sandybridge (AVX)."""
    flags = Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else ""
    if now.lower() != "haswell":
        return "Haswell"
    return "SkylakeX" if "avx512f" in flags else "Sandybridge"


if __name__ == "__main__":
    now = current()
    print(other(now) if "--other" in sys.argv[1:] else now)
