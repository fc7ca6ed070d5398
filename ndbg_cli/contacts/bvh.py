"""Which boxes meet which, through a bounding-volume hierarchy compiled ahead of time
(:mod:`ndbg_cli.kernels._box_kernels`).

It finds the pairs an R-tree query of the same boxes finds (closed boxes: touching ones
meet; finite coordinates), without the R-tree's cost per query (about 7 microseconds through
``rtree``'s ``intersection_v`` on the engine GLB's parts, a third to a tenth of that here:
benchmarks/NOTES.md, stop 55). The pairs come grouped by query box, in the hierarchy's order
within a query, not the R-tree's: the finger probes (:func:`ndbg_cli.planning.fingers.covered`)
and the near-triangle test of edge contacts want the set alone, and the narrow phase
(:func:`ndbg_cli.contacts.contacts3d._triangle_candidates`) puts it in R-tree order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.assembly import Part
from ..kernels.compiled import loaded

__all__ = ["BoxHierarchy", "forget_hierarchies", "triangle_hierarchy"]


@dataclass(frozen=True, eq=False)
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
        """The hierarchy of the boxes ``[lo, hi]`` (each ``(n, 3)``): median splits along
        the widest spread of their centres, 4 boxes a leaf, the same tree on every machine
        (:func:`ndbg_cli.kernels._box_kernels.hierarchy`)."""
        lo = np.ascontiguousarray(lo, dtype=np.float64)
        hi = np.ascontiguousarray(hi, dtype=np.float64)
        return cls(lo, hi, tuple(loaded("_box_kernels").hierarchy(lo, hi)))

    def meeting(self, qlo: np.ndarray, qhi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(rows, cols)``: for each query box ``[qlo[k], qhi[k]]`` (each ``(m, 3)``) in
        turn, the indices of the boxes it meets; ``rows`` repeats ``k`` for each, so the
        pairs come grouped by query, ascending."""
        return loaded("_box_kernels").meeting_pairs(*self.tree, self.lo, self.hi, qlo, qhi)


def triangle_hierarchy(part: Part, boxes: BoxHierarchy | None = None
                       ) -> tuple[np.ndarray, BoxHierarchy]:
    """The part's triangles ``(f, 3, 3)`` (assembly frame) and the :class:`BoxHierarchy` of
    their boxes, built once per :attr:`~ndbg_cli.core.assembly.Part.hash` (``boxes``: that
    hierarchy when the caller has it, made by
    :func:`~ndbg_cli.contacts.facets.part_geometries`' forked child): the box queries of the
    narrow phase and of the finger probes."""
    got = _BY_PART.get(part.hash)
    if got is None:
        tri = np.asarray(part.mesh.triangles, dtype=np.float64)
        if boxes is None:
            boxes = BoxHierarchy.build(tri.min(axis=1), tri.max(axis=1))
        got = _BY_PART[part.hash] = (tri, boxes)
    return got


def forget_hierarchies() -> None:
    """Forget every part's hierarchy (:func:`ndbg_cli.contacts.facets.clear_caches`)."""
    _BY_PART.clear()


#: :func:`triangle_hierarchy` by part hash.
_BY_PART: dict[str, tuple[np.ndarray, BoxHierarchy]] = {}
