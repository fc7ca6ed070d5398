"""Small helpers shared by the tests: running the real CLI, writing real mesh files."""

from __future__ import annotations

import atexit
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args: str, cwd: Path | None = None, stdin: str | None = None
            ) -> subprocess.CompletedProcess:
    """Run ``python -m ndbg_cli ARGS`` as a user would; returns the completed process.

    The process is forked from a server that has the stages imported and the kernels loaded
    (``tests/cli_server.py``): a real separate process with this process's working folder,
    environment and umask, its own streams and exit code, without the 2 s start-up each time.
    ``NDBG_TEST_SPAWN=1`` starts a fresh interpreter for every run instead."""
    argv = [str(a) for a in args]
    if not os.environ.get("NDBG_TEST_SPAWN"):
        got = _forked(argv, cwd, stdin)
        if got is not None:
            return got
    return subprocess.run([sys.executable, "-m", "ndbg_cli", *argv], cwd=cwd,
                          capture_output=True, text=True, input=stdin, timeout=300)


_SERVER: list = []


def _server() -> subprocess.Popen | None:
    if not _SERVER:
        log = None if os.environ.get("NDBG_TEST_SERVER_LOG") else subprocess.DEVNULL
        proc = subprocess.Popen([sys.executable, str(ROOT / "tests" / "cli_server.py"),
                                 str(ROOT)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                stderr=log)
        from cli_server import _read

        ready = _read(proc.stdout)
        _SERVER.append(proc if ready == "ready" else None)
        if ready == "ready":
            atexit.register(_stop, proc)
    return _SERVER[0]


def _stop(proc: subprocess.Popen) -> None:
    try:
        proc.stdin.close()
        proc.wait(timeout=30)
    except (OSError, subprocess.TimeoutExpired):
        proc.kill()


def _forked(argv: list[str], cwd: Path | None, stdin: str | None
            ) -> subprocess.CompletedProcess | None:
    from cli_server import _read, _write

    proc = _server()
    if proc is None:
        return None
    mask = os.umask(0o022)  # read the caller's umask (the child takes it), and put it back
    os.umask(mask)
    req = (argv, str(cwd or os.getcwd()), dict(os.environ), (stdin or "").encode(), 300, mask)
    try:
        _write(proc.stdin, req)
        got = _read(proc.stdout)
    except OSError:  # the server is gone: plain subprocesses from now on
        got = None
    if got is None:
        if proc.poll() is not None:
            _SERVER[0] = None
        return None
    code, out, err = got
    return subprocess.CompletedProcess([sys.executable, "-m", "ndbg_cli", *argv], code,
                                       _text(out), _text(err))


def _text(data: bytes) -> str:
    """Bytes as ``subprocess.run(..., text=True)`` decodes them (the locale's encoding,
    strict, universal newlines)."""
    import locale

    return (data.decode(locale.getpreferredencoding(False))
            .replace("\r\n", "\n").replace("\r", "\n"))


def box(lo, hi) -> trimesh.Trimesh:
    """A closed axis-aligned box from corner ``lo`` to corner ``hi``."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def write_two_boxes(folder: Path, units: str = "mm", extra: str = "") -> Path:
    """A manifest with two stacked 10 mm cubes (meshes in ``folder/meshes``)."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    box((0, 0, 0), (10, 10, 10)).export(folder / "meshes" / "a.stl")
    box((0, 0, 0), (10, 10, 10)).export(folder / "meshes" / "b.stl")
    text = (f"name: two\nunits: {units}\nparts:\n  - id: a\n    mesh: meshes/a.stl\n"
            f"  - id: b\n    mesh: meshes/b.stl\n    translation: [0, 0, 10]\n{extra}")
    path = folder / "two.yaml"
    path.write_text(text)
    return path
