"""Directions merged within an angular tolerance: :func:`merge_directions` (the NDBG's
circles, the contacts' normals through :func:`ndbg_cli.geometry.normals.cluster_normals`) and
the frames :func:`circle_frames` measures angles in.

Directions within ``tol`` are grouped by single linkage (:func:`cluster_labels`), and a group
that chained wider than ``tol`` (a finely tessellated cylinder's facet normals, each within
it of the next) is cut into pieces whose members lie within ``tol`` of their mean
(:func:`_cut`). Groups and pieces depend on the set of directions only: not on their order
(the parts' order), their signs or the frame (issue 34).
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..core.constants import ANGLE_TOL_RAD
from .vectors import close_pairs, cross, unique_rows, unit

__all__ = ["TWO_PI", "chord", "circle_frames", "cluster_labels", "merge_directions"]

TWO_PI = 2.0 * np.pi
#: Up to this many distinct points, :func:`cluster_labels` compares all pairs directly.
_DENSE = 64


def cluster_labels(points: np.ndarray, radius: float) -> np.ndarray:
    """Single-linkage cluster label of each row of ``points`` (Euclidean ``radius``), in order
    of first appearance: the connected components of the graph of the pairs within
    ``radius`` (:func:`merge_directions`' groups, and the arrangement's merged vertices)."""
    if len(points) == 0:
        return np.zeros(0, dtype=np.int64)
    # Repeated points (shared CAD normals) first collapse exactly: query_pairs would list
    # every pair of copies.
    r = np.round(points, 12)
    first, inv = unique_rows(r)
    m = len(first)
    if m <= _DENSE:
        # a few points (one contact's normals): all distances and a min-label propagation
        # cost less than a k-d tree and a sparse graph, and give the same components
        u = r[first]
        near = ((u[:, None, :] - u[None, :, :]) ** 2).sum(axis=2) <= radius * radius
        labels = np.arange(m)
        while True:
            new = np.where(near, labels[None, :], m).min(axis=1)
            if (new == labels).all():
                break
            labels = new
        return _first_seen(labels[inv])
    p, q = close_pairs(r[first], radius)
    graph = coo_matrix((np.ones(len(p)), (p, q)), shape=(m, m))
    _, labels = connected_components(graph, directed=False)
    return _first_seen(labels[inv])


def _first_seen(labels: np.ndarray) -> np.ndarray:
    """``labels`` (any integers) renumbered 0, 1, ... in order of first appearance (for
    determinism)."""
    _, first, inv = np.unique(labels, return_index=True, return_inverse=True)
    order = np.argsort(first)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[inv.reshape(-1)]


def chord(angle: float) -> float:
    """Euclidean distance between two unit vectors at ``angle`` radians."""
    return 2.0 * np.sin(min(angle, np.pi) / 2.0)


def merge_directions(normals: np.ndarray, tol: float = ANGLE_TOL_RAD, *,
                     antipodal: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Merge unit vectors within ``tol`` radians (and, with ``antipodal``, ``n`` with ``-n``).

    Returns ``(dirs, index, sign)``: the merged unit directions ``(k, dim)`` in order of first
    appearance, and for each input row the index of its direction and the sign ``s`` (+1 or
    -1; always +1 without ``antipodal``) with ``normals[i] ~= s * dirs[index[i]]``.

    Why single linkage: at a rounding tolerance (1e-6 rad) it leaves the circles pairwise
    more than ``tol`` apart (nearly equal circles would cut sliver regions), which a greedy
    clustering does not (it can leave two means within ``tol`` of each other), and chaining
    across noise is harmless; at a contact tolerance (1 degree) a group that chained wider
    than ``tol`` is cut (:func:`_unchain`). It also joins ``n`` with ``-n`` (one circle) and
    maps every input row to its direction, which the NDBG builder needs.

    Examples
    --------
    >>> import numpy as np
    >>> dirs, index, sign = merge_directions(np.array([[0, 0, 1.0], [0, 0, -1.0], [1.0, 0, 0]]))
    >>> dirs.tolist(), index.tolist(), sign.tolist()
    ([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], [0, 0, 1], [1, -1, 1])
    """
    n = unit(np.asarray(normals, dtype=float).reshape(len(normals), -1))
    m = len(n)
    if m == 0:
        return n.copy(), np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    pts = np.vstack([n, -n]) if antipodal else n
    labels = cluster_labels(pts, chord(tol))
    if antipodal:
        # Node i and node i + m (its antipode) belong to the same circle: join their labels.
        graph = coo_matrix((np.ones(m), (labels[:m], labels[m:])),
                           shape=(labels.max() + 1,) * 2)
        _, circle = connected_components(graph, directed=False)
        index = _first_seen(circle[labels[:m]])
        _, first = np.unique(index, return_index=True)
        ref = n[first]  # first member of each circle fixes its orientation
        sign = np.where(np.einsum("ij,ij->i", n, ref[index]) >= 0, 1, -1)
    else:
        index = labels
        sign = np.ones(m, dtype=np.int64)
    index = _unchain(n, index, sign, tol)
    dirs = np.zeros((index.max() + 1, n.shape[1]))
    np.add.at(dirs, index, n * sign[:, None])
    return unit(dirs), index.astype(np.int64), sign.astype(np.int64)


def _unchain(n: np.ndarray, index: np.ndarray, sign: np.ndarray, tol: float) -> np.ndarray:
    """``index`` with every single-linkage cluster that chained wider than ``tol`` (a member
    more than ``tol`` from the cluster's mean) cut into pieces by :func:`_cut`.

    Chaining is harmless at rounding tolerances but not at a contact tolerance (the NDBG's
    1 degree): the facet normals of a cylinder tessellated finer than that (a fine STEP
    export) are each within it of the next, and the whole ring would become one meaningless
    mean. A cut cluster's pieces may lie within ``tol`` of each other: the arrangement's
    vertex merging absorbs that, and a few more regions are the price of keeping every
    constraint (paper 4.3: each contact normal bounds the free cone)."""
    cos = np.cos(tol)
    k = int(index.max()) + 1
    v = n * sign[:, None]
    dirs = np.zeros((k, n.shape[1]))
    np.add.at(dirs, index, v)
    dirs = unit(dirs)
    wide = np.zeros(k, dtype=bool)
    np.logical_or.at(wide, index, np.einsum("ij,ij->i", v, dirs[index]) < cos)
    if not wide.any():
        return index
    out = index.copy()
    nxt = k
    for c in np.flatnonzero(wide).tolist():
        rows = np.flatnonzero(index == c)
        for piece in _cut(v[rows], tol):
            out[rows[piece]] = nxt  # every piece a new label; relabelled below
            nxt += 1
    return _first_seen(out)


def _cut(v: np.ndarray, tol: float, scale: float = 0.999) -> list[np.ndarray]:
    """Pieces of the unit rows ``v`` (index arrays) whose members each lie within ``tol``
    radians of their piece's mean.

    The pieces depend on the set of directions only: not on the rows' order (the parts'
    order), the frame, or the sign the cluster was given (its antipodal merging), which the
    greedy cut this replaces (seeds in input order) did, so a permuted model drew different
    circles (issue 34). The directions are mapped to the plane tangent at their mean by
    the azimuthal equidistant map (exact along geodesics through the mean, so a chain of
    facet normals along a great circle keeps its spacing), expressed in their principal axes
    and binned into an equal grid spanning exactly their extent: mirror-symmetric, so the
    axes' signs do not matter. Directions without a meaningful mean (a long arc, a whole
    ring of a bore's facets) are placed along their great circle instead
    (:func:`_ring_coords`). A cell's diagonal is at most ``scale * tol``; a piece the
    map's distortion leaves wider than ``tol`` (clusters spanning tens of degrees) is cut
    again with a smaller cell. The one arbitrary case left is a cluster with no principal
    axis (as spread one way as the other), whose axes follow rounding."""
    v = np.asarray(v, dtype=float)
    if len(v) < 2:
        return [np.arange(len(v))]
    total = v.sum(axis=0)
    if np.linalg.norm(total) >= 0.5 * len(v):
        xy = _tangent_coords(v, unit(total))
        centred = xy - xy.mean(axis=0)
        _, axes = np.linalg.eigh(centred.T @ centred)  # ascending: minor, major
        t = xy @ axes
    else:  # no meaningful mean: a long arc or a whole ring (a finely tessellated bore)
        t = _ring_coords(v)
    lo, span = t.min(axis=0), np.ptp(t, axis=0)
    if not span.any() or scale < 1e-6:
        # no grid separates them (a zero row among directions, or one direction given twice
        # with rounding apart): each its own piece
        return [np.array([i]) for i in range(len(v))]
    width = scale * tol
    minor, k_minor = _bins(t[:, 0] - lo[0], span[0],
                           max(1, int(np.ceil(span[0] / (width / np.sqrt(2.0))))))
    w_minor = span[0] / k_minor
    major, _ = _bins(t[:, 1] - lo[1], span[1],
                     max(1, int(np.ceil(span[1] / np.sqrt(max(width * width - w_minor ** 2,
                                                               0.5 * width * width))))))
    cell = minor * (int(major.max()) + 1) + major
    out = []
    for c in np.unique(cell).tolist():
        rows = np.flatnonzero(cell == c)
        mean = unit(v[rows].sum(axis=0))
        if len(rows) == 1 or (v[rows] @ mean).min() >= np.cos(tol):
            out.append(rows)
        else:
            out += [rows[p] for p in _cut(v[rows], tol, scale / 2)]
    return out


def _bins(x: np.ndarray, span: float, k: int) -> tuple[np.ndarray, int]:
    """Bin of each of ``x`` (``0 <= x <= span``) among ``k'`` equal bins spanning exactly
    ``[0, span]``, and ``k'``: the first count from ``k`` up with no value within 1e-6 of a
    bin's width from an inner edge. A tessellation's facet normals are evenly spaced, so with
    ``k`` bins some may sit exactly on an edge, where rounding (hence the frame) would pick
    the side; more, narrower bins are as valid (:func:`_cut`)."""
    if span <= 0 or k <= 1:
        return np.zeros(len(x), dtype=np.int64), 1
    f = x / span
    for kk in range(k, k + 64):
        g = f * kk
        edge = np.round(g)
        if not ((np.abs(g - edge) < 1e-6) & (edge > 0) & (edge < kk)).any():
            break
    return np.clip(np.floor(g), 0, kk - 1).astype(np.int64), kk


def _ring_coords(v: np.ndarray) -> np.ndarray:
    """Coordinates ``(k, 2)`` of unit rows ``v`` spread along a great circle (a long arc or a
    whole ring of facet normals, whose mean says nothing): the angle off the circle that
    fits them best, and the angle along it from the far end of their widest gap. The widest
    gap does not depend on the frame, the order or the sign; in a ring with several widest
    gaps (to rounding) the first in the frame's angle is taken."""
    m = np.linalg.svd(v, full_matrices=False)[2][-1]
    e1, e2 = circle_frames(m)
    theta = np.mod(np.arctan2(v @ e2[0], v @ e1[0]), TWO_PI)
    s = np.sort(theta)
    gaps = np.diff(np.r_[s, s[0] + TWO_PI])
    start = s[(int(np.argmax(np.round(gaps, 12))) + 1) % len(s)]
    along = np.mod(theta - start, TWO_PI)
    off = np.arcsin(np.clip(v @ m, -1.0, 1.0))
    return np.c_[off, along]


def _tangent_coords(v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Azimuthal equidistant coordinates ``(k, 2)`` of the unit rows ``v`` about the unit
    ``m``: each row's angle from ``m`` along its direction in the plane orthogonal to ``m``
    (any orthonormal basis of it; :func:`_cut` turns them into principal axes)."""
    e1, e2 = circle_frames(m)
    x, y = v @ e1[0], v @ e2[0]
    ang = np.arctan2(np.hypot(x, y), v @ m)
    r = np.hypot(x, y)
    f = np.divide(ang, r, out=np.zeros_like(r), where=r > 0)
    return np.c_[x * f, y * f]


def circle_frames(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal ``(e1, e2)`` rows spanning the planes orthogonal to the rows of ``m``, with
    ``e1 x e2 = m``: the frames :func:`arrangement_s2` measures angles about its circles and
    vertices in, and the gap cones' projections and the grasp pieces' orthants start from.

    Not :func:`ndbg_cli.geometry.vectors.plane_basis` (whose helper axis is along ``m``'s
    smallest component): here ``e1`` is ``m x x`` unless ``|m_x| >= 0.9`` (then ``m x y``).
    The two agree for axis-aligned ``m`` only, and this one's choice reaches the reports (a
    lone circle's edge representative is ``e1``; arc midpoints, cone rays and piece directions
    are computed in this frame, and the regions' order follows), so these callers keep it."""
    m = np.atleast_2d(m)
    helper = np.where((np.abs(m[:, 0]) < 0.9)[:, None], [[1.0, 0, 0]], [[0, 1.0, 0]])
    e1 = unit(cross(m, helper))
    e2 = cross(m, e1)
    return e1, e2
