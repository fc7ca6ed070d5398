"""Ending a process pool at once (Ctrl-C, SIGTERM, an error, a consumer that stops early):
:func:`end_pool`, shared by the batch (:mod:`ndbg_cli.pipeline.batch`) and one assembly's pair
workers (:mod:`ndbg_cli.ndbg.infinite.pair_workers`).
"""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor

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
