"""A skip in CI (``CI`` true) is a failure unless ``tests/skips-allowed.txt`` lists the start of its reason, with
why that skip is acceptable (issue 40 §5): a test that skips where it should run cannot pass silently. A pytest
plugin: tests/conftest.py imports its hooks; ``pytest -p ci_skips`` loads it alone (with tests/ on the path)."""

from __future__ import annotations

import os

import pytest

ALLOWED_SKIPS = os.path.join(os.path.dirname(__file__), "skips-allowed.txt")
_UNLISTED: list[str] = []


def allowed_skips(path: str = ALLOWED_SKIPS) -> dict[str, str]:
    """``{reason prefix: why it is acceptable}`` from the allow-list (lines ``PREFIX :: WHY``; ``#`` comments)."""
    out = {}
    with open(path, encoding="utf-8") as f:
        for number, line in enumerate(f, 1):
            if line.strip() and not line.lstrip().startswith("#"):
                prefix, sep, why = line.partition(" :: ")
                if not sep or not prefix.strip() or not why.strip():
                    raise ValueError(f"{path}:{number}: expected 'REASON PREFIX :: WHY IT IS ALLOWED'")
                out[prefix.strip()] = why.strip()
    return out


def skip_reason(report) -> str | None:
    """The reason of a skipped test's report (None when it did not skip; an xfail is not a skip)."""
    if not report.skipped or hasattr(report, "wasxfail"):
        return None
    longrepr = report.longrepr
    reason = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    return reason.removeprefix("Skipped: ")


def pytest_runtest_logreport(report):  # runs in the controller under xdist too
    reason = skip_reason(report)
    if reason is not None and os.environ.get("CI", "").lower() in ("1", "true", "yes"):
        if not any(reason.startswith(prefix) for prefix in allowed_skips()):
            _UNLISTED.append(f"{report.nodeid}: {reason}")


def pytest_sessionfinish(session, exitstatus):
    if _UNLISTED and exitstatus == 0:
        session.exitstatus = pytest.ExitCode.TESTS_FAILED


def pytest_terminal_summary(terminalreporter):
    if _UNLISTED:
        terminalreporter.section("skipped in CI but not in tests/skips-allowed.txt (the run fails)", red=True)
        for line in _UNLISTED:
            terminalreporter.line(line)
