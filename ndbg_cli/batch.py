"""Batches of assemblies: worker processes, results in input order, clean interruption.

:func:`run_batch` analyses every target with ``jobs`` worker processes and yields the reports
(or error records) **in input order**, whatever order they complete in, so a JSON Lines stream
or a folder of reports is the same for ``--jobs 1`` and ``--jobs 8``. Each assembly is
analysed independently by the same pure function, so the reports are byte-identical too.

An internal error in one assembly becomes its error record (exit code 3); the others go on.
SIGTERM stops the batch: pending work is cancelled, the workers are ended, and since reports
are written atomically (:func:`ndbg_cli.report.write_atomic`) only complete files remain.
"""

from __future__ import annotations

import os
import signal
import traceback
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path

from .analysis import Options, analyze_path, error_record
from .errors import NdbgError


class Interrupted(Exception):
    """The batch was stopped by SIGTERM."""


def analyze_one(target: Path, options: Options, debug: bool = False) -> dict:
    """Analyse one target; never raises: a bug becomes an error record (exit code 3)."""
    try:
        return analyze_path(target, options)
    except Exception as exc:  # a bug: record it and let the batch go on
        if debug:
            traceback.print_exc()
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
    """Yield one report or error record per target, in the order of ``targets``."""
    if jobs <= 1 or len(targets) <= 1:
        for t in targets:
            yield analyze_one(t, options, debug)
        return
    previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    pool = ProcessPoolExecutor(max_workers=min(jobs, len(targets)), initializer=_worker_init)
    try:
        futures: list[Future] = [pool.submit(analyze_one, t, options, debug) for t in targets]
        for f in futures:
            yield f.result()
    finally:
        procs = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in procs:
            if proc.is_alive():
                proc.terminate()
        signal.signal(signal.SIGTERM, previous)
