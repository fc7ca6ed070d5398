"""Compiled kernels (numba, ``@njit(cache=True)``) of the hot loops of the infinite-translation
NDBG: per-item loops that the numpy versions ran as padded, masked array passes.

Each kernel computes, operation by operation, what the numpy code it replaces computed (same
expressions, same evaluation order, no fast-math; a fused multiply-add exactly where numpy's
matmul uses one, see the dot products below), so the results are bit-identical; only the
padding of the outputs (entries past a count) may differ, and no caller reads it. The first
call in a fresh environment compiles the kernels (the cache lives in ``__pycache__`` beside
this file, or in the user's cache folder when that is not writable). Numba freezes module
globals (:data:`~.cube_faces.FACES`) into the compiled code.
"""

from __future__ import annotations

import llvmlite.ir as llir
import numpy as np
from numba import njit, types
from numba.extending import intrinsic

from .cube_faces import FACES

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "clip_cones": "Tuple((f8[:,:,::1],i8[::1]))(f8[:,:,::1],i8,f8[:,::1],f8,i8)",
    "cone_normals": "f8[:,:,::1](f8[:,:,::1],i8[::1],i8[::1],f8)",
    "compact": "f8[:,:,::1](f8[:,:,::1])",
    "flat": "b1[::1](f8[:,:,::1],f8)",
    "circle_crossings": "Tuple((f8[:,::1],i8[::1]))(f8[:,::1],i8,i8,b1[::1],b1[::1],f8,"
                        "f8[:,::1])",
    "first_crossings": "Tuple((f8[:,::1],i8[::1]))(f8[:,::1],b1[:,::1],f8,f8[:,::1],"
                       "f8[:,:,::1],i8[::1],f8,i8,i8[:,::1],i8[:,::1])",
    "open_hits": "b1[::1](f8[:,:,::1],f8[:,::1],f8[::1],f8[::1],f8[:,::1],i8[::1],f8)",
}

# --------------------------------------------------------------------------------------------
# Dot products of 3-vectors, rounded as numpy rounds them
# --------------------------------------------------------------------------------------------
# numpy's matmul (OpenBLAS, with fused multiply-adds) and einsum (its own sum-of-products
# loops) each sum three products in their own order; to give the same bits the kernels
# repeat that order (measured on this stack for every shape the callers use; a matmul of
# fewer than about 8 rows may take another order, a last-bit difference that only a
# comparison exactly at its threshold could see).


@intrinsic
def _fma(typingctx, a, b, c):
    """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = llir.DoubleType()
        fn = builder.module.declare_intrinsic("llvm.fma", [d], llir.FunctionType(d, [d, d, d]))
        return builder.call(fn, args)

    return sig, codegen


@njit(cache=True, inline="always")
def dot_matmul(x0, x1, x2, y0, y1, y2):
    """``x . y`` as numpy's matmul of ``(n, 3) @ (3, m)`` rounds it:
    ``fma(x2, y2, fma(x1, y1, x0 y0))``."""
    return _fma(x2, y2, _fma(x1, y1, x0 * y0))


@njit(cache=True, inline="always")
def dot_matvec(x0, x1, x2, y0, y1, y2):
    """``x . y`` as numpy's matmul of ``(..., 3) @ (3,)`` (OpenBLAS's gemv) rounds it:
    ``fma(x2, y2, (0 + x0 y0) + x1 y1)`` (from ``+0``: a zero result is never ``-0``)."""
    return _fma(x2, y2, (0.0 + x0 * y0) + x1 * y1)


@njit(cache=True, inline="always")
def dot_einsum(x0, x1, x2, y0, y1, y2):
    """``x . y`` as ``np.einsum`` contracting an axis of length 3 rounds it:
    ``(x0 y0 + x2 y2) + x1 y1``."""
    return (x0 * y0 + x2 * y2) + x1 * y1


@njit(cache=True, inline="always")
def cut_polygon(cur: np.ndarray, n: int, f: np.ndarray, buf: np.ndarray) -> int:
    """One Sutherland-Hodgman step: the part of the polygon ``cur[:n]`` (``(., 2)``) where
    ``f`` (its values at the vertices ``f[:n]``, affine along the edges) is ``>= 0``, written
    to ``buf`` (room for ``2 n`` vertices); returns its vertex count. A crossing of edge
    ``p -> q`` is ``p + w (q - p)``, ``w = f(p) / (f(p) - f(q))``."""
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
    return m


@njit(cache=True)
def _clip(coef: np.ndarray, sq: np.ndarray, cur: np.ndarray, buf: np.ndarray, f: np.ndarray):
    """Clip the quadrilateral ``sq`` ``(4, 2)`` by the half-planes ``coef`` ``(k, 3)`` of one
    cone (see :func:`clip_cones`), in the work arrays ``cur``, ``buf`` ``(c, 2)`` and ``f``
    ``(c,)`` (``c >= 4``; replaced by larger ones when a step needs more room). Returns
    ``(n, widest, cur, buf, f)``: the polygon is ``cur[:n]``; ``widest`` is the largest vertex
    count a cut produced (-1 without a cut)."""
    k = coef.shape[0]
    widest = -1
    # a half-plane with the four corners strictly outside excludes the square (convex)
    for r in range(k):
        a, b, c = coef[r, 0], coef[r, 1], coef[r, 2]
        out = True
        for j in range(4):
            if not sq[j, 0] * a + sq[j, 1] * b + c < 0.0:
                out = False
                break
        if out:
            return 0, widest, cur, buf, f
    for j in range(4):
        cur[j, 0] = sq[j, 0]
        cur[j, 1] = sq[j, 1]
    n = 4
    for r in range(k):
        a, b, c = coef[r, 0], coef[r, 1], coef[r, 2]
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
        m = cut_polygon(cur, n, f, buf)
        cur, buf = buf, cur
        if len(f) < len(cur):
            f = np.empty(len(cur))
        n = m
        widest = max(widest, m)
    return n, widest, cur, buf, f


@njit(cache=True)
def clip_cones(normals: np.ndarray, face: int, sq: np.ndarray, shrink: float,
               max_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Clip the convex quadrilateral ``sq`` ``(4, 2)`` (counter-clockwise, chart units) of ``face``
    by the chart half-planes ``a s + b t + c >= 0`` of each open cone of ``normals`` ``(p, k, 3)``
    (:func:`ndbg_cli.ndbg.infinite.cubemap.clip_halfplanes`): row ``m`` gives ``(a, b, c) = (m . u,
    m . v, m . e)`` (as numpy's matmul rounds them), ``c`` lowered by ``shrink * hypot(a, b)`` when
    ``shrink > 0``; an all-zero row is no constraint (padding).

    Returns ``(poly, count)``: ``poly`` ``(p, w, 2)`` vertices (counter-clockwise; the entries
    past ``count[i]`` are zero) and ``count`` ``(p,)``; ``count[i] < 3`` when cone ``i``
    misses the quadrilateral (0 when one half-plane has all four corners strictly outside,
    tested before any clipping). ``w`` is the largest count produced (at least 4), capped at
    ``max_vertices``. Sutherland-Hodgman, one half-plane at a time in row order, skipping a
    polygon once it has fewer than 3 vertices; a vertex is inside when its value is ``>= 0``
    and a crossing of edge ``p -> q`` is ``p + w (q - p)``, ``w = f(p) / (f(p) - f(q))``.
    """
    p, k, _ = normals.shape
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]
    keep = max(4, max_vertices)
    store = np.zeros((p, keep, 2))
    count = np.zeros(p, dtype=np.int64)
    coef = np.empty((k, 3))
    cur = np.empty((8 + 2 * k, 2))
    buf = np.empty_like(cur)
    f = np.empty(len(cur))
    width = 4
    grown = False
    for i in range(p):
        for r in range(k):
            m0, m1, m2 = normals[i, r, 0], normals[i, r, 1], normals[i, r, 2]
            a = dot_matvec(m0, m1, m2, u[0], u[1], u[2])
            b = dot_matvec(m0, m1, m2, v[0], v[1], v[2])
            c = dot_matvec(m0, m1, m2, e[0], e[1], e[2])
            if shrink > 0.0:
                c -= shrink * np.hypot(a, b)
            coef[r, 0], coef[r, 1], coef[r, 2] = a, b, c
        n, widest, cur, buf, f = _clip(coef, sq, cur, buf, f)
        if widest >= 0:
            grown = True
            width = max(width, widest)
        count[i] = n
        for j in range(min(n, keep)):
            store[i, j, 0] = cur[j, 0]
            store[i, j, 1] = cur[j, 1]
    if grown and width > max_vertices:
        width = max_vertices
    return store[:, :width].copy(), count


@njit(cache=True)
def _cone_normals(gens: np.ndarray, pa: np.ndarray, pb: np.ndarray, rel_tol: float,
                  out: np.ndarray, scale: np.ndarray) -> bool:
    """:func:`cone_normals` of one generator set ``gens`` ``(g, 3)`` into ``out`` ``(2 q, 3)``
    (zeroed by the caller; ``scale``: work array ``(g,)``). Returns whether some candidate
    has every generator in its plane (its ``-n`` written to row ``q + c``)."""
    g = gens.shape[0]
    q = len(pa)
    any_both = False
    big = 0.0
    for k in range(g):
        x0, x1, x2 = gens[k, 0], gens[k, 1], gens[k, 2]
        scale[k] = np.sqrt((x0 * x0 + x1 * x1) + x2 * x2)
        if k == 0 or scale[k] > big:
            big = scale[k]
    for c in range(q):
        a0, a1, a2 = gens[pa[c], 0], gens[pa[c], 1], gens[pa[c], 2]
        b0, b1, b2 = gens[pb[c], 0], gens[pb[c], 1], gens[pb[c], 2]
        n0 = a1 * b2 - a2 * b1
        n1 = a2 * b0 - a0 * b2
        n2 = a0 * b1 - a1 * b0
        norm = np.sqrt((n0 * n0 + n1 * n1) + n2 * n2)
        valid = norm > 1e-12 * big * big
        if valid:
            n0, n1, n2 = n0 / norm, n1 / norm, n2 / norm
        else:
            n0, n1, n2 = 0.0, 0.0, 0.0
        pos = True
        neg = True
        for k in range(g):
            d = dot_einsum(n0, n1, n2, gens[k, 0], gens[k, 1], gens[k, 2])
            lim = rel_tol * scale[k]
            if not d >= -lim:
                pos = False
            if not d <= lim:
                neg = False
            if not (pos or neg):  # generators on both sides: not a facet
                break
        sign = 1.0 if pos else (-1.0 if neg else 0.0)
        out[c, 0] = n0 * sign
        out[c, 1] = n1 * sign
        out[c, 2] = n2 * sign
        if pos and neg and valid:
            any_both = True
            out[q + c, 0] = -n0
            out[q + c, 1] = -n1
            out[q + c, 2] = -n2
    return any_both


@njit(cache=True)
def cone_normals(gens: np.ndarray, pa: np.ndarray, pb: np.ndarray, rel_tol: float
                 ) -> np.ndarray:
    """Candidate facets of the conic hulls of generator sets (see
    :func:`ndbg_cli.ndbg.infinite.cubemap.cone_normals`): ``gens`` ``(p, g, 3)``, candidate planes
    through generators ``pa[c]``, ``pb[c]`` (``(q,)`` each). Returns ``(p, q, 3)`` signed unit
    normals (zero where the candidate is not a facet), or ``(p, 2 q, 3)`` when some candidate of the
    batch has every generator in its plane within tolerance: its ``-n`` is then in row ``q + c``
    (zero rows elsewhere). A candidate is valid when ``|n| > 1e-12 big^2`` (``big`` the longest
    generator) and a side holds every generator within ``rel_tol`` times its length."""
    p, g, _ = gens.shape
    q = len(pa)
    out = np.zeros((p, 2 * q, 3))
    scale = np.empty(g)
    any_both = False
    for i in range(p):
        if _cone_normals(gens[i], pa, pb, rel_tol, out[i], scale):
            any_both = True
    if any_both:
        return out
    return out[:, :q].copy()


@njit(cache=True)
def _before(key, q, a, b):
    """Row ``a`` sorts before row ``b``: by ``key``, then the rounded components in order."""
    if key[a] != key[b]:
        return key[a] < key[b]
    for t in range(3):
        if q[a, t] != q[b, t]:
            return q[a, t] < q[b, t]
    return False


@njit(cache=True)
def _compact(normals: np.ndarray, w0: int, rows: np.ndarray, sel: np.ndarray,
             key: np.ndarray, q: np.ndarray, order: np.ndarray) -> int:
    """:func:`compact` of one cone ``normals`` ``(k, 3)``, sorting the first ``w0`` rows of
    its stable partition nonzero-first; the kept rows go to ``rows`` (``(>= w0, 3)``), their
    number is returned (``sel`` ``(k,)``, ``key``, ``q``, ``order``: work arrays of ``w0``
    rows)."""
    k = normals.shape[0]
    m = 0
    for r in range(k):
        if normals[r, 0] != 0.0 or normals[r, 1] != 0.0 or normals[r, 2] != 0.0:
            sel[m] = r
            m += 1
    for r in range(k):
        if not (normals[r, 0] != 0.0 or normals[r, 1] != 0.0 or normals[r, 2] != 0.0):
            sel[m] = r
            m += 1
    for t in range(w0):
        x0, x1, x2 = normals[sel[t], 0], normals[sel[t], 1], normals[sel[t], 2]
        key[t] = np.rint(dot_matvec(x0, x1, x2, 1.0, np.pi, np.e) * 1e9)
        q[t, 0] = np.rint(x0 * 1e9)
        q[t, 1] = np.rint(x1 * 1e9)
        q[t, 2] = np.rint(x2 * 1e9)
        # stable insertion sort
        s = t
        while s > 0 and _before(key, q, t, order[s - 1]):
            order[s] = order[s - 1]
            s -= 1
        order[s] = t
    kept = 0
    for t in range(w0):
        r = sel[order[t]]
        if normals[r, 0] == 0.0 and normals[r, 1] == 0.0 and normals[r, 2] == 0.0:
            continue
        if t > 0:
            u = order[t - 1]
            v = order[t]
            if key[u] == key[v] and q[u, 0] == q[v, 0] and q[u, 1] == q[v, 1] \
                    and q[u, 2] == q[v, 2]:
                continue
        rows[kept, 0] = normals[r, 0]
        rows[kept, 1] = normals[r, 1]
        rows[kept, 2] = normals[r, 2]
        kept += 1
    return kept


@njit(cache=True)
def compact(normals: np.ndarray) -> np.ndarray:
    """Drop zero rows and duplicates per cone (see :func:`ndbg_cli.ndbg.infinite.cubemap.compact`):
    ``normals`` ``(p, k, 3)`` to ``(p, w, 3)``, ``w`` the most rows kept (at least 1), the
    kept rows first, zero rows after. Within a cone the first ``w0`` rows of the stable
    partition nonzero-first (``w0`` the most nonzero rows of a cone of the batch) are sorted
    stably by ``key = round(1e9 n . (1, pi, e))``, then by the rows rounded to ``1e-9``;
    a row equal to the previous one in both is a duplicate."""
    p, k, _ = normals.shape
    w0 = 1
    for i in range(p):
        nz = 0
        for r in range(k):
            if normals[i, r, 0] != 0.0 or normals[i, r, 1] != 0.0 or normals[i, r, 2] != 0.0:
                nz += 1
        w0 = max(w0, nz)
    w0 = min(w0, k)
    rows = np.empty((p, w0, 3))
    kept = np.zeros(p, dtype=np.int64)
    sel = np.empty(k, dtype=np.int64)
    key = np.empty(w0)
    q = np.empty((w0, 3))
    order = np.empty(w0, dtype=np.int64)
    for i in range(p):
        kept[i] = _compact(normals[i], w0, rows[i], sel, key, q, order)
    w = 1
    for i in range(p):
        w = max(w, kept[i])
    out = np.zeros((p, w, 3))
    for i in range(p):
        for t in range(kept[i]):
            out[i, t, 0] = rows[i, t, 0]
            out[i, t, 1] = rows[i, t, 1]
            out[i, t, 2] = rows[i, t, 2]
    return out


@njit(cache=True)
def flat(cones: np.ndarray, tol: float) -> np.ndarray:
    """``(p,)`` whether some two rows ``m``, ``m'`` of each cone ``(p, k, 3)`` have
    ``m . m' <= -1 + tol`` (a row with itself included, as the einsum of the numpy version
    had it)."""
    p, k, _ = cones.shape
    out = np.zeros(p, dtype=np.bool_)
    lim = -1.0 + tol
    for i in range(p):
        for a in range(k):
            for b in range(k):
                if dot_einsum(cones[i, a, 0], cones[i, a, 1], cones[i, a, 2],
                              cones[i, b, 0], cones[i, b, 1], cones[i, b, 2]) <= lim:
                    out[i] = True
                    break
            if out[i]:
                break
    return out


@njit(cache=True, inline="always")
def _pair_at(c: int, start: int) -> tuple[int, int]:
    """The pair ``(i, j)`` at position ``start`` of the row-major order of ``i < j < c``."""
    i, t = 0, 0
    while i < c - 1 and t + (c - 1 - i) <= start:
        t += c - 1 - i
        i += 1
    return i, i + 1 + (start - t)


@njit(cache=True, inline="always")
def _crossing(n: np.ndarray, i: int, j: int) -> tuple[bool, float, float, float]:
    """``n_i x n_j / |n_i x n_j|``, and whether ``|n_i x n_j| > 1e-12`` (else unusable)."""
    a0, a1, a2 = n[i, 0], n[i, 1], n[i, 2]
    b0, b1, b2 = n[j, 0], n[j, 1], n[j, 2]
    d0 = a1 * b2 - a2 * b1
    d1 = a2 * b0 - a0 * b2
    d2 = a0 * b1 - a1 * b0
    ln = np.sqrt((d0 * d0 + d1 * d1) + d2 * d2)
    if not ln > 1e-12:
        return False, 0.0, 0.0, 0.0
    return True, d0 / ln, d1 / ln, d2 / ln


@njit(cache=True, inline="always")
def _face(d0: float, d1: float, d2: float) -> int:
    """The cube face of a direction: the largest ``d . e`` (the first of equals)."""
    f, best = 0, d0
    for g, val in ((1, -d0), (2, d1), (3, -d1), (4, d2), (5, -d2)):
        if val > best:
            f, best = g, val
    return f


@njit(cache=True, inline="always")
def _chart(f: int, d0: float, d1: float, d2: float) -> tuple[float, float]:
    """The chart point ``(s, t)`` of a direction on face ``f``."""
    e, u, v = FACES[f, 0], FACES[f, 1], FACES[f, 2]
    de = dot_matvec(d0, d1, d2, e[0], e[1], e[2])
    return (dot_matvec(d0, d1, d2, u[0], u[1], u[2]) / de,
            dot_matvec(d0, d1, d2, v[0], v[1], v[2]) / de)


@njit(cache=True, inline="always")
def _kept(s: float, t: float, inside: float, box: np.ndarray) -> bool:
    """Whether a chart point is strictly inside ``|s|, |t| < inside`` and in the closed
    ``box`` ``(x0, y0, x1, y1)``."""
    return (abs(s) < inside and abs(t) < inside
            and box[0] <= s <= box[2] and box[1] <= t <= box[3])


@njit(cache=True)
def circle_crossings(n: np.ndarray, start: int, stop: int, meets: np.ndarray,
                     faces: np.ndarray, inside: float, boxes: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Crossings of great circles (unit normals ``n`` ``(c, 3)``) on the cube faces, for the
    circle pairs ``start <= t < stop`` of the row-major order of ``i < j`` (that of
    ``np.triu_indices(c, 1)``) whose circles both have ``meets`` ``(c,)``.

    Each pair gives ``d = n_i x n_j / |n_i x n_j|`` (skipped when ``|n_i x n_j| <= 1e-12``)
    and ``-d``; a direction lies on the face whose axis has the largest ``d . e`` (the first
    of equals), and is kept when that face is flagged in ``faces`` ``(6,)``, its chart point
    has ``|s|, |t| < inside`` and lies in the face's closed box ``boxes[f]``
    ``(x0, y0, x1, y1)`` (chart units). Returns chart points ``(m, 2)`` and their faces
    ``(m,)``: all the ``+d`` of the pairs in order, then all the ``-d``."""
    c = n.shape[0]
    i, j = _pair_at(c, start)
    npairs = max(stop - start, 0)
    dirs = np.empty((npairs, 3))
    m = 0
    for _ in range(npairs):
        if i >= c - 1:
            break
        if meets[i] and meets[j]:
            ok, d0, d1, d2 = _crossing(n, i, j)
            if ok:
                dirs[m, 0], dirs[m, 1], dirs[m, 2] = d0, d1, d2
                m += 1
        j += 1
        if j >= c:
            i += 1
            j = i + 1
    pts = np.empty((2 * m, 2))
    lab = np.empty(2 * m, dtype=np.int64)
    k = 0
    for sgn in (1.0, -1.0):
        for r in range(m):
            d0, d1, d2 = dirs[r, 0], dirs[r, 1], dirs[r, 2]
            if sgn < 0.0:
                d0, d1, d2 = -d0, -d1, -d2
            f = _face(d0, d1, d2)
            if not faces[f]:
                continue
            s, tt = _chart(f, d0, d1, d2)
            if not _kept(s, tt, inside, boxes[f]):
                continue
            pts[k, 0] = s
            pts[k, 1] = tt
            lab[k] = f
            k += 1
    return pts[:k].copy(), lab[:k].copy()


@njit(cache=True)
def open_hits(cones: np.ndarray, d: np.ndarray, x: np.ndarray, y: np.ndarray,
              boxes: np.ndarray, cand: np.ndarray, tol: float) -> np.ndarray:
    """``(r,)`` whether direction ``d[k]`` ``(r, 3)`` (unit; chart point ``(x[k], y[k])``)
    lies in the open cone ``cones[cand[p]]`` (``(P, K, 3)``, unit or zero rows; inside
    meaning ``m . d > tol`` for every nonzero row ``m``) of some piece ``p`` whose chart
    bounding box ``boxes[p]`` (``x0, y0, x1, y1``) holds the point, ends included (what an
    STR-tree query by the point's envelope returns). Pieces are tried in order up to the
    first hit."""
    r = len(d)
    hit = np.zeros(r, dtype=np.bool_)
    K = cones.shape[1]
    for k in range(r):
        d0, d1, d2 = d[k, 0], d[k, 1], d[k, 2]
        px, py = x[k], y[k]
        for h in range(len(cand)):
            if px < boxes[h, 0] or px > boxes[h, 2] or py < boxes[h, 1] or py > boxes[h, 3]:
                continue
            c = cand[h]
            inside = True
            for t in range(K):
                m0, m1, m2 = cones[c, t, 0], cones[c, t, 1], cones[c, t, 2]
                if m0 == 0.0 and m1 == 0.0 and m2 == 0.0:
                    continue
                if not dot_einsum(m0, m1, m2, d0, d1, d2) > tol:
                    inside = False
                    break
            if inside:
                hit[k] = True
                break
    return hit


@njit(cache=True)
def _inside_rectilinear(x: float, y: float, edges: np.ndarray, m: int) -> bool:
    """Whether ``(x, y)`` lies strictly inside the polygon of axis-parallel ``edges[:m]``
    (``x0, y0, x1, y1`` each, every ring): on no edge, and left of an odd number of vertical
    edges (half-open in ``y``). Exact: only comparisons."""
    cross = 0
    for k in range(m):
        x0, y0, x1, y1 = edges[k, 0], edges[k, 1], edges[k, 2], edges[k, 3]
        if x0 == x1:
            lo, hi = min(y0, y1), max(y0, y1)
            if x == x0 and lo <= y <= hi:
                return False
            if x0 > x and lo <= y < hi:
                cross += 1
        elif y == y0 and min(x0, x1) <= x <= max(x0, x1):
            return False
    return cross % 2 == 1


@njit(cache=True, nogil=True)
def first_crossings(n: np.ndarray, meets: np.ndarray, inside: float, boxes: np.ndarray,
                    edges: np.ndarray, nedges: np.ndarray, q: float, chunk: int,
                    key_lo: np.ndarray, key_n: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`circle_crossings` over all circle pairs, each face's points cut to the domain
    and merged as :func:`ndbg_cli.ndbg.infinite.arrangement.circle_crossings` does, in one pass.

    A pair's crossing on face ``f`` counts when both circles have ``meets[f]`` (``(6, c)``),
    it passes :func:`circle_crossings`'s tests (``inside``, ``boxes`` ``(6, 4)``) and lies
    strictly inside the face's rectilinear domain polygon (``edges[f, :nedges[f]]``, see
    :func:`_inside_rectilinear`). Points are visited in that function's order (chunks of
    ``chunk`` pairs; in each, every ``+d``, then every ``-d``), and one is kept when no
    earlier kept point of its face rounds to the same key ``rint(p / q)``: the first of
    each key. Keys are offsets from ``key_lo[f]`` (``(6, 2)``) in a dense ``key_n[f]``
    (``(6, 2)``) grid, which must hold every key of the face's box. Returns the kept points
    ``(m, 2)`` and their faces ``(m,)``, in order per face."""
    c = n.shape[0]
    npairs = c * (c - 1) // 2
    base = np.zeros(7, dtype=np.int64)
    for f in range(6):
        base[f + 1] = base[f] + key_n[f, 0] * key_n[f, 1]
    seen = np.zeros(base[6], dtype=np.bool_)
    pts = np.empty((base[6], 2))
    lab = np.empty(base[6], dtype=np.int64)
    k = 0
    for s0 in range(0, npairs, chunk):
        s1 = min(s0 + chunk, npairs)
        for sgn in (1.0, -1.0):
            i, j = _pair_at(c, s0)
            for _ in range(s1 - s0):
                if i >= c - 1:
                    break
                ok, d0, d1, d2 = _crossing(n, i, j)
                ii, jj = i, j
                j += 1
                if j >= c:
                    i += 1
                    j = i + 1
                if not ok:
                    continue
                if sgn < 0.0:
                    d0, d1, d2 = -d0, -d1, -d2
                f = _face(d0, d1, d2)
                if not (meets[f, ii] and meets[f, jj]):
                    continue
                s, tt = _chart(f, d0, d1, d2)
                if not _kept(s, tt, inside, boxes[f]):
                    continue
                kx = np.int64(np.rint(s / q)) - key_lo[f, 0]
                ky = np.int64(np.rint(tt / q)) - key_lo[f, 1]
                slot = base[f] + kx * key_n[f, 1] + ky
                if seen[slot]:
                    continue
                if not _inside_rectilinear(s, tt, edges[f], nedges[f]):
                    continue
                seen[slot] = True
                pts[k, 0] = s
                pts[k, 1] = tt
                lab[k] = f
                k += 1
    return pts[:k].copy(), lab[:k].copy()
