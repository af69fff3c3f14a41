"""The suite's own rules (issue 40 §5), each shown to bite on a small throw-away suite run by pytest in a
subprocess: in CI an unlisted skip fails the run and a listed one does not; a misspelt marker is an error
(``--strict-markers``); a hung test fails at its timeout (``pytest-timeout``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


from ci_skips import allowed_skips

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent


def _pytest(folder: Path, source: str, *args: str, ci: bool = True) -> subprocess.CompletedProcess:
    (folder / "test_tiny.py").write_text(source)
    env = {k: v for k, v in os.environ.items() if k != "CI"} | {"PYTHONPATH": str(TESTS)}
    if ci:
        env["CI"] = "true"
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "ci_skips", "-p", "no:cacheprovider",
                           "-c", str(ROOT / "pyproject.toml"), "--rootdir", str(folder), *args,
                           str(folder / "test_tiny.py")], env=env, capture_output=True, text=True, timeout=300)


def test_unlisted_skip_fails_in_ci_only(tmp_path):
    source = "import pytest\n\ndef test_a():\n    pytest.skip('a tool is missing')\n"
    done = _pytest(tmp_path, source)
    assert done.returncode == 1, done.stdout
    assert "not in tests/skips-allowed.txt" in done.stdout and "a tool is missing" in done.stdout
    assert _pytest(tmp_path, source, ci=False).returncode == 0


def test_listed_skip_passes_in_ci(tmp_path):
    reason = next(iter(allowed_skips()))
    done = _pytest(tmp_path, f"import pytest\n\ndef test_a():\n    pytest.skip({reason + ' (load 9)'!r})\n")
    assert done.returncode == 0, done.stdout


def test_xfail_is_not_a_skip(tmp_path):
    done = _pytest(tmp_path, "import pytest\n\n@pytest.mark.xfail(reason='known')\ndef test_a():\n    assert 0\n")
    assert done.returncode == 0, done.stdout


def test_every_allowed_skip_has_a_reason():
    listed = allowed_skips()
    assert listed and all(len(why) > 20 for why in listed.values())


def test_misspelt_marker_is_an_error(tmp_path):
    done = _pytest(tmp_path, "import pytest\n\n@pytest.mark.realtme\ndef test_a():\n    pass\n", ci=False)
    assert done.returncode != 0 and "'realtme' not found in `markers`" in done.stdout + done.stderr


def test_hung_test_times_out(tmp_path):
    done = _pytest(tmp_path, "import time\n\ndef test_a():\n    time.sleep(60)\n", "--timeout", "2", ci=False)
    assert done.returncode == 1 and "Timeout" in done.stdout + done.stderr


def test_timeout_and_strict_markers_are_configured():
    config = (ROOT / "pyproject.toml").read_text()
    assert "--strict-markers" in config and 'timeout_method = "thread"' in config and "\ntimeout = 600\n" in config
    import pytest_timeout  # noqa: F401
