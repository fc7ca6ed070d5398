"""A bounding-box tree over one part's triangles, for the pruning walk of
:func:`ndbg_cli.blocking_cones.pruned_pair_cones`: median splits along the longest axis of the
centroids, each node with its box and its two largest triangles (the walk emits their terms
first: they fill the union from the inside)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Most triangles in a leaf of the tree.
LEAF = 8


@dataclass(frozen=True)
class TriTree:
    """A bounding-box tree over a part's triangles. Node ``k`` holds the triangles
    ``perm[start[k]:stop[k]]`` inside the box ``lo[k]..hi[k]`` (``(m, 3)``, model units);
    ``left``/``right`` are ``-1`` for leaves; ``big[k]`` are the node's two largest triangles
    (indices into the part's triangles, repeated when the node has one)."""

    perm: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    start: np.ndarray
    stop: np.ndarray
    left: np.ndarray
    right: np.ndarray
    big: np.ndarray


def tri_tree(tri: np.ndarray, leaf: int = LEAF) -> TriTree:
    """Median-split tree over triangles ``(t, 3, 3)`` (longest box axis of the centroids)."""
    cen = tri.mean(axis=1)
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    perm = np.arange(len(tri))
    start, stop, left, right = [0], [len(tri)], [-1], [-1]
    todo = [0] if len(tri) > leaf else []
    while todo:
        k = todo.pop()
        s, e = start[k], stop[k]
        idx = perm[s:e]
        c = cen[idx]
        axis = int(np.argmax(c.max(axis=0) - c.min(axis=0)))
        perm[s:e] = idx[np.argsort(c[:, axis], kind="stable")]
        mid = (s + e) // 2
        for a, b in ((s, mid), (mid, e)):
            start.append(a)
            stop.append(b)
            left.append(-1)
            right.append(-1)
            if b - a > leaf:
                todo.append(len(start) - 1)
        left[k], right[k] = len(start) - 2, len(start) - 1
    start_a, stop_a = np.array(start), np.array(stop)
    left_a, right_a = np.array(left), np.array(right)
    lo, hi, big = _node_boxes(tri, area, perm, start_a, stop_a, left_a, right_a)
    return TriTree(perm, lo, hi, start_a, stop_a, left_a, right_a, big)


def _node_boxes(tri: np.ndarray, area: np.ndarray, perm: np.ndarray, start: np.ndarray,
                stop: np.ndarray, left: np.ndarray, right: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per node of a :func:`tri_tree`: its box ``lo``, ``hi`` ``(m, 3)`` and its two
    largest triangles ``(m, 2)`` (by area, ties to the first in ``perm`` order; a node of one
    triangle lists it twice). The leaves' from their triangles, each inner node's from its
    two children's, deepest nodes first (a child's index is larger than its parent's)."""
    m = len(start)
    lo, hi = np.zeros((m, 3)), np.zeros((m, 3))
    big = np.zeros((m, 2), dtype=np.int64)
    leaf = np.flatnonzero(left < 0)
    # the leaves partition perm; visit them in perm order for reduceat
    leaf = leaf[np.argsort(start[leaf], kind="stable")]
    pts = tri[perm]
    lo[leaf] = np.minimum.reduceat(pts.min(axis=1), start[leaf], axis=0)
    hi[leaf] = np.maximum.reduceat(pts.max(axis=1), start[leaf], axis=0)
    size = stop[leaf] - start[leaf]
    slot = np.arange(int(size.max(initial=1)))
    pos = np.minimum(start[leaf][:, None] + slot, len(perm) - 1)
    idx = perm[pos]
    key = np.where(slot < size[:, None], -area[idx], np.inf)  # padding sorts last
    top = np.take_along_axis(idx, np.argsort(key, axis=1, kind="stable")[:, :2], axis=1)
    big[leaf, 0] = top[:, 0]
    big[leaf, 1] = np.where(size > 1, top[:, -1], top[:, 0])
    depth = np.zeros(m, dtype=np.int64)
    for k in range(m):  # parents come first
        if left[k] >= 0:
            depth[left[k]] = depth[right[k]] = depth[k] + 1
    inner = np.flatnonzero(left >= 0)
    for d in range(int(depth.max(initial=0)), -1, -1):
        k = inner[depth[inner] == d]
        if not len(k):
            continue
        a, b = left[k], right[k]
        lo[k] = np.minimum(lo[a], lo[b])
        hi[k] = np.maximum(hi[a], hi[b])
        # the two largest of the union are among the children's two largest; the left
        # child's triangles come first in perm, so a stable sort keeps the tie order
        cand = np.concatenate([big[a], big[b]], axis=1)
        order = np.argsort(-area[cand], axis=1, kind="stable")
        big[k] = np.take_along_axis(cand, order[:, :2], axis=1)
    return lo, hi, big
