"""The ``ndbg`` command line: a thin layer over the library (:mod:`ndbg_cli.pipeline`).

Exit codes (:mod:`ndbg_cli.core.errors`): 0 ok, 1 a violation a gate asked about, 2 usage or
input error, 3 internal error, 130 interrupted.
"""

from __future__ import annotations

import atexit
import gc
import os
import sys
import threading
import traceback
from typing import NoReturn

import click

from ..core.errors import EXIT_INPUT, EXIT_INTERNAL, EXIT_OK, InputError, NdbgError
from ..core.files import ESCAPE
from ..core.stack import allow_deep_trees
from . import analyze, commands  # noqa: F401  (each registers its commands on the group)
from ._app import STATE, cli, fail


def _one_blas_thread() -> None:
    """One BLAS/OpenMP thread for this process and its workers, unless the caller chose.

    Every matrix ndbg hands to BLAS/LAPACK is tiny (6 x 6 systems, m x 6 SVDs): threads buy
    nothing there, and on a busy machine (a CI runner, ``--jobs N`` workers) their spinning
    made single SVDs many times slower. Set here, by the program that owns the process, and
    not on ``import ndbg_cli``, which must leave a library user's process alone; effective
    because the CLI has not imported numpy yet (workers inherit the environment)."""
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(var, "1")


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI, mapping exceptions to exit codes and one-line messages.

    stdout and stderr write what their encoding cannot (the undecodable bytes of a file name
    that is not UTF-8, kept by Python as lone surrogates) as ``\\xNN``, as the reports do
    (:data:`ndbg_cli.core.files.ESCAPE`): otherwise a text report or an error message naming
    such a file fails with UnicodeEncodeError (stdout's default is strict), or writes
    the raw byte (a C locale's surrogateescape), which is not UTF-8."""
    _one_blas_thread()
    allow_deep_trees()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors=ESCAPE)
        except (AttributeError, ValueError, OSError):  # replaced by a non-TextIOWrapper
            pass
    try:
        cli.main(args=argv, prog_name="ndbg", standalone_mode=False)
    except click.exceptions.Exit as exc:
        sys.exit(exc.exit_code)
    except click.ClickException as exc:
        exc.show()
        sys.exit(EXIT_INPUT)
    except click.exceptions.Abort:
        click.echo("ndbg: aborted", err=True)
        sys.exit(130)
    except InputError as exc:
        fail(exc.message, exc.exit_code)
    except NdbgError as exc:
        fail(exc.message, exc.exit_code)
    except SystemExit:
        raise
    except BrokenPipeError:
        sys.exit(EXIT_OK)
    except Exception as exc:
        if STATE.debug:
            traceback.print_exc()
        fail(f"internal error: {exc.__class__.__name__}: {exc} "
             "(run with --debug for a traceback)", EXIT_INTERNAL)



def run() -> NoReturn:
    """The ``ndbg`` program (``python -m ndbg_cli`` and the console script): :func:`main`, then
    :func:`end_process`. A library caller wanting ``SystemExit`` calls :func:`main`."""
    _collect_less()
    _no_cad_reader_here()
    try:
        main()
    except SystemExit as exc:
        end_process(exc.code)
    end_process(0)


#: The garbage collector's thresholds in the ``ndbg`` program (:func:`gc.set_threshold`;
#: Python's are 700, 10, 10).
GC_THRESHOLDS = (10_000, 10, 10)


def _collect_less() -> None:
    """Fewer garbage collections in the ``ndbg`` program: a young collection per
    :data:`GC_THRESHOLDS` allocations instead of Python's 700. ndbg allocates mostly
    acyclic numpy arrays and small tuples, freed by reference counting, so the collections
    find little; with Python's thresholds, the middle and full ones, which walk the
    libraries' and the model's hundreds of thousands of objects, cost 0.05 s of the bell's
    run and 0.17 s of the engine's (two full ones). Cycles are still collected, later. Set
    by the program that owns the process (its forked workers inherit it), not on ``import
    ndbg_cli``."""
    gc.set_threshold(*GC_THRESHOLDS)


def _no_cad_reader_here() -> None:
    """Keep OpenCASCADE (``cascadio``) out of the ``ndbg`` program's own process. ndbg reads
    STEP and IGES files only in its reader's child, a new interpreter
    (:mod:`ndbg_cli.io.isolated`), but ``import trimesh`` imports cascadio for trimesh's
    own STEP loader: 0.05-0.07 s of every run (and 0.14 s of C++ static destructors at exit,
    which :func:`end_process` skips already). ``None`` in ``sys.modules`` makes ``import
    cascadio`` fail here, as trimesh allows for (it then registers no STEP loader of its
    own). Set by the program that owns the process, not on ``import ndbg_cli``: a library
    user's process may read STEP files with trimesh."""
    sys.modules.setdefault("cascadio", None)


def end_process(code: int | str | None) -> NoReturn:
    """End the process as the interpreter ends it on ``sys.exit(code)`` (``None`` is 0; a
    message goes to stderr, then 1): non-daemon threads joined, the exit functions run, the
    streams flushed; but without its teardown of every module and object, which frees numba's
    compiled code one object at a time (0.3 s or more per run, longer than many analyses).
    Everything ndbg writes is closed before :func:`main` returns (reports are written
    atomically)."""
    if code is None:
        code = 0
    elif not isinstance(code, int):
        print(code, file=sys.stderr)
        code = 1
    try:
        threading._shutdown()  # type: ignore[attr-defined]  # what Py_FinalizeEx does first
        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):  # a closed pipe: nothing left to tell
                pass
    finally:
        os._exit(code & 0xFF)
