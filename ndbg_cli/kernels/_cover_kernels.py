"""Compiled kernels (numba) of the raster cover's tests
(:class:`ndbg_cli.ndbg.infinite.cover.Cover`): the window tests on a term's generators or facets,
the summed-area tables and the fused "inside the covered cells" tests of a cone. The same
conventions as :mod:`ndbg_cli.kernels._cone_kernels` (whose dot products and per-cone clip and
facet helpers they use): numpy's rounding repeated, so the results are bit-identical to the numpy
code they replace.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._cone_kernels import FACES, _clip, _compact, _cone_normals, dot_matmul, dot_matvec

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "misses_spanned_open": "b1[::1](f8[:,:,::1],f8[:,:,::1],f8[:,:,::1],f8[:,:,::1])",
    "outside": "b1[::1](f8[:,:,::1],f8[:,::1])",
    "update_sat": "void(b1[:,::1],i4[:,::1],i8)",
    "covers": "b1[::1](f8[:,:,::1],i8[::1],f8[:,:,::1],f8[:,::1],i4[:,:,::1],i8[:,::1],f8,i8)",
    "covers_spanned": "b1[::1](f8[:,:,::1],i8[::1],i8[::1],i8[::1],f8[:,:,::1],f8[:,::1],"
                      "i4[:,:,::1],i8[:,::1],f8,i8)",
    "mark_cells": "i8(f8[:,:,::1],i8[::1],f8,b1[:,::1])",
    "open_window": "Tuple((b1,f8,f8,f8,f8))(b1[:,::1],i8,i8,i8,i8,f8)",
    "window_pyramid": "UniTuple(f8[:,::1],2)(i8,f8,f8,f8,f8)",
}
#: The arguments (positions) an entry point writes into, in place (the build ahead of time
#: writes into the caller's array, as here: :func:`~ndbg_cli.kernels.compiled._checked`).
WRITES = {"update_sat": (1,), "mark_cells": (3,)}


@njit(cache=True, inline="always")
def _separates(rows: np.ndarray, pts: np.ndarray, strict: bool) -> bool:
    """Whether some row ``m`` of ``rows`` ``(k, 3)`` has every point ``q`` of ``pts``
    ``(n, 3)`` on its negative side: ``m . q < 0`` (``strict``) or ``<= 0``. The dot product
    as numpy's matmul rounds it, which is symmetric in its two vectors."""
    for r in range(rows.shape[0]):
        allout = True
        for c in range(pts.shape[0]):
            d = dot_matmul(rows[r, 0], rows[r, 1], rows[r, 2], pts[c, 0], pts[c, 1], pts[c, 2])
            if not (d < 0.0 if strict else d <= 0.0):
                allout = False
                break
        if allout:
            return True
    return False


@njit(cache=True, inline="always")
def spanned_misses(gens: np.ndarray, facing: np.ndarray, corners: np.ndarray,
                   sides: np.ndarray) -> bool:
    """Whether one term (the cone spanned by ``gens`` ``(g, 3)`` cut by the open half-spaces
    ``facing`` ``(f, 3)``) misses every window (:func:`misses_spanned_open`)."""
    for w in range(corners.shape[0]):
        # every generator strictly outside one side, or the corners outside a facing one
        if not (_separates(sides[w], gens, True) or _separates(facing, corners[w], False)):
            return False
    return True


@njit(cache=True, inline="always")
def open_misses(normals: np.ndarray, facing: np.ndarray, corners: np.ndarray) -> bool:
    """Whether the open cone of the rows ``normals`` and ``facing`` (``(k, 3)``, ``(f, 3)``;
    zero rows never separate) misses every window: on each, one of its half-spaces has the
    window's four corners strictly outside (:func:`outside` on every face)."""
    for w in range(corners.shape[0]):
        if not (_separates(normals, corners[w], True) or _separates(facing, corners[w], True)):
            return False
    return True


@njit(cache=True)
def misses_spanned_open(gens: np.ndarray, facing: np.ndarray, corners: np.ndarray,
                        sides: np.ndarray) -> np.ndarray:
    """``(p,)`` whether each term (cone spanned by ``gens`` ``(p, g, 3)`` cut by the open
    half-spaces ``facing`` ``(p, f, 3)``) misses every window ``w`` (its corner directions
    ``corners[w]`` ``(4, 3)``, the inward normals of its sides ``sides[w]`` ``(4, 3)``): on
    each, every generator strictly outside one side (``< 0``) or the four corners outside
    one facing half-space (``<= 0``). With no window, every term misses."""
    p = gens.shape[0]
    out = np.ones(p, dtype=np.bool_)
    for i in range(p):
        out[i] = spanned_misses(gens[i], facing[i], corners, sides)
    return out


@njit(cache=True)
def outside(cones: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """``(p,)`` whether one half-space ``m . d > 0`` of each open cone ``(p, k, 3)`` has the
    four ``corners`` ``(4, 3)`` (a window's corner directions) strictly outside
    (``m . c < 0``); a zero row never has."""
    p = cones.shape[0]
    out = np.zeros(p, dtype=np.bool_)
    for i in range(p):
        out[i] = _separates(cones[i], corners, True)
    return out


@njit(cache=True)
def update_sat(covered: np.ndarray, sat: np.ndarray, r0: int) -> None:
    """Bring the summed-area table ``sat`` ``(m + 1, n + 1)`` (int32; ``sat[y, x]`` the
    number of set cells of ``covered`` ``(m, n)`` in rows ``< y`` and columns ``< x``, zero
    first row and column) up to date for rows ``>= r0`` of ``covered`` (the rows above
    unchanged since it was last right). In place; integer sums, so exact."""
    m, n = covered.shape
    for y in range(r0, m):
        run = 0
        for x in range(n):
            run += covered[y, x]
            sat[y + 1, x + 1] = sat[y, x + 1] + run


@njit(cache=True)
def box_covered(sat: np.ndarray, block: np.ndarray, lo0: float, lo1: float, hi0: float,
                hi1: float, h: float, r: int) -> bool:
    """Whether every cell of an ``r x r`` raster (cells ``h`` chart units wide from -1)
    meeting the chart box ``lo..hi`` (clipped to the face) is covered, given that every cell
    outside ``block`` (``row0, row1, col0, col1``) is: one lookup in the block's summed-area
    table ``sat`` (``sat[y, x]``: the covered cells in the block's rows ``< y`` and columns
    ``< x``), for the box's part in the block (none: covered)."""
    top = r - 1
    x0 = max(int(min(max(np.floor((lo0 + 1.0) / h), 0.0), top)), block[2])
    y0 = max(int(min(max(np.floor((lo1 + 1.0) / h), 0.0), top)), block[0])
    x1 = min(int(min(max(np.floor((hi0 + 1.0) / h), 0.0), top)), block[3] - 1)
    y1 = min(int(min(max(np.floor((hi1 + 1.0) / h), 0.0), top)), block[1] - 1)
    if x0 > x1 or y0 > y1:
        return True
    x0, x1, y0, y1 = x0 - block[2], x1 - block[2], y0 - block[0], y1 - block[0]
    got = sat[y1 + 1, x1 + 1] - sat[y0, x1 + 1] - sat[y1 + 1, x0] + sat[y0, x0]
    return got == (y1 - y0 + 1) * (x1 - x0 + 1)


@njit(cache=True)
def _cone_covered(cone: np.ndarray, faces: np.ndarray, corners: np.ndarray,
                  rects: np.ndarray, sats: np.ndarray, blocks: np.ndarray, h: float, size: int,
                  coef: np.ndarray, cur: np.ndarray, buf: np.ndarray, f: np.ndarray):
    """Whether the closed cone ``cone`` ``(k, 3)`` lies in covered cells on every window
    face it meets (see :func:`covers`; ``size``: the raster's; ``coef`` ``(k, 3)``,
    ``cur``, ``buf``, ``f``: work arrays). Returns ``(covered, cur, buf, f)``."""
    k = cone.shape[0]
    for w in range(len(faces)):
        fc = faces[w]
        # quick test: a half-space with the window's four corners strictly outside
        if _separates(cone, corners[w], True):
            continue
        e, u, v = FACES[fc, 0], FACES[fc, 1], FACES[fc, 2]
        for r in range(k):
            m0, m1, m2 = cone[r, 0], cone[r, 1], cone[r, 2]
            coef[r, 0] = dot_matvec(m0, m1, m2, u[0], u[1], u[2])
            coef[r, 1] = dot_matvec(m0, m1, m2, v[0], v[1], v[2])
            coef[r, 2] = dot_matvec(m0, m1, m2, e[0], e[1], e[2])
        x0, y0, x1, y1 = rects[w, 0], rects[w, 1], rects[w, 2], rects[w, 3]
        sq = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        n, _, cur, buf, f = _clip(coef[:k], sq, cur, buf, f)
        if n < 3:
            continue
        lo0, lo1, hi0, hi1 = np.inf, np.inf, -np.inf, -np.inf
        for j in range(n):
            lo0 = min(lo0, cur[j, 0])
            lo1 = min(lo1, cur[j, 1])
            hi0 = max(hi0, cur[j, 0])
            hi1 = max(hi1, cur[j, 1])
        if not box_covered(sats[fc], blocks[fc], lo0, lo1, hi0, hi1, h, size):
            return False, cur, buf, f
    return True, cur, buf, f


@njit(cache=True)
def covers(cones: np.ndarray, faces: np.ndarray, corners: np.ndarray, rects: np.ndarray,
           sats: np.ndarray, blocks: np.ndarray, h: float, size: int) -> np.ndarray:
    """``(p,)`` whether each closed cone ``(p, k, 3)`` lies in covered cells on every face it meets
    (:meth:`ndbg_cli.ndbg.infinite.cover.Cover.covers`). Only the faces ``faces`` ``(w,)`` with a
    window count (elsewhere every cell is covered): window ``w`` has corner directions
    ``corners[w]`` ``(4, 3)`` and chart rectangle ``rects[w]`` (``x0, y0, x1, y1``). A cone with a
    half-space that has the four corners strictly outside misses the window; else its polygon
    clipped to the rectangle, when it has 3 vertices or more, must have its bounding box in covered
    cells (the summed-area tables ``sats`` ``(6, ., .)`` of the ``blocks`` ``(6, 4)`` of a ``size x
    size`` raster, cells ``h`` chart units wide: :func:`box_covered`)."""
    p, k, _ = cones.shape
    ok = np.ones(p, dtype=np.bool_)
    coef = np.empty((k, 3))
    cur = np.empty((8 + 2 * k, 2))
    buf = np.empty_like(cur)
    f = np.empty(len(cur))
    for i in range(p):
        ok[i], cur, buf, f = _cone_covered(cones[i], faces, corners, rects, sats, blocks, h,
                                           size, coef, cur, buf, f)
    return ok


@njit(cache=True)
def covers_spanned(gens: np.ndarray, pa: np.ndarray, pb: np.ndarray, faces: np.ndarray,
                   corners: np.ndarray, rects: np.ndarray, sats: np.ndarray,
                   blocks: np.ndarray, h: float, size: int) -> np.ndarray:
    """``(p,)`` whether each closed cone spanned by ``gens`` ``(p, g, 3)`` lies in covered
    cells on every window face it meets (:meth:`ndbg_cli.ndbg.infinite.cover.Cover.covers_spanned`;
    ``faces``, ``corners``, ``rects``, ``sats``, ``blocks``, ``h``, ``size`` as :func:`covers`
    takes them). A cone
    with every generator in front of a window face's plane (``g . e > 0``) or behind it on
    every window face is tested by the bounding box of its generators' chart points; one
    with generators on both sides of some window face's plane by its facets (candidates
    through the generator pairs ``pa``, ``pb``; :func:`_cone_normals`, :func:`_compact`)
    as :func:`covers` tests a cone."""
    p, g, _ = gens.shape
    q = len(pa)
    nf = len(faces)
    ok = np.ones(p, dtype=np.bool_)
    normals = np.zeros((2 * q, 3))
    scale = np.empty(g)
    rows = np.empty((2 * q, 3))
    sel = np.empty(2 * q, dtype=np.int64)
    key = np.empty(2 * q)
    qq = np.empty((2 * q, 3))
    order = np.empty(2 * q, dtype=np.int64)
    coef = np.empty((2 * q, 3))
    cur = np.empty((8 + 4 * q, 2))
    buf = np.empty_like(cur)
    f = np.empty(len(cur))
    front = np.empty((g, nf), dtype=np.bool_)
    for i in range(p):
        mixed = False
        for w in range(nf):
            e = FACES[faces[w], 0]
            some, every = False, True
            for k in range(g):
                front[k, w] = dot_matmul(gens[i, k, 0], gens[i, k, 1], gens[i, k, 2],
                                         e[0], e[1], e[2]) > 0.0
                some |= front[k, w]
                every &= front[k, w]
            if some and not every:
                mixed = True
        if mixed:
            normals[:] = 0.0
            rows_in = q
            if _cone_normals(gens[i], pa, pb, 1e-9, normals, scale):
                rows_in = 2 * q
            nz = 0
            for r in range(rows_in):
                if normals[r, 0] != 0.0 or normals[r, 1] != 0.0 or normals[r, 2] != 0.0:
                    nz += 1
            kept = _compact(normals[:rows_in], max(nz, 1), rows, sel, key, qq, order)
            ok[i], cur, buf, f = _cone_covered(rows[:kept], faces, corners, rects, sats,
                                               blocks, h, size, coef, cur, buf, f)
            continue
        for w in range(nf):
            every = True
            for k in range(g):
                every &= front[k, w]
            if not every:
                continue
            fc = faces[w]
            e, u, v = FACES[fc, 0], FACES[fc, 1], FACES[fc, 2]
            lo0, lo1, hi0, hi1 = np.inf, np.inf, -np.inf, -np.inf
            for k in range(g):
                x0, x1, x2 = gens[i, k, 0], gens[i, k, 1], gens[i, k, 2]
                de = dot_matmul(x0, x1, x2, e[0], e[1], e[2])
                s = dot_matvec(x0, x1, x2, u[0], u[1], u[2]) / de
                t = dot_matvec(x0, x1, x2, v[0], v[1], v[2]) / de
                lo0, hi0 = min(lo0, s), max(hi0, s)
                lo1, hi1 = min(lo1, t), max(hi1, t)
            if not (hi0 >= -1.0 and hi1 >= -1.0 and lo0 <= 1.0 and lo1 <= 1.0):
                continue
            if not box_covered(sats[fc], blocks[fc], lo0, lo1, hi0, hi1, h, size):
                ok[i] = False
                break
    return ok


@njit(cache=True)
def mark_cells(poly: np.ndarray, cnt: np.ndarray, h: float, covered: np.ndarray) -> int:
    """Mark in ``covered`` ``(r, r)`` (one face, ``covered[row, col]``; cells ``h`` chart
    units wide from -1) the cells wholly inside each convex polygon ``poly`` ``(p, m, 2)``
    (``cnt`` ``(p,)`` vertices, counter-clockwise). Returns the first row marked (``r`` when
    none).

    Per polygon: a convex polygon holding a cell has inradius at least ``h / 2`` and at most
    ``2 area / perimeter``, so the slivers (most terms) are skipped at once. Otherwise each
    grid line ``y_g`` between the polygon's lowest and highest point meets it in ``[left,
    right]``, found on the edges going down (left chain) and up (right chain); the band
    between two consecutive lines holds ``[max(left), min(right)]`` (convexity), and the
    cells wholly in that span are marked. The same crossings (``x_a + (y - y_a) (x_b - x_a)
    / (y_b - y_a)``) and cell bounds as the numpy version this replaced."""
    r = covered.shape[0]
    first = r
    left = np.empty(r + 1)
    right = np.empty(r + 1)
    for i in range(len(cnt)):
        n = cnt[i]
        if n < 3:
            continue
        area = 0.0
        perim = 0.0
        ylo, yhi = poly[i, 0, 1], poly[i, 0, 1]
        for k in range(n):
            f = k + 1 if k + 1 < n else 0
            ax, ay, bx, by = poly[i, k, 0], poly[i, k, 1], poly[i, f, 0], poly[i, f, 1]
            area += ax * by - ay * bx
            perim += np.sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay))
            ylo, yhi = min(ylo, ay), max(yhi, ay)
        if not 4.0 * (0.5 * abs(area)) >= h * perim:
            continue
        g0 = max(int(np.ceil((ylo + 1.0) / h)), 0)
        g1 = min(int(np.floor((yhi + 1.0) / h)), r)
        if g1 - g0 + 1 < 2:  # a band needs two grid lines inside the polygon
            continue
        for g in range(g0, g1 + 1):
            left[g - g0] = np.inf
            right[g - g0] = -np.inf
        for k in range(n):
            f = k + 1 if k + 1 < n else 0
            xa, ya, xb, yb = poly[i, k, 0], poly[i, k, 1], poly[i, f, 0], poly[i, f, 1]
            if ya == yb:
                continue
            e0 = max(int(np.ceil((min(ya, yb) + 1.0) / h)), g0)
            e1 = min(int(np.floor((max(ya, yb) + 1.0) / h)), g1)
            slope = (xb - xa) / (yb - ya)
            for g in range(e0, e1 + 1):
                x = xa + ((-1.0 + g * h) - ya) * slope
                if yb < ya:
                    left[g - g0] = min(left[g - g0], x)
                else:
                    right[g - g0] = max(right[g - g0], x)
        for g in range(g0, g1):
            lo = max(left[g + 1 - g0], left[g - g0])
            hi = min(right[g + 1 - g0], right[g - g0])
            if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi) or g >= r:
                continue
            c0 = max(int(np.ceil((lo + 1.0) / h)), 0)
            c1 = min(int(np.floor((hi + 1.0) / h)), r)
            if c1 <= c0:
                continue
            for c in range(c0, c1):
                covered[g, c] = True
            first = min(first, g)
    return first


@njit(cache=True)
def open_window(covered: np.ndarray, row0: int, row1: int, col0: int, col1: int,
                margin: float) -> tuple[bool, float, float, float, float]:
    """:func:`ndbg_cli.ndbg.infinite.cover.cells_window` of the cells not ``covered`` (``(r, r)``,
    one face) in the block ``row0:row1, col0:col1`` (every other cell covered): ``(found, x0, y0,
    x1, y1)``, the chart rectangle on cell boundaries, ``margin`` (the chart square's half side)
    where it reaches the face's border."""
    r = covered.shape[0]
    h = 2.0 / r
    lo_r, hi_r, lo_c, hi_c = r, -1, r, -1
    for y in range(row0, row1):
        for x in range(col0, col1):
            if not covered[y, x]:
                lo_r, hi_r = min(lo_r, y), max(hi_r, y)
                lo_c, hi_c = min(lo_c, x), max(hi_c, x)
    if hi_r < 0:
        return False, 0.0, 0.0, 0.0, 0.0
    x0 = -margin if lo_c == 0 else -1.0 + lo_c * h
    y0 = -margin if lo_r == 0 else -1.0 + lo_r * h
    x1 = margin if hi_c + 1 == r else -1.0 + (hi_c + 1) * h
    y1 = margin if hi_r + 1 == r else -1.0 + (hi_r + 1) * h
    return True, x0, y0, x1, y1


@njit(cache=True)
def window_pyramid(face: int, x0: float, y0: float, x1: float, y1: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The chart rectangle ``x0..x1, y0..y1`` of ``face`` as a cone: its corner directions
    ``(4, 3)`` (in turn round it) and the inward normals of its sides ``(4, 3)`` (the cross
    products of consecutive corners, signed to hold the rectangle's centre), as
    :meth:`ndbg_cli.ndbg.infinite.cover.Cover._window_pyramid` computed them with numpy."""
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]
    corners = np.empty((4, 3))
    sides = np.empty((4, 3))
    xs = (x0, x1, x1, x0)
    ys = (y0, y0, y1, y1)
    cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
    centre = np.empty(3)
    for k in range(3):
        centre[k] = (e[k] + cx * u[k]) + cy * v[k]
    for c in range(4):
        for k in range(3):
            corners[c, k] = (e[k] + xs[c] * u[k]) + ys[c] * v[k]
    for c in range(4):
        a0, a1, a2 = corners[c, 0], corners[c, 1], corners[c, 2]
        n = (c + 1) % 4
        b0, b1, b2 = corners[n, 0], corners[n, 1], corners[n, 2]
        s0 = a1 * b2 - a2 * b1
        s1 = a2 * b0 - a0 * b2
        s2 = a0 * b1 - a1 * b0
        d = dot_matvec(s0, s1, s2, centre[0], centre[1], centre[2])
        sg = 1.0 if d > 0 else (-1.0 if d < 0 else 0.0)
        sides[c, 0], sides[c, 1], sides[c, 2] = s0 * sg, s1 * sg, s2 * sg
    return corners, sides
