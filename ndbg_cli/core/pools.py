"""Process pools: ending one at once (Ctrl-C, SIGTERM, an error, a consumer that stops early),
:func:`end_pool`, shared by the batch (:mod:`ndbg_cli.pipeline.batch`) and :class:`ForkMapper`;
one function run beside the caller in a forked process (:class:`Forked`); a forked process
computing batches of items beside the caller (:class:`Helper`); and where one
assembly's per-pair work runs (:class:`Mapper`: :class:`ForkMapper`, forked processes on this
machine, or :class:`ndbg_cli.pipeline.cluster.ClusterMapper`, a dask.distributed cluster).
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import signal
import threading
import time
import weakref
from abc import ABC, abstractmethod
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

#: Seconds to wait for a terminated worker before killing it.
JOIN_S = 5.0
#: Seconds between a :class:`ForkMapper` worker's checks that its parent is alive.
ORPHAN_POLL = 0.5


@contextlib.contextmanager
def frozen_heap() -> Iterator[None]:
    """Fork inside this: the objects this process holds are frozen out of the garbage
    collector's reach (:func:`gc.freeze`) for the fork, and given back to it here after.

    A forked child shares its parent's memory page by page until either writes to a page.
    A full collection in the child walks every object the parent made (the loaded model,
    trimesh, scipy: hundreds of thousands), writing to each one's header, so the child
    copies most of the parent's heap, and spends the walk's time, on work that frees
    nothing of the parent's. Frozen, they are never walked in the child (Python's advice
    for ``fork`` without ``exec``). The parent's collector has them back at once, all in its
    oldest generation (a young reference cycle of the parent's is then freed by its next full
    collection, not by a young one). About 0.05-0.1 s of a two-core run of the bell, the beam
    or AS1, in system time and in the workers' start. A process that froze objects of its
    own (a preforking server) keeps its freeze: nothing is frozen or given back then."""
    if gc.get_freeze_count():
        yield
        return
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


def end_pool(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` now: its workers ended, its pending calls failed, its thread joined.

    The order matters:

    1. the workers are terminated (then killed if still alive after :data:`JOIN_S`), so no
       work under way is waited for;
    2. the pool's result pipe is closed on our side: a worker killed while writing a result
       larger than the pipe's buffer leaves the pool's manager thread blocked in a read that
       would never end (the parent holds the pipe's writing end); that read now gets
       end-of-file and the manager cleans up as for a broken pool;
    3. the pool is shut down, waiting for its manager thread: left running, that thread raced
       with the interpreter's exit and printed a traceback from it.

    Steps 1 and 2 rely on two private attributes of :class:`ProcessPoolExecutor`
    (``_processes``, ``_result_queue``), checked for; without them only step 3 is done."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=JOIN_S)
        if proc.is_alive():
            proc.kill()
            proc.join(timeout=JOIN_S)
    writer = getattr(getattr(pool, "_result_queue", None), "_writer", None)
    if writer is not None:
        try:
            writer.close()
        except OSError:
            pass
    pool.shutdown(wait=True, cancel_futures=True)


class Forked:
    """``fn(*args)`` computed in a forked child process while the caller goes on; its value
    by :meth:`result`.

    For a pure function of data the caller already holds (the child sees it through fork's
    copy-on-write, nothing is pickled on the way in): the value is the same as calling
    ``fn`` here, which is what :meth:`result` does when no child could be started (no
    ``fork``, a daemonic process, ``enabled`` false) or the child died or failed. Only the
    value travels back, pickled; ``seconds`` is the child's own time for it.

    With ``later``, ``fn`` is called as ``fn(*args, get)``: the child starts at once on what
    it can do with ``args``, and ``get()`` waits for the one value the caller gives later by
    :meth:`send` (pickled on its way; ``EOFError`` in the child when the caller dropped the
    job without sending, which ends the child).

    As a context manager, the job is dropped (:meth:`cancel`) at the end of the ``with``
    block unless its value was taken there: a block that raises, or no longer needs the
    value, does not leave a child working or waiting.

    >>> job = Forked(lambda x, get: x + get(), 1, later=True)
    >>> job.send(2)
    >>> job.result()
    3
    """

    _UNSENT = object()

    def __init__(self, fn: Callable[..., Any], *args: Any, enabled: bool = True,
                 later: bool = False) -> None:
        self._fn, self._args, self._later = fn, args, later
        self._proc = self._input = None
        self._sent: Any = self._UNSENT
        self.seconds = 0.0
        if not enabled:
            return
        try:
            ctx = multiprocessing.get_context("fork")
            self._recv, send = ctx.Pipe(duplex=False)
            get = None
            if later:
                get, self._input = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_forked_child, daemon=True, args=(
                send, fn, args, get, (self._recv, self._input)))
            with frozen_heap():
                self._proc.start()
            send.close()
            if get is not None:
                get.close()
            _RUNNING.add(self)
        except (OSError, ValueError, AssertionError):  # no fork here, or a daemonic process
            self._proc = self._input = None

    def busy(self) -> bool:
        """Whether a child works on the job (or waits for its input): it has not sent its
        value yet."""
        return self._proc is not None and not self._recv.poll()

    def send(self, value: Any) -> None:
        """Give the child the value its ``get()`` waits for (once; ``later`` jobs only)."""
        if not self._later or self._sent is not self._UNSENT:
            raise RuntimeError("send() is for a job made with later=True, once")
        self._sent = value
        if self._input is not None:
            try:
                self._input.send(value)
            except (OSError, ValueError):  # the child is gone: result() computes it here
                pass
            finally:
                self._input.close()
                self._input = None

    def result(self) -> Any:
        """The value of ``fn(*args)``: the child's, else computed here."""
        _RUNNING.discard(self)
        if self._proc is not None:
            proc, self._proc = self._proc, None
            try:
                ok, value, seconds = self._recv.recv()
            except (EOFError, OSError):  # the child died (killed, out of memory)
                ok = False
            finally:
                self._recv.close()
                _reap(proc)
            if ok:
                self.seconds = seconds
                return value
        t0 = time.perf_counter()
        value = self._fn(*self._args, self._given) if self._later else self._fn(*self._args)
        self.seconds = time.perf_counter() - t0
        return value

    def cancel(self) -> None:
        """Drop the job: its child ended now (a ``later`` child waiting for its input first
        reads end of file), nothing computed here."""
        _RUNNING.discard(self)
        if self._input is not None:
            self._input.close()
            self._input = None
        if self._proc is not None:
            proc, self._proc = self._proc, None
            self._recv.close()
            _reap(proc, terminate=True)

    def __enter__(self) -> Forked:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.cancel()  # nothing left to drop once the value was taken

    def _given(self) -> Any:
        if self._sent is self._UNSENT:
            raise RuntimeError("the job's input was never sent")
        return self._sent


def _reap(proc: Any, terminate: bool = False) -> None:
    """Wait for the child ``proc`` to end (terminated first with ``terminate``), killed when
    still alive after :data:`JOIN_S`."""
    if terminate:
        proc.terminate()
    proc.join(timeout=JOIN_S)
    if proc.is_alive():
        proc.kill()
        proc.join()


#: This process's :class:`Forked` jobs with a child, until their value is taken.
_RUNNING: weakref.WeakSet = weakref.WeakSet()


def spare_workers(workers: int) -> int:
    """How many processes beside this one are free for more work, of ``workers`` in all:
    ``workers - 1`` less this process's :class:`Forked` jobs whose child still works (so
    that a :class:`Helper` does not make three busy processes on two cores). Work this
    process must wait for anyway may be forked regardless
    (:func:`ndbg_cli.pipeline.proofs.cross_check`'s exact check)."""
    return workers - 1 - sum(1 for job in list(_RUNNING) if job.busy())


def _forked_child(send: Any, fn: Callable[..., Any], args: tuple, get: Any = None,
                  parent_ends: tuple = ()) -> None:
    """:class:`Forked`'s child: ``(True, value, seconds)`` sent back, or ``(False, None, 0)``
    when ``fn`` raised (the parent then calls it itself, and sees the error there);
    ``seconds`` leaves out the wait for a ``later`` job's input. ``get``: the reading end of
    that input. ``parent_ends``: the parent's ends of the pipes, inherited through fork and
    closed here, so that the parent's dropping the job reads as end of file here (its input)
    and as a broken pipe (the result), never as a wait without end."""
    t0 = time.perf_counter()
    for end in parent_ends:
        if end is not None:
            end.close()
    reader = _reader(get) if get is not None else None
    try:
        value = fn(*args, reader) if reader is not None else fn(*args)
        got = (True, value, time.perf_counter() - t0 - getattr(reader, "waited", 0.0))
    except BaseException:  # noqa: BLE001 (re-raised in the parent by its own call)
        got = (False, None, 0.0)
    _answer(send, got, (False, None, 0.0))
    send.close()


def _answer(conn: Any, value: Any, failed: Any) -> bool:
    """A child's answer to its parent: ``value`` sent on ``conn``, or ``failed`` when
    ``value`` does not pickle (the parent then computes it itself); False when nobody reads
    (the parent dropped the job, or is gone)."""
    for got in (value, failed):
        try:
            conn.send(got)
            return True
        except OSError:
            return False
        except Exception:  # noqa: BLE001 (a value that does not pickle)
            continue
    return True


def _reader(conn: Any) -> Callable[[], Any]:
    """``get()`` of a ``later`` job's child: the value is read from ``conn`` by a thread from
    the start, so that the parent's :meth:`Forked.send` of a value larger than the pipe's
    buffer returns at once instead of waiting for the child to ask (``get.waited``: the
    seconds the child then waited for it)."""
    box: list = []

    def read() -> None:
        try:
            box.append((True, conn.recv()))
        except BaseException as exc:  # noqa: BLE001 (EOFError: the parent dropped the job)
            box.append((False, exc))

    thread = threading.Thread(target=read, daemon=True)
    thread.start()

    def get() -> Any:
        t0 = time.perf_counter()
        thread.join()
        get.waited = time.perf_counter() - t0  # type: ignore[attr-defined]
        ok, value = box[0]
        if not ok:
            raise value
        return value

    return get


class Helper:
    """One forked process computing ``fn(context, item)`` for the batches of items the caller
    hands it (:meth:`start`) while the caller computes others; :meth:`values` gives a
    batch's values, in order. As for :class:`Forked`, ``fn`` and ``context`` reach the child
    through fork; the items and the values travel pickled. Where no child could be started
    (no ``fork``, a daemonic process), or it died or ``fn`` raised there, :meth:`values`
    computes the batch here: the values are always those of a loop here. :meth:`close` (or
    the end of a ``with`` block) ends the child.

    >>> with Helper(lambda c, x: c * x, 10) as h:
    ...     h.start([1, 2])
    ...     h.values()
    [10, 20]
    """

    def __init__(self, fn: Callable[[Any, Any], Any], context: Any) -> None:
        self._fn, self._context = fn, context
        self._batch: list | None = None
        self._proc = None
        try:
            ctx = multiprocessing.get_context("fork")
            self._conn, child = ctx.Pipe(duplex=True)
            self._proc = ctx.Process(target=_helper_child, daemon=True,
                                     args=(child, self._conn, fn, context))
            with frozen_heap():
                self._proc.start()
            child.close()
        except (OSError, ValueError, AssertionError):  # no fork here, or a daemonic process
            self._proc = None

    def start(self, items: list) -> None:
        """Hand the child ``items`` (the previous batch's values must have been taken)."""
        if self._batch is not None:
            raise RuntimeError("values() of the previous batch first")
        self._batch = list(items)
        if self._proc is not None:
            try:
                self._conn.send(self._batch)
            except Exception:  # noqa: BLE001 (the child is gone, or the items do not
                self.close()    # pickle: values() computes them here)

    def values(self) -> list:
        """The values of the batch given to :meth:`start`: the child's, else computed here."""
        batch, self._batch = self._batch, None
        if batch is None:
            raise RuntimeError("start() a batch first")
        if self._proc is not None:
            try:
                ok, got = self._conn.recv()
                if ok:
                    return got
            except (EOFError, OSError):  # the child died (killed, out of memory)
                self.close()
        return [self._fn(self._context, x) for x in batch]

    def share(self, items: list) -> list:
        """``[fn(context, x) for x in items]``, every other item (the second, the fourth...)
        computed in the child while this process computes the others.

        >>> with Helper(lambda c, x: c + x, 1) as h:
        ...     h.share([1, 2, 3])
        [2, 3, 4]
        """
        if len(items) < 2:
            return [self._fn(self._context, x) for x in items]
        out: list = [None] * len(items)
        self.start(items[1::2])
        out[::2] = [self._fn(self._context, x) for x in items[::2]]
        out[1::2] = self.values()
        return out

    def close(self) -> None:
        """End the child: it reads end of file when idle; with a batch under way (the caller
        left before its values), it is terminated (killed after :data:`JOIN_S`)."""
        if self._proc is not None:
            proc, self._proc = self._proc, None
            self._conn.close()
            _reap(proc, terminate=self._batch is not None)

    def __enter__(self) -> Helper:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


def _helper_child(conn: Any, parent_end: Any, fn: Callable[[Any, Any], Any],
                  context: Any) -> None:
    """:class:`Helper`'s child: each batch received gets ``(True, values)`` back, or
    ``(False, None)`` when ``fn`` raised (the parent then computes the batch itself); ends
    at end of file. Ctrl-C is left to the parent (which then ends it)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent_end.close()
    while True:
        try:
            batch = conn.recv()
        except (EOFError, OSError):
            break
        try:
            got = (True, [fn(context, x) for x in batch])
        except BaseException:  # noqa: BLE001 (re-raised in the parent by its own call)
            got = (False, None)
        if not _answer(conn, got, (False, None)):
            break
    conn.close()


class Mapper(ABC):
    """Where one assembly's per-pair work runs: ``fn(context, item)`` for each item.

    ``fn`` is a pure function of its arguments defined at a module's top level (a cluster's
    workers unpickle it by name); ``context`` is what every item needs (the parts' geometry,
    the tolerances), sent once to each worker; ``items`` are small (part pairs). Whichever
    implementation computes them, the values are those of a loop in this process, so no
    report depends on it: :class:`ForkMapper` (forked processes here, the default) or
    :class:`ndbg_cli.pipeline.cluster.ClusterMapper` (a dask.distributed cluster). The stages
    receive one and do not know which. A cache in ``context`` (filled by ``fn``) is filled
    per process: each worker has its own copy."""

    @abstractmethod
    def imap(self, fn: Callable[[Any, Any], Any], context: Any, items: Sequence,
             order: Sequence[int] | None = None, *, small: bool = False,
             meanwhile: Callable[[], Any] | None = None, drop: set[int] | None = None
             ) -> Iterator[tuple[int, Any]]:
        """``(k, fn(context, items[k]))`` for every ``k``, each as soon as it is known.

        Parameters
        ----------
        fn, context, items
            As in the class's description.
        order : sequence of int, optional
            The order in which the items are handed out (e.g. the costliest first, so that no
            worker is left with a long one at the end); the values may come in that order.
        small : bool
            The caller's estimate that the work is too small to pay for starting processes: a
            pool that would start them computes it in this process instead.
        meanwhile : callable, optional
            Called here once while the workers compute (work this process needs later, e.g.
            loading compiled kernels), or first when there are none.
        drop : set of int, optional
            Items the caller no longer wants, which it may add to while it reads the values
            (e.g. once some values tell it): an item not yet started then is not computed
            and not yielded. A mapper may still compute and yield it: the caller must
            accept both.

        Yields
        ------
        tuple of (int, object)
            ``k`` and ``fn(context, items[k])``. An exception ``fn`` raises is raised here,
            as in a loop; an item whose worker failed otherwise (it died, the cluster lost
            it) is computed here.
        """

    def map(self, fn: Callable[[Any, Any], Any], context: Any, items: Sequence,
            order: Sequence[int] | None = None, *, small: bool = False,
            meanwhile: Callable[[], Any] | None = None) -> list:
        """``[fn(context, x) for x in items]``, computed by :meth:`imap` (same parameters)."""
        out: list = [None] * len(items)
        for k, value in self.imap(fn, context, items, order, small=small, meanwhile=meanwhile):
            out[k] = value
        return out


@dataclass(frozen=True)
class ForkMapper(Mapper):
    """:class:`Mapper` over up to ``workers`` forked processes of this machine; ``workers`` 1
    (:data:`IN_PROCESS`), or work the caller calls ``small``, is computed in this process, in
    index order, and so is everything where this process cannot fork (no ``fork``, a daemonic
    pool worker).

    ``fn``, ``context`` and ``items`` reach the workers through fork (nothing but an index is
    pickled on the way in; only the values come back pickled). The workers leave Ctrl-C to
    the parent, which then ends them at once, and exit by themselves within
    :data:`ORPHAN_POLL` seconds when their parent has died (SIGTERM, SIGKILL); if one dies
    (out of memory, say), the items not yet done are computed here."""

    workers: int = 1

    def imap(self, fn: Callable[[Any, Any], Any], context: Any, items: Sequence,
             order: Sequence[int] | None = None, *, small: bool = False,
             meanwhile: Callable[[], Any] | None = None, drop: set[int] | None = None
             ) -> Iterator[tuple[int, Any]]:
        n = len(items)
        drop = set() if drop is None else drop
        ctx = None if small or self.workers <= 1 or n <= 1 else _fork_context()
        if ctx is None:
            if meanwhile is not None:
                meanwhile()
            for k in range(n):
                if k not in drop:
                    yield k, fn(context, items[k])
            return
        order = list(range(n)) if order is None else list(order)
        pool = ProcessPoolExecutor(max_workers=min(self.workers, n), mp_context=ctx,
                                   initializer=_fork_init,
                                   initargs=((fn, context, items), os.getpid()))
        futures: dict = {}
        done: set[int] = set()  # yielded, or dropped before a worker took it
        dropped = 0
        try:
            try:
                with frozen_heap():  # the first submit forks every worker
                    futures = {k: pool.submit(_fork_call, k) for k in order}
                if meanwhile is not None:
                    meanwhile()
                for k in order:
                    if len(drop) > dropped:  # not started yet: not started at all
                        dropped = len(drop)
                        for j in drop:
                            if j not in done and j in futures and futures[j].cancel():
                                done.add(j)
                    if k in done:
                        continue
                    value = futures[k].result()
                    done.add(k)
                    yield k, value
            except BrokenProcessPool:  # a worker died: its values known so far, the rest here
                for k in order:
                    if k not in done and k not in drop:
                        f = futures.get(k)
                        ok = (f is not None and f.done() and not f.cancelled()
                              and f.exception() is None)
                        value = f.result() if ok else fn(context, items[k])
                        done.add(k)
                        yield k, value
        finally:
            # normal end: the workers are idle; else (Ctrl-C, an error, the caller stopping)
            # they are ended now rather than after the items under way
            if len(done) < n:
                end_pool(pool)
            else:
                pool.shutdown(wait=True)


#: Computes every item in this process (:class:`ForkMapper` with one worker).
IN_PROCESS = ForkMapper(1)


def _fork_context() -> Any:
    """The ``fork`` multiprocessing context, or ``None`` where this process cannot start
    workers by fork (no ``fork`` here, or a daemonic process: a batch's pool worker)."""
    if multiprocessing.current_process().daemon:
        return None
    try:
        return multiprocessing.get_context("fork")
    except ValueError:  # no fork here
        return None


#: In a :class:`ForkMapper` worker: ``(fn, context, items)``, set by :func:`_fork_init`.
_FORK_JOB: list = []


def _fork_init(job: tuple, parent: int) -> None:
    """A :class:`ForkMapper` worker's start: ``job`` (inherited through fork, not pickled)
    kept for :func:`_fork_call`; Ctrl-C left to the parent, SIGTERM fatal, and an exit of its
    own once the parent is gone."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True).start()
    _FORK_JOB[:] = [job]


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(ORPHAN_POLL)
        if os.getppid() != parent:
            os._exit(1)


def _fork_call(k: int) -> Any:
    fn, context, items = _FORK_JOB[0]
    return fn(context, items[k])
