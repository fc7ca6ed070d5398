"""Compiled kernels (numba) of the direct sweep test (:mod:`ndbg_cli.ndbg.infinite.sweep`),
which calls them compiled ahead of time when built (:mod:`.compiled`), else through numba's
just-in-time compiler.

One part pair along one direction: the facing triangles of the moved part and of the blocker,
projected along the direction to ``(u, v, z)``, are binned on a grid over the common part of
their shadows, and each triangle pair whose boxes meet is tested exactly (convex clipping of
``t_i`` by ``t_j``'s edges, then by the line where the depth difference reaches ``-tau``). The
first blocking pair ends the test. These kernels share no code with the arrangement's
(:mod:`ndbg_cli.kernels._cone_kernels`): the sweep test is the independent check of it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Vertices a clipped polygon can reach: a triangle cut by four lines.
MAX_VERTICES = 8

#: The kernels :mod:`ndbg_cli.ndbg.infinite.sweep` calls, and :func:`boxes` and
#: :func:`wide_triangles`, which :func:`facing` composes (exported too, so that the build is
#: compared with the source piece by piece), with their numba signatures (C-contiguous
#: float64 and int64 arrays, as the wrappers pass them): :mod:`.compiled` builds these
#: ahead of time and reads them from this file's text (string literals only).
EXPORTS = {
    "facing": "Tuple((f8[:,:,::1],f8[:,::1],f8[:,:,::1],f8[:,::1]))(f8[:,:,::1],f8[:,::1],"
              "f8[:,::1],i8,f8,f8)",
    "boxes": "f8[:,::1](f8[:,:,::1])",
    "wide_triangles": "b1[::1](f8[:,:,::1],f8)",
    "first_blocking": "Tuple((i8,i8,i8[:,::1],i8))(f8[:,:,::1],f8[:,:,::1],f8[:,::1],"
                      "f8[:,::1],f8,f8,f8)",
    "front_polygons": "Tuple((f8[:,::1],i8[::1]))(f8[:,:,::1],f8[:,:,::1],i8[:,::1],f8,f8)",
    "clipped_areas": "f8[::1](f8[:,::1],i8[::1],i8[::1],i8[::1],f8,f8,f8,f8)",
    "overlap_centroid": "UniTuple(f8,2)(f8[:,::1],f8[:,::1])",
    "plane": "UniTuple(f8,3)(f8[:,::1])",
}


@njit(cache=True)
def clip_half_plane(px: np.ndarray, py: np.ndarray, n: int, ax: float, ay: float, b: float,
                    qx: np.ndarray, qy: np.ndarray) -> int:
    """Clip the convex polygon ``(px, py)[:n]`` to ``ax x + ay y <= b`` into ``(qx, qy)``
    (Sutherland-Hodgman: each edge keeps its start when inside and adds its crossing of the
    line); returns the new vertex count."""
    m = 0
    for k in range(n):
        k2 = (k + 1) % n
        s = ax * px[k] + ay * py[k] - b
        s2 = ax * px[k2] + ay * py[k2] - b
        if s <= 0:
            qx[m] = px[k]
            qy[m] = py[k]
            m += 1
        if (s <= 0) != (s2 <= 0):
            w = s / (s - s2)
            qx[m] = px[k] + w * (px[k2] - px[k])
            qy[m] = py[k] + w * (py[k2] - py[k])
            m += 1
    return m


@njit(cache=True)
def polygon_area(px: np.ndarray, py: np.ndarray, n: int) -> float:
    """The area of the polygon ``(px, py)[:n]`` (shoelace; fewer than 3 vertices: 0)."""
    if n < 3:
        return 0.0
    s = 0.0
    for k in range(n):
        k2 = (k + 1) % n
        s += px[k] * py[k2] - py[k] * px[k2]
    return 0.5 * abs(s)


@njit(cache=True)
def plane(t: np.ndarray) -> tuple[float, float, float]:
    """``(c0, cu, cv)`` of the depth ``z = c0 + cu u + cv v`` of a projected triangle ``(3, 3)``."""
    e1u, e1v, e1z = t[1, 0] - t[0, 0], t[1, 1] - t[0, 1], t[1, 2] - t[0, 2]
    e2u, e2v, e2z = t[2, 0] - t[0, 0], t[2, 1] - t[0, 1], t[2, 2] - t[0, 2]
    det = e1u * e2v - e1v * e2u
    if det == 0:
        det = 1e-300
    cu = (e1z * e2v - e2z * e1v) / det
    cv = (e1u * e2z - e2u * e1z) / det
    return t[0, 2] - cu * t[0, 0] - cv * t[0, 1], cu, cv


@njit(cache=True)
def front_overlap(ti: np.ndarray, tj: np.ndarray, amin: float, tau: float, buf: np.ndarray,
                  out: np.ndarray) -> int:
    """The part of the overlap of projected triangles ``ti``, ``tj`` ``(3, 3)`` (u, v, z) where
    ``tj`` is not behind ``ti`` (``z_j - z_i >= -tau``), written to ``out`` ``(2,
    MAX_VERTICES)`` (u, v rows); returns its vertex count, 0 when the whole overlap's area is
    at most ``amin``. ``buf`` ``(4, MAX_VERTICES)`` is scratch space."""
    ox, oy = buf[0], buf[1]
    qx, qy = buf[2], buf[3]
    e0u, e0v = tj[1, 0] - tj[0, 0], tj[1, 1] - tj[0, 1]
    e1u, e1v = tj[2, 0] - tj[1, 0], tj[2, 1] - tj[1, 1]
    cr = e0u * e1v - e0v * e1u
    if cr == 0:
        return 0  # an edge-on t_j (zero projected area) overlaps nothing
    orient = 1.0 if cr > 0 else -1.0
    for k in range(3):
        ox[k] = ti[k, 0]
        oy[k] = ti[k, 1]
    n = 3
    for k in range(3):  # inside t_j: orient * cross(e_k, x - p_k) >= 0
        k2 = (k + 1) % 3
        eu, ev = tj[k2, 0] - tj[k, 0], tj[k2, 1] - tj[k, 1]
        ax, ay = orient * ev, -orient * eu
        n = clip_half_plane(ox, oy, n, ax, ay, ax * tj[k, 0] + ay * tj[k, 1], qx, qy)
        ox, oy, qx, qy = qx, qy, ox, oy
        if n == 0:
            return 0
    if polygon_area(ox, oy, n) <= amin:
        return 0
    ci0, ciu, civ = plane(ti)
    cj0, cju, cjv = plane(tj)
    # z_j - z_i >= -tau  <=>  -(dc_u u + dc_v v) <= tau + dc_0
    n = clip_half_plane(ox, oy, n, -(cju - ciu), -(cjv - civ), tau + (cj0 - ci0), qx, qy)
    for k in range(n):
        out[0, k] = qx[k]
        out[1, k] = qy[k]
    return n


@njit(cache=True)
def front_polygons(pi: np.ndarray, pj: np.ndarray, pairs: np.ndarray, amin: float,
                   tau: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`front_overlap` of each row ``(k_i, k_j)`` of ``pairs``: the vertices, closed
    rings one after another ``(v, 2)``, and each ring's vertex count (its first vertex
    repeated; 0 for a pair whose overlap is empty), for shapely's ragged constructors."""
    buf = np.empty((4, MAX_VERTICES))
    poly = np.empty((2, MAX_VERTICES))
    coords = np.empty((pairs.shape[0] * (MAX_VERTICES + 1), 2))
    counts = np.zeros(pairs.shape[0], np.int64)
    m = 0
    for q in range(pairs.shape[0]):
        n = front_overlap(pi[pairs[q, 0]], pj[pairs[q, 1]], amin, tau, buf, poly)
        if n < 3:
            continue
        for k in range(n + 1):
            coords[m, 0] = poly[0, k % n]
            coords[m, 1] = poly[1, k % n]
            m += 1
        counts[q] = n + 1
    return coords[:m], counts


@njit(cache=True)
def polygon_perimeter(px: np.ndarray, py: np.ndarray, n: int) -> float:
    """The perimeter of the polygon ``(px, py)[:n]``."""
    s = 0.0
    for k in range(n):
        k2 = (k + 1) % n
        s += np.hypot(px[k2] - px[k], py[k2] - py[k])
    return s


@njit(cache=True)
def boxes(t: np.ndarray) -> np.ndarray:
    """Per triangle ``(u_lo, v_lo, u_hi, v_hi, z_lo, z_hi)``."""
    out = np.empty((t.shape[0], 6))
    for k in range(t.shape[0]):
        out[k, 0] = min(t[k, 0, 0], t[k, 1, 0], t[k, 2, 0])
        out[k, 1] = min(t[k, 0, 1], t[k, 1, 1], t[k, 2, 1])
        out[k, 2] = max(t[k, 0, 0], t[k, 1, 0], t[k, 2, 0])
        out[k, 3] = max(t[k, 0, 1], t[k, 1, 1], t[k, 2, 1])
        out[k, 4] = min(t[k, 0, 2], t[k, 1, 2], t[k, 2, 2])
        out[k, 5] = max(t[k, 0, 2], t[k, 1, 2], t[k, 2, 2])
    return out


@njit(cache=True)
def facing(tris: np.ndarray, normals: np.ndarray, frame: np.ndarray, sense: int, tol: float,
           eps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The triangles ``tris`` ``(n, 3, 3)`` whose unit ``normals`` ``(n, 3)`` face along the
    frame's third row ``d`` (``n . d > tol``; with ``sense`` not positive, against it:
    ``< -tol``), in
    their order, projected on the orthonormal rows ``(u, v, d)`` of ``frame``: ``(a, 3, 3)``
    (u, v, z), their :func:`boxes`, and the same two of the :func:`wide_triangles` only.
    Each coordinate is ``x f0 + y f1 + z f2`` in that order, without a fused multiply-add,
    so that every machine projects alike (a BLAS product's rounding depends on its kernel)."""
    n = tris.shape[0]
    keep = np.empty(n, np.int64)
    m = 0
    for k in range(n):
        s = normals[k, 0] * frame[2, 0] + normals[k, 1] * frame[2, 1] \
            + normals[k, 2] * frame[2, 2]
        if s > tol if sense > 0 else s < -tol:
            keep[m] = k
            m += 1
    t = np.empty((m, 3, 3))
    for a in range(m):
        k = keep[a]
        for c in range(3):
            x, y, z = tris[k, c, 0], tris[k, c, 1], tris[k, c, 2]
            for r in range(3):
                t[a, c, r] = x * frame[r, 0] + y * frame[r, 1] + z * frame[r, 2]
    b = boxes(t)
    wide = wide_triangles(t, eps)
    w = np.flatnonzero(wide)
    wt = np.empty((len(w), 3, 3))
    wb = np.empty((len(w), 6))
    for a in range(len(w)):
        wt[a] = t[w[a]]
        wb[a] = b[w[a]]
    return t, b, wt, wb


@njit(cache=True)
def _grid(bj: np.ndarray, sel: np.ndarray, lo_u: float, lo_v: float, hi_u: float,
          hi_v: float) -> tuple[int, int]:
    """Cells along u and v of :func:`first_blocking`'s grid over ``[lo_u, hi_u] x [lo_v,
    hi_v]``: about the mean size of the selected boxes ``bj[sel]`` along each side (the long
    thin facets of a finely tessellated cylinder, seen from the side, each fill a cell or two,
    not a column of square ones), and at most about four cells per selected box in all."""
    m = sel.shape[0]
    wu, wv = 0.0, 0.0
    for q in range(m):
        k = sel[q]
        wu += min(bj[k, 2], hi_u) - max(bj[k, 0], lo_u)
        wv += min(bj[k, 3], hi_v) - max(bj[k, 1], lo_v)
    lu, lv = hi_u - lo_u, hi_v - lo_v
    gu = min(4096, int(lu / max(wu / m, 1e-300 + lu / 4096)) + 1)
    gv = min(4096, int(lv / max(wv / m, 1e-300 + lv / 4096)) + 1)
    cap = 4 * m + 16
    if gu * gv > cap:
        f = np.sqrt(gu * gv / cap)
        gu, gv = max(1, int(gu / f)), max(1, int(gv / f))
    return gu, gv


@njit(cache=True)
def wide_triangles(t: np.ndarray, eps: float) -> np.ndarray:
    """``(a,)`` whether each projected triangle's inradius ``2 A / P`` exceeds ``eps / 2``
    (only two such triangles can overlap in a region that holds a disk of diameter ``eps``)."""
    out = np.zeros(t.shape[0], np.bool_)
    for k in range(t.shape[0]):
        u, v = t[k, :, 0], t[k, :, 1]
        twice = 2.0 * polygon_area(u, v, 3)
        # the perimeter is at least twice the longest side: below that bound (with a margin
        # far above rounding) a triangle is narrow without its three square roots, as most
        # of a fine tessellation's slivers are; else (or when a square overflows) the exact
        # test as written
        longest = 0.0
        for c in range(3):
            c2 = (c + 1) % 3
            longest = max(longest, (u[c2] - u[c]) ** 2 + (v[c2] - v[c]) ** 2)
        if longest < np.inf and twice < 0.5 * eps * 2.0 * np.sqrt(longest) * (1.0 - 1e-9):
            continue
        out[k] = twice > 0.5 * eps * polygon_perimeter(u, v, 3)
    return out


@njit(cache=True)
def first_blocking(pi: np.ndarray, pj: np.ndarray, bi: np.ndarray, bj: np.ndarray,
                   eps: float, amin: float, tiny: float
                   ) -> tuple[int, int, np.ndarray, int]:
    """The first *wide* triangle pair ``(k_i, k_j)`` (``(-1, -1)`` when none) of ``pi``
    ``(a, 3, 3)`` (the moved part's, facing the direction) and ``pj`` ``(b, 3, 3)`` (the
    blocker's, facing against it), projected (u, v, z), with their :func:`boxes` ``bi``,
    ``bj``: their boxes meet by more than ``tiny``, ``t_j`` reaches in front of ``t_i - eps``,
    and the part of their overlap where ``t_j`` is in front (:func:`front_overlap`, ``tau =
    1e-3 eps``) has area over ``amin`` and holds a disk of diameter ``eps`` for sure (area over
    ``eps / 2`` times its perimeter: a convex polygon's inradius is at least area /
    perimeter). The narrower pairs met before are returned too, ``(m, 2)`` rows of which the
    first ``count`` are used: together they may still hold such a disk (a ring tessellated
    into slivers), which the caller decides.

    Only the triangles meeting the common box of both shadows are binned, on a grid of cells
    about their mean size (:func:`_grid`), each in the cells the triangle itself meets (not
    its box: a long diagonal sliver of a tessellated planar face has a box of many cells), so
    the cost follows the triangle pairs that really meet."""
    thin = np.empty((16, 2), np.int64)
    count = 0
    if pi.shape[0] == 0 or pj.shape[0] == 0:
        return -1, -1, thin, count
    lo_u = max(bi[:, 0].min(), bj[:, 0].min())
    lo_v = max(bi[:, 1].min(), bj[:, 1].min())
    hi_u = min(bi[:, 2].max(), bj[:, 2].max())
    hi_v = min(bi[:, 3].max(), bj[:, 3].max())
    if lo_u >= hi_u - tiny or lo_v >= hi_v - tiny:
        return -1, -1, thin, count
    zi_lo = bi[:, 4].min()
    sel = np.empty(bj.shape[0], np.int64)
    m = 0
    for k in range(bj.shape[0]):
        if bj[k, 2] > lo_u and bj[k, 0] < hi_u and bj[k, 3] > lo_v and bj[k, 1] < hi_v \
                and bj[k, 5] > zi_lo - eps:
            sel[m] = k
            m += 1
    if m == 0:
        return -1, -1, thin, count
    gu, gv = _grid(bj, sel[:m], lo_u, lo_v, hi_u, hi_v)
    su, sv = (hi_u - lo_u) / gu, (hi_v - lo_v) / gv
    start, items = _binned(pj, bj, sel[:m], lo_u, lo_v, su, sv, gu, gv, tiny)
    stamp = np.full(bj.shape[0], -1, np.int64)
    buf = np.empty((4, MAX_VERTICES))
    poly = np.empty((2, MAX_VERTICES))
    tau, half = 1e-3 * eps, 0.5 * eps
    for i in range(bi.shape[0]):
        b = bi[i]
        if b[2] <= lo_u or b[0] >= hi_u or b[3] <= lo_v or b[1] >= hi_v:
            continue
        u0, u1, v0, v1 = _cells(b, lo_u, lo_v, su, sv, gu, gv)
        for cu in range(u0, u1 + 1):
            for cv in range(v0, v1 + 1):
                c = cu * gv + cv
                if start[c] == start[c + 1] or not _meets_cell(pi[i], lo_u, lo_v, su, sv, cu,
                                                               cv, tiny):
                    continue
                for q in range(start[c], start[c + 1]):
                    k = items[q]
                    if stamp[k] == i:
                        continue
                    stamp[k] = i
                    o = bj[k]
                    if not (b[0] < o[2] - tiny and o[0] < b[2] - tiny and b[1] < o[3] - tiny
                            and o[1] < b[3] - tiny and o[5] > b[4] - eps):
                        continue
                    n = front_overlap(pi[i], pj[k], amin, tau, buf, poly)
                    area = polygon_area(poly[0], poly[1], n)
                    if area <= amin:
                        continue
                    if area > half * polygon_perimeter(poly[0], poly[1], n):
                        return i, k, thin, count
                    if count == thin.shape[0]:
                        more = np.empty((2 * count, 2), np.int64)
                        more[:count] = thin
                        thin = more
                    thin[count, 0] = i
                    thin[count, 1] = k
                    count += 1
    return -1, -1, thin, count


@njit(cache=True)
def overlap_centroid(ti: np.ndarray, tj: np.ndarray) -> tuple[float, float]:
    """The centroid ``(u, v)`` of the overlap of two projected triangles (vertex mean of the
    clipped polygon; ``t_i``'s own when they do not overlap): where a blocking pair meets."""
    buf = np.empty((4, MAX_VERTICES))
    ox, oy, qx, qy = buf[0], buf[1], buf[2], buf[3]
    for k in range(3):
        ox[k] = ti[k, 0]
        oy[k] = ti[k, 1]
    n = 3
    cr = (tj[1, 0] - tj[0, 0]) * (tj[2, 1] - tj[1, 1]) \
        - (tj[1, 1] - tj[0, 1]) * (tj[2, 0] - tj[1, 0])
    orient = 1.0 if cr > 0 else -1.0
    for k in range(3):
        k2 = (k + 1) % 3
        eu, ev = tj[k2, 0] - tj[k, 0], tj[k2, 1] - tj[k, 1]
        ax, ay = orient * ev, -orient * eu
        m = clip_half_plane(ox, oy, n, ax, ay, ax * tj[k, 0] + ay * tj[k, 1], qx, qy)
        if m == 0:
            break
        ox, oy, qx, qy = qx, qy, ox, oy
        n = m
    return ox[:n].mean(), oy[:n].mean()


@njit(cache=True)
def _binned(pj: np.ndarray, bj: np.ndarray, sel: np.ndarray, lo_u: float, lo_v: float,
            su: float, sv: float, gu: int, gv: int, pad: float) -> tuple[np.ndarray, np.ndarray]:
    """The triangles ``sel`` of ``pj`` in the cells of :func:`first_blocking`'s grid that
    each meets (:func:`_meets_cell`, cells grown by ``pad``), as a CSR list per cell: cell
    ``c``'s are ``items[start[c]:start[c + 1]]``, in the order of ``sel``. Each triangle is
    tested once against each cell of its box; the cells met are kept for the second pass,
    which places them."""
    bound = 0
    for q in range(sel.shape[0]):
        u0, u1, v0, v1 = _cells(bj[sel[q]], lo_u, lo_v, su, sv, gu, gv)
        bound += (u1 - u0 + 1) * (v1 - v0 + 1)
    met_k = np.empty(bound, np.int64)
    met_c = np.empty(bound, np.int64)
    n = 0
    cnt = np.zeros(gu * gv + 1, np.int64)
    for q in range(sel.shape[0]):
        k = sel[q]
        u0, u1, v0, v1 = _cells(bj[k], lo_u, lo_v, su, sv, gu, gv)
        for cu in range(u0, u1 + 1):
            for cv in range(v0, v1 + 1):
                if _meets_cell(pj[k], lo_u, lo_v, su, sv, cu, cv, pad):
                    c = cu * gv + cv
                    met_k[n] = k
                    met_c[n] = c
                    n += 1
                    cnt[c + 1] += 1
    start = np.cumsum(cnt)
    fill = start[:-1].copy()
    items = np.empty(start[-1], np.int64)
    for t in range(n):
        c = met_c[t]
        items[fill[c]] = met_k[t]
        fill[c] += 1
    return start, items


@njit(cache=True)
def _cells(box: np.ndarray, lo_u: float, lo_v: float, su: float, sv: float, gu: int,
           gv: int) -> tuple[int, int, int, int]:
    """The grid cells (first and last along u, then v) a triangle's box covers, clamped."""
    u0 = min(max(int((box[0] - lo_u) / su), 0), gu - 1)
    u1 = min(max(int((box[2] - lo_u) / su), 0), gu - 1)
    v0 = min(max(int((box[1] - lo_v) / sv), 0), gv - 1)
    v1 = min(max(int((box[3] - lo_v) / sv), 0), gv - 1)
    return u0, u1, v0, v1


@njit(cache=True)
def _meets_cell(t: np.ndarray, lo_u: float, lo_v: float, su: float, sv: float, cu: int,
                cv: int, pad: float) -> bool:
    """Whether projected triangle ``t`` meets grid cell ``(cu, cv)`` grown by ``pad`` (the
    cell lies inside the triangle's box range already: only the triangle's three edge lines
    can separate them; an edge-on triangle meets every cell of its box)."""
    cr = (t[1, 0] - t[0, 0]) * (t[2, 1] - t[0, 1]) - (t[1, 1] - t[0, 1]) * (t[2, 0] - t[0, 0])
    if cr == 0:
        return True
    o = 1.0 if cr > 0 else -1.0
    u0, v0 = lo_u + cu * su - pad, lo_v + cv * sv - pad
    u1, v1 = lo_u + (cu + 1) * su + pad, lo_v + (cv + 1) * sv + pad
    for k in range(3):
        k2 = (k + 1) % 3
        eu, ev = o * (t[k2, 0] - t[k, 0]), o * (t[k2, 1] - t[k, 1])
        # the triangle's inside of edge k: eu (v - t_v) - ev (u - t_u) >= 0; a cell wholly
        # outside it has its best corner outside too
        cu_ = u0 if ev > 0 else u1
        cv_ = v1 if eu > 0 else v0
        if eu * (cv_ - t[k, 1]) - ev * (cu_ - t[k, 0]) < 0:
            return False
    return True


@njit(cache=True)
def clipped_areas(coords: np.ndarray, starts: np.ndarray, counts: np.ndarray,
                  idx: np.ndarray, u0: float, v0: float, u1: float, v1: float) -> np.ndarray:
    """The area inside the window ``[u0, u1] x [v0, v1]`` of each convex ring ``idx`` of
    :func:`front_polygons`' output (``starts``, ``counts``: where each ring begins and its
    vertex count, first vertex repeated)."""
    out = np.zeros(idx.shape[0])
    buf = np.empty((4, MAX_VERTICES + 5))
    for q in range(idx.shape[0]):
        r = idx[q]
        n = counts[r] - 1
        ox, oy, qx, qy = buf[0], buf[1], buf[2], buf[3]
        for k in range(n):
            ox[k] = coords[starts[r] + k, 0]
            oy[k] = coords[starts[r] + k, 1]
        for ax, ay, b in ((-1.0, 0.0, -u0), (1.0, 0.0, u1), (0.0, -1.0, -v0), (0.0, 1.0, v1)):
            n = clip_half_plane(ox, oy, n, ax, ay, b, qx, qy)
            ox, oy, qx, qy = qx, qy, ox, oy
            if n == 0:
                break
        out[q] = polygon_area(ox, oy, n)
    return out
