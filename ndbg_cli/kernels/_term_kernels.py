"""Compiled kernels (numba) of the terms of ``B_ij``
(:func:`ndbg_cli.ndbg.infinite.blocking_cones.terms`): which triangle pairs can face each other
(:func:`facing_pairs`), then (:func:`terms`), per triangle pair, the generators, the cover's quick
window tests, the facets, their compaction and the flat test, one pair at a time with no
intermediate arrays. The same operations in the same order as the batched numpy and kernel code it
replaces (see :mod:`ndbg_cli.kernels._cone_kernels`), so each kept cone has the same nonzero rows,
bit for bit, in the same order; only where the zero padding sits differs (after the facing rows
here, before them there), which no consumer of a cone reads.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._cone_kernels import _compact, _cone_normals, dot_einsum
from ._cover_kernels import covers_spanned, open_misses, spanned_misses

#: The entry points and their one signature, for the build ahead of time
#: (:mod:`ndbg_cli.kernels.compiled`): what the callers pass, C-contiguous.
EXPORTS = {
    "terms": "Tuple((f8[:,:,::1],i8))(f8[:,:,::1],f8[:,::1],f8[:,:,::1],f8[:,::1],i8[::1],"
             "i8[::1],b1[::1],f8,i8[::1],i8[::1],f8,f8,b1,f8[:,:,::1],f8[:,:,::1],f8[:,:,::1],"
             "b1[::1],f8[:,:,::1],b1[::1])",
    "facing_pairs": "UniTuple(b1[::1],2)(f8[:,:,::1],f8[:,::1],f8[:,:,::1],f8[:,::1],i8[::1],"
                    "i8[::1],f8,f8[:,::1],f8[:,::1],f8[:,::1],f8[:,::1])",
    "prune_pairs": "Tuple((b1[::1],i8))(i8[::1],i8[::1],f8[:,::1],f8[:,::1],f8[:,::1],"
                   "f8[:,::1],f8,i8[::1],i8[::1],Tuple((i8[::1],f8[:,:,::1],f8[:,::1],"
                   "i4[:,:,::1],i8[:,::1],f8,i8)),b1,Tuple((i8[::1],f8[:,:,::1],f8[:,::1],"
                   "i4[:,:,::1],i8[:,::1],f8,i8)),b1)",
}


@njit(cache=True)
def terms(ti: np.ndarray, ni: np.ndarray, tj: np.ndarray, nj: np.ndarray, ia: np.ndarray,
          jb: np.ndarray, near: np.ndarray, eps: float, pa: np.ndarray, pb: np.ndarray,
          rel_tol: float, flat_tol: float, use_cover: bool, corners: np.ndarray,
          sides: np.ndarray, di: np.ndarray, gi: np.ndarray, dj: np.ndarray,
          gj: np.ndarray) -> tuple[np.ndarray, int]:
    """The open cones of the triangle pairs ``(ti[ia[k]], tj[jb[k]])`` (those given can face
    each other), in the order given: ``(p, w, 3)`` and their number ``p`` (rows past it
    unused).

    Pair ``k``'s generators are ``tj[jb[k], v] - ti[ia[k], w]`` (index ``3 v + w``), both triangles
    moved inward by ``1.5 eps`` along their normals when ``near[k]``, and their vertices by ``di``,
    ``dj`` ``(t, 3, 3)`` in their planes (:mod:`ndbg_cli.ndbg.infinite.erosion`; a near pair with a
    triangle ``gi`` / ``gj`` gone has no term); its facing half-spaces are ``ni[ia[k]]`` and
    ``-nj[jb[k]]``. With ``use_cover`` a pair is dropped when it misses every window (corner
    directions ``corners`` ``(nw, 4, 3)``, inward side normals ``sides``), first on its generators
    and facing half-spaces (:func:`ndbg_cli.kernels._cover_kernels.spanned_misses`), then on
    its facets and facing half-spaces (:func:`ndbg_cli.kernels._cover_kernels.open_misses`).
    The facets are the candidates ``pa``, ``pb``
    (:func:`ndbg_cli.kernels._cone_kernels.cone_normals`, ``rel_tol``), compacted
    (:func:`ndbg_cli.kernels._cone_kernels.compact`); a cone with two rows ``m . m' <= -1 +
    flat_tol`` (:func:`ndbg_cli.kernels._cone_kernels.flat`) is dropped. Two such cones are known
    early and dropped then, the same ones: facing rows anti-parallel (parallel faces facing the same
    way, as in a row of identical bolts: up to half of some pairs' terms), and every generator in
    one candidate's plane (its rows ``n`` and ``-n``)."""
    n = len(ia)
    q = len(pa)
    width = 2 * q + 2
    out = np.zeros((n, width, 3))
    gens = np.empty((9, 3))
    facing = np.empty((2, 3))
    normals = np.zeros((2 * q, 3))
    scale = np.empty(9)
    rows = np.empty((2 * q, 3))
    sel = np.empty(2 * q, dtype=np.int64)
    key = np.empty(2 * q)
    qq = np.empty((2 * q, 3))
    order = np.empty(2 * q, dtype=np.int64)
    cone = np.empty((width, 3))
    grow = 1.5 * eps
    p = 0
    used = 1
    for k in range(n):
        a, b = ia[k], jb[k]
        # faces meeting at an angle (not opposed within 45 degrees) move in their planes too
        inset = near[k] and dot_einsum(ni[a, 0], ni[a, 1], ni[a, 2],
                                       nj[b, 0], nj[b, 1], nj[b, 2]) > -0.7071067811865476
        if inset and (gi[a] or gj[b]):
            continue
        # facing rows n_i and -n_j anti-parallel (parallel faces facing the same way): the
        # flat test below would drop the cone, whatever its facets
        if dot_einsum(ni[a, 0], ni[a, 1], ni[a, 2],
                      -nj[b, 0], -nj[b, 1], -nj[b, 2]) <= -1.0 + flat_tol:
            continue
        if near[k]:
            s0 = grow * (ni[a, 0] - nj[b, 0])
            s1 = grow * (ni[a, 1] - nj[b, 1])
            s2 = grow * (ni[a, 2] - nj[b, 2])
        for v in range(3):
            for w in range(3):
                g = 3 * v + w
                if inset:
                    gens[g, 0] = (tj[b, v, 0] + dj[b, v, 0]) - (ti[a, w, 0] + di[a, w, 0])
                    gens[g, 1] = (tj[b, v, 1] + dj[b, v, 1]) - (ti[a, w, 1] + di[a, w, 1])
                    gens[g, 2] = (tj[b, v, 2] + dj[b, v, 2]) - (ti[a, w, 2] + di[a, w, 2])
                else:
                    gens[g, 0] = tj[b, v, 0] - ti[a, w, 0]
                    gens[g, 1] = tj[b, v, 1] - ti[a, w, 1]
                    gens[g, 2] = tj[b, v, 2] - ti[a, w, 2]
                if near[k]:
                    gens[g, 0] = gens[g, 0] + s0
                    gens[g, 1] = gens[g, 1] + s1
                    gens[g, 2] = gens[g, 2] + s2
        facing[0, 0], facing[0, 1], facing[0, 2] = ni[a, 0], ni[a, 1], ni[a, 2]
        facing[1, 0], facing[1, 1], facing[1, 2] = -nj[b, 0], -nj[b, 1], -nj[b, 2]
        if use_cover and spanned_misses(gens, facing, corners, sides):
            continue
        normals[:] = 0.0
        if _cone_normals(gens, pa, pb, rel_tol, normals, scale):
            # every generator in one plane: rows n and -n, anti-parallel, so flat
            continue
        if use_cover and open_misses(normals, facing, corners):
            continue
        nz = 0
        for r in range(2 * q):
            if normals[r, 0] != 0.0 or normals[r, 1] != 0.0 or normals[r, 2] != 0.0:
                nz += 1
        kept = _compact(normals, max(nz, 1), rows, sel, key, qq, order)
        m = kept + 2
        for r in range(kept):
            cone[r, 0], cone[r, 1], cone[r, 2] = rows[r, 0], rows[r, 1], rows[r, 2]
        for r in range(2):
            cone[kept + r, 0] = facing[r, 0]
            cone[kept + r, 1] = facing[r, 1]
            cone[kept + r, 2] = facing[r, 2]
        lim = -1.0 + flat_tol
        is_flat = False
        for x in range(m):
            for y in range(m):
                if dot_einsum(cone[x, 0], cone[x, 1], cone[x, 2],
                              cone[y, 0], cone[y, 1], cone[y, 2]) <= lim:
                    is_flat = True
                    break
            if is_flat:
                break
        if is_flat:
            continue
        for r in range(m):
            out[p, r, 0], out[p, r, 1], out[p, r, 2] = cone[r, 0], cone[r, 1], cone[r, 2]
        used = max(used, m)
        p += 1
    return out[:p, :used].copy(), p


@njit(cache=True)
def facing_pairs(ti: np.ndarray, ni: np.ndarray, tj: np.ndarray, nj: np.ndarray,
                 ia: np.ndarray, jb: np.ndarray, eps: float, lo_i: np.ndarray,
                 hi_i: np.ndarray, lo_j: np.ndarray, hi_j: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """For the triangle pairs ``(ti[ia[k]], tj[jb[k]])`` (triangles ``(n, 3, 3)``, unit
    normals ``(n, 3)``, model units): ``(p,)`` whether they can face each other (some vertex
    of each in front of the other's plane by more than ``-2 eps``) and ``(p,)`` whether their
    bounding boxes (``lo_*``, ``hi_*`` ``(n, 3)``) are within ``4 eps`` (gap: the largest
    separation along an axis)."""
    p = len(ia)
    keep = np.zeros(p, dtype=np.bool_)
    near = np.zeros(p, dtype=np.bool_)
    lim = -2 * eps
    for k in range(p):
        a, b = ia[k], jb[k]
        na0, na1, na2 = ni[a, 0], ni[a, 1], ni[a, 2]
        nb0, nb1, nb2 = nj[b, 0], nj[b, 1], nj[b, 2]
        oi = dot_einsum(na0, na1, na2, ti[a, 0, 0], ti[a, 0, 1], ti[a, 0, 2])
        oj = dot_einsum(nb0, nb1, nb2, tj[b, 0, 0], tj[b, 0, 1], tj[b, 0, 2])
        fj = False
        fi = False
        for v in range(3):
            if dot_einsum(na0, na1, na2, tj[b, v, 0], tj[b, v, 1], tj[b, v, 2]) - oi > lim:
                fj = True
            if dot_einsum(nb0, nb1, nb2, ti[a, v, 0], ti[a, v, 1], ti[a, v, 2]) - oj > lim:
                fi = True
        keep[k] = fj and fi
        gap = -np.inf
        for x in range(3):
            gap = max(gap, max(lo_j[b, x] - hi_i[a, x], lo_i[a, x] - hi_j[b, x]))
        near[k] = gap <= 4 * eps
    return keep, near


@njit(cache=True)
def prune_pairs(a: np.ndarray, b: np.ndarray, lo_i: np.ndarray, hi_i: np.ndarray,
                lo_j: np.ndarray, hi_j: np.ndarray, eps: float, pa: np.ndarray,
                pb: np.ndarray, cover: tuple, use_cover: bool, outside: tuple,
                use_outside: bool) -> tuple[np.ndarray, int]:
    """Which node pairs ``(a[k], b[k])`` of two triangle trees (node boxes ``lo_*``,
    ``hi_*`` ``(nodes, 3)``, model units) a pruning walk keeps
    (:meth:`ndbg_cli.ndbg.infinite.blocking_cones._Walk.prune`), and how many far pairs it tested.

    A pair's box cone is spanned by the 8 corners of the box of differences grown by ``2 eps``.
    Pairs whose grown box holds the origin are kept. Far pairs (gap above ``4 eps``) are dropped
    when ``cover`` covers their box cone, near ones when ``outside`` does (the domain alone), each
    when its ``use_*`` is set: :func:`~ndbg_cli.kernels._cover_kernels.covers_spanned` with
    the generator pairs ``pa``, ``pb`` and the cover's windows ``(faces, corners, rects, sats,
    blocks, h, size)``."""
    p = len(a)
    keep = np.ones(p, dtype=np.bool_)
    grow = 2.0 * eps
    gens = np.empty((p, 8, 3))
    far = np.zeros(p, dtype=np.bool_)
    test = np.zeros(p, dtype=np.bool_)
    nfar = 0
    for k in range(p):
        i, j = a[k], b[k]
        around = True
        gap = -np.inf
        for x in range(3):
            lo = lo_j[j, x] - hi_i[i, x] - grow
            hi = hi_j[j, x] - lo_i[i, x] + grow
            around &= (lo < 0) & (hi > 0)
            gap = max(gap, max(lo_j[j, x] - hi_i[i, x], lo_i[i, x] - hi_j[j, x]))
            for c in range(8):  # corner c takes the high end on axis x when bit (2 - x) is set
                gens[k, c, x] = hi if (c >> (2 - x)) & 1 else lo
        if around:
            continue
        far[k] = gap > 4 * eps
        if far[k]:
            nfar += 1
        test[k] = use_cover if far[k] else use_outside
    for which in (True, False):
        sel = np.flatnonzero(test & (far == which))
        if not len(sel):
            continue
        faces, corners, rects, sats, blocks, h, size = cover if which else outside
        drop = covers_spanned(gens[sel], pa, pb, faces, corners, rects, sats, blocks, h, size)
        for t in range(len(sel)):
            if drop[t]:
                keep[sel[t]] = False
    return keep, nfar
