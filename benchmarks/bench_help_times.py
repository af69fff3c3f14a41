"""The times the CLI's help texts state, measured: each command run once as a user runs it, its wall and CPU seconds.

Run: ``.venv/bin/python benchmarks/bench_help_times.py [--only NAME ...] [--json data/bench_help_times.json]``.
``tests/test_help_times.py`` holds every help text's stated time to the stored record (issue 40 §4(d)).

Each case is a fresh process (``spherestep.cli.main`` under ``sys.executable``), in a temporary folder; its CPU is the
process's and its children's (``resource.RUSAGE_CHILDREN``: a synthesis's Dask workers included). On a shared
machine the wall time grows with the load while the CPU time hardly does; the test compares the stated time with
the CPU seconds (every case but the synthesis runs on one core), and the record keeps both with the load.
``first-compile`` is ``move --axis 1,0.5,2 --angle 90`` with numba's cache in an empty folder
(``NUMBA_CACHE_DIR``), less the same command with that cache warm: the seconds numba spends compiling the fast
kernels on first use (the progress line's "about N s", :data:`spherestep._fast.compiling.FIRST_COMPILE_SECONDS`).
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import Record  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CLI = "import sys; from spherestep.cli import main; sys.exit(main(sys.argv[1:]))"
MOVE = ["move", "--axis", "1,0.5,2", "--angle", "90", "--out", "m"]
CASES = {  # name: the command line (after ``spherestep``)
    "forces-core-both": ["forces", "--core", "both", "--out", "f"],
    "demo-quick": ["demo", "--quick", "--out", "d"],
    "explore-quick": ["explore", "--quick", "--out", "e"],
    "synthesize-quick": ["synthesize", str(ROOT / "examples" / "specs" / "camera-gimbal.yaml"), "--out", "s",
                         "--budget", "quick", "--workers", "2"],
    "gallery-measure": ["gallery", "--measure"],
}


def run(args: list[str], env: dict | None = None) -> dict:
    """Run ``spherestep ARGS`` in a temporary folder: wall and CPU seconds, the exit status, the load."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        done = subprocess.run([sys.executable, "-c", CLI, *args], cwd=tmp, env=env,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        print(f"  exit {done.returncode}: {done.stderr.strip().splitlines()[-1:]}")
    return {"wall_s": wall, "cpu_s": cpu, "exit": done.returncode, "load": [load, os.getloadavg()[0]]}


def main() -> None:
    record = Record("help_times")
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", nargs="*", help=f"these cases only (names: first-compile and {', '.join(CASES)})")
    args = parser.parse_args()
    names = args.only or ["first-compile", *CASES]
    print(f"# bench_help_times  load average at start {os.getloadavg()[0]:.1f}  cpus={os.cpu_count()}")
    for name in names:
        if name == "first-compile":
            with tempfile.TemporaryDirectory() as cache:
                env = dict(os.environ, NUMBA_CACHE_DIR=cache)
                cold = run(MOVE, env)
                warm = run(MOVE, env)
            value = {"cold": cold, "warm": warm, "wall_s": cold["wall_s"] - warm["wall_s"],
                     "cpu_s": cold["cpu_s"] - warm["cpu_s"], "exit": max(cold["exit"], warm["exit"])}
        else:
            value = run(CASES[name])
        print(f"{name:<18} wall {value['wall_s']:7.1f} s  CPU {value['cpu_s']:7.1f} s  exit {value['exit']}")
        record.put(name, value)
    record.write()


if __name__ == "__main__":
    main()
