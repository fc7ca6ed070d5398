"""Batches of assemblies: worker processes, results in input order, clean interruption.

:func:`run_batch` analyses every target with ``jobs`` worker processes and yields the reports
(or error records) **in input order**, whatever order they complete in, so a JSON Lines stream
or a folder of reports is the same for ``--jobs 1`` and ``--jobs 8``. Each assembly is
analysed independently by the same pure function, so the reports are byte-identical too.

An internal error in one assembly becomes its error record (exit code 3); the others go on.
SIGTERM stops the batch: pending work is cancelled, the workers are ended, and since reports
are written atomically (:func:`ndbg_cli.report.write_atomic`) only complete files remain.

:func:`run_batch_dask` does the same on a dask.distributed cluster (``ndbg analyze
--scheduler``): an existing one (``tcp://HOST:PORT``) or a local one started for the run
(``local``). It submits the same :func:`analyze_one`, so the reports are byte-identical to a
local run. ``distributed`` is imported only there (``pip install 'ndbg-cli[dask]'``).
"""

from __future__ import annotations

import asyncio
import dataclasses
import os
import signal
import traceback
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path

from .analysis import Options, analyze_path, error_record
from .errors import InputError, NdbgError
from .pools import end_pool


class Interrupted(Exception):
    """The batch was stopped by SIGTERM."""


def analyze_one(target: Path, options: Options, debug: bool = False) -> dict:
    """Analyse one target; never raises: a bug becomes an error record (exit code 3)."""
    try:
        return analyze_path(target, options)
    except Exception as exc:  # a bug: record it and let the batch go on
        if debug:
            traceback.print_exc()
        return _internal_error(target, exc)


def _internal_error(target: Path, exc: BaseException) -> dict:
    """The error record of an unexpected exception while analysing ``target``."""
    err = NdbgError(f"internal error: {exc.__class__.__name__}: {exc} "
                    "(run with --debug for a traceback)", file=str(target))
    return error_record(target, err)


def default_jobs() -> int:
    """Worker processes by default: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _raise_interrupted(signum, frame) -> None:
    raise Interrupted()


def _worker_init() -> None:
    """Workers die quietly on SIGTERM (the parent ends them) and leave Ctrl-C to it."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def run_batch(targets: list[Path], options: Options, jobs: int = 1, *,
              debug: bool = False) -> Iterator[dict]:
    """Yield one report or error record per target, in the order of ``targets``. A single
    target is analysed here, with ``jobs`` processes for its infinite-translation NDBG
    (``Options.workers``; same report)."""
    # one target: its pairs in ``jobs`` processes; several: one process each (never nested),
    # and the batch's own progress bar only
    one = len(targets) == 1
    options = dataclasses.replace(options, workers=jobs if one else 1,
                                  progress=options.progress and one)
    if jobs <= 1 or len(targets) <= 1:
        for t in targets:
            yield analyze_one(t, options, debug)
        return
    previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    pool = ProcessPoolExecutor(max_workers=min(jobs, len(targets)), initializer=_worker_init)
    done = False
    try:
        futures: list[Future] = [pool.submit(analyze_one, t, options, debug) for t in targets]
        for f in futures:
            yield f.result()
        done = True
    finally:
        try:
            if done:
                # every worker is idle: a waiting shutdown is quick, and it lets the pool's
                # manager thread finish before the interpreter's exit (ending the workers
                # under it once printed an OSError traceback from that thread at exit)
                pool.shutdown(wait=True)
            else:  # interrupted, or the consumer stopped early: end the workers now
                end_pool(pool)
        finally:  # a SIGTERM during the shutdown still leaves the caller's handler back
            signal.signal(signal.SIGTERM, previous)


DASK_MISSING = "--scheduler needs dask.distributed: pip install 'ndbg-cli[dask]'"
CONNECT_TIMEOUT = 10.0  # seconds to reach an existing scheduler


def run_batch_dask(targets: list[Path], options: Options, address: str, jobs: int = 1, *,
                   debug: bool = False) -> Iterator[dict]:
    """Like :func:`run_batch`, on a dask.distributed cluster; yields in the order of ``targets``.

    ``address`` is ``tcp://HOST:PORT`` of a running scheduler (its workers must see the input
    files at the same paths), or ``local`` to start a :class:`distributed.LocalCluster` on
    loopback with ``jobs`` single-threaded worker processes for the duration of the batch.

    Connects before returning: a missing ``distributed`` or an unreachable scheduler raises
    :class:`InputError` (exit code 2) here, not while iterating. A task that fails on the
    cluster (a worker died, a result could not be sent) becomes the error record
    :func:`analyze_one` would make (exit code 3); the other targets go on.
    """
    # dask workers are daemons (no pools) and their stderr is not ours
    options = dataclasses.replace(options, workers=1, progress=False)
    try:
        import distributed
    except ImportError:
        raise InputError(DASK_MISSING) from None
    if address != "local":
        from distributed.comm import get_address_host_port
        try:  # a malformed address would leave a half-made Client behind
            get_address_host_port(address)
        except ValueError as exc:
            raise InputError(f"--scheduler {address}: {exc} (give tcp://HOST:PORT or local)"
                             ) from None
    cluster = None
    try:
        if address == "local":
            import logging
            cluster = distributed.LocalCluster(
                n_workers=max(1, min(jobs, len(targets))), threads_per_worker=1,
                processes=True, host="127.0.0.1", dashboard_address=None,
                # shutdown races (a worker's last heartbeat to a closed scheduler) are logged
                # as errors with tracebacks: not ours to show unless --debug
                silence_logs=logging.ERROR if debug else logging.CRITICAL + 1)
            client = distributed.Client(cluster, set_as_default=False)
        else:
            client = distributed.Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except Exception as exc:
        if cluster is not None:
            cluster.close()
        where = "start a local dask cluster" if address == "local" else \
            f"reach the dask scheduler at {address}"
        raise InputError(f"cannot {where}: {exc.__class__.__name__}: {exc}") from None
    return _gather_in_order(client, cluster, targets, options, debug)


def _gather_in_order(client, cluster, targets: list[Path], options: Options,
                     debug: bool) -> Iterator[dict]:
    previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    futures: list = []
    try:
        futures = client.map(analyze_one, targets, options=options, debug=debug, pure=False)
        for k, target in enumerate(targets):
            future, futures[k] = futures[k], None  # let the cluster forget finished results
            try:
                result = future.result()
            except Interrupted:
                raise
            except (Exception, asyncio.CancelledError) as exc:  # the task failed on the cluster
                if debug:
                    traceback.print_exc()
                result = _internal_error(target, exc)
            future.release()
            yield result
    finally:
        signal.signal(signal.SIGTERM, previous)
        pending = [f for f in futures if f is not None]
        quiet = None
        if cluster is not None and not debug:
            import logging
            quiet = logging.getLogger("distributed")
            level = quiet.level
            quiet.setLevel(logging.CRITICAL + 1)
        try:
            if pending:
                client.cancel(pending)
            client.close()
        finally:
            if cluster is not None:
                cluster.close()
            if quiet is not None:
                quiet.setLevel(level)
