"""Python's cyclic garbage collector paused while a build allocates (:func:`gc_paused`)."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def gc_paused() -> Iterator[None]:
    """Cyclic garbage collection off for the block (also as a decorator); the previous state
    is restored on exit. For builds that make many short-lived objects and no reference
    cycles worth collecting, where each full collection walks every live object: an AND/OR
    search's sets, lists and tuples of ints, the infinite NDBG's arrays and geometries (what
    the collections cost: benchmarks/NOTES.md)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()
