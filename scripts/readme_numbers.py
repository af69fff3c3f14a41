"""Kept for the old command: ``python scripts/readme_numbers.py [summary.json]`` is
``python scripts/docs_numbers.py demo [summary.json]`` (store the demo run, rewrite every generated block)."""

import runpy
import sys
from pathlib import Path

if __name__ == "__main__":
    sys.argv = [sys.argv[0], "demo", *sys.argv[1:]]
    runpy.run_path(str(Path(__file__).with_name("docs_numbers.py")), run_name="__main__")
