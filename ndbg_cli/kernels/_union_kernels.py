"""Compiled kernels (numba) of :mod:`ndbg_cli.ndbg.infinite.chart_union`: the areas and
bounding boxes of a pair's chart pieces, and which of them the union needs
(:func:`maximal_pieces`, :func:`inside_kept`).

A pair's set near a contact is a fan of wedges and half-planes, most of them inside another single
one (many exact duplicates within their window), so only a small fraction of the pieces enters the
unions. Finding them costs a scan of the kept pieces' boxes per piece, far less than building and
testing the others in GEOS (:func:`ndbg_cli.ndbg.infinite.chart_union.union`).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._cone_kernels import cut_polygon

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "piece_boxes": "Tuple((f8[::1],f8[:,::1]))(f8[:,:,::1],i8[::1])",
    "maximal_pieces": "b1[::1](f8[:,:,::1],i8[::1],f8[:,::1],i8[::1])",
    "inside_kept": "b1[::1](f8[:,:,::1],i8[::1],f8[:,::1],b1[::1],f8[:,:,::1],i8[::1],"
                   "f8[:,::1],i8)",
    "inset_convex": "Tuple((f8[:,:,::1],i8[::1]))(f8[:,::1],i8[::1],i8[::1],f8[::1])",
}


@njit(cache=True)
def piece_boxes(poly: np.ndarray, cnt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For convex polygons ``poly`` ``(p, m, 2)`` with ``cnt`` ``(p,)`` vertices each
    (counter-clockwise, :func:`ndbg_cli.kernels._cone_kernels.clip_cones`'s output): their areas
    ``(p,)`` (shoelace, 0 below 3 vertices) and bounding boxes ``(p, 4)`` (``x0, y0, x1, y1``)."""
    p = len(cnt)
    area = np.zeros(p)
    boxes = np.zeros((p, 4))
    for i in range(p):
        n = cnt[i]
        if n < 1:
            continue
        x0, y0 = poly[i, 0, 0], poly[i, 0, 1]
        x1, y1 = x0, y0
        s = 0.0
        for k in range(n):
            x, y = poly[i, k, 0], poly[i, k, 1]
            nx = poly[i, k + 1, 0] if k + 1 < n else poly[i, 0, 0]
            ny = poly[i, k + 1, 1] if k + 1 < n else poly[i, 0, 1]
            s += x * ny - nx * y
            x0, x1 = min(x0, x), max(x1, x)
            y0, y1 = min(y0, y), max(y1, y)
        area[i] = 0.5 * s if n >= 3 else 0.0
        boxes[i, 0], boxes[i, 1], boxes[i, 2], boxes[i, 3] = x0, y0, x1, y1
    return area, boxes


@njit(cache=True)
def _edges_hold(poly: np.ndarray, cnt: np.ndarray, a: int, kpoly: np.ndarray,
                kcnt: np.ndarray, b: int) -> bool:
    """Whether every vertex of convex polygon ``a`` (``poly``, ``cnt``) is on the inner side
    of, or on, every edge ``p -> q`` of convex polygon ``b`` (``kpoly``, ``kcnt``), both
    counter-clockwise: ``(q - p) x (v - p) >= 0`` in floating point. With ``b``'s bounding
    box holding ``a``'s (tested by the callers, in their loops: written there, the scans run
    much faster than through one inlined function with both tests; benchmarks/NOTES.md),
    ``a`` lies inside ``b``."""
    nb = kcnt[b]
    for e in range(nb):
        px, py = kpoly[b, e, 0], kpoly[b, e, 1]
        f = e + 1 if e + 1 < nb else 0
        ex, ey = kpoly[b, f, 0] - px, kpoly[b, f, 1] - py
        for v in range(cnt[a]):
            if ex * (poly[a, v, 1] - py) - ey * (poly[a, v, 0] - px) < 0.0:
                return False
    return True


@njit(cache=True)
def maximal_pieces(poly: np.ndarray, cnt: np.ndarray, boxes: np.ndarray,
                   order: np.ndarray) -> np.ndarray:
    """``(p,)`` whether each convex polygon (``poly``, ``cnt``, ``boxes`` as
    :func:`piece_boxes`; counter-clockwise) of ``order`` (indices, largest area first) lies
    inside none of the polygons before it in ``order`` that were kept; polygons not in
    ``order`` are not kept. The union of the kept polygons is the union of those of
    ``order``.

    Containment: ``b``'s bounding box holds ``a``'s and :func:`_edges_hold`. It is
    transitive, and a polygon can only hold one of at most its area, so testing the kept
    ones suffices. The rounding of the cross products
    (about 1e-16 chart units for chart coordinates of order 1) is the most a dropped
    polygon can stick out of a kept one."""
    keep = np.zeros(len(cnt), dtype=np.bool_)
    kept = np.empty(len(order), dtype=np.int64)
    nk = 0
    for t in range(len(order)):
        a = order[t]
        x0, y0, x1, y1 = boxes[a, 0], boxes[a, 1], boxes[a, 2], boxes[a, 3]
        inside = False
        for s in range(nk):
            b = kept[s]
            if boxes[b, 0] <= x0 and boxes[b, 1] <= y0 and boxes[b, 2] >= x1 \
                    and boxes[b, 3] >= y1 and _edges_hold(poly, cnt, a, poly, cnt, b):
                inside = True
                break
        if not inside:
            kept[nk] = a
            nk += 1
            keep[a] = True
    return keep


@njit(cache=True)
def inside_kept(poly: np.ndarray, cnt: np.ndarray, boxes: np.ndarray, test: np.ndarray,
                kpoly: np.ndarray, kcnt: np.ndarray, kboxes: np.ndarray, nk: int
                ) -> np.ndarray:
    """``(p,)`` whether each convex polygon ``poly[i]`` with ``test[i]`` lies inside one of
    the first ``nk`` polygons ``kpoly`` (the same layout as :func:`maximal_pieces`;
    containment as there)."""
    out = np.zeros(len(cnt), dtype=np.bool_)
    for a in range(len(cnt)):
        if not test[a]:
            continue
        x0, y0, x1, y1 = boxes[a, 0], boxes[a, 1], boxes[a, 2], boxes[a, 3]
        for b in range(nk):
            if kboxes[b, 0] <= x0 and kboxes[b, 1] <= y0 and kboxes[b, 2] >= x1 \
                    and kboxes[b, 3] >= y1 and _edges_hold(poly, cnt, a, kpoly, kcnt, b):
                out[a] = True
                break
    return out


@njit(cache=True)
def inset_convex(xy: np.ndarray, start: np.ndarray, cnt: np.ndarray, delta: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Convex polygons moved inward: polygon ``i`` has the vertices ``xy[start[i]:start[i] +
    cnt[i]]`` (``(v, 2)``, either orientation, not closed); its inset is the polygon cut by
    each edge's line moved ``delta[i]`` inward (the points at least ``delta[i]`` inside every
    edge). Returns the vertices ``(p, w, 2)`` and counts ``(p,)`` (0: nothing left, or the
    polygon is not convex: a turn against its orientation)."""
    p = len(cnt)
    w = 2 * (cnt.max() if p else 0) + 2
    out = np.zeros((p, w, 2))
    num = np.zeros(p, dtype=np.int64)
    cur = np.empty((w, 2))
    buf = np.empty((w, 2))
    f = np.empty(w)
    for i in range(p):
        n0, s0 = cnt[i], start[i]
        if n0 < 3:
            continue
        area = 0.0
        for k in range(n0):
            a, b = xy[s0 + k], xy[s0 + (k + 1) % n0]
            area += a[0] * b[1] - b[0] * a[1]
        sign = 1.0 if area > 0.0 else -1.0  # counter-clockwise: the inside is on the left
        convex = True
        for k in range(n0):
            a, b, c = xy[s0 + k], xy[s0 + (k + 1) % n0], xy[s0 + (k + 2) % n0]
            turn = (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
            if turn * sign < 0.0:
                convex = False
                break
        if not convex:
            continue
        for k in range(n0):
            cur[k, 0], cur[k, 1] = xy[s0 + k, 0], xy[s0 + k, 1]
        n = n0
        for e in range(n0):
            px, py = xy[s0 + e, 0], xy[s0 + e, 1]
            qx, qy = xy[s0 + (e + 1) % n0, 0], xy[s0 + (e + 1) % n0, 1]
            dx, dy = qx - px, qy - py
            ln = np.sqrt(dx * dx + dy * dy)
            if ln == 0.0 or n < 3:
                continue
            # inward unit normal (-dy, dx) sign / ln; keep (v - p) . nin >= delta
            ax, ay = -dy * sign / ln, dx * sign / ln
            for j in range(n):
                f[j] = (cur[j, 0] - px) * ax + (cur[j, 1] - py) * ay - delta[i]
            m = cut_polygon(cur, n, f, buf)
            for j in range(m):
                cur[j, 0], cur[j, 1] = buf[j, 0], buf[j, 1]
            n = m
        if n >= 3:
            num[i] = n
            for j in range(n):
                out[i, j, 0], out[i, j, 1] = cur[j, 0], cur[j, 1]
    return out, num
