"""Compiled kernels (numba) of the narrow phase's triangle predicates, row by row: the point
of a triangle closest to a point (Ericson, *Real-Time Collision Detection* 5.1.5), the
closest points of two segments (5.1.9), the distance of two triangles with its direction and
midpoint, the separating-axis gap of two triangles (the 11 axes of the triangle-triangle
test), and the filter of candidate pairs by the two triangles' planes.
:mod:`ndbg_cli.contacts.facets` and :func:`ndbg_cli.contacts.contacts3d._plane_filter` wrap
them and document what each means.

Why compiled: the contact pairs call them tens of thousands of times on a few rows each
(the engine GLB: 20,000 triangle pairs' distances in 150 calls), where numpy's cost per
call, not per row, dominated (benchmarks/NOTES.md, stop 56).

The arithmetic is numpy's, operation by operation, so that the contacts found do not
change: a sum of three products is ``0 + ((p0 + p2) + p1)`` (the order of numpy's
``einsum("ij,ij->i")``, whose results these replace), a length ``sqrt((x0^2 + x1^2) +
x2^2)`` (``np.linalg.norm``'s), a clamp to ``[0, 1]`` that of ``np.clip`` (a NaN quotient
of ``0 / 0`` first made 0, as ``np.nan_to_num`` did). Numba compiles without fast-math or
fused multiply-adds. A division by zero, where the numpy code let IEEE arithmetic give an
infinity or a NaN, is spelled out (:func:`_quotient`): compiled code would raise there.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "closest_on_triangle": "f8[:,::1](f8[:,::1],f8[:,:,::1])",
    "segment_closest": "Tuple((f8[:,::1],f8[:,::1]))(f8[:,::1],f8[:,::1],f8[:,::1],"
                       "f8[:,::1])",
    "triangle_gap": "Tuple((f8[::1],f8[:,::1],f8[:,::1]))(f8[:,:,::1],f8[:,:,::1])",
    "sat_gap": "f8[::1](f8[:,:,::1],f8[:,:,::1])",
    "plane_filter": "Tuple((i8[::1],f8[::1],f8[::1]))(f8[:,:,::1],f8[:,::1],f8[::1],"
                    "f8[:,:,::1],f8[:,::1],f8[::1],i8[::1],i8[::1],f8)",
}


@njit(cache=True)
def _dot(x0, x1, x2, y0, y1, y2):
    """``x . y`` summed in numpy ``einsum``'s order."""
    return 0.0 + ((x0 * y0 + x2 * y2) + x1 * y1)


@njit(cache=True)
def _length(x0, x1, x2):
    """``|x|`` as ``np.linalg.norm`` sums it."""
    return math.sqrt((x0 * x0 + x1 * x1) + x2 * x2)


@njit(cache=True)
def _quotient(x, y):
    """``x / y`` in IEEE arithmetic, ``y`` zero included (an infinity signed by ``x`` and
    the sign of the zero ``y``, or NaN for ``0 / 0``)."""
    if y != 0.0:
        return x / y
    if x != x or x == 0.0:
        return np.nan
    if (x > 0.0) != (math.copysign(1.0, y) < 0.0):
        return np.inf
    return -np.inf


@njit(cache=True)
def _clip(x):
    """``np.clip(x, 0, 1)``: a NaN stays NaN, and -0.0 stays -0.0 (numpy's comparison)."""
    if x != x:
        return x
    x = x if x >= 0.0 else 0.0
    return x if x <= 1.0 else 1.0


@njit(cache=True)
def _unit_clip(x):
    """``np.clip(np.nan_to_num(x), 0, 1)``."""
    return _clip(0.0 if x != x else x)


@njit(cache=True)
def _along_edges(ab0, ab1, ab2, ac0, ac1, ac2, p, v):
    """``(ab . (p - v), ac . (p - v))``: where ``p`` lies along the edges AB and AC, seen
    from the vertex ``v``."""
    w0, w1, w2 = p[0] - v[0], p[1] - v[1], p[2] - v[2]
    return _dot(ab0, ab1, ab2, w0, w1, w2), _dot(ac0, ac1, ac2, w0, w1, w2)


@njit(cache=True)
def _closest(p, t, out):
    """Ericson's closest point of triangle ``t`` ``(3, 3)`` to ``p`` ``(3,)``, into ``out``:
    the regions tested in order vertex A, B, C, edge AB, AC, BC, else the interior."""
    a0, a1, a2 = t[0, 0], t[0, 1], t[0, 2]
    b0, b1, b2 = t[1, 0], t[1, 1], t[1, 2]
    c0, c1, c2 = t[2, 0], t[2, 1], t[2, 2]
    ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
    ac0, ac1, ac2 = c0 - a0, c1 - a1, c2 - a2
    d1, d2 = _along_edges(ab0, ab1, ab2, ac0, ac1, ac2, p, t[0])
    if d1 <= 0 and d2 <= 0:
        out[:] = t[0]
        return
    d3, d4 = _along_edges(ab0, ab1, ab2, ac0, ac1, ac2, p, t[1])
    if d3 >= 0 and d4 <= d3:
        out[:] = t[1]
        return
    d5, d6 = _along_edges(ab0, ab1, ab2, ac0, ac1, ac2, p, t[2])
    if d6 >= 0 and d5 <= d6:
        out[:] = t[2]
        return
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    if vc <= 0 and d1 >= 0 and d3 <= 0:
        e = _unit_clip(_quotient(d1, d1 - d3))
        out[0], out[1], out[2] = a0 + ab0 * e, a1 + ab1 * e, a2 + ab2 * e
        return
    if vb <= 0 and d2 >= 0 and d6 <= 0:
        e = _unit_clip(_quotient(d2, d2 - d6))
        out[0], out[1], out[2] = a0 + ac0 * e, a1 + ac1 * e, a2 + ac2 * e
        return
    if va <= 0 and d4 - d3 >= 0 and d5 - d6 >= 0:
        e = _unit_clip(_quotient(d4 - d3, (d4 - d3) + (d5 - d6)))
        out[0] = b0 + (c0 - b0) * e
        out[1] = b1 + (c1 - b1) * e
        out[2] = b2 + (c2 - b2) * e
        return
    denom = va + vb + vc
    denom = denom if abs(denom) > 1e-300 else 1e-300
    v, w = vb / denom, vc / denom
    out[0], out[1], out[2] = a0 + ab0 * v + ac0 * w, a1 + ab1 * v + ac1 * w, \
        a2 + ab2 * v + ac2 * w


@njit(cache=True)
def closest_on_triangle(p, t):
    """The point ``(n, 3)`` of each triangle ``t[k]`` closest to ``p[k]``."""
    out = np.empty((len(p), 3))
    for k in range(len(p)):
        _closest(p[k], t[k], out[k])
    return out


@njit(cache=True)
def _segment(p1, q1, p2, q2, c1, c2):
    """The closest points of segments ``p1 q1`` and ``p2 q2`` (each ``(3,)``), into ``c1``
    and ``c2`` (Ericson's clamped parameters; a segment of length 0 is its point)."""
    d10, d11, d12 = q1[0] - p1[0], q1[1] - p1[1], q1[2] - p1[2]
    d20, d21, d22 = q2[0] - p2[0], q2[1] - p2[1], q2[2] - p2[2]
    r0, r1, r2 = p1[0] - p2[0], p1[1] - p2[1], p1[2] - p2[2]
    a = _dot(d10, d11, d12, d10, d11, d12)
    e = _dot(d20, d21, d22, d20, d21, d22)
    f = _dot(d20, d21, d22, r0, r1, r2)
    c = _dot(d10, d11, d12, r0, r1, r2)
    b = _dot(d10, d11, d12, d20, d21, d22)
    a_ = a if a >= 1e-300 else 1e-300
    e_ = e if e >= 1e-300 else 1e-300
    denom = a * e - b * b
    s = 0.0
    if denom > 1e-12 * a_ * e_:
        s = _clip((b * f - c * e) / (denom if denom >= 1e-300 else 1e-300))
    t = (b * s + f) / e_
    if t < 0 or e == 0.0:  # before the end's clamp, or a second segment of length 0
        s = _clip(-c / a_)
    elif t > 1:
        s = _clip((b - c) / a_)
    t = _clip(t)
    c1[0], c1[1], c1[2] = p1[0] + d10 * s, p1[1] + d11 * s, p1[2] + d12 * s
    c2[0], c2[1], c2[2] = p2[0] + d20 * t, p2[1] + d21 * t, p2[2] + d22 * t


@njit(cache=True)
def segment_closest(p1, q1, p2, q2):
    """The closest points ``(n, 3)`` of segments ``p1[k] q1[k]`` and ``p2[k] q2[k]``, on
    each."""
    c1 = np.empty((len(p1), 3))
    c2 = np.empty((len(p1), 3))
    for k in range(len(p1)):
        _segment(p1[k], q1[k], p2[k], q2[k], c1[k], c2[k])
    return c1, c2


@njit(cache=True)
def _pierces(ta, tb):
    """Whether an edge of triangle ``ta`` crosses the plane of ``tb`` strictly (its ends on
    either side) at a point of ``tb``, edges included. A degenerate ``tb`` (no plane) never
    is; an edge touching the plane at an end meets ``tb`` only where the closest-feature
    distance is 0 already."""
    b0 = tb[0]
    u0, u1, u2 = tb[1, 0] - b0[0], tb[1, 1] - b0[1], tb[1, 2] - b0[2]
    v0, v1, v2 = tb[2, 0] - b0[0], tb[2, 1] - b0[1], tb[2, 2] - b0[2]
    n0, n1, n2 = _cross(u0, u1, u2, v0, v1, v2)
    for k in range(3):
        p, q = ta[k], ta[(k + 1) % 3]
        sp = _dot(p[0] - b0[0], p[1] - b0[1], p[2] - b0[2], n0, n1, n2)
        sq = _dot(q[0] - b0[0], q[1] - b0[1], q[2] - b0[2], n0, n1, n2)
        if not sp * sq < 0:
            continue
        h = sp / (sp - sq)
        x0, x1, x2 = p[0] + (q[0] - p[0]) * h, p[1] + (q[1] - p[1]) * h, \
            p[2] + (q[2] - p[2]) * h
        inside = True
        for m in range(3):
            e0, e1 = tb[m], tb[(m + 1) % 3]
            g0, g1, g2 = e1[0] - e0[0], e1[1] - e0[1], e1[2] - e0[2]
            w0, w1, w2 = x0 - e0[0], x1 - e0[1], x2 - e0[2]
            c0, c1, c2 = _cross(g0, g1, g2, w0, w1, w2)
            if not _dot(c0, c1, c2, n0, n1, n2) >= 0:
                inside = False
                break
        if inside:
            return True
    return False


@njit(cache=True)
def triangle_gap(ta, tb):
    """Distance ``(p,)`` of triangles ``ta[k]`` and ``tb[k]``, the unit direction ``(p, 3)``
    from A's closest point to B's and their midpoint ``(p, 3)``: the nearest of the 6
    vertex-triangle and 9 edge-edge candidates (the first of equals, in that order), 0 and
    no direction when the triangles meet."""
    n = len(ta)
    best = np.empty(n)
    direction = np.zeros((n, 3))
    mid = np.empty((n, 3))
    x, y = np.empty(3), np.empty(3)
    pa, pb = np.empty(3), np.empty(3)
    for r in range(n):
        a, b = ta[r], tb[r]
        d_best = np.inf
        pa[:] = 0.0
        pb[:] = 0.0
        for c in range(15):
            if c < 6:
                k = c // 2
                if c % 2 == 0:
                    x[:] = a[k]
                    _closest(a[k], b, y)
                else:
                    _closest(b[k], a, x)
                    y[:] = b[k]
            else:
                k, m = (c - 6) // 3, (c - 6) % 3
                _segment(a[k], a[(k + 1) % 3], b[m], b[(m + 1) % 3], x, y)
            d = _length(y[0] - x[0], y[1] - x[1], y[2] - x[2])
            if d < d_best:
                d_best = d
                pa[:] = x
                pb[:] = y
        meet = d_best <= 0 or _pierces(a, b) or _pierces(b, a)
        best[r] = 0.0 if meet else d_best
        if not meet:
            for i in range(3):
                direction[r, i] = (pb[i] - pa[i]) / d_best
        for i in range(3):
            mid[r, i] = (pa[i] + pb[i]) / 2.0
    return best, direction, mid


@njit(cache=True)
def sat_gap(ta, tb):
    """The largest separation ``(p,)`` of triangles ``ta[k]`` and ``tb[k]`` along the 11
    axes (both normals, the 9 edge-edge cross products) that are not degenerate (an axis
    shorter than 1e-9 of the longest is left out; none left gives -inf)."""
    n = len(ta)
    out = np.empty(n)
    axes = np.empty((11, 3))
    norm = np.empty(11)
    ea, eb = np.empty((3, 3)), np.empty((3, 3))
    u, origin = np.empty(3), np.zeros(3)
    for r in range(n):
        a, b = ta[r], tb[r]
        for k in range(3):
            for d in range(3):
                ea[k, d] = a[(k + 1) % 3, d] - a[k, d]
                eb[k, d] = b[(k + 1) % 3, d] - b[k, d]
        _cross_into(ea[0], ea[1], axes[0])
        _cross_into(eb[0], eb[1], axes[1])
        for k in range(3):
            for m in range(3):
                _cross_into(ea[k], eb[m], axes[2 + 3 * k + m])
        scale = -np.inf
        for k in range(11):
            norm[k] = _length(axes[k, 0], axes[k, 1], axes[k, 2])
            scale = norm[k] if norm[k] > scale else scale
        scale = scale if scale >= 1e-300 else 1e-300
        gap = -np.inf
        for k in range(11):
            if not norm[k] > 1e-9 * scale:
                continue
            for d in range(3):
                u[d] = axes[k, d] / norm[k]
            lo_a, hi_a = _span(a, origin, u)
            lo_b, hi_b = _span(b, origin, u)
            g1, g2 = lo_b - hi_a, lo_a - hi_b
            g = g1 if g1 > g2 else g2
            gap = g if g > gap else gap
        out[r] = gap
    return out


@njit(cache=True)
def _cross(x0, x1, x2, y0, y1, y2):
    """``x x y`` (``geometry.vectors.cross``'s products and differences)."""
    return x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0


@njit(cache=True)
def _cross_into(x, y, out):
    """:func:`_cross` of the rows ``x`` and ``y``, into ``out``."""
    out[0], out[1], out[2] = _cross(x[0], x[1], x[2], y[0], y[1], y[2])


@njit(cache=True)
def _span(t, p, n):
    """The least and greatest of ``(t[v] - p) . n`` over the 3 vertices of ``t`` (with ``p``
    zero, the triangle's extent along ``n``: ``t[v] - 0`` is ``t[v]`` to the bit)."""
    s0 = _dot(t[0, 0] - p[0], t[0, 1] - p[1], t[0, 2] - p[2], n[0], n[1], n[2])
    s1 = _dot(t[1, 0] - p[0], t[1, 1] - p[1], t[1, 2] - p[2], n[0], n[1], n[2])
    s2 = _dot(t[2, 0] - p[0], t[2, 1] - p[1], t[2, 2] - p[2], n[0], n[1], n[2])
    lo = s0 if s0 < s1 else s1
    hi = s0 if s0 > s1 else s1
    return (lo if lo < s2 else s2), (hi if hi > s2 else s2)


@njit(cache=True)
def plane_filter(tri_a, nrm_a, sag_a, tri_b, nrm_b, sag_b, i, j, tol):
    """The pairs ``k`` of triangles ``i[k]`` of A and ``j[k]`` of B that no plane of either
    separates by more than ``g = tol + sag_a[i] + sag_b[j]`` (B's vertices against A's
    plane first, then A's against B's), with the largest absolute offset of B's vertices
    from A's plane and of A's from B's, for each kept."""
    keep = np.empty(len(i), dtype=np.int64)
    off_b = np.empty(len(i))
    off_a = np.empty(len(i))
    n = 0
    for k in range(len(i)):
        a, b = i[k], j[k]
        g = tol + sag_a[a] + sag_b[b]
        lo, hi = _span(tri_b[b], tri_a[a, 0], nrm_a[a])
        if not (lo <= g and hi >= -g):
            continue
        lo_a, hi_a = _span(tri_a[a], tri_b[b, 0], nrm_b[b])
        if not (lo_a <= g and hi_a >= -g):
            continue
        keep[n] = k
        off_b[n] = max(abs(lo), abs(hi))
        off_a[n] = max(abs(lo_a), abs(hi_a))
        n += 1
    return keep[:n].copy(), off_b[:n].copy(), off_a[:n].copy()
