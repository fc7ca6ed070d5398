"""Finger placements for the prismatic form-closure grasp (paper section 7.2): for every part,
the outward face orientations a fixed point finger can touch, on a face no other part covers."""

from __future__ import annotations

import numpy as np
import shapely

from ..contacts.bvh import triangle_hierarchy
from ..contacts.facets import point_triangle_distance
from ..core.assembly import Assembly, Part
from ..core.constants import CONTACT_ANGLE_TOL_RAD


def exterior_faces(asm: Assembly, digits: int = 6) -> list[tuple[int, list[float], list[float]]]:
    """Candidate finger placements for the form-closure grasp: for every part, each distinct
    outward face orientation (3D: triangle normals within the contact angle tolerance of
    their group's largest face, :func:`orientations`, each face keeping its own normal
    rounded to ``digits``; 2D: edge
    normals) with a point on a face of that orientation that no other
    part covers: the centroid of the largest such triangle (2D: the midpoint of the longest
    such edge) whose point just outside, ``2 eps`` along the normal, is not next to another
    part (:func:`covered`; at most :data:`FINGER_TRIES` faces tried per orientation, and none
    kept if all are covered: a finger cannot touch a face another part lies on; a part that
    interpenetrates the face deeply is not seen, interferences are reported apart)."""
    gap = 2.0 * asm.length_tolerance
    # the faces tried, orientation by orientation (each one's largest first): their part,
    # orientation (numbered over all parts) and rank in it, normal key, point and outward
    # unit normal, as arrays (the engine tries about 100,000 faces)
    tried = [_tried_faces(part, asm.dimension, digits) for part in asm.parts]
    sizes = [int(t[0].max()) + 1 if len(t[0]) else 0 for t in tried]
    first = np.cumsum([0] + sizes[:-1])
    owner = np.concatenate([np.full(len(t[0]), k) for k, t in enumerate(tried)]).astype(int)
    group = np.concatenate([t[0] + f for t, f in zip(tried, first)]).astype(int)
    rank, keys, point, normal = (np.concatenate([t[j] for t in tried])
                                 for j in range(1, 5))
    # round r tries the r-th face of every orientation still without an exposed one (in the
    # orientations' order, as the probes' test wants them)
    chosen = np.full(sum(sizes), -1)
    for r in range(FINGER_TRIES):
        todo = np.flatnonzero((rank == r) & (chosen[group] < 0))
        if not len(todo):
            break
        free = todo[~covered(asm, owner[todo], point[todo] + gap * normal[todo], gap)]
        chosen[group[free]] = free
    got = chosen[chosen >= 0]
    return list(zip(owner[got].tolist(), keys[got].tolist(), point[got].tolist()))


def _tried_faces(part: Part, dimension: int, digits: int) -> tuple[np.ndarray, ...]:
    """:func:`exterior_faces`' faces of one part: ``(orientation, rank, key, point, normal)``
    arrays, orientation by orientation (numbered from 0), largest face first in each (ties:
    lower index first), at most :data:`FINGER_TRIES` each. 3D: triangles, keyed by their
    normal rounded to ``digits``, at their centroid; 2D: polygon edges, keyed and directed
    by their rounded normal, at their midpoint."""
    if dimension == 2:
        poly = part.polygon
        xy = np.asarray(poly.exterior.coords)[:-1]
        ccw = poly.exterior.is_ccw
        edges: dict[tuple[float, ...], list[tuple[float, list[float]]]] = {}
        for a, b in zip(xy, np.roll(xy, -1, axis=0)):
            e = b - a
            nrm = np.array([e[1], -e[0]]) if ccw else np.array([-e[1], e[0]])
            length = np.linalg.norm(nrm)
            if length > 0:
                key = tuple(np.round(nrm / length, digits).tolist())
                edges.setdefault(key, []).append((float(length), ((a + b) / 2).tolist()))
        rows = [(g, r, key, mid) for g, (key, cands) in enumerate(edges.items())
                for r, (_, mid) in enumerate(sorted(cands, key=lambda c: -c[0])[:FINGER_TRIES])]
        if not rows:
            return np.zeros(0, int), np.zeros(0, int), *(np.zeros((0, 2)),) * 3
        g, r, key, mid = (np.array(x) for x in zip(*rows))
        return g, r, key.astype(float), mid.astype(float), key.astype(float)
    mesh = part.mesh
    unit = np.asarray(mesh.face_normals)
    areas = np.asarray(mesh.area_faces)
    # one orientation: normals within the contact angle tolerance of a leader's (a finely
    # tessellated curved face is not thousands of orientations: a finger blocks the same
    # directions on any of them, up to that tolerance)
    inverse = orientations(unit, areas)
    # each orientation's faces, largest first (ties: lower index first)
    order = np.lexsort((np.arange(len(areas)), -areas, inverse))
    counts = np.bincount(inverse)
    starts = np.cumsum(counts) - counts
    rank = np.arange(len(order)) - np.repeat(starts, counts)
    keep = rank < FINGER_TRIES
    faces = order[keep]
    return (inverse[faces], rank[keep], np.round(unit[faces], digits),
            np.asarray(mesh.triangles_center)[faces], unit[faces])


def orientations(normals: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """``(faces,)`` the orientation of each face: the largest face not yet grouped leads an
    orientation, which takes every ungrouped face whose normal is within
    :data:`CONTACT_ANGLE_TOL_RAD` of its own (ties of area: lower index first). Numbered in
    the leaders' order, so the groups and their order depend on the part's geometry alone:
    a grid of cells on the coordinates (as before issue 34) split a face's normals
    differently in another frame, and the finger count changed with it."""
    from scipy.spatial import cKDTree

    n = len(normals)
    label = np.full(n, -1, dtype=np.intp)
    if n == 0:
        return label
    tree = cKDTree(normals)
    chord = 2.0 * np.sin(CONTACT_ANGLE_TOL_RAD / 2.0)
    grouped = bytearray(n)  # read once per face: a numpy element read costs far more
    k = 0
    for i in np.lexsort((np.arange(n), -areas)).tolist():
        if grouped[i]:
            continue
        near = [j for j in tree.query_ball_point(normals[i], chord) if not grouped[j]]
        for j in near:
            grouped[j] = 1
        label[near] = k
        k += 1
    return label


#: Faces of one orientation tried per part by :func:`exterior_faces` (largest first).
FINGER_TRIES = 8


def covered(asm: Assembly, owner: np.ndarray, q: np.ndarray, gap: float) -> np.ndarray:
    """``(m,)`` whether each point ``q[i]`` (``gap`` outside a face of part ``owner[i]``) is
    within ``1.5 gap`` of another part's surface: a part resting on that face has its surface
    there (within the tolerance), so the point is inside it at about ``gap`` from it. The
    distance to each part whose box holds the point, from its triangles near the point (2D:
    shapely distances)."""
    out = np.zeros(len(q), dtype=bool)
    reach = 1.5 * gap
    by_x = np.argsort(q[:, 0], kind="stable") if asm.dimension == 3 else None
    xs = q[by_x, 0] if by_x is not None else None
    for j, other in enumerate(asm.parts):
        if asm.dimension == 2:
            near = owner != j
            if near.any():
                pts = shapely.points(q[near])
                out[near] |= shapely.distance(other.polygon, pts) <= reach
            continue
        lo, hi = other.mesh.bounds
        # the points in the part's grown box: those in its x range first (sorted by x)
        span = by_x[np.searchsorted(xs, lo[0] - reach, "left"):
                    np.searchsorted(xs, hi[0] + reach, "right")]
        near = np.sort(span[(owner[span] != j) & ~out[span]
                            & np.all((q[span] >= lo - reach) & (q[span] <= hi + reach), axis=1)])
        if len(near):
            # the triangles whose boxes meet each point's ball (the part's compiled box
            # hierarchy, all points in one call), then the exact point-triangle distances
            tri, boxes = triangle_hierarchy(other)
            r, ids = boxes.meeting(q[near] - reach, q[near] + reach)
            rows = near[r]
            hit = point_triangle_distance(q[rows], tri[ids]) <= reach
            out[rows[hit]] = True
    return out

