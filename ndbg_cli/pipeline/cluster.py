"""ndbg on a dask.distributed cluster (``ndbg analyze --scheduler``): reaching one
(:func:`connect`, :func:`disconnect`), and one assembly's per-pair work computed on it
(:class:`ClusterMapper`). ``distributed`` is imported here only, and only when a cluster is
asked for; the stages see a :class:`~ndbg_cli.core.pools.Mapper` and never know which one.
"""

from __future__ import annotations

import asyncio
import logging
import os
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..core.errors import InputError
from ..core.pools import Mapper

DASK_MISSING = "--scheduler needs dask.distributed: pip install 'ndbg-cli[dask]'"
#: Seconds to reach an existing scheduler (``$NDBG_SCHEDULER_TIMEOUT`` overrides).
CONNECT_TIMEOUT = 10.0


def connect_timeout() -> float:
    """:data:`CONNECT_TIMEOUT`, or ``$NDBG_SCHEDULER_TIMEOUT`` seconds when set to a positive
    number (a malformed value is ignored)."""
    try:
        value = float(os.environ.get("NDBG_SCHEDULER_TIMEOUT", ""))
    except ValueError:
        return CONNECT_TIMEOUT
    return value if value > 0 else CONNECT_TIMEOUT


def connect(address: str, workers: int, debug: bool = False) -> tuple[Any, Any]:
    """A ``distributed.Client`` of the cluster at ``address``, and the cluster started here
    (``None`` unless ``address`` is ``local``).

    ``address`` is ``tcp://HOST:PORT`` of a running scheduler, or ``local`` to start a
    :class:`distributed.LocalCluster` on loopback with ``workers`` single-threaded worker
    processes (until :func:`disconnect`). A missing ``distributed``, a malformed address or
    an unreachable scheduler raises :class:`InputError` (exit code 2)."""
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
            cluster = distributed.LocalCluster(
                n_workers=max(1, workers), threads_per_worker=1, processes=True,
                host="127.0.0.1", dashboard_address=None,
                # shutdown races (a worker's last heartbeat to a closed scheduler) are logged
                # as errors with tracebacks: not ours to show unless --debug
                silence_logs=logging.ERROR if debug else logging.CRITICAL + 1)
            client = distributed.Client(cluster, set_as_default=False)
        else:
            client = distributed.Client(address, timeout=connect_timeout(), set_as_default=False)
    except Exception as exc:
        if cluster is not None:
            cluster.close()
        where = "start a local dask cluster" if address == "local" else \
            f"reach the dask scheduler at {address}"
        raise InputError(f"cannot {where}: {exc.__class__.__name__}: {exc}") from None
    return client, cluster


def disconnect(client: Any, cluster: Any, debug: bool = False, pending: Sequence = ()) -> None:
    """Cancel the ``pending`` futures, close ``client`` and the ``cluster`` started here (if
    any); the shutdown's races are logged by ``distributed`` only with ``debug``."""
    quiet = None
    if cluster is not None and not debug:
        quiet = logging.getLogger("distributed")
        level = quiet.level
        quiet.setLevel(logging.CRITICAL + 1)
    try:
        if pending:
            client.cancel(list(pending))
        client.close()
    finally:
        if cluster is not None:
            cluster.close()
        if quiet is not None:
            quiet.setLevel(level)


def task_prefix(fn: Callable) -> str:
    """The name of the tasks computing ``fn`` on a cluster, what the dashboard and the task
    stream show: ``ndbg-`` and its name in words joined by ``-`` (``_pair_blocked_sets``:
    ``ndbg-pair-blocked-sets``; ``dask.utils.key_split`` keeps only such words)."""
    return "-".join(["ndbg", *fn.__name__.strip("_").split("_")])


#: Tasks a map is cut into per thread of the cluster's workers. Enough for the scheduler to even
#: out unequal items (dealt round-robin from the costliest, so each task holds a like mix),
#: few enough that dask's cost per task (milliseconds, more on a loaded machine) stays small
#: beside theirs: rack-296's 472 contact pairs took 12 s as 472 tasks on a loaded 2-core
#: machine, 3 to 4 s as 8 to 59 (benchmarks/NOTES.md, stop 42).
TASKS_PER_THREAD = 4


def deal(order: Sequence[int], tasks: int) -> list[list[int]]:
    """The items ``order`` lists dealt round-robin into ``tasks`` hands (at most one per
    item): hand ``j`` holds ``order[j::tasks]``."""
    tasks = min(max(1, tasks), len(order))
    return [list(order[j::tasks]) for j in range(tasks)]


def _hand(context: Any, job: tuple[Callable[[Any, Any], Any], list]) -> list:
    """One task of :class:`ClusterMapper`: ``job`` is ``(fn, items)``; their values in order."""
    fn, items = job
    return [fn(context, x) for x in items]


class ClusterMapper(Mapper):
    """:class:`~ndbg_cli.core.pools.Mapper` on a dask.distributed cluster, through ``client``.

    ``context`` is scattered once to every worker (each keeps one copy, which its tasks share:
    a cache in it is filled per worker); the items, in the order handed out, are dealt into
    :data:`TASKS_PER_THREAD` tasks per worker thread (:func:`deal`), ``fn`` pickled by name, so
    the workers must import this version of ndbg; the values are gathered here. Every item
    goes to the cluster, however ``small`` (a running cluster has no start-up to save). The
    items of a task that fails on the cluster (a worker died, the cluster lost it, ``fn``
    raised) are computed here: an error of ``fn``'s own is then raised here, as in a loop."""

    def __init__(self, client: Any) -> None:
        self.client = client

    def imap(self, fn: Callable[[Any, Any], Any], context: Any, items: Sequence,
             order: Sequence[int] | None = None, *, small: bool = False,
             meanwhile: Callable[[], Any] | None = None, drop: set[int] | None = None
             ) -> Iterator[tuple[int, Any]]:
        # ``drop`` is not used: the hands are dealt before any value is known
        order = list(range(len(items))) if order is None else list(order)
        if not order:
            if meanwhile is not None:
                meanwhile()
            return
        threads = sum(self.client.nthreads().values())
        hands = deal(order, TASKS_PER_THREAD * max(1, threads))
        # a list, so that a tuple context is one piece of data, not one per element
        [shared] = self.client.scatter([context], broadcast=True, hash=False)
        # the scheduler starts a map's tasks first come, first served; named after fn
        futures = self.client.map(_hand, [shared] * len(hands),
                                  [(fn, [items[k] for k in hand]) for hand in hands],
                                  key=task_prefix(fn), pure=False)
        try:
            if meanwhile is not None:
                meanwhile()
            for j, hand in enumerate(hands):
                future, futures[j] = futures[j], None
                try:
                    values = future.result()
                except (Exception, asyncio.CancelledError):  # failed there: computed here
                    values = [fn(context, items[k]) for k in hand]
                finally:
                    future.release()  # the cluster may forget it
                yield from zip(hand, values)
        finally:
            pending = [f for f in futures if f is not None]
            if pending:  # an error here, or the caller stopped: nothing left to compute
                self.client.cancel(pending)
            shared.release()
