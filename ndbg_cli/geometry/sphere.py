"""Arrangements of great circles on S^2 and of points on S^1, exactly (no direction sampling):
:func:`arrangement_s2`, and for 2D :func:`cluster_angles` and :func:`free_cone_2d`.

Every comparison of directions uses one explicit angular tolerance ``tol`` in radians
(:data:`ndbg_cli.core.constants.ANGLE_TOL_RAD` = 1e-6 rad, about 0.2 arc-seconds), since CAD
contacts share normals that differ only by rounding: normals within ``tol`` (or of antipodal,
for great circles) are merged (:func:`ndbg_cli.geometry.directions.merge_directions`);
arrangement vertices within ``tol`` are one vertex (no sliver triangles); ``d`` is on the
circle of ``m`` when ``|d . m| <= tol`` (:func:`signs`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..core.constants import ANGLE_TOL_RAD
from .directions import TWO_PI, chord, circle_frames, cluster_labels, merge_directions
from .lp import solve_lp
from .vectors import plane_basis, unit


def signs(directions: np.ndarray, normals: np.ndarray, tol: float = ANGLE_TOL_RAD
          ) -> np.ndarray:
    """Sign matrix ``(len(directions), len(normals))`` of ``d . n`` with ``|d . n| <= tol``
    counted as zero (int8: -1, 0, +1)."""
    dots = np.atleast_2d(directions) @ np.atleast_2d(normals).T
    out = (dots > tol).view(np.int8)
    out -= (dots < -tol).view(np.int8)
    return out


@dataclass
class Arrangement:
    """The arrangement of great circles ``circles`` (unit normals, rows) on S^2.

    ``vertices`` ``(V, 3)`` with ``vertex_circles[v]`` the circles through vertex ``v``;
    ``edges`` as ``edge_circle``/``edge_start``/``edge_end`` (vertex indices, ``-1`` for a
    closed circle) and ``edge_mid`` ``(E, 3)``; faces as ``face_vertices`` (boundary vertex
    cycles, counter-clockwise seen from outside) and ``face_rep`` ``(F, 3)``.
    """

    circles: np.ndarray
    tol: float
    vertices: np.ndarray
    vertex_circles: list[tuple[int, ...]]
    edge_circle: np.ndarray
    edge_start: np.ndarray
    edge_end: np.ndarray
    edge_mid: np.ndarray
    face_vertices: list[tuple[int, ...]]
    face_rep: np.ndarray
    _index: dict = field(default_factory=dict, repr=False)

    @property
    def counts(self) -> dict[int, int]:
        """Number of regions by dimension ``{0: V, 1: E, 2: F}``."""
        return {0: len(self.vertices), 1: len(self.edge_mid), 2: len(self.face_rep)}

    def regions(self) -> list[tuple[int, np.ndarray]]:
        """Every region as ``(dimension, representative unit direction)``: vertices, then
        edges, then faces."""
        out = [(0, v) for v in self.vertices]
        out += [(1, e) for e in self.edge_mid]
        out += [(2, f) for f in self.face_rep]
        return out

    def representatives(self) -> tuple[np.ndarray, np.ndarray]:
        """``(dimensions (R,), directions (R, 3))`` of all regions, in :meth:`regions` order."""
        dims = np.repeat([0, 1, 2], [len(self.vertices), len(self.edge_mid),
                                     len(self.face_rep)])
        reps = np.vstack([self.vertices.reshape(-1, 3), self.edge_mid.reshape(-1, 3),
                          self.face_rep.reshape(-1, 3)])
        return dims, reps

    def sign_vectors(self) -> np.ndarray:
        """Sign vector of every region (rows in :meth:`regions` order)."""
        _, reps = self.representatives()
        return signs(reps, self.circles, self.tol)

    def locate(self, d: np.ndarray) -> int:
        """Index (in :meth:`regions` order) of the region containing direction ``d``, matched
        by sign vector; ``-1`` if ``d`` is within ``tol`` of a feature it was not built with
        (cannot happen for the arrangement's own regions)."""
        if not self._index:
            for k, row in enumerate(self.sign_vectors()):
                self._index.setdefault(row.tobytes(), k)
        key = signs(unit(np.asarray(d, float))[None], self.circles, self.tol)[0].tobytes()
        return self._index.get(key, -1)


def _vertices(circles: np.ndarray, tol: float) -> tuple[np.ndarray, list[tuple[int, ...]]]:
    """All intersection points of the circles, merged within ``tol``, with their circles."""
    k = len(circles)
    i, j = np.triu_indices(k, 1)
    c = unit(np.cross(circles[i], circles[j]))
    pts = np.vstack([c, -c])
    gen = np.vstack([np.column_stack([i, j])] * 2)
    labels = cluster_labels(pts, chord(tol))
    nv = int(labels.max()) + 1
    verts = np.zeros((nv, 3))
    np.add.at(verts, labels, pts)
    verts = unit(verts)
    order = np.lexsort((gen[:, 1], gen[:, 0], labels))
    vc: list[set[int]] = [set() for _ in range(nv)]
    for lab, (a, b) in zip(labels[order], gen[order]):
        vc[lab].add(int(a))
        vc[lab].add(int(b))
    return verts, [tuple(sorted(s)) for s in vc]


def arrangement_s2(circles: np.ndarray, tol: float = ANGLE_TOL_RAD) -> Arrangement:
    """The arrangement of the great circles with unit normals ``circles`` (rows, assumed
    already merged: pairwise more than ``tol`` apart, also from antipodal).

    Vertices (dimension 0: where two or more circles meet), edges (1: open arcs between
    consecutive vertices on a circle, or a whole circle, only when there is one) and faces (2:
    the components of the complement, found by walking a doubly connected edge list, never by
    sampling). Each region's representative direction is strictly inside it: the vertex, the
    arc's midpoint, or for a face the normalised sum of its boundary edges' midpoints (a
    strictly positive combination of points of the convex spherical polygon, not all on one
    great circle; for a lune its bisector). A region is also determined by its *sign vector*
    ``(sign(m_c . d))_c``, which :meth:`Arrangement.locate` uses."""
    circles = unit(np.asarray(circles, dtype=float).reshape(-1, 3))
    k = len(circles)
    empty_i = np.zeros(0, dtype=np.int64)
    if k == 0:  # the whole sphere is one face
        return Arrangement(circles, tol, np.zeros((0, 3)), [], empty_i, empty_i, empty_i,
                           np.zeros((0, 3)), [()], np.array([[0.0, 0.0, 1.0]]))
    if k == 1:  # two hemispheres and the circle itself, a closed loop
        e1, _ = circle_frames(circles)
        return Arrangement(circles, tol, np.zeros((0, 3)), [], np.array([0]), np.array([-1]),
                           np.array([-1]), e1.copy(), [(), ()],
                           np.vstack([circles[0], -circles[0]]))
    verts, vcirc = _vertices(circles, tol)
    e1, e2 = circle_frames(circles)
    # Incidences (circle, vertex) sorted by circle then angle about the circle's normal.
    inc_c = np.array([c for vc in vcirc for c in vc], dtype=np.int64)
    inc_v = np.array([v for v, vc in enumerate(vcirc) for _ in vc], dtype=np.int64)
    ang = np.arctan2(np.einsum("ij,ij->i", verts[inc_v], e2[inc_c]),
                     np.einsum("ij,ij->i", verts[inc_v], e1[inc_c]))
    order = np.lexsort((ang, inc_c))
    inc_c, inc_v, ang = inc_c[order], inc_v[order], ang[order]
    # Successor of each incidence on its circle (cyclic).
    starts = np.flatnonzero(np.r_[True, inc_c[1:] != inc_c[:-1]])
    ends = np.r_[starts[1:], len(inc_c)]
    nxt = np.arange(1, len(inc_c) + 1)
    nxt[ends - 1] = starts
    edge_circle = inc_c
    edge_start = inc_v
    edge_end = inc_v[nxt]
    a0, a1 = ang, ang[nxt]
    a1 = np.where(a1 <= a0, a1 + TWO_PI, a1)
    mid = 0.5 * (a0 + a1)
    edge_mid = unit(np.cos(mid)[:, None] * e1[edge_circle] + np.sin(mid)[:, None]
                    * e2[edge_circle])
    # Half-edges: 2e runs start->end (counter-clockwise about the circle normal), 2e+1 back.
    ne = len(edge_circle)
    m = circles[edge_circle]
    origin = np.empty(2 * ne, dtype=np.int64)
    origin[0::2], origin[1::2] = edge_start, edge_end
    dest = np.empty(2 * ne, dtype=np.int64)
    dest[0::2], dest[1::2] = edge_end, edge_start
    tangent = np.empty((2 * ne, 3))
    tangent[0::2] = np.cross(m, verts[edge_start])
    tangent[1::2] = -np.cross(m, verts[edge_end])
    va, vb = circle_frames(verts)  # tangent basis at each vertex, vb = v x va
    tang_ang = np.arctan2(np.einsum("ij,ij->i", tangent, vb[origin]),
                          np.einsum("ij,ij->i", tangent, va[origin]))
    around = np.lexsort((tang_ang, origin))  # outgoing half-edges, CCW about each vertex
    pos = np.empty(2 * ne, dtype=np.int64)
    pos[around] = np.arange(2 * ne)
    first = np.searchsorted(origin[around], np.arange(len(verts)))
    count = np.bincount(origin, minlength=len(verts))
    twin = np.arange(2 * ne) ^ 1
    # next(h): at dest(h), the outgoing half-edge just clockwise of twin(h): face on the left.
    tp = pos[twin]
    base = first[dest]
    prev_pos = base + (tp - base - 1) % count[dest]
    nxt_h = around[prev_pos]
    face_of = np.full(2 * ne, -1, dtype=np.int64)
    face_vertices: list[tuple[int, ...]] = []
    nxt_list = nxt_h.tolist()
    origin_list = origin.tolist()
    for h0 in range(2 * ne):
        if face_of[h0] >= 0:
            continue
        f = len(face_vertices)
        cyc = []
        h = h0
        while face_of[h] < 0:
            face_of[h] = f
            cyc.append(origin_list[h])
            h = nxt_list[h]
        face_vertices.append(tuple(cyc))
    face_rep = np.zeros((len(face_vertices), 3))
    np.add.at(face_rep, face_of, edge_mid[np.arange(2 * ne) // 2])
    face_rep = unit(face_rep)
    return Arrangement(circles, tol, verts, vcirc, edge_circle, edge_start, edge_end,
                       edge_mid, face_vertices, face_rep)


# -- S^1 ----------------------------------------------------------------------------------

def angle_of(v: np.ndarray) -> np.ndarray:
    """Angles in ``[0, 2 pi)`` of 2D vectors (rows)."""
    v = np.atleast_2d(v)
    return np.mod(np.arctan2(v[:, 1], v[:, 0]), TWO_PI)


def cluster_angles(angles: np.ndarray, tol: float = ANGLE_TOL_RAD
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Merge angles on the circle within ``tol`` (single linkage, across ``2 pi`` too).

    Returns ``(centres, label)``: the sorted cluster angles in ``[0, 2 pi)`` and each input's
    cluster index.
    """
    a = np.mod(np.asarray(angles, dtype=float), TWO_PI)
    if len(a) == 0:
        return np.zeros(0), np.zeros(0, dtype=np.int64)
    order = np.argsort(a, kind="stable")
    s = a[order]
    new = np.r_[True, np.diff(s) > tol]
    lab_sorted = np.cumsum(new) - 1
    nclus = int(lab_sorted[-1]) + 1
    if nclus > 1 and s[0] + TWO_PI - s[-1] <= tol:  # the last cluster wraps onto the first
        lab_sorted[lab_sorted == nclus - 1] = 0
        s = np.where(lab_sorted == 0, np.where(s > np.pi, s - TWO_PI, s), s)
        nclus -= 1
    centres = np.array([s[lab_sorted == c].mean() for c in range(nclus)])
    centres = np.mod(centres, TWO_PI)
    relabel = np.argsort(np.argsort(centres, kind="stable"), kind="stable")
    label = np.empty(len(a), dtype=np.int64)
    label[order] = relabel[lab_sorted]
    return np.sort(centres), label


@dataclass(frozen=True)
class Cone2D:
    """The closed cone ``{d : d . n <= 0 for all n}`` of directions in which a part is locally
    free relative to another, in the plane.

    ``kind`` is ``"halfplane"`` (one normal), ``"wedge"`` (a sector narrower than a half
    plane), ``"ray"``, ``"line"`` or ``"zero"``; ``boundary`` the indices of the normals whose
    diameters bound it (the paper's refinement: at most two diameters per pair of parts).
    """

    kind: str
    boundary: tuple[int, ...]


def free_cone_2d(normals: np.ndarray, tol: float = ANGLE_TOL_RAD) -> Cone2D:
    """The free cone of ``normals`` (2D unit rows, pairwise more than ``tol`` apart).

    With the normal angles sorted, the largest cyclic gap ``g`` decides: one normal gives a
    half plane; ``g > pi`` a wedge bounded by the two normals at the ends of the gap;
    ``g = pi`` (within ``tol``) a ray between two opposite normals, or a line when those are
    the only normals; ``g < pi`` only the zero vector.
    """
    k = len(normals)
    if k == 0:
        raise ValueError("a contact has at least one normal")
    if k == 1:
        return Cone2D("halfplane", (0,))
    ang = angle_of(normals)
    order = np.argsort(ang, kind="stable")
    s = ang[order]
    gaps = np.diff(np.r_[s, s[0] + TWO_PI])
    g = int(np.argmax(gaps))
    lo, hi = int(order[g]), int(order[(g + 1) % k])
    if gaps[g] > np.pi + tol:
        return Cone2D("wedge", (lo, hi))
    if gaps[g] >= np.pi - tol:
        if k == 2:
            return Cone2D("line", (lo,))
        return Cone2D("ray", (lo, hi))
    return Cone2D("zero", ())


# -- free cones of contact normals on S^2 ------------------------------------------------

def snap_normals(normals: np.ndarray, tol: float) -> np.ndarray:
    """One contact constraint's unit normals with tessellation noise removed: if they all lie
    within ``tol`` of a line (``+-v``) they become ``+-v``; else if all within ``tol`` of a
    plane (a facetted cylinder, a peg) they are projected onto it, so that all their circles
    pass exactly through the plane's normal ``+-m`` (one vertex pair, no sliver faces)."""
    if len(normals) < 2:
        return normals
    _, _, vt = np.linalg.svd(normals)
    v = vt[0]
    along = normals @ v
    if (np.linalg.norm(normals - np.outer(along, v), axis=1) <= tol).all():
        return np.outer(np.sign(along), v)
    m = vt[2]
    off = normals @ m
    if (np.abs(off) <= tol).all() and np.abs(off).max() > 0:
        return unit(normals - np.outer(off, m))
    return normals


def cone_boundary_circles(normals: np.ndarray, circle: np.ndarray, tol: float) -> set[int]:
    """The great circles needed to bound the free cone ``F = {d : N d <= 0}`` of one pair of parts
    whose distinct merged unit normals are the rows of ``normals`` (``circle[k]``: the global circle
    index of normal ``k``; returns a set of those indices). Why they suffice:
    :func:`ndbg_cli.ndbg.infinitesimal.build.build_ndbg_3d`. Normals on a line: their circle; in a
    plane (orthogonal to ``m``): the circles bounding the 2D cone, or for a ray or the zero cone two
    circles through ``+-m`` so that ``+-m`` are vertices; a pointed cone: its extreme rays (2D hull
    in a central projection); else, after one LP for the implicit equalities ``E``: none (``F =
    {0}``), two circles of ``E`` (``F`` a ray or line), or the circle of ``E`` and the circles
    through the two ends of the planar sector ``F``."""
    k = len(normals)
    everything = {int(c) for c in circle}
    if len(everything) <= 2:
        return everything
    _, s, vt = np.linalg.svd(normals)
    rank = int(np.sum(s > tol * np.sqrt(k)))
    if rank <= 1:
        return everything
    if rank == 2:
        xy = unit(normals @ vt[:2].T)
        cone = free_cone_2d(xy, tol)
        if cone.kind == "wedge":
            return {int(circle[i]) for i in cone.boundary}
        if cone.kind in ("ray", "zero"):
            return {int(circle[i]) for i in _transverse_pair(normals, tol, cone.boundary[:1])}
        return everything
    u = normals.sum(axis=0)
    if np.linalg.norm(u) > 0 and (normals @ u).min() > tol * np.linalg.norm(u):
        return _extreme_circles(normals, circle, u / np.linalg.norm(u), tol)
    # Not (visibly) pointed: find the implicit equalities E of N d <= 0 with one LP; the
    # free cone F spans the null space of N_E.
    normals = _snap_lineality_plane(normals, tol)
    found = _implicit_equalities(normals, tol)
    if found is None:
        return everything
    implicit, interior = found
    if not implicit.any():  # F is full-dimensional after all: -interior points the cone
        return _extreme_circles(normals, circle, -interior, tol)
    ne = normals[implicit]
    s_e = np.linalg.svd(ne, compute_uv=False)
    rank_e = int(np.sum(s_e > tol * np.sqrt(len(ne))))
    if rank_e >= 3:  # F = {0}: blocked both ways in every direction, no boundary at all
        return set()
    if rank_e == 2:  # F is a ray or a line: its points must be vertices, two circles suffice
        sel = np.flatnonzero(implicit)
        return {int(circle[sel[i]]) for i in _transverse_pair(ne, tol)}
    # rank 1: F is a 2D cone in the plane m^T d = 0; its ends lie on the circles of the
    # normals bounding the projected 2D cone.
    m = ne[0]
    e1, e2 = plane_basis(m)
    rest = np.flatnonzero(~implicit)
    xy = np.column_stack([normals[rest] @ e1, normals[rest] @ e2])
    big = np.linalg.norm(xy, axis=1) > tol
    rest, xy = rest[big], unit(xy[big])
    if len(rest) == 0:
        return {int(circle[np.flatnonzero(implicit)[0]])}
    dirs, which, _ = merge_directions(xy, tol, antipodal=False)
    cone = free_cone_2d(dirs, tol)
    if cone.kind not in ("halfplane", "wedge"):
        return everything
    keep = {int(circle[np.flatnonzero(implicit)[0]])}
    for b in cone.boundary:
        keep.add(int(circle[rest[int(np.flatnonzero(which == b)[0])]]))
    return keep


def _transverse_pair(normals: np.ndarray, tol: float, fixed: tuple[int, ...] = ()
                     ) -> tuple[int, int]:
    """Two rows of ``normals`` whose circles cross most steeply (least ``|n_i . n_j|``: the
    cosine, which unlike the sine does not flatten out near a right angle), the first one
    ``fixed[0]`` when given: any two distinct circles through ``+-m`` make ``+-m`` vertices,
    and choosing by the normals' own angles (not the first row) draws the same two in any
    part order and frame (issue 34). Pairs whose cosine is within ``tol`` (the angular
    tolerance; near a right angle a cosine difference is an angle) of the steepest tie, and
    ties go to the lower index: three normals 120 degrees apart in a plane cross equally, and
    noise far below the tolerance (CAD rounding) then does not choose among them (it still
    can for a pair whose cosine lies just at the window's edge)."""
    if fixed:
        cos = np.abs(normals @ normals[fixed[0]])
        cos[fixed[0]] = np.inf
        return fixed[0], int(np.flatnonzero(cos <= cos.min() + tol)[0])
    i, j = np.triu_indices(len(normals), 1)
    cos = np.abs(np.einsum("ij,ij->i", normals[i], normals[j]))
    best = int(np.flatnonzero(cos <= cos.min() + tol)[0])
    return int(i[best]), int(j[best])


def _extreme_circles(normals: np.ndarray, circle: np.ndarray, u: np.ndarray,
                     tol: float) -> set[int]:
    """Circles of the extreme rays of the pointed cone of ``normals`` (``u . n > 0`` for all):
    the vertices of their 2D convex hull in the central projection onto the plane ``u . x =
    1``."""
    from scipy.spatial import ConvexHull, QhullError

    h = normals @ u
    e1, e2 = plane_basis(u)
    p = normals / h[:, None]
    xy = np.column_stack([p @ e1, p @ e2])
    try:
        ring = [int(i) for i in ConvexHull(xy).vertices]  # counter-clockwise
    except QhullError:  # nearly collinear projections: keep every circle (still exact)
        return {int(c) for c in circle}
    # A hull vertex within tol of the plane of its two neighbours is (within the tolerance)
    # a positive combination of them: not extreme, its circle is not needed.
    changed = True
    while changed and len(ring) > 3:
        changed = False
        for k, i in enumerate(ring):
            m = np.cross(normals[ring[k - 1]], normals[ring[(k + 1) % len(ring)]])
            if abs(normals[i] @ m) <= tol * np.linalg.norm(m):
                del ring[k]
                changed = True
                break
    return {int(circle[i]) for i in ring}


def _snap_lineality_plane(normals: np.ndarray, tol: float) -> np.ndarray:
    """Normals lying within ``tol`` of one plane through at least three of them (a hexagonal
    peg's faces, each its own planar contact, plus a floor) projected exactly onto it, so
    that the LP sees the plane the tolerance says is there, not rounding noise. The result
    is expressed in a rotated frame (the plane is ``z = 0``); circle choices do not depend on
    the frame."""
    k = len(normals)
    if k < 3 or k > 64:
        return normals
    i, j = np.triu_indices(k, 1)
    m = np.cross(normals[i], normals[j])
    ok = np.linalg.norm(m, axis=1) > tol
    if not ok.any():
        return normals
    m = unit(m[ok])
    near = np.abs(m @ normals.T) <= tol
    best = int(np.argmax(near.sum(axis=1)))
    members = near[best]
    if members.sum() < 3:
        return normals
    # Rotate the plane's normal to +z and zero the members' z exactly: the LP solver drops
    # matrix entries below 1e-9, which would undo a projection done in the original frame.
    e1, e2 = plane_basis(m[best])
    frame = np.vstack([e1, e2, m[best]])
    out = normals @ frame.T
    out[members, 2] = 0.0
    return unit(out)


#: How far (times the angular tolerance, over the unit box of directions) a constraint of
#: :func:`_implicit_equalities`' first LP may be exceeded: far above the normals' rounding,
#: far below the half-tolerance slack that makes a constraint not implicit.
NOISE = 0.01


def _implicit_equalities(normals: np.ndarray, tol: float
                         ) -> tuple[np.ndarray, np.ndarray] | None:
    """The constraints ``n . d <= 0`` that hold with equality on the whole free cone, within
    the tolerance, and a direction deep inside it when there are none.

    LP 1: ``max sum t_i`` s.t. ``N d + t <= NOISE``, ``|d|_inf <= 1 / tol``, ``0 <= t_i <= 1``
    (the box ``|d|_inf <= 1`` and slacks up to ``tol``, scaled by ``1 / tol`` for the
    solver). A constraint that some ``d`` of the unit box slackens by ``k tol`` or more
    reaches ``t_i = 1`` (average the maximisers), so ``t_i < 1/2`` marks it implicit: rounding
    noise cannot open a sliver of free directions. LP 2 (no implicit constraint): ``max s``
    s.t. ``N d + s <= 0``, ``|d|_inf <= 1``: a well-centred interior direction. ``None``
    when the solver fails, by simplex and then by interior points (the caller then keeps
    every circle, which is still exact, but other noise gives another arrangement).
    """
    def solve(c, **kwargs):
        res = solve_lp(c, (("highs", {}), ("highs-ipm", {})), **kwargs)
        return res if res.status == 0 else None

    k = len(normals)
    big = 1.0 / tol
    # each constraint may be exceeded by NOISE tol (over the unit box): rounding of the
    # normals (1e-9) must not close a free ray that the exact normals leave
    res = solve(np.r_[np.zeros(3), -np.ones(k)], A_ub=np.hstack([normals, np.eye(k)]),
                b_ub=np.full(k, NOISE), bounds=[(-big, big)] * 3 + [(0.0, 1.0)] * k)
    if res is None:
        # HiGHS can stop with no status ("Not Set") on normals 1e-9 from a degenerate
        # configuration (five normals of two pairs): the same LP with d in the unit box and
        # the slacks scaled by tol instead
        res = solve(np.r_[np.zeros(3), -np.ones(k)], A_ub=np.hstack([normals, tol * np.eye(k)]),
                    b_ub=np.full(k, NOISE * tol), bounds=[(-1.0, 1.0)] * 3 + [(0.0, 1.0)] * k)
    if res is None:  # numerical trouble (d = 0, t = 0 is feasible, all is bounded)
        return None
    implicit = res.x[3:] < 0.5
    if implicit.any():
        return implicit, res.x[:3]
    res = solve(np.r_[np.zeros(3), -1.0], A_ub=np.hstack([normals, np.ones((k, 1))]),
                b_ub=np.zeros(k), bounds=[(-1.0, 1.0)] * 3 + [(0.0, 1.0)])
    if res is None:
        return None
    return implicit, res.x[:3]
