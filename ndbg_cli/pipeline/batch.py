"""Batches of assemblies: worker processes, results in input order, clean interruption.

:func:`run_batch` analyses every target with ``jobs`` worker processes and yields the reports
(or error records) **in input order**, whatever order they complete in; each assembly is
analysed independently by the same pure function, so a JSON Lines stream or a folder of
reports is byte-identical for ``--jobs 1`` and ``--jobs 8``. An internal error in one
assembly becomes its error record (exit code 3); the others go on. SIGTERM stops the batch:
pending work is cancelled, the workers are ended, and since reports are written atomically
(:func:`ndbg_cli.core.files.write_atomic`) only complete files remain. :func:`run_batch_dask`
does the same on a dask.distributed cluster (:mod:`ndbg_cli.pipeline.cluster`, the one module
that imports ``distributed``), where a single assembly's pair work is spread instead.
"""

from __future__ import annotations

import dataclasses
import multiprocessing
import os
import signal
import traceback
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from ..core.assembly import Assembly
from ..core.errors import NdbgError
from ..core.options import Options
from ..core.pools import end_pool
from .analysis import analyze_path, error_record


class Interrupted(Exception):
    """The batch was stopped by SIGTERM."""


def analyze_one(target: Path, options: Options, debug: bool = False,
                on_loaded: Callable[[Path, Assembly], None] | None = None) -> dict:
    """Analyse one target; never raises: a bug becomes an error record (exit code 3).
    ``on_loaded``: as for :func:`~ndbg_cli.pipeline.analysis.analyze_path`."""
    try:
        return analyze_path(target, options, on_loaded)
    except Exception as exc:  # a bug: record it and let the batch go on
        if debug:
            traceback.print_exc()
        return _internal_error(target, exc, options.root)


def _internal_error(target: Path, exc: BaseException, root: str | None) -> dict:
    """The error record of an unexpected exception while analysing ``target`` (paths
    relative to ``root``, as in a report)."""
    err = NdbgError(f"internal error: {exc.__class__.__name__}: {exc} "
                    "(run with --debug for a traceback)", file=str(target))
    return error_record(target, err, root)


def default_jobs() -> int:
    """Worker processes by default: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _raise_interrupted(signum, frame) -> None:
    raise Interrupted()


#: Pool restarts in a row that may end no assembly (a worker dying before it takes any, or
#: dying idle) before the remaining assemblies are given up as error records.
MAX_FRUITLESS_RESTARTS = 2

#: In a worker: the batch's shared array of the pid that took each target (0: not taken).
_TAKEN: list = []


def _worker_init(taken) -> None:
    """Workers die quietly on SIGTERM (the parent ends them) and leave Ctrl-C to it; they
    record in ``taken`` (shared, one slot per target) which target each of them takes."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _TAKEN[:] = [taken]


def _analyze_taken(k: int, target: Path, options: Options, debug: bool) -> dict:
    """In a worker: :func:`analyze_one`, after recording that this process took target ``k``
    (so that if it dies, the parent knows which assembly was under way in it)."""
    _TAKEN[0][k] = os.getpid()
    return analyze_one(target, options, debug)


def _worker_died(target: Path, exitcode: int | None, root: str | None) -> dict:
    """The error record (exit code 3) of an assembly whose worker process died under it
    (paths relative to ``root``, as in a report)."""
    if exitcode is not None and exitcode < 0:
        try:
            how = f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            how = f"killed by signal {-exitcode}"
        if exitcode == -signal.SIGKILL:
            how += ", out of memory?"
    else:
        how = f"exit code {exitcode}"
    err = NdbgError(f"internal error: the worker process analysing it died ({how}); the other "
                    "assemblies were analysed (run it alone, with --debug)", file=str(target))
    return error_record(target, err, root)


def _exitcodes(procs: dict | None) -> dict[int, int | None] | None:
    """``pid -> exit code`` of a pool's (ended) workers, or ``None`` if they are not known."""
    if procs is None:
        return None
    return {pid: p.exitcode for pid, p in list(procs.items())}


def run_batch(targets: list[Path], options: Options, jobs: int = 1, *,
              debug: bool = False,
              on_loaded: Callable[[Path, Assembly], None] | None = None) -> Iterator[dict]:
    """Yield one report or error record per target, in the order of ``targets``. A single
    target is analysed here, with ``jobs`` processes for its per-pair work (contacts, the
    infinite-translation NDBG; ``Options.workers``, or ``Options.mapper`` when given; same
    report).

    A worker process that dies (SIGKILL from the out-of-memory killer, a segfault in a
    native library) breaks its pool: the assembly it was analysing gets an error record
    (exit code 3), a new pool is started, and the assemblies the old one had not finished
    (including those under way in the workers it ended) are analysed again there.

    ``on_loaded(path, assembly)`` is called with each assembly loaded in this process (one
    target, or ``jobs`` 1), before its report is yielded; not for those of worker
    processes."""
    # one target: its pairs in ``jobs`` processes; several: one process each (never nested),
    # and the batch's own progress bar only
    one = len(targets) == 1
    options = dataclasses.replace(options, workers=jobs if one else 1,
                                  mapper=options.mapper if one else None,
                                  progress=options.progress and one)
    if jobs <= 1 or len(targets) <= 1:
        for t in targets:
            yield analyze_one(t, options, debug, on_loaded)
        return
    previous = signal.signal(signal.SIGTERM, _raise_interrupted)
    try:
        yield from _pooled(targets, options, min(jobs, len(targets)), debug)
    finally:  # a SIGTERM during the shutdown still leaves the caller's handler back
        signal.signal(signal.SIGTERM, previous)


def _pooled(targets: list[Path], options: Options, jobs: int, debug: bool) -> Iterator[dict]:
    """:func:`run_batch` with worker processes, restarting the pool when a worker dies."""
    taken = multiprocessing.RawArray("q", len(targets))  # pid that took target k, 0: none
    ready: dict[int, dict] = {}  # results known before their turn to be yielded
    k = 0  # the next target to yield
    fruitless = 0
    while k < len(targets):
        todo = [j for j in range(k, len(targets)) if j not in ready]
        if not todo:
            yield ready.pop(k)
            k += 1
            continue
        pool = ProcessPoolExecutor(max_workers=min(jobs, len(todo)), initializer=_worker_init,
                                   initargs=(taken,))
        # the dict of the pool's workers, kept (the pool drops it at shutdown) to read
        # their exit codes once a broken pool is ended; private, hence checked for
        procs = getattr(pool, "_processes", None)
        futures: dict[int, Future] = {}
        broken = False
        try:
            try:
                for j in todo:
                    taken[j] = 0
                    futures[j] = pool.submit(_analyze_taken, j, targets[j], options, debug)
            except BrokenProcessPool:
                broken = True
            while not broken and k < len(targets):
                if k not in ready:
                    try:
                        ready[k] = futures[k].result()
                    except BrokenProcessPool:
                        broken = True
                        break
                yield ready.pop(k)
                k += 1
        finally:
            if broken or k < len(targets):
                # a dead worker, an interruption, or the consumer stopping early: end the
                # workers now (so that the exit codes below are final)
                end_pool(pool)
            else:
                # every worker is idle: a waiting shutdown is quick, and it lets the pool's
                # manager thread finish before the interpreter's exit (ending the workers
                # under it once printed an OSError traceback from that thread at exit)
                pool.shutdown(wait=True)
        before = len(ready)
        _collect(futures, ready, taken, _exitcodes(procs), targets, options.root)
        fruitless = 0 if len(ready) > before else fruitless + 1
        if fruitless > MAX_FRUITLESS_RESTARTS:  # workers die before doing anything
            for j in range(k, len(targets)):
                ready.setdefault(j, _worker_died(targets[j], None, options.root))


def _collect(futures: dict[int, Future], ready: dict[int, dict], taken,
             exitcodes: dict[int, int | None] | None, targets: list[Path],
             root: str | None = None) -> None:
    """After a broken pool was ended: into ``ready``, the results it completed, and an error
    record for each target that was under way in a worker that died by itself (not ended
    by SIGTERM from the pool or :func:`~ndbg_cli.core.pools.end_pool`). The other targets are
    left to the next pool. Without the workers' exit codes, every target under way is
    taken to be the culprit (each restart then ends at least one)."""
    ended = (0, -signal.SIGTERM, None)
    for j, f in futures.items():
        if f.done() and not f.cancelled() and f.exception() is None:
            ready[j] = f.result()
            continue
        pid = taken[j]
        if pid == 0:
            continue  # not started: the next pool takes it
        code = exitcodes.get(pid) if exitcodes is not None else None
        if exitcodes is None or code not in ended:
            ready[j] = _worker_died(targets[j], code, root)


def run_batch_dask(targets: list[Path], options: Options, address: str, jobs: int = 1, *,
                   debug: bool = False,
                   on_loaded: Callable[[Path, Assembly], None] | None = None) -> Iterator[dict]:
    """Like :func:`run_batch`, on a dask.distributed cluster (``ndbg analyze --scheduler``);
    yields in the order of ``targets``; the reports are byte-identical to a local run
    (``pip install 'ndbg-cli[dask]'``).

    Several targets: each is one task, the same :func:`analyze_one` on a worker. A single
    target is analysed here, as by :func:`run_batch`, and its per-pair work (contacts, the
    infinite-translation NDBG's blocked sets) is computed on the cluster
    (:class:`~ndbg_cli.pipeline.cluster.ClusterMapper`); ``jobs`` threads and forks here the
    rest, and ``on_loaded`` is called as by :func:`run_batch`.

    ``address`` is ``tcp://HOST:PORT`` of a running scheduler (its workers must see the input
    files at the same paths, and import this version of ndbg), or ``local`` to start a
    :class:`distributed.LocalCluster` on loopback with ``jobs`` single-threaded worker
    processes (at most one per target in a batch) for the duration of the run.

    Connects before returning: a missing ``distributed`` or an unreachable scheduler raises
    :class:`InputError` (exit code 2) here, not while iterating. A task that fails on the
    cluster (a worker died, a result could not be sent) becomes the error record
    :func:`analyze_one` would make (exit code 3); the other targets go on.
    """
    from .cluster import ClusterMapper, connect

    one = len(targets) == 1
    client, cluster = connect(address, jobs if one else min(jobs, len(targets)), debug)
    if one:
        options = dataclasses.replace(options, workers=jobs, mapper=ClusterMapper(client))
        return _one_here(client, cluster, targets[0], options, debug, on_loaded)
    # dask workers are daemons (no pools) and their stderr is not ours
    options = dataclasses.replace(options, workers=1, mapper=None, progress=False)
    return _gather_in_order(client, cluster, targets, options, debug)


def _one_here(client, cluster, target: Path, options: Options, debug: bool,
              on_loaded: Callable[[Path, Assembly], None] | None) -> Iterator[dict]:
    """:func:`run_batch_dask`'s single target, analysed in this process (its pair work on the
    cluster); the client and the cluster are closed once it is done or abandoned."""
    from .cluster import disconnect

    try:
        yield analyze_one(target, options, debug, on_loaded)
    finally:
        disconnect(client, cluster, debug)


def _gather_in_order(client, cluster, targets: list[Path], options: Options,
                     debug: bool) -> Iterator[dict]:
    import asyncio  # here: a cluster's run only (its import costs 20 ms on every run)

    from .cluster import disconnect

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
                result = _internal_error(target, exc, options.root)
            future.release()
            yield result
    finally:
        signal.signal(signal.SIGTERM, previous)
        disconnect(client, cluster, debug, [f for f in futures if f is not None])
