r"""Atomic file writes and the escaping of file-name bytes that UTF-8 cannot encode.

File names that are not UTF-8: Python reads a byte it cannot decode (``0xff`` in a file
name, on a UTF-8 system) as a lone surrogate (``\udcff``), which UTF-8 cannot encode. Every
output writes such a byte as the four characters ``\xff`` (:func:`printable`): JSON strings
(so ``"tw\\xffo.yaml"`` in the JSON text), text reports, files, and every line printed
(the CLI sets the :data:`ESCAPE` error handler on stdout and stderr). Any other lone
surrogate is written ``\udXXX``. The same name always gives the same text; a name that holds
a literal backslash-x followed by two hex digits is written the same way, so the mapping is
not reversible in that (unlikely) case.
"""

from __future__ import annotations

import codecs
import contextlib
import os
import signal
import stat
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

#: The codec error handler that writes what UTF-8 cannot encode as ``\xNN`` (an undecodable
#: byte of a file name) or ``\udXXX`` (any other lone surrogate); see the module docstring.
ESCAPE = "ndbg-escape"


def _escape(exc: UnicodeError) -> tuple[str, int]:
    if not isinstance(exc, UnicodeEncodeError):
        raise exc
    out = []
    for ch in exc.object[exc.start:exc.end]:
        c = ord(ch)
        if 0xDC80 <= c <= 0xDCFF:  # surrogateescape's stand-in for the byte c - 0xDC00
            out.append(f"\\x{c - 0xDC00:02x}")
        else:
            out.append(f"\\u{c:04x}" if c <= 0xFFFF else f"\\U{c:08x}")
    return "".join(out), exc.end


codecs.register_error(ESCAPE, _escape)


def printable(text: str) -> str:
    r"""``text`` with what UTF-8 cannot encode (the undecodable bytes of a file name) escaped
    as ``\xNN``, so that it can be written anywhere; ``text`` itself when it can be."""
    if text.isascii():
        return text
    return text.encode("utf-8", ESCAPE).decode("utf-8")


#: What ``str.splitlines`` breaks a line at, as :func:`one_line` escapes it.
_LINE_BREAKS = {c: c.encode("unicode_escape").decode("ascii")
                for c in "\n\r\v\f\x1c\x1d\x1e\x85\u2028\u2029"}


def one_line(text: str) -> str:
    r"""``text`` with its line breaks escaped (``\n``, ``\x85``, ``\u2028``, ...): a message
    quoting a part id or a file name that holds one stays the one line a shell pipeline or a
    CI log reads as one error (the fuzzing campaign's unicode part ids split them).

    Examples
    --------
    >>> one_line("part 'a\nb' is listed twice")
    "part 'a\\nb' is listed twice"
    """
    if text.isprintable() or not any(c in text for c in _LINE_BREAKS):
        return text
    return "".join(_LINE_BREAKS.get(c, c) for c in text)


def write_atomic(path: str | Path, data: str | bytes, *, durable: bool = True) -> None:
    """Write ``data`` (text as UTF-8, undecodable file-name bytes escaped as :func:`printable`
    does, or bytes) to ``path`` atomically: a temporary file in the same folder, renamed
    over the target, so a reader never sees a half-written file.
    ``durable`` fsyncs before the rename (reports); a cache entry can skip it.

    The file gets the permissions a plain ``open(path, "w")`` would give it (the temporary
    file's are 0600): an existing file's, else ``0o666`` less the umask. Cache entries too,
    so that a cache shared through ``$NDBG_CACHE_DIR`` is readable as its folder says."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    raw = data.encode("utf-8", ESCAPE) if isinstance(data, str) else data
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
    except OSError:  # a new file (or one we cannot stat: the rename will say)
        mode = 0o666 & ~_umask()
    # A SIGTERM handler that raises (a batch being stopped) could otherwise fire between
    # mkstemp and the try below, or inside the cleanup, and leave the temporary file behind:
    # hold the signal until the file is either in place or gone.
    with _signals_held():
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        try:
            with os.fdopen(fd, "wb") as fh:
                os.fchmod(fh.fileno(), mode)
                fh.write(raw)
                if durable:
                    fh.flush()
                    os.fsync(fh.fileno())
            os.replace(tmp, path)
        except BaseException:
            try:
                os.unlink(tmp)
            except OSError:
                pass
            raise


def _umask() -> int:
    """The process's umask: from /proc (Linux), else by setting it and back (a moment in
    which another thread's new file would get 022)."""
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Defer SIGTERM and SIGINT for the body; one that came in is raised again on exit.

    A signal mask would not do: the kernel may deliver the signal to another thread (a
    process pool's manager thread) and Python still runs the handler in the main thread. So
    the handlers are swapped for a recorder; outside the main thread, where handlers cannot
    be set and never run, there is nothing to hold."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    caught: list[int] = []
    held = (signal.SIGTERM, signal.SIGINT)
    previous = {s: signal.signal(s, lambda signum, frame: caught.append(signum)) for s in held}
    try:
        yield
    finally:
        for s, handler in previous.items():  # None: set outside Python, treat as default
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in dict.fromkeys(caught):
            signal.raise_signal(s)
