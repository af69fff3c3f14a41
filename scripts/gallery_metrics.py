"""Measure every gallery entry and store the metrics with the package (src/spherestep/data/gallery/metrics.csv).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/gallery_metrics.py [--samples 20000] [--capability 500]

Each entry's design file is loaded fresh and measured by ``spherestep.gallery.measure`` (escape check included);
the timing of each is printed. The file is written whole or not at all.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from spherestep import gallery
from spherestep.atomic import write_text

OUT = Path(__file__).resolve().parent.parent / "src" / "spherestep" / "data" / "gallery" / "metrics.csv"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20_000, help="orientations for the resolution")
    parser.add_argument("--capability", type=int, default=500, help="orientations for the torque capability")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    rows = []
    for e in gallery.entries():
        t = time.perf_counter()
        m = gallery.measure(e, samples=args.samples, capability_samples=args.capability)
        print(f"{e.key:20s} {m.states:7d} states  {time.perf_counter() - t:6.1f} s  ({m.model})", flush=True)
        rows.append(m)
    write_text(args.out, gallery.metrics_csv(rows))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
