"""Which boxes meet which, through a bounding-volume hierarchy compiled ahead of time
(:mod:`ndbg_cli.kernels._box_kernels`).

It finds the pairs an R-tree query of the same boxes finds (closed boxes: touching ones
meet), without the R-tree's cost per query (about 7 microseconds through ``rtree``'s
``intersection_v``, a tenth of that here). The pairs come grouped by query box, in the
hierarchy's order within a query, not the R-tree's: for callers to whom only the set matters
(:func:`ndbg_cli.planning.fingers.covered`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kernels.compiled import loaded

__all__ = ["BoxHierarchy"]


@dataclass(frozen=True)
class BoxHierarchy:
    """A hierarchy over the boxes ``[lo, hi]`` (each ``(n, 3)``) and the queries it answers.

    Examples
    --------
    >>> import numpy as np
    >>> lo = np.array([[0.0, 0, 0], [2, 0, 0], [4, 0, 0]])
    >>> boxes = BoxHierarchy.build(lo, lo + 1.0)  # three unit cubes along x
    >>> rows, cols = boxes.meeting(np.array([[1.0, 0, 0], [9, 9, 9]]),
    ...                            np.array([[2.5, 1, 1], [9, 9, 9]]))
    >>> sorted(zip(rows.tolist(), cols.tolist()))  # the first query touches cube 0, meets 1
    [(0, 0), (0, 1)]
    """

    lo: np.ndarray
    hi: np.ndarray
    #: the compiled hierarchy: node boxes (low, high corners), children, box order
    tree: tuple

    @classmethod
    def build(cls, lo: np.ndarray, hi: np.ndarray) -> BoxHierarchy:
        lo = np.ascontiguousarray(lo, dtype=np.float64)
        hi = np.ascontiguousarray(hi, dtype=np.float64)
        return cls(lo, hi, tuple(loaded("_box_kernels").hierarchy(lo, hi)))

    def meeting(self, qlo: np.ndarray, qhi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, cols)``: every pair of a query box ``[qlo[r], qhi[r]]`` and a box
        ``cols`` it meets, grouped by query (ascending)."""
        return loaded("_box_kernels").meeting_pairs(*self.tree, self.lo, self.hi, qlo, qhi)
