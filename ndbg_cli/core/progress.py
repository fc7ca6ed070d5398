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
