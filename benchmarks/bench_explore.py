"""Sweep throughput: designs evaluated per minute on a local Dask cluster of 1 and 2 worker processes (and 2
threads in one process), medians of repeats of one small fixed sweep, and the speed-up, measured in one run.

Run: ``.venv/bin/python benchmarks/bench_explore.py [--quick] [--core air|iron] [--workers 1]``.

The sweep: 32 designs, the 60- and 30-pole rotors of the truncated icosahedron and the icosidodecahedron
over four stators (truncated cuboctahedron, rhombicosidodecahedron, truncated octahedron, rhombicuboctahedron),
unrefined and refined once, in 60° and 80° caps, 500 resolution samples and the holding torque of 8
states and the capability at 100 orientations each, on each design's own model (default: iron cores, the coupled
model: its tables are built per design, ~5 s; ``--core air``: the air-core map, 0.05 s to 3 s per design).
"s/design" is the median and mean time inside one design (1 worker process: the cost per design).
Each cluster is started once and warmed up (every worker imports spherestep and evaluates one design)
before the timed repeats; each repeat writes to a fresh results folder, so nothing is resumed. "Busy
workers" is the time spent inside the designs, summed over designs, over the wall time: about 2 when two
workers are kept busy (whether or not they get a core each). The load average is printed because the
machine may be shared: other processes take cores from the workers.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import tempfile
import time
from dataclasses import replace

from distributed import Client, LocalCluster

from spherestep.explore import DesignPoint, Grid, ResultStore, evaluate, run_sweep

GRID = Grid(rotors=("truncated-icosahedron", "icosidodecahedron"),
            stators=("truncated-cuboctahedron", "rhombicosidodecahedron", "truncated-octahedron",
                     "rhombicuboctahedron"),
            rotor_levels=(0,), stator_levels=(0, 1), cap_half_angles_deg=(60.0, 80.0), primary_ratio_max=None,
            samples=500)
WARM_UP = DesignPoint("icosidodecahedron", 0, "truncated-octahedron", 0, 60.0, samples=50)


def designs_per_minute(client: Client, points: list, repeats: int) -> tuple[list[float], list[float], list]:
    """Designs per minute of each repeat, the busy workers (summed time inside the designs over wall time) and
    the time inside each design (s)."""
    rates, busy, inside_each = [], [], []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory() as folder:
            store = ResultStore(folder)
            start = time.perf_counter()
            summary = run_sweep(points, store, client, batch_size=8)
            seconds = time.perf_counter() - start
            table = store.read()
            inside = float(table["seconds"].sum())
            inside_each.extend(table["seconds"].tolist())
            models = table["model"].value_counts().to_dict() if "model" in table else {}
        assert summary.evaluated == len(points) and not summary.lost
        rates.append(60.0 * len(points) / seconds)
        busy.append(inside / seconds)
    print(f"#   models: {models or 'air-core torque map, default drive limits (before issue 25)'}")
    return rates, busy, inside_each


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat instead of three")
    parser.add_argument("--core", choices=("air", "iron"), help="the designs' cores (default: the grid's, iron)")
    parser.add_argument("--workers", type=int, choices=(1, 2), help="only this cluster (default: all three)")
    args = parser.parse_args()
    repeats = 1 if args.quick else 3
    points = (replace(GRID, core=args.core) if args.core else GRID).points()
    print(f"# bench_explore  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  load average at start="
          f"{os.getloadavg()[0]:.1f}")
    print(f"# sweep: {len(points)} designs; median of {repeats} repeats")
    print(f"{'cluster':<22} {'designs/min':>11} {'busy workers':>12} {'s/design':>15}  repeats (designs/min)")
    medians = {}
    clusters = (("1 worker process", dict(n_workers=1, processes=True)),
                ("2 worker processes", dict(n_workers=2, processes=True)),
                ("2 threads, 1 process", dict(n_workers=1, threads_per_worker=2, processes=False)))
    if args.workers:
        clusters = clusters[args.workers - 1:args.workers]
    for label, kwargs in clusters:
        kwargs.setdefault("threads_per_worker", 1)
        cluster = LocalCluster(host="127.0.0.1" if kwargs["processes"] else None, dashboard_address="127.0.0.1:0",
                               **kwargs)
        try:
            with Client(cluster) as client:
                client.run(evaluate, WARM_UP)  # every worker imports spherestep and builds its packings once
                rates, busy, each = designs_per_minute(client, points, repeats)
        finally:
            cluster.close()
        medians[label] = statistics.median(rates)
        per = f"{statistics.median(each):.2f} / {statistics.fmean(each):.2f}"
        print(f"{label:<22} {medians[label]:>11.1f} {statistics.median(busy):>12.2f} {per:>15}  "
              f"{', '.join(f'{r:.1f}' for r in rates)}")
    if len(medians) < 3:
        print(f"(load average at end {os.getloadavg()[0]:.1f})")
        return
    ratio = medians["2 worker processes"] / medians["1 worker process"]
    threads = medians["2 threads, 1 process"] / medians["1 worker process"]
    print(f"speed-up with 2 worker processes: {ratio:.2f}x; with 2 threads: {threads:.2f}x "
          f"(load average at end {os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    main()
