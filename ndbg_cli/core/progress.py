"""A progress bar on stderr, shown only on a terminal and never with ``--quiet``."""

from __future__ import annotations

import sys
import time
from collections.abc import Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def progress(items: Iterable[T], total: int, label: str, *, quiet: bool = False) -> Iterator[T]:
    """Yield ``items``, drawing ``label [#####     ] k/total`` on stderr when it is a TTY."""
    show = not quiet and total > 1 and sys.stderr.isatty()
    start = time.monotonic()
    for k, item in enumerate(items):
        if show:
            width = 30
            done = int(width * k / total)
            sys.stderr.write(f"\r{label} [{'#' * done}{' ' * (width - done)}] {k}/{total} "
                             f"{time.monotonic() - start:5.1f}s")
            sys.stderr.flush()
        yield item
    if show:
        sys.stderr.write("\r" + " " * 70 + "\r")
        sys.stderr.flush()


class StatusLine:
    """What a long step with no count (a model file being read and tessellated) is doing, on
    stderr: on a terminal a line redrawn in place from :data:`TTY_AFTER_S` on; elsewhere (a
    log) one line once the step has lasted :data:`LOG_AFTER_S`, then at each new stage and
    every :data:`LOG_EVERY_S`. Call :meth:`update` often, :meth:`close` at the end."""

    TTY_AFTER_S = 1.0
    LOG_AFTER_S = 10.0
    LOG_EVERY_S = 60.0

    def __init__(self, label: str, *, quiet: bool = False) -> None:
        self.label = label
        self.quiet = quiet
        self.tty = sys.stderr.isatty()
        self.drawn = False
        self.logged: tuple[str, float] | None = None  # stage and time of the last line

    def update(self, stage: str, elapsed: float) -> None:
        if self.quiet:
            return
        if self.tty:
            if elapsed >= self.TTY_AFTER_S:
                text = f"{self.label}: {stage} {elapsed:5.1f}s"
                sys.stderr.write("\r" + text[:99].ljust(99))
                sys.stderr.flush()
                self.drawn = True
            return
        if elapsed < self.LOG_AFTER_S:
            return
        if (self.logged is None or self.logged[0] != stage
                or elapsed - self.logged[1] >= self.LOG_EVERY_S):
            sys.stderr.write(f"ndbg: {self.label}: {stage} ({elapsed:.0f} s so far)\n")
            sys.stderr.flush()
            self.logged = (stage, elapsed)

    def close(self) -> None:
        if self.drawn:
            sys.stderr.write("\r" + " " * 99 + "\r")
            sys.stderr.flush()
            self.drawn = False
