"""Python's recursion limit raised for the trees of large products.

A plan, a decomposition or a class witness is a binary tree as deep as the product has parts
when it comes apart one part at a time (a rack of 996 parts: a linear tree 995 deep; the
fuzzing campaign's 2,000 cubes). ndbg's tree walks, the JSON encoder and decoder and the
schema validator recurse a few frames per level, and Python's default limit of 1,000 frames
ended such runs with a RecursionError (exit 3). Since Python 3.11 a call from Python code to
Python code takes no C stack, and the C recursions left (the JSON scanner, generators) take
well under a kilobyte a level: json and jsonschema at 6,000 levels were checked on the 8 MiB
main-thread stack.
"""

from __future__ import annotations

import sys

__all__ = ["FRAMES_PER_PART", "RECURSION_LIMIT", "allow_deep_trees"]

#: Frames allowed at least: reports about 2,000 levels deep can be read and written (the
#: schema validator takes about six frames a level). A JSON input nested deeper than this
#: still fails as "nested too deeply".
RECURSION_LIMIT = 20_000
#: Frames a tree may need per part of the assembly analysed, above :data:`RECURSION_LIMIT`.
FRAMES_PER_PART = 8


def allow_deep_trees(parts: int = 0) -> None:
    """Raise the interpreter's recursion limit (never lower it) to :data:`RECURSION_LIMIT`, or
    to what the trees of an assembly of ``parts`` parts need if more.

    Examples
    --------
    >>> import sys
    >>> allow_deep_trees(3000)
    >>> sys.getrecursionlimit() >= RECURSION_LIMIT + FRAMES_PER_PART * 3000
    True
    """
    need = RECURSION_LIMIT + FRAMES_PER_PART * parts
    if sys.getrecursionlimit() < need:
        sys.setrecursionlimit(need)
