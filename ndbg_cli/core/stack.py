"""Python's recursion limit raised for the trees of large products.

A plan, a decomposition or a class witness is a binary tree as deep as the product has parts
when it comes apart one part at a time (a rack of 996 parts: a linear tree 995 deep). ndbg's
tree walks, the JSON encoder and decoder and the schema validator recurse once (a few frames)
per level, and Python's default limit of 1,000 frames ended such a run with a RecursionError.
Since Python 3.11 a call from Python code to Python code takes no C stack, and the C
recursions left (the JSON scanner, generators) take well under a kilobyte a level, so
:data:`RECURSION_LIMIT` frames fit the 8 MiB main-thread stack with room to spare.
"""

from __future__ import annotations

import sys

__all__ = ["RECURSION_LIMIT", "allow_deep_trees"]

#: Frames allowed: trees about 3,000 levels deep (the schema validator takes about six
#: frames a level). A JSON input nested deeper still fails as "nested too deeply".
RECURSION_LIMIT = 20_000


def allow_deep_trees() -> None:
    """Raise the interpreter's recursion limit to :data:`RECURSION_LIMIT` (never lower it).

    Examples
    --------
    >>> import sys
    >>> allow_deep_trees()
    >>> sys.getrecursionlimit() >= RECURSION_LIMIT
    True
    """
    if sys.getrecursionlimit() < RECURSION_LIMIT:
        sys.setrecursionlimit(RECURSION_LIMIT)
