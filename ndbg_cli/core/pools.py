"""Ending a process pool at once (Ctrl-C, SIGTERM, an error, a consumer that stops early):
:func:`end_pool`, shared by the batch (:mod:`ndbg_cli.pipeline.batch`) and one assembly's pair
workers (:mod:`ndbg_cli.ndbg.infinite.pair_workers`); and one function run beside the caller
in a forked process (:class:`Forked`), or over a list in forked workers (:func:`fork_map`).
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

#: Seconds to wait for a terminated worker before killing it.
JOIN_S = 5.0


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
    value travels back, pickled; ``seconds`` is the child's own time for it."""

    def __init__(self, fn: Callable[..., Any], *args: Any, enabled: bool = True) -> None:
        self._fn, self._args = fn, args
        self._proc = None
        self.seconds = 0.0
        if not enabled:
            return
        try:
            ctx = multiprocessing.get_context("fork")
            self._recv, send = ctx.Pipe(duplex=False)
            self._proc = ctx.Process(target=_forked_child, args=(send, fn, args), daemon=True)
            self._proc.start()
            send.close()
        except (OSError, ValueError, AssertionError):  # no fork here, or a daemonic process
            self._proc = None

    def result(self) -> Any:
        """The value of ``fn(*args)``: the child's, else computed here."""
        if self._proc is not None:
            proc, self._proc = self._proc, None
            try:
                ok, value, seconds = self._recv.recv()
            except (EOFError, OSError):  # the child died (killed, out of memory)
                ok = False
            finally:
                self._recv.close()
                proc.join(timeout=JOIN_S)
                if proc.is_alive():
                    proc.kill()
                    proc.join()
            if ok:
                self.seconds = seconds
                return value
        t0 = time.perf_counter()
        value = self._fn(*self._args)
        self.seconds = time.perf_counter() - t0
        return value


def _forked_child(send: Any, fn: Callable[..., Any], args: tuple) -> None:
    """:class:`Forked`'s child: ``(True, value, seconds)`` sent back, or ``(False, None, 0)``
    when ``fn`` raised (the parent then calls it itself, and sees the error there)."""
    t0 = time.perf_counter()
    try:
        got = (True, fn(*args), time.perf_counter() - t0)
    except BaseException:  # noqa: BLE001 (re-raised in the parent by its own call)
        got = (False, None, 0.0)
    try:
        send.send(got)
    except Exception:  # noqa: BLE001 (a value that does not pickle: the parent computes it)
        send.send((False, None, 0.0))
    send.close()


#: What :func:`fork_map`'s workers compute (set before they are forked, read by
#: :func:`_fork_call`: nothing but an index is pickled on the way in).
_FORK_JOB: tuple | None = None


def fork_map(fn: Callable[[Any], Any], items: list, workers: int,
             order: list[int] | None = None,
             meanwhile: Callable[[], Any] | None = None) -> list:
    """``[fn(x) for x in items]``, computed by up to ``workers`` forked processes when
    ``workers`` > 1 (each takes the next item when done: ``order``, e.g. the costliest first,
    is the order they are handed out). ``fn`` and ``items`` reach the workers through fork;
    only the results are pickled. In this process instead when it cannot fork (no ``fork``,
    a daemonic process), and for what is left when a worker dies. An exception ``fn`` raises
    is raised here, as in a loop. ``meanwhile``: called here while the workers compute (work
    this process needs later, e.g. loading compiled kernels), or first without workers."""
    global _FORK_JOB
    n = len(items)
    ctx = None
    if workers > 1 and n > 1 and not multiprocessing.current_process().daemon:
        try:
            ctx = multiprocessing.get_context("fork")
        except ValueError:  # no fork here
            pass
    if ctx is None:
        if meanwhile is not None:
            meanwhile()
        return [fn(x) for x in items]
    _FORK_JOB = (fn, items)
    pool = ProcessPoolExecutor(max_workers=min(workers, n), mp_context=ctx)
    done = False
    futures: dict = {}
    try:
        futures = {k: pool.submit(_fork_call, k) for k in (order or range(n))}
        if meanwhile is not None:
            meanwhile()
        out = [futures[k].result() for k in range(n)]
        done = True
    except BrokenProcessPool:  # a worker died (out of memory, killed): the rest here
        out = [futures[k].result() if k in futures and futures[k].done()
               and not futures[k].exception() else fn(items[k]) for k in range(n)]
    finally:
        _FORK_JOB = None
        if done:
            pool.shutdown(wait=True)
        else:
            end_pool(pool)
    return out


def _fork_call(k: int) -> Any:
    fn, items = _FORK_JOB
    return fn(items[k])
