"""Timings of spherestep.packing (medians of repeats, time.perf_counter), with a brute-force baseline
measured in the same run.

Run: ``.venv/bin/python benchmarks/bench_packing.py [--quick] [--json PATH]``.

* refine the truncated icosahedron (60 caps) until it has at least 10,000 caps (level 6: 21,872 caps);
* ``validate()`` and ``min_separation()`` on that packing (KD-tree neighbourhoods);
* ``symmetry_order()`` on that packing and on the 120-cap truncated icosidodecahedron;
* ``semiregular()``: building all 21 base packings;
* baseline: the smallest separation by a brute-force N² scan (the Gram matrix by BLAS, in row blocks) on the
  3,242-cap level-4 rhombicosidodecahedron, against ``min_separation()`` on the same packing.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform

import numpy as np
import scipy

from _record import Record
from _timing import median_seconds
from spherestep.packing import by_name, refine, semiregular


def brute_min_separation(centers: np.ndarray, block: int = 1024) -> float:
    """Smallest arc between two centres by scanning all N² pairs: the largest off-diagonal entry of the Gram
    matrix C Cᵀ (BLAS, row blocks of ``block``), then the arc ``2 asin(½ √(2 − 2 c·c'))``."""
    best = -np.inf
    n = len(centers)
    for start in range(0, n, block):
        gram = centers[start:start + block] @ centers.T
        idx = np.arange(start, min(start + block, n))
        gram[idx - start, idx] = -np.inf
        best = max(best, float(gram.max()))
    return float(2.0 * np.arcsin(0.5 * np.sqrt(max(0.0, 2.0 - 2.0 * best))))


def fmt(seconds: float) -> str:
    return f"{seconds * 1e3:10.2f} ms" if seconds < 10 else f"{seconds:10.2f} s "


def main() -> None:
    record = Record("packing")  # --json PATH: the numbers below stored for scripts/docs_numbers.py
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args()
    few, many = (2, 3) if args.quick else (5, 15)

    print("# spherestep.packing benchmark")
    print(f"date: {datetime.datetime.now().astimezone().isoformat(timespec='seconds')}")
    print(f"machine: {platform.platform()}, {platform.machine()}, os.cpu_count() = {os.cpu_count()}")
    print(f"python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}")
    print()

    ti = by_name("truncated-icosahedron")
    big = refine(ti, target=10_000)
    rows = []
    rows.append((f"refine(truncated-icosahedron, target=10000) -> {len(big)} caps (L{big.level})",
                 median_seconds(few, lambda: refine(ti, target=10_000)), few))
    rows.append((f"validate() on {len(big)} caps", median_seconds(many, big.validate), many))
    rows.append((f"min_separation() on {len(big)} caps", median_seconds(many, big.min_separation), many))
    rows.append((f"symmetry_order() on {len(big)} caps -> {big.symmetry_order()}",
                 median_seconds(few, big.symmetry_order), few))
    tid = by_name("truncated-icosidodecahedron")
    rows.append((f"symmetry_order() on {len(tid)} caps -> {tid.symmetry_order()}",
                 median_seconds(many, tid.symmetry_order), many))
    rows.append(("semiregular(): the 21 base packings", median_seconds(few, semiregular), few))

    mid = refine(by_name("rhombicosidodecahedron"), levels=4)
    kd = median_seconds(many, mid.min_separation)
    brute = median_seconds(few, lambda: brute_min_separation(mid.centers))
    agree = abs(mid.min_separation() - brute_min_separation(mid.centers))
    rows.append((f"min_separation() on {len(mid)} caps (KD-tree)", kd, many))
    rows.append((f"brute-force N² min separation on {len(mid)} caps (baseline)", brute, few))

    width = max(len(r[0]) for r in rows)
    print(f"| {'operation':<{width}} | {'median':>13} | repeats |")
    print(f"|{'-' * (width + 2)}|{'-' * 15}|---------|")
    for label, seconds, repeats in rows:
        print(f"| {label:<{width}} | {fmt(seconds)} | {repeats:7d} |")
    print()
    print(f"brute-force N² / KD-tree min separation on {len(mid)} caps: {brute / kd:.1f}x "
          f"(results agree to {agree:.1e} rad)")
    record.put("refined caps", len(big))
    record.put("seconds", {key: row[1] for key, row in zip(("refine", "validate", "min_separation", "symmetry_order",
                                                            "symmetry_order 120", "semiregular", "kd", "brute"), rows)})
    record.put("brute caps", len(mid))
    record.write()


if __name__ == "__main__":
    main()
