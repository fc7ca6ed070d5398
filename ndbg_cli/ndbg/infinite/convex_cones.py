"""Convex parts far apart: ``B_ij`` is one open cone, spanned by the Minkowski difference ``P_j -
P_i = conv(V_j - V_i)`` (:func:`convex_pair_cone`), instead of the union of the triangle pairs'
terms (:mod:`ndbg_cli.ndbg.infinite.blocking_cones`): the same set, far cheaper. Which pairs qualify
(:func:`far_convex`: closed convex parts whose bounding boxes are more than ``4 eps`` apart, with
few enough difference vectors), their cones (:func:`convex_pairs`) and their chart entries
(:func:`convex_entries`).
"""

from __future__ import annotations

import numpy as np

from .blocking_cones import stack_cones
from .chart_union import face_polygons

#: Most difference vectors (``|V_i| |V_j|``, each costing time) of a convex pair's cone
#: (:func:`convex_pair_cone`); pairs of larger parts go through the terms.
CONVEX_DIFFERENCES = 1_000_000
#: A convex pair's cone is accepted when every difference vector is inside it within this
#: (radians, about); else (qhull rounding with a gap tiny against the parts) the terms decide.
CONVEX_CHECK = 1e-9
#: Most triangles of a part tested for convexity (:func:`is_convex`; the test is
#: ``O(triangles x vertices)``).
CONVEX_TRIANGLES = 4096


def is_convex(tri: np.ndarray, nrm: np.ndarray, rel_tol: float = 1e-9) -> bool:
    """Whether the closed triangle mesh ``tri`` ``(t, 3, 3)`` (unit outward normals ``nrm``
    ``(t, 3)``) bounds a convex solid: every vertex lies behind every triangle's plane, within
    ``rel_tol`` times the mesh's bounding-box diagonal (float rounding only: a dent of any
    depth above that makes the part non-convex). Parts of more than
    :data:`CONVEX_TRIANGLES` triangles are not tested (``False``)."""
    if not len(tri) or len(tri) > CONVEX_TRIANGLES:
        return False
    v = np.unique(tri.reshape(-1, 3), axis=0)
    tol = rel_tol * float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))
    off = np.einsum("tk,tk->t", nrm, tri[:, 0])
    for s in range(0, len(tri), 256):
        if np.any(v @ nrm[s:s + 256].T - off[s:s + 256] > tol):
            return False
    return True


def convex_pair_cone(vi: np.ndarray, vj: np.ndarray, eps: float) -> np.ndarray | None:
    """``B_ij`` of two convex parts (vertices ``vi`` ``(a, 3)`` moving, ``vj`` ``(b, 3)``
    blocking) whose bounding boxes are more than ``4 eps`` apart: the one open cone
    ``(1, k, 3)`` spanned by the Minkowski difference ``P_j - P_i = conv(vj - vi)``, or
    ``None`` when the boxes are closer, there are more than :data:`CONVEX_DIFFERENCES`
    difference vectors, or the hull fails its check (:data:`CONVEX_CHECK`): use the terms.
    Both parts must be closed and consistently wound (:func:`is_convex` assumes it).

    Exact, and the same set as the union of the terms: every triangle pair is far (no
    erosion), the closure of the union of the terms is the radial projection of the
    Minkowski difference, and its interior is the open cone. No contact circles."""
    lo_i, hi_i = vi.min(axis=0), vi.max(axis=0)
    lo_j, hi_j = vj.min(axis=0), vj.max(axis=0)
    ahead, behind = lo_j - hi_i, lo_i - hi_j
    gap = np.maximum(ahead, behind)
    k = int(np.argmax(gap))
    if gap[k] <= 4 * eps:
        return None
    if len(vi) * len(vj) > CONVEX_DIFFERENCES:
        return None
    c = np.zeros(3)
    c[k] = 1.0 if ahead[k] >= behind[k] else -1.0
    d = (vj[:, None, :] - vi[None, :, :]).reshape(-1, 3)
    u = np.roll(c, 1)
    w = np.cross(c, u)  # (u, w, c) right-handed
    h = d / (d @ c)[:, None]  # on the plane c . x = 1 (every d . c >= gap > 0)
    st = np.stack([h @ u, h @ w], axis=1)
    from scipy.spatial import ConvexHull

    try:
        hull = ConvexHull(st)
    except Exception:  # degenerate (flat) difference: let the terms decide
        return None
    ring = st[hull.vertices]  # counter-clockwise in (u, w)
    p = c + ring[:, :1] * u + ring[:, 1:] * w
    m = np.cross(p, np.roll(p, -1, axis=0))  # (u, w, c) right-handed, ring ccw: inward
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    # qhull works at the projected scale (up to size / gap): every generator must be inside
    if (d @ m.T).min() < -CONVEX_CHECK * np.linalg.norm(d, axis=1).max():
        return None
    return m[None]


def far_convex(tris: list[tuple[np.ndarray, np.ndarray]], closed: list[bool], eps: float
               ) -> tuple[list[np.ndarray | None], np.ndarray]:
    """Which pairs of parts take the convex route: the vertices of each closed
    (``closed``: watertight, consistently wound) convex part (``None`` for the others), and
    the unordered pairs ``(i, j)``, ``i < j`` (``(k, 2)``) of such parts whose bounding boxes
    are more than ``4 eps`` apart with at most :data:`CONVEX_DIFFERENCES` difference vectors:
    those :func:`convex_pair_cone` takes, unless its hull check fails. ``tris``: triangles
    and normals per part, as :func:`part_triangles`."""
    verts = [np.unique(t.reshape(-1, 3), axis=0) if ok and is_convex(t, nrm) else None
             for (t, nrm), ok in zip(tris, closed)]
    idx = np.array([k for k, v in enumerate(verts) if v is not None], dtype=np.int64)
    if len(idx) < 2:
        return verts, np.zeros((0, 2), dtype=np.int64)
    lo = np.array([verts[k].min(axis=0) for k in idx])
    hi = np.array([verts[k].max(axis=0) for k in idx])
    nv = np.array([len(verts[k]) for k in idx], dtype=float)
    gap = np.maximum(lo[None] - hi[:, None], lo[:, None] - hi[None]).max(axis=2)
    ok = np.triu((gap > 4 * eps) & (nv[:, None] * nv[None, :] <= CONVEX_DIFFERENCES), k=1)
    a, b = np.nonzero(ok)
    return verts, np.stack([idx[a], idx[b]], axis=1)


def convex_pairs(tris: list[tuple[np.ndarray, np.ndarray]], sizes: list[int], eps: float,
                 closed: list[bool]) -> dict[tuple[int, int], np.ndarray]:
    """The cones of :func:`convex_pair_cone` for every unordered pair of parts that has one
    (:func:`far_convex`), keyed by the ordered pair ``(a, b)`` computed (the part with fewer
    triangles, ``sizes``, moving: the orientation :func:`ndbg_cli.ndbg.infinite.build.blocked_sets`
    computes)."""
    verts, pairs = far_convex(tris, closed, eps)
    out: dict[tuple[int, int], np.ndarray] = {}
    for i, j in pairs.tolist():
        a, b = (i, j) if sizes[i] <= sizes[j] else (j, i)
        cone = convex_pair_cone(verts[a], verts[b], eps)
        if cone is not None:
            out[(a, b)] = cone
    return out


def convex_entries(cones: list[np.ndarray]) -> list[list[tuple | None]]:
    """:func:`~ndbg_cli.ndbg.infinite.chart_union.cones_to_face_geoms` of many one-cone sets
    (``(1, k, 3)`` each), clipped all at once. The union of one convex piece is the piece and
    needs no boxes: the entries are ``(polygon, None, [0])``."""
    out: list[list[tuple | None]] = [[None] * 6 for _ in cones]
    if not cones:
        return out
    stacked = stack_cones(cones)
    for face in range(6):
        # a cone of k facets clips the chart square to at most k + 4 vertices
        polys, index = face_polygons(stacked, face, max_vertices=stacked.shape[1] + 4)
        for g, k in zip(polys, index):
            out[k][face] = (g, None, np.zeros(1, dtype=np.int64))
    return out
