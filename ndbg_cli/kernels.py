"""Compiled kernels (numba, ``@njit(cache=True)``) of the hot loops of the infinite-translation
NDBG: per-item loops that the numpy versions ran as padded, masked array passes.

Each kernel computes, operation by operation, what the numpy code it replaces computed
(same expressions, same evaluation order, no fast-math, no fused multiply-add), so the
results are bit-identical; only the padding of the outputs (entries past a count) may differ,
and no caller reads it. The first call of a kernel in a fresh environment compiles it (the
cache then lives in ``__pycache__`` beside this file).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def clip_square(coef: np.ndarray, sq: np.ndarray, max_vertices: int
                ) -> tuple[np.ndarray, np.ndarray]:
    """Clip the convex quadrilateral ``sq`` ``(4, 2)`` (counter-clockwise, chart units) by the
    half-planes ``a s + b t + c >= 0`` of each cone: ``coef`` ``(p, k, 3)`` rows ``(a, b, c)``,
    an all-zero row being no constraint (padding).

    Returns ``(poly, count)``: ``poly`` ``(p, w, 2)`` vertices (counter-clockwise; the entries
    past ``count[i]`` are zero) and ``count`` ``(p,)``; ``count[i] < 3`` when cone ``i``
    misses the quadrilateral (0 when one half-plane has all four corners strictly outside,
    tested before any clipping). ``w`` is the largest count produced (at least 4), capped at
    ``max_vertices``. Sutherland-Hodgman, one half-plane at a time in row order, skipping a
    polygon once it has fewer than 3 vertices; a vertex is inside when its value is ``>= 0``
    and a crossing of edge ``p -> q`` is ``p + w (q - p)``, ``w = f(p) / (f(p) - f(q))``.
    """
    p, k, _ = coef.shape
    keep = max(4, max_vertices)  # no output row is wider
    store = np.zeros((p, keep, 2))
    count = np.zeros(p, dtype=np.int64)
    cap = 8 + 2 * k
    cur = np.empty((cap, 2))
    buf = np.empty((cap, 2))
    f = np.empty(cap)
    width = 4
    grown = False
    for i in range(p):
        # a half-plane with the four corners strictly outside excludes the square (convex)
        miss = False
        for r in range(k):
            a, b, c = coef[i, r, 0], coef[i, r, 1], coef[i, r, 2]
            out = True
            for j in range(4):
                if not sq[j, 0] * a + sq[j, 1] * b + c < 0.0:
                    out = False
                    break
            if out:
                miss = True
                break
        if miss:
            continue
        for j in range(4):
            cur[j, 0] = sq[j, 0]
            cur[j, 1] = sq[j, 1]
        n = 4
        for r in range(k):
            a, b, c = coef[i, r, 0], coef[i, r, 1], coef[i, r, 2]
            if (a == 0.0 and b == 0.0 and c == 0.0) or n < 3:
                continue
            some_in = False
            some_out = False
            for j in range(n):
                f[j] = cur[j, 0] * a + cur[j, 1] * b + c
                if f[j] >= 0.0:
                    some_in = True
                if f[j] < 0.0:
                    some_out = True
            if not some_in:
                n = 0
                continue
            if not some_out:
                continue
            if 2 * n > len(buf):  # more crossings than a convex polygon has: room for all
                buf = np.empty((2 * n, 2))
            m = 0
            for j in range(n):
                nx = j + 1 if j + 1 < n else 0
                fa, fb = f[j], f[nx]
                if fa >= 0.0:
                    buf[m, 0] = cur[j, 0]
                    buf[m, 1] = cur[j, 1]
                    m += 1
                if (fa >= 0.0 and fb < 0.0) or (fa < 0.0 and fb >= 0.0):
                    w = fa / (fa - fb)
                    buf[m, 0] = cur[j, 0] + w * (cur[nx, 0] - cur[j, 0])
                    buf[m, 1] = cur[j, 1] + w * (cur[nx, 1] - cur[j, 1])
                    m += 1
            cur, buf = buf, cur
            if len(f) < len(cur):
                f = np.empty(len(cur))
            n = m
            grown = True
            if m > width:
                width = m
        count[i] = n
        for j in range(min(n, keep)):
            store[i, j, 0] = cur[j, 0]
            store[i, j, 1] = cur[j, 1]
    if grown and width > max_vertices:
        width = max_vertices
    return store[:, :width].copy(), count
