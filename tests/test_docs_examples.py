"""Every Python block of README.md and docs/*.md runs as written (issue 12 §1).

The blocks of one page run in order in one namespace (a page may build on its earlier blocks), in a fresh
temporary folder, so files they write do not touch the repository.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # the heaviest module-wide: make check leaves it out

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def blocks(page: Path) -> list[str]:
    return BLOCK.findall(page.read_text(encoding="utf-8"))


def test_the_readme_has_a_python_example():
    assert blocks(ROOT / "README.md"), "README.md has no ```python block"


@pytest.mark.slow
@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p)], ids=lambda p: p.name)
def test_python_blocks_run_as_written(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace: dict = {"__name__": f"docs_{page.stem}"}
    for number, code in enumerate(blocks(page), 1):
        try:
            exec(compile(code, f"{page.name} block {number}", "exec"), namespace)
        except Exception as exc:  # noqa: BLE001  (report which block of which page failed)
            pytest.fail(f"{page.name}, Python block {number} failed: {type(exc).__name__}: {exc}")
