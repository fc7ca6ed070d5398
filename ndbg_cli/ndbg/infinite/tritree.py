"""A bounding-box tree over one part's triangles, for the pruning walk of
:func:`ndbg_cli.ndbg.infinite.blocking_cones.pruned_pair_cones`: median splits along the longest
axis of the centroids, each node with its box and its two largest triangles (the walk emits their
terms first: they fill the union from the inside)."""

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
    """Median-split tree over triangles ``(t, 3, 3)`` (longest box axis of the centroids).

    Each node's triangles are sorted (stably) along the longest extent of their centroids
    and halved; nodes of more than ``leaf`` triangles are split. The splits of one depth are
    made together (a node's split depends on its own triangles only); the nodes are numbered
    as a depth-first construction would number them: a node's two children get the next two
    numbers when it is split, the right child's subtree split first."""
    n = len(tri)
    cen = tri.mean(axis=1)
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    perm = np.arange(n)
    split: set[tuple[int, int]] = set()  # the (start, stop) of every inner node
    seg = np.array([[0, n]]) if n > leaf else np.zeros((0, 2), dtype=np.int64)
    while len(seg):
        s, e = seg[:, 0], seg[:, 1]
        split.update(zip(s.tolist(), e.tolist()))
        # the segments' triangles, in their current order, each tagged with its segment
        size = e - s
        owner = np.repeat(np.arange(len(seg)), size)
        pos = np.arange(int(size.sum())) - np.repeat(np.cumsum(size) - size, size) \
            + np.repeat(s, size)
        c = cen[perm[pos]]
        starts = np.cumsum(size) - size
        ext = np.maximum.reduceat(c, starts, axis=0) - np.minimum.reduceat(c, starts, axis=0)
        axis = np.argmax(ext, axis=1)
        key = c[np.arange(len(c)), axis[owner]]
        order = np.lexsort((key, owner))  # stable: ties keep their order
        perm[pos] = perm[pos[order]]
        mid = (s + e) // 2
        kids = np.concatenate([np.stack([s, mid], axis=1), np.stack([mid, e], axis=1)])
        seg = kids[kids[:, 1] - kids[:, 0] > leaf]
    # number the nodes in the order of the depth-first construction
    start, stop, left, right = [0], [n], [-1], [-1]
    todo = [0] if n > leaf else []
    while todo:
        k = todo.pop()
        s0, e0 = start[k], stop[k]
        mid = (s0 + e0) // 2
        for a0, b0 in ((s0, mid), (mid, e0)):
            start.append(a0)
            stop.append(b0)
            left.append(-1)
            right.append(-1)
            if (a0, b0) in split:
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
        # a child of one triangle lists it twice: its second entry is no candidate
        single = np.stack([np.zeros(len(k), bool), stop[a] - start[a] == 1,
                           np.zeros(len(k), bool), stop[b] - start[b] == 1], axis=1)
        order = np.argsort(np.where(single, np.inf, -area[cand]), axis=1, kind="stable")
        big[k] = np.take_along_axis(cand, order[:, :2], axis=1)
    return lo, hi, big
