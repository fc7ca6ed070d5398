"""Running a reader that can crash or hang where that cannot take ndbg down
(:func:`run_isolated`).

A native reader (OpenCASCADE's STEP/IGES reader, libxml2 under a 3DXML or 3MF file, image
decoders under a glTF's textures) runs in a child process, with a time limit and a memory
limit. A segmentation fault, an abort, a timeout or an out-of-memory there becomes one
:class:`InputError` naming the file and what happened (a damaged input is an input error),
in the calling process, whatever it is: the CLI, a batch worker, a library user's program.

The child is a plain ``python -c`` subprocess (``fork`` + ``exec``), not a ``multiprocessing``
process: that is safe when the caller has threads (a process pool's manager thread, a dask
worker) and when it is itself a daemonic pool worker, which may not start ``multiprocessing``
children. The request goes to the child's stdin as a pickle; the child answers on a private
pipe with length-prefixed pickles: progress stages while it reads, then the result (numpy
arrays, which pickle as their raw buffers: cheap to send, no trimesh object crosses) or the
error. The child's C-level stdout and stderr go to a temporary log, from which the reader's
own complaints are quoted when it crashes (``NDBG_DEBUG_NATIVE=1`` passes them to stderr).
"""

from __future__ import annotations

import os
import pickle
import re
import select
import signal
import struct
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..core.errors import InputError

#: Frame header: the pickle's length, 8 bytes little-endian.
_HEADER = struct.Struct("<Q")
#: Seconds between two progress calls while the child works.
TICK_S = 0.25
#: Seconds the child's own alarm allows beyond the time limit (a backstop if the parent is
#: stopped before it can end the child; the parent's death ends it at once on Linux).
BACKSTOP_S = 30

_BOOT = ("import sys; sys.path.insert(0, sys.argv[1]); "
         "from ndbg_cli.io.isolated import child_main; "
         "child_main(int(sys.argv[2]), int(sys.argv[3]), sys.argv[4:])")

_SIGNALS = {
    "SIGSEGV": "segmentation fault", "SIGBUS": "bus error", "SIGABRT": "aborted",
    "SIGFPE": "arithmetic fault", "SIGILL": "illegal instruction",
    "SIGKILL": "killed", "SIGXCPU": "CPU time limit", "SIGALRM": "time limit",
}


class _Child:
    """A started child: waiting for its request on stdin, answering on ``fd``."""

    def __init__(self, preload: tuple[str, ...]) -> None:
        root = str(Path(__file__).resolve().parents[2])  # the folder holding ndbg_cli
        debug = bool(os.environ.get("NDBG_DEBUG_NATIVE"))
        self.log = None if debug else tempfile.TemporaryFile(prefix="ndbg-reader-")
        out = sys.stderr if debug else self.log
        self.fd, w = os.pipe()
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", _BOOT, root, str(w), str(os.getpid()), *preload],
                stdin=subprocess.PIPE, stdout=out, stderr=out, pass_fds=(w,),
                start_new_session=True)
        except BaseException:
            os.close(self.fd)
            raise
        finally:
            os.close(w)

    def end(self) -> str:
        """Kill the child if it still runs, reap it; the reader's complaints from its log."""
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        os.close(self.fd)
        notes = _reader_notes(self.log)
        if self.log is not None:
            self.log.close()
        return notes


#: Children started ahead of their request (:func:`prestart`), by what they import.
_WAITING: dict[tuple[str, ...], _Child] = {}


def prestart(*preload: str) -> None:
    """Start a child that imports the modules ``preload`` and then waits for the request of
    the next :func:`run_isolated` call with the same ``preload``: its start-up (a Python
    interpreter importing numpy, trimesh and OpenCASCADE, about a second) then overlaps
    with whatever the caller does meanwhile, e.g. the CLI importing the stages. A child
    never used ends when this process does (it reads end-of-file)."""
    if preload not in _WAITING:
        _WAITING[preload] = _Child(preload)


def run_isolated(func: str, args: tuple, *, file: str, reader: str, timeout: float | None,
                 memory_gib: float | None, preload: tuple[str, ...] = (),
                 timeout_hint: str = "", part: str | None = None,
                 progress: Callable[[str, float], None] | None = None,
                 meanwhile: Callable[[], Any] | None = None) -> Any:
    """``func(*args, stage=...)`` (``func`` named ``"module:function"``) in a child process;
    its return value. ``stage(text)`` inside the child reports what it is doing; here,
    ``progress(stage, seconds)`` is called with the latest stage every :data:`TICK_S`.
    ``preload``: modules the child imports before it reads its request (a child
    :func:`prestart`-ed with the same ones is used if there is one). ``timeout_hint``: what
    the timeout's message suggests besides a longer limit. ``meanwhile()`` is called here
    once the request is sent, before the answer is read: work of this process that the
    child's time then hides (the time limit still counts from the request; an answer
    already waiting when it has passed is read, not called a timeout).

    An :class:`InputError` raised in the child is raised here (with ``file``, and ``part``
    when it names none); any other
    exception there, a crash, ``timeout`` seconds passing (``None``: no limit) or the child
    needing more than ``memory_gib`` GiB of address space (``None``: no limit) is an
    :class:`InputError` naming ``file`` (and ``part``) and ``reader`` (e.g. "the STEP reader
    (OpenCASCADE)")."""
    request = pickle.dumps({"func": func, "args": args, "timeout": timeout,
                            "memory": None if not memory_gib else int(memory_gib * 2**30)})
    child = _WAITING.pop(preload, None)
    if child is not None and child.proc.poll() is not None:  # it died waiting: a new one
        child.end()
        child = None
    start = time.monotonic()
    if child is None:
        child = _Child(preload)
    try:
        try:
            child.proc.stdin.write(request)
            child.proc.stdin.close()
        except BrokenPipeError:  # the child died at once: told below
            pass
        if meanwhile is not None:
            meanwhile()
        messages = _receive(child.fd, start, timeout, progress)
    finally:
        notes = child.end()
    proc = child.proc
    elapsed = time.monotonic() - start
    if messages is None:
        hint = f"; {timeout_hint}" if timeout_hint else ""
        raise InputError(f"{reader} did not finish within {timeout:g} s (--load-timeout{hint})",
                         file=file, part=part)
    for kind, value in messages:
        if kind == "ok":
            return value
        if kind == "input-error":
            raise InputError(value["problem"], file=file, part=value["part"] or part,
                             line=value["line"])
        if kind == "memory":
            raise InputError(f"{reader} ran out of memory (limit {memory_gib:g} GiB, "
                             "--load-memory)", file=file, part=part)
        if kind == "error":
            raise InputError(f"{reader} failed: {value}", file=file, part=part)
    crash = _crash(reader, proc.returncode, notes, memory_gib,
                   timed_out=timeout is not None and elapsed >= timeout)
    raise InputError(crash, file=file, part=part)


def _receive(fd: int, start: float, timeout: float | None,
             progress: Callable[[str, float], None] | None) -> list[tuple[str, Any]] | None:
    """The child's messages until it closes the pipe (``None``: the time ran out)."""
    buf = bytearray()
    stage = "starting the reader"
    messages: list[tuple[str, Any]] = []
    last_tick = -TICK_S
    while True:
        now = time.monotonic() - start
        late = timeout is not None and now >= timeout
        if progress is not None and now - last_tick >= TICK_S:
            progress(stage, now)
            last_tick = now
        wait = TICK_S if timeout is None else min(TICK_S, timeout - now)
        ready, _, _ = select.select([fd], [], [], max(wait, 0.0))
        if not ready:
            if late:  # nothing more came (what came before the limit has been read)
                return None
            continue
        chunk = os.read(fd, 1 << 20)
        if not chunk:
            return messages
        buf += chunk
        while len(buf) >= _HEADER.size:
            (n,) = _HEADER.unpack_from(buf)
            if len(buf) < _HEADER.size + n:
                break
            kind, value = pickle.loads(bytes(buf[_HEADER.size:_HEADER.size + n]))
            del buf[:_HEADER.size + n]
            if kind == "stage":
                stage = value
                if progress is not None:
                    progress(stage, time.monotonic() - start)
            else:
                messages.append((kind, value))


def _crash(reader: str, code: int | None, notes: str, memory_gib: float | None, *,
           timed_out: bool) -> str:
    """The message of a child that ended without an answer."""
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        how = f"{_SIGNALS.get(name, 'killed')} ({name})"
        if name in ("SIGABRT", "SIGKILL") and memory_gib:
            how += f", possibly out of memory (limit {memory_gib:g} GiB, --load-memory)"
        if name in ("SIGALRM", "SIGXCPU") or timed_out:
            how += ", the time limit (--load-timeout)"
    else:
        how = f"exit code {code}"
    text = f"{reader} crashed on this file: {how}"
    if notes:
        text += f"; it had reported: {notes}"
    return text + " (the file is damaged or not one the reader handles)"


_ANSI = re.compile(r"\x1b\[[0-9;]*m")
_COMPLAINT = re.compile(r"\b(ERR|ERROR|Error|Fail|FAIL|Exception|exception)\b")


def _reader_notes(log, keep: int = 2, limit: int = 160) -> str:
    """The last complaints (lines naming an error) the reader printed, one line."""
    if log is None:
        return ""
    try:
        size = log.seek(0, os.SEEK_END)
        log.seek(max(0, size - 65536))
        text = log.read().decode("utf-8", "replace")
    except (OSError, ValueError):
        return ""
    lines = []
    for line in text.splitlines():
        line = " ".join(_ANSI.sub("", line).replace("*", " ").split())
        if not _COMPLAINT.search(line):
            continue
        line = re.sub(r"^ERR\b\s*", "", re.sub(r"\s+:\s+", ": ", line))[:limit]
        if line and line not in lines:
            lines.append(line)
    return "; ".join(lines[-keep:])


# -- in the child -------------------------------------------------------------------------

_IN_CHILD = False


def in_child() -> bool:
    """Whether this process is a reader's child (its stdout and stderr are the log already,
    so a reader need not silence native output)."""
    return _IN_CHILD

def child_main(fd: int, parent: int, preload: list[str]) -> None:
    """The child's entry point: import ``preload``, read the request from stdin, set the
    limits, run the reader, send its result (or error) on ``fd``, and exit without the
    interpreter's teardown (a native library's static destructors are not run)."""
    global _IN_CHILD
    _IN_CHILD = True
    _die_with_parent(parent)
    for module in preload:
        try:
            __import__(module)
        except Exception:  # an import error is told when the reader needs the module
            pass
    try:
        req = pickle.load(sys.stdin.buffer)
    except EOFError:  # a prestarted child never used: its parent is done
        os._exit(0)
    if req["memory"]:
        _limit_memory(req["memory"])
    if req["timeout"]:
        signal.alarm(int(req["timeout"]) + BACKSTOP_S)

    def send(kind: str, value: Any) -> None:
        data = pickle.dumps((kind, value), protocol=pickle.HIGHEST_PROTOCOL)
        view = memoryview(_HEADER.pack(len(data)) + data)
        while view:
            view = view[os.write(fd, view):]

    try:
        module, _, name = req["func"].partition(":")
        func = getattr(__import__(module, fromlist=[name]), name)
        result = func(*req["args"], stage=lambda text: send("stage", text))
        send("ok", result)
    except InputError as exc:
        send("input-error", {"problem": exc.problem, "part": exc.part, "line": exc.line})
    except MemoryError:
        send("memory", None)
    except Exception as exc:
        lines = str(exc).strip().splitlines()
        send("error", f"{exc.__class__.__name__}: {lines[0] if lines else ''}".strip(": "))
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _limit_memory(limit: int) -> None:
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    if soft == resource.RLIM_INFINITY or limit < soft:
        resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


def _die_with_parent(parent: int) -> None:
    """Linux: the child gets SIGKILL when its parent dies (a killed ndbg leaves no reader
    running on)."""
    try:
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
        if os.getppid() != parent:  # the parent died before the call
            os._exit(1)
    except (OSError, AttributeError):
        pass
