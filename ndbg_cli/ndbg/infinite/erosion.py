"""The in-plane part of the erosion of near triangle pairs
(:mod:`ndbg_cli.ndbg.infinite.blocking_cones`): each triangle's edges on a convex sharp edge of
its part are moved inward by ``r`` in the triangle's plane, as eroding the solid would.

Moving near triangles only along their normals (``r = 1.5 eps``) does not erode a solid at
its edges: two faces meeting at an angle (an L-shaped corner touching along an edge or at a
point) cross once moved and their term blocks a whole facing quarter of the sphere (the
Fig. 10 latch: latch_b "blocked" latch_a along half of all directions, where the sweep test
and manifold3d find it free). Pulling faces back from convex edges sharper than
:data:`SHARP_DEGREES` keeps them apart; smooth (tessellated) and concave edges are left.
"""

from __future__ import annotations

import numpy as np

#: Dihedral angle (degrees between the two faces' normals) above which an edge is sharp.
SHARP_DEGREES = 30.0


def edge_insets(tri: np.ndarray, nrm: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """For triangles ``tri`` ``(t, 3, 3)`` with unit outward normals ``nrm`` ``(t, 3)`` (one
    part, model units): the displacement of each vertex ``(t, 3, 3)`` that moves every edge
    lying on a convex sharp edge of the part (or on its boundary: an edge no other triangle
    shares) inward by ``r`` in the triangle's plane, and ``(t,)`` whether the triangle is then
    gone (narrower than the inset). Displacements are exactly zero for a triangle with no
    such edge. Edges are matched by their end points' exact coordinates."""
    t = len(tri)
    disp = np.zeros((t, 3, 3))
    gone = np.zeros(t, dtype=bool)
    if not t or r <= 0.0:
        return disp, gone
    a = tri
    b = np.roll(tri, -1, axis=1)  # edge k runs from vertex k to vertex k + 1
    ends = np.stack([a, b], axis=2).reshape(t * 3, 2, 3)
    # an undirected key per edge: its two end points, the lexicographically smaller first
    first, second = ends[:, 0], ends[:, 1]
    less = (first[:, 0] < second[:, 0]) | ((first[:, 0] == second[:, 0]) & (
        (first[:, 1] < second[:, 1]) | ((first[:, 1] == second[:, 1])
                                        & (first[:, 2] <= second[:, 2]))))
    lo = np.where(less[:, None], first, second)
    hi = np.where(less[:, None], second, first)
    key = np.ascontiguousarray(np.concatenate([lo, hi], axis=1))
    _, inv, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    owner = np.arange(t * 3) // 3
    # the other triangle on each edge shared by exactly two
    order = np.argsort(inv, kind="stable")
    other = np.full(t * 3, -1)
    grp = inv[order]
    pair = np.flatnonzero((grp[1:] == grp[:-1]) & (counts[grp[1:]] == 2))
    other[order[pair]] = owner[order[pair + 1]]
    other[order[pair + 1]] = owner[order[pair]]
    inset = np.zeros(t * 3, dtype=bool)
    boundary = counts[inv] == 1
    inset |= boundary
    shared = other >= 0
    k = np.flatnonzero(shared)
    n1, n2 = nrm[owner[k]], nrm[other[k]]
    sharp = (n1 * n2).sum(axis=1) < np.cos(np.radians(SHARP_DEGREES))
    # convex: the other triangle lies behind this one's plane
    third = tri[other[k]].mean(axis=1)
    convex = ((third - ends[k, 0]) * n1).sum(axis=1) < 0.0
    inset[k] = sharp & convex
    off = np.where(inset, r, 0.0).reshape(t, 3)
    has = off.any(axis=1)
    if not has.any():
        return disp, gone
    s = np.flatnonzero(has)
    p, n, o = tri[s], nrm[s], off[s]
    e = np.roll(p, -1, axis=1) - p  # (m, 3, 3) edges
    m = np.cross(n[:, None, :], e)  # in-plane normals, inward for counter-clockwise
    ln = np.linalg.norm(m, axis=2)
    bad = (ln <= 0.0).any(axis=1)
    m = m / np.where(ln > 0.0, ln, 1.0)[:, :, None]
    # vertex k lies on edges k - 1 and k: x = s m_{k-1} + u m_k with m_{k-1}.x = o_{k-1} and
    # m_k.x = o_k
    mp, op = np.roll(m, 1, axis=1), np.roll(o, 1, axis=1)
    c = (mp * m).sum(axis=2)
    det = 1.0 - c * c
    bad |= (det <= 1e-12).any(axis=1)
    det = np.where(det > 1e-12, det, 1.0)
    sa = (op - c * o) / det
    ua = (o - c * op) / det
    x = sa[:, :, None] * mp + ua[:, :, None] * m
    new = p + x
    # empty when a new vertex lies outside the third (moved) edge's line: the inset is wider
    # than the triangle there
    out = ((new - np.roll(p, -1, axis=1)) * np.roll(m, -1, axis=1)).sum(axis=2) \
        < np.roll(o, -1, axis=1) - 1e-9 * r
    area = (np.cross(new[:, 1] - new[:, 0], new[:, 2] - new[:, 0]) * n).sum(axis=1)
    dead = bad | out.any(axis=1) | (area <= 0.0)
    disp[s] = np.where(dead[:, None, None], 0.0, x)
    gone[s] = dead
    return disp, gone
