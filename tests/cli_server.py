"""A fork server for the tests' CLI runs (:func:`helpers.run_cli`).

Every ``ndbg`` process pays about 2 s before it reads its input: the interpreter, numpy,
scipy, trimesh, and the compiled kernels loaded from numba's cache. The suite starts about 150
of them. This server imports all of that once and warms the kernels on one small analysis;
then, for each request, it forks a child that runs ``python -m ndbg_cli ARGS`` from there: a
separate process with its own working folder, environment, standard streams and exit code,
which runs the real CLI to its normal interpreter exit. Only the start-up is shared.

The server is single-threaded when it forks (checked before each fork; it answers "spawn"
otherwise, and the caller starts a plain subprocess). Protocol on stdin/stdout, each message
pickled behind its length: a request ``(args, cwd, env, stdin_bytes, timeout, umask)``, an
answer ``(returncode, stdout_bytes, stderr_bytes)`` or ``None`` (spawn instead).
"""

from __future__ import annotations

import os
import pickle
import shutil
import struct
import sys
import tempfile
import threading


def _read(stream) -> object | None:
    head = stream.read(4)
    if len(head) < 4:
        return None
    (size,) = struct.unpack("!I", head)
    return pickle.loads(stream.read(size))


def _write(stream, obj: object) -> None:
    data = pickle.dumps(obj)
    stream.write(struct.pack("!I", len(data)) + data)
    stream.flush()


def _warm(root: str) -> None:
    """Import the stages and load the compiled kernels (one small analysis, one process)."""
    import ndbg_cli
    import ndbg_cli.cli.main  # noqa: F401
    from ndbg_cli.core.options import Options

    asm = ndbg_cli.load(os.path.join(root, "assemblies", "bolt-plain.yaml"))
    ndbg_cli.analyze(asm, Options(cache=None))


def _child(args: list[str], cwd: str, env: dict, stdin: bytes, folder: str,
           timeout: float, umask: int) -> None:
    """In the forked child: become ``python -m ndbg_cli ARGS`` (never returns)."""
    import io
    import runpy
    import signal

    os.chdir(cwd)
    os.umask(umask)
    os.environ.clear()
    os.environ.update(env)
    with open(os.path.join(folder, "in"), "wb") as fh:
        fh.write(stdin)
    for fd, name, flags in ((0, "in", os.O_RDONLY), (1, "out", os.O_WRONLY | os.O_CREAT),
                            (2, "err", os.O_WRONLY | os.O_CREAT)):
        f = os.open(os.path.join(folder, name), flags, 0o600)
        os.dup2(f, fd)
        os.close(f)
    enc, errs = sys.__stdout__.encoding, sys.__stdout__.errors
    sys.stdin = io.TextIOWrapper(io.FileIO(0, "r", closefd=False), encoding=enc, errors=errs)
    sys.stdout = io.TextIOWrapper(io.FileIO(1, "w", closefd=False), encoding=enc, errors=errs)
    sys.stderr = io.TextIOWrapper(io.FileIO(2, "w", closefd=False), encoding=enc,
                                  errors="backslashreplace", line_buffering=True)
    # the dispositions a fresh interpreter starts with
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    signal.alarm(int(timeout))
    sys.argv = [os.path.join(os.path.dirname(sys.modules["ndbg_cli"].__file__), "__main__.py"),
                *args]
    runpy.run_module("ndbg_cli", run_name="__main__", alter_sys=True)


def _exit_as_python_does(exc: BaseException | None) -> None:
    """End the child as an interpreter ends (``ndbg_cli.cli.main.end_process``): the exit code
    of a ``SystemExit`` (its message on stderr when it is not a number), a traceback and 1
    for any other exception. Never returns. (``python -m ndbg_cli`` ends there itself.)"""
    import traceback

    from ndbg_cli.cli.main import end_process

    if isinstance(exc, SystemExit):
        end_process(exc.code)
    if exc is not None:
        traceback.print_exception(exc)
    end_process(0 if exc is None else 1)


def _slurp(path: str) -> bytes:
    try:
        with open(path, "rb") as fh:
            return fh.read()
    except OSError:
        return b""


def serve(root: str) -> None:
    _warm(root)
    inp, out = sys.stdin.buffer, sys.stdout.buffer
    _write(out, "ready")
    while True:
        req = _read(inp)
        if req is None:
            return
        args, cwd, env, stdin, timeout, umask = req
        if threading.active_count() > 1:
            _write(out, None)
            continue
        # mkdtemp, not TemporaryDirectory: a child would run that one's exit finaliser
        folder = tempfile.mkdtemp(prefix="ndbg-cli-")
        try:
            pid = os.fork()
            if pid == 0:
                try:
                    _child(args, cwd, env, stdin, folder, timeout, umask)
                    _exit_as_python_does(None)
                except BaseException as exc:  # noqa: BLE001 (the child ends here, always)
                    _exit_as_python_does(exc)
            _, status = os.waitpid(pid, 0)
            code = os.waitstatus_to_exitcode(status)
            so, se = (_slurp(os.path.join(folder, n)) for n in ("out", "err"))
        finally:
            shutil.rmtree(folder, ignore_errors=True)
        _write(out, (code, so, se))


if __name__ == "__main__":
    serve(sys.argv[1])
