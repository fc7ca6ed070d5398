"""Compiled kernels (numba) of a bounding-volume hierarchy over axis-aligned boxes: its build
and the pairs of query boxes and boxes that meet (:class:`ndbg_cli.contacts.bvh.BoxHierarchy`
wraps them).

A query box meets a box when their closed intervals overlap on every axis: the comparisons
libspatialindex's R-tree makes (``lo > q_hi`` or ``hi < q_lo`` on an axis: apart), so the pairs
found are the R-tree's, whatever the order (for finite coordinates: ndbg's parts are
validated; a NaN box would be met or not depending on its node). A node's box is the min
and max of its boxes' coordinates, exactly, so a node is skipped only when none of its boxes
can meet the query.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "hierarchy": "Tuple((f8[:,::1],f8[:,::1],i8[:,::1],i8[::1]))(f8[:,::1],f8[:,::1])",
    "meeting_pairs": "Tuple((i8[::1],i8[::1]))(f8[:,::1],f8[:,::1],i8[:,::1],i8[::1],"
                     "f8[:,::1],f8[:,::1],f8[:,::1],f8[:,::1])",
}

#: Boxes per leaf: a leaf's boxes are tested one by one.
LEAF = 4
#: Depth of the explicit stacks: the tree is balanced (median splits), about
#: ``log2(n / LEAF)`` deep, so 64 levels hold any array that fits in memory.
DEPTH = 64


@njit(cache=True)
def _bounds(lo, hi, order, a, b, node_lo, node_hi, k):
    """Node ``k``'s box: the min of ``lo`` and the max of ``hi`` over ``order[a:b]``."""
    for d in range(3):
        m = np.inf
        M = -np.inf
        for i in range(a, b):
            t = order[i]
            if lo[t, d] < m:
                m = lo[t, d]
            if hi[t, d] > M:
                M = hi[t, d]
        node_lo[k, d] = m
        node_hi[k, d] = M


@njit(cache=True)
def _widest(lo, hi, order, a, b):
    """The axis along which the centres of the boxes ``order[a:b]`` spread most (the lowest
    of equal ones) and the centres along it."""
    best = 0
    width = -1.0
    for d in range(3):
        m = np.inf
        M = -np.inf
        for i in range(a, b):
            c = 0.5 * (lo[order[i], d] + hi[order[i], d])
            if c < m:
                m = c
            if c > M:
                M = c
        if M - m > width:
            width = M - m
            best = d
    keys = np.empty(b - a)
    for i in range(a, b):
        keys[i - a] = 0.5 * (lo[order[i], best] + hi[order[i], best])
    return keys


@njit(cache=True)
def hierarchy(lo, hi):
    """A hierarchy over the boxes ``[lo, hi]`` (each ``(n, 3)``), top down: each node's boxes
    split in two halves at the median of their centres along the axis where the centres
    spread most (a stable sort: the same tree on every machine). Returns ``(node_lo,
    node_hi, kids, order)``: node ``k``'s box; ``kids[k]`` its two children, or for a leaf
    ``(-1 - first, count)``, its boxes being ``order[first:first + count]``; node 0 is the
    root (no nodes without boxes)."""
    n = lo.shape[0]
    order = np.arange(n)
    cap = 2 * n + 1  # a binary tree of at most n leaves
    node_lo = np.empty((cap, 3))
    node_hi = np.empty((cap, 3))
    kids = np.empty((cap, 2), dtype=np.int64)
    if n == 0:
        return node_lo[:0], node_hi[:0], kids[:0], order
    stack = np.empty((DEPTH, 3), dtype=np.int64)  # (node, first, end)
    stack[0, 0], stack[0, 1], stack[0, 2] = 0, 0, n
    sp = 1
    nodes = 1
    while sp > 0:
        sp -= 1
        k, a, b = stack[sp, 0], stack[sp, 1], stack[sp, 2]
        _bounds(lo, hi, order, a, b, node_lo, node_hi, k)
        if b - a <= LEAF:
            kids[k, 0], kids[k, 1] = -1 - a, b - a
            continue
        keys = _widest(lo, hi, order, a, b)
        sub = order[a:b][np.argsort(keys, kind="mergesort")]
        order[a:b] = sub
        mid = (a + b) // 2
        kids[k, 0], kids[k, 1] = nodes, nodes + 1
        stack[sp, 0], stack[sp, 1], stack[sp, 2] = nodes + 1, mid, b
        stack[sp + 1, 0], stack[sp + 1, 1], stack[sp + 1, 2] = nodes, a, mid
        sp += 2
        nodes += 2
    return node_lo[:nodes].copy(), node_hi[:nodes].copy(), kids[:nodes].copy(), order


@njit(cache=True)
def _apart(alo, ahi, i, blo, bhi, j):
    """Whether box ``i`` of ``[alo, ahi]`` and box ``j`` of ``[blo, bhi]`` are apart."""
    return (alo[i, 0] > bhi[j, 0] or ahi[i, 0] < blo[j, 0]
            or alo[i, 1] > bhi[j, 1] or ahi[i, 1] < blo[j, 1]
            or alo[i, 2] > bhi[j, 2] or ahi[i, 2] < blo[j, 2])


@njit(cache=True)
def meeting_pairs(node_lo, node_hi, kids, order, lo, hi, qlo, qhi):
    """Every pair ``(query q, box t)`` whose boxes ``[qlo[q], qhi[q]]`` and ``[lo[t], hi[t]]``
    meet, the boxes' hierarchy given (:func:`hierarchy` of ``lo, hi``): ``(rows, cols)``,
    grouped by query, ascending, each query's boxes in the tree's order."""
    m = qlo.shape[0]
    cap = max(2 * m, 64)
    rows = np.empty(cap, dtype=np.int64)
    cols = np.empty(cap, dtype=np.int64)
    got = 0
    if node_lo.shape[0] == 0:
        return rows[:0], cols[:0]
    stack = np.empty(DEPTH, dtype=np.int64)
    for q in range(m):
        stack[0] = 0
        sp = 1
        while sp > 0:
            sp -= 1
            k = stack[sp]
            if _apart(node_lo, node_hi, k, qlo, qhi, q):
                continue
            if kids[k, 0] >= 0:
                stack[sp] = kids[k, 1]
                stack[sp + 1] = kids[k, 0]
                sp += 2
                continue
            first = -1 - kids[k, 0]
            for i in range(first, first + kids[k, 1]):
                t = order[i]
                if _apart(lo, hi, t, qlo, qhi, q):
                    continue
                if got == cap:
                    cap *= 2
                    grown = np.empty(cap, dtype=np.int64)
                    grown[:got] = rows[:got]
                    rows = grown
                    grown = np.empty(cap, dtype=np.int64)
                    grown[:got] = cols[:got]
                    cols = grown
                rows[got] = q
                cols[got] = t
                got += 1
    return rows[:got].copy(), cols[:got].copy()
