"""``spherestep --help`` start-up time (issue 12 §5: under 0.5 s), against the bare interpreter and, with
``--before DIR`` (a source tree, e.g. ``git archive 0bbd80e src | tar -x -C DIR``), an older version, measured
side by side in one run: medians of fresh processes.

    python benchmarks/bench_cli_startup.py [--repeats 7] [--before /tmp/old]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

from _timing import median_seconds

SRC = Path(__file__).resolve().parents[1] / "src"


def run(code: str, src: Path | None) -> None:
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1")
    if src is not None:
        env["PYTHONPATH"] = str(src)
    subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--before", type=Path, help="source tree of an older version (its src/ folder's parent)")
    args = parser.parse_args()
    help_code = "from spherestep.cli import main; main(['--help'])"
    rows = [("python -c pass", median_seconds(args.repeats, run, "pass", None)),
            ("spherestep --help", median_seconds(args.repeats, run, help_code, SRC)),
            ("import spherestep", median_seconds(args.repeats, run, "import spherestep", SRC))]
    if args.before is not None:
        rows.append(("spherestep --help (before)", median_seconds(args.repeats, run, help_code, args.before / "src")))
    base = rows[1][1]
    print(f"{'what':<30} {'median s':>9} {'÷ --help':>9}")
    for name, seconds in rows:
        print(f"{name:<30} {seconds:9.3f} {seconds / base:9.2f}")


if __name__ == "__main__":
    main()
