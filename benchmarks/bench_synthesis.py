"""Synthesis throughput: candidates through the ladder per second on local Dask clusters of 1 and 2 worker processes
(and 2 threads in one process), the speed-up, and what the tasks' sizes allow on more workers; measured in one run.

Run: ``.venv/bin/python benchmarks/bench_synthesis.py [--quick]``.

The work: the camera-gimbal spec (examples/specs/camera-gimbal.yaml: air cores, a 45° cone, 60-mm ball) over 24
layouts — the truncated icosahedron and the icosidodecahedron, unrefined, on the truncated cuboctahedron, the
rhombicuboctahedron and the truncated octahedron, unrefined and refined once, in 60° and 80° caps — each through
geometry → states → capability (:class:`spherestep.synthesis.Ladder`), 400 resolution and 32 capability samples.
Each cluster is started once and warmed up (every worker imports spherestep and climbs the ladder once) before the
timed repeats. "Busy workers" is the time inside the tasks, summed, over the wall time.

**16 workers.** Issue 29 asks for ≥ 12× on 16 local workers; this machine has 2 cores, so that cannot be measured
here. What can be said from the measured task times: with ``n`` workers and these tasks the wall time is at least
``max(Σt / n, max t)`` (the longest task cannot be split), so the speed-up is at most ``min(n, Σt / max t)``; the
script prints that bound for 16 workers from the tasks it timed.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import statistics
import time
from pathlib import Path

from distributed import Client, LocalCluster, as_completed

from spherestep.synthesis import Candidate, Ladder, load_spec

SPEC = Path(__file__).resolve().parents[1] / "examples" / "specs" / "camera-gimbal.yaml"
LAYOUTS = [Candidate(r, 0, s, sl, cap, 0.060, samples=400, capability_samples=32)
           for r in ("truncated-icosahedron", "icosidodecahedron")
           for s in ("truncated-cuboctahedron", "rhombicuboctahedron", "truncated-octahedron")
           for sl in (0, 1) for cap in (60.0, 80.0)]
WARM_UP = Candidate("icosidodecahedron", 0, "truncated-octahedron", 0, 60.0, 0.060, samples=50, capability_samples=8)


def run(client: Client, ladder: Ladder, layouts: list) -> tuple[float, list[float]]:
    """Wall time of one pass over ``layouts`` and every task's own time (s)."""
    start = time.perf_counter()
    futures = [client.submit(ladder, c, pure=False) for c in layouts]
    inside = []
    for future in as_completed(futures):
        rows = future.result()
        inside.append(float(rows[0]["seconds"]))
    return time.perf_counter() - start, inside


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat instead of three")
    args = parser.parse_args()
    repeats = 1 if args.quick else 3
    spec = load_spec(SPEC)
    ladder = Ladder(spec, False, None)
    print(f"# bench_synthesis  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  load average at start="
          f"{os.getloadavg()[0]:.1f}")
    print(f"# work: {len(LAYOUTS)} layouts of the camera-gimbal spec; median of {repeats} repeats")
    print(f"{'cluster':<22} {'designs/s':>9} {'busy workers':>12}  repeats (designs/s)")
    medians, tasks = {}, []
    for label, kwargs in (("1 worker process", dict(n_workers=1, processes=True)),
                          ("2 worker processes", dict(n_workers=2, processes=True)),
                          ("2 threads, 1 process", dict(n_workers=1, threads_per_worker=2, processes=False))):
        kwargs.setdefault("threads_per_worker", 1)
        cluster = LocalCluster(host="127.0.0.1" if kwargs["processes"] else None, dashboard_address="127.0.0.1:0",
                               **kwargs)
        rates, busy = [], []
        try:
            with Client(cluster) as client:
                client.run(ladder, WARM_UP)
                for _ in range(repeats):
                    wall, inside = run(client, ladder, LAYOUTS)
                    rates.append(len(LAYOUTS) / wall)
                    busy.append(sum(inside) / wall)
                    if label == "1 worker process":
                        tasks.extend(inside)
        finally:
            cluster.close()
        medians[label] = statistics.median(rates)
        print(f"{label:<22} {medians[label]:>9.3f} {statistics.median(busy):>12.2f}  "
              f"{', '.join(f'{r:.3f}' for r in rates)}")
    ratio = medians["2 worker processes"] / medians["1 worker process"]
    threads = medians["2 threads, 1 process"] / medians["1 worker process"]
    per_pass = sum(tasks) / repeats
    longest = max(tasks)
    print(f"speed-up with 2 worker processes: {ratio:.2f}x; with 2 threads: {threads:.2f}x "
          f"(load average at end {os.getloadavg()[0]:.1f})")
    print(f"16 workers: not measurable on {os.cpu_count()} cores; these {len(LAYOUTS)} tasks (Σt = {per_pass:.1f} s, "
          f"longest {longest:.1f} s) allow at most {min(16.0, per_pass / longest):.1f}x; a normal-budget search "
          "(hundreds of tasks) is not bounded by its longest task in the same way")


if __name__ == "__main__":
    main()
