"""Running a sweep on Dask: a local cluster with no set-up, or an existing one; results stream to a store.

:func:`dask_client` opens a ``distributed.Client``: on a :class:`~distributed.LocalCluster` of worker
processes (one thread each) on the loopback interface, on one process with threads (``threads=True``), or
connected to a running scheduler (``scheduler="tcp://HOST:PORT"``, whose workers must be able to import
``spherestep``). :func:`run_sweep` submits every design of the grid that the store does not already hold,
with ``retries`` so a design whose worker dies is run again elsewhere, and appends the rows to the store in
batches as they complete. Designs whose futures still fail (a worker lost more than Dask's
``distributed.scheduler.allowed-failures`` times, an error outside the metrics) are reported in the summary
and not written, so the next run picks them up.
"""

from __future__ import annotations

import logging
import os
import re
import time
from contextlib import contextmanager
from dataclasses import dataclass, field
from collections.abc import Callable

import pandas as pd

from .. import checks
from ..errors import InputError, bad_value
from ..packing import named
from .build import Limits, evaluate
from .grid import DesignPoint
from .store import ResultStore

CONNECT_TIMEOUT = 10.0  # seconds to wait for an existing scheduler
QUIT_TIMEOUT = 2.0  # s: on an interrupt the client and a local cluster are closed within this (issue 40 §3: ≤ 3 s)
_SCHEDULER = re.compile(r"^(tcp|tls|inproc|ucx|ws|wss)://\S+$")


@contextmanager
def dask_client(scheduler: str | None = None, *, threads: bool = False, workers: int | None = None):
    """A ``distributed.Client`` for a sweep, closed (with its local cluster) on exit.

    ``scheduler``: address of a running scheduler; otherwise a local cluster of ``workers`` processes (default:
    the CPU count) with one thread each, or with ``threads=True`` one process running ``workers`` threads.
    """
    from distributed import Client, LocalCluster

    if workers is not None:
        workers = checks.count(workers, "workers", 1, 512, expected="an integer in 1..512")
    if scheduler is not None:
        if threads or workers is not None:
            error = InputError("scheduler: an existing cluster brings its own workers; give either scheduler or "
                               "threads/workers, not both")
            error.field = "scheduler"
            raise error
        if not _SCHEDULER.match(scheduler):
            raise bad_value("scheduler", "an address like tcp://HOST:PORT", scheduler)
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError) as exc:
            error = InputError(f"scheduler: could not connect to {scheduler} within {CONNECT_TIMEOUT:g} s ({exc}); "
                               "start a scheduler there, or leave out the scheduler for a local cluster")
            error.field = "scheduler"
            raise error from None
        try:
            yield client
        except BaseException:
            _quietly(client.close, timeout=QUIT_TIMEOUT)
            raise
        client.close()
        return
    n = workers or os.cpu_count() or 1
    with _sigint_ignored():  # worker processes inherit it: Ctrl-C reaches this process alone, which closes them
        if threads:
            cluster = LocalCluster(n_workers=1, threads_per_worker=n, processes=False,
                                   dashboard_address="127.0.0.1:0")
        else:
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address="127.0.0.1:0", silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        yield client
    except BaseException:  # an interrupt (or a failure): stop the cluster quickly and without Dask's warnings
        _quietly(client.close, timeout=QUIT_TIMEOUT / 2)
        _quietly(cluster.close, timeout=QUIT_TIMEOUT / 2)
        _kill_workers()  # a worker busy in a long task does not answer the close: its process is ended
        cluster.shutdown_on_close = False  # else Dask's atexit hook tries the close again, for 10 s, at exit
        raise
    client.close()
    cluster.close()


@contextmanager
def _sigint_ignored():
    """SIGINT ignored while inside (in the main thread): processes started meanwhile inherit the disposition across
    exec and Python keeps it, so a terminal's Ctrl-C, sent to the whole process group, does not print a
    KeyboardInterrupt traceback from every worker; the command that started them stops them."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _kill_workers() -> None:
    """End the local cluster's worker processes that are still alive (children of this process)."""
    import multiprocessing

    for child in multiprocessing.active_children():
        child.kill()
    for child in multiprocessing.active_children():
        child.join(timeout=0.5)


def _quietly(close: Callable, timeout: float) -> None:
    """``close(timeout=timeout)`` with Dask's loggers silenced and its errors ignored: after an interrupt the run
    is over, and what a closing cluster says about the tasks it drops is noise on the user's terminal."""
    loggers = [logging.getLogger(name) for name in ("distributed", "tornado", "asyncio")]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        close(timeout=timeout)
    except BaseException:  # noqa: BLE001 (a second Ctrl-C or a timeout while closing: the run is over either way)
        pass
    finally:
        for logger, level in zip(loggers, levels):
            logger.setLevel(level)


def finished_keys(table: pd.DataFrame, limits: Limits) -> set[str]:
    """Keys of stored rows that need no new run: every row, except those skipped for a limit that no longer
    holds (``over_budget`` with coils now within the budget; ``too_large`` with poles, lookup voxels and
    candidates now within the limits, counting what was not measured as within)."""
    if table.empty:
        return set()
    coils = table["coils"].astype("Float64").fillna(float("inf"))
    poles = table["rotor_poles"].astype("Float64")
    voxels = table["lookup_voxels"].astype("Float64").fillna(0.0)
    cands = table["candidates"].astype("Float64").fillna(0.0)
    rerun = ((table["status"] == "over_budget") & (coils <= limits.budget_coils)) | (
        (table["status"] == "too_large") & (poles <= limits.max_rotor_poles)
        & (voxels <= limits.max_lookup_voxels) & (cands <= limits.max_candidates))
    return set(table.loc[~rerun.fillna(False).astype(bool), "key"])


@dataclass
class SweepSummary:
    """What a run did: designs in the grid, already stored, evaluated now, and lost (keys and errors)."""

    total: int
    stored_before: int
    evaluated: int = 0
    lost: dict[str, str] = field(default_factory=dict)
    parts: list = field(default_factory=list)
    seconds: float = 0.0


def run_sweep(points: list[DesignPoint], store: ResultStore, client, limits: Limits = Limits(), *,
              batch_size: int = 32, flush_seconds: float = 15.0, retries: int = 2,
              on_start: Callable[[int, int], None] | None = None,
              on_result: Callable[[dict], None] | None = None) -> SweepSummary:
    """Evaluate the designs of ``points`` that ``store`` lacks on ``client``'s cluster; rows go to ``store``.

    Rows are written every ``batch_size`` results or ``flush_seconds``, whichever comes first, and once more
    at the end (also on an interrupt, before it propagates). ``on_start(total, todo)`` is called once before
    the first submission, ``on_result(row)`` once per completed design (on the calling thread).
    Larger rotors are submitted at higher priority, so the longest designs start first.
    """
    from distributed import as_completed

    batch_size = checks.count(batch_size, "batch_size", expected="a positive integer")
    retries = checks.count(retries, "retries", 0, expected="a non-negative integer")
    unique = list({p.key: p for p in points}.values())
    done = finished_keys(store.read(), limits)
    todo = [p for p in unique if p.key not in done]
    summary = SweepSummary(total=len(unique), stored_before=len(unique) - len(todo))
    if on_start is not None:
        on_start(summary.total, len(todo))
    start = time.perf_counter()
    futures = {client.submit(evaluate, p, limits, pure=False, retries=retries,
                             priority=len(named(p.rotor, p.rotor_level))): p for p in todo}
    pending: list[dict] = []
    last_flush = time.perf_counter()

    def flush():
        nonlocal pending, last_flush
        path = store.append(pending)
        if path is not None:
            summary.parts.append(path)
        summary.evaluated += len(pending)
        pending, last_flush = [], time.perf_counter()

    try:
        for future in as_completed(list(futures)):
            point = futures[future]
            if future.status != "finished":
                why = repr(future.exception()) if future.status == "error" else future.status
                summary.lost[point.key] = f"{point.label}: {why}"
                continue
            row = future.result()
            pending.append(row)
            future.release()
            if on_result is not None:
                on_result(row)
            if len(pending) >= batch_size or time.perf_counter() - last_flush >= flush_seconds:
                flush()
    finally:
        flush()
        unfinished = [f for f in futures if f.status == "pending"]
        if unfinished:
            client.cancel(unfinished)
        summary.seconds = time.perf_counter() - start
    return summary
