"""Per-part geometric data for contact analysis, built once per part and cached by
:attr:`ndbg_cli.core.assembly.Part.hash` (plus the tolerances where the result depends on
them), so a subassembly reuses the work done on the whole assembly: the python-fcl BVH
(:func:`fcl_model`), the manifold3d solid (:func:`manifold_model`), triangle data with the
tessellation sag (:func:`part_geometry`, :class:`PartGeometry`), and the vectorised triangle
predicates of the narrow phase (:func:`sat_gap`, :func:`point_triangle_distance`,
:func:`segment_distance`). Lengths are in the assembly unit, angles in radians.
"""

from __future__ import annotations

import atexit
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import fcl
import manifold3d
import numpy as np
import rtree
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..core.assembly import Part
from ..geometry.vectors import cross
from ..kernels.compiled import loaded
from .bvh import BoxHierarchy, forget_hierarchies, triangle_hierarchy

#: Largest dihedral angle (radians) between adjacent triangles that is read as the tessellation
#: of a smooth (curved) surface rather than as a real edge: 31 degrees, i.e. a cylinder, cone or
#: sphere tessellated with at least 12 segments per turn. Real edges of CAD parts (boxes,
#: hexagons, chamfers) have dihedral angles of 45 degrees or more.
SMOOTH_DIHEDRAL_MAX = np.radians(31.0)

#: Smallest dihedral angle (radians) of a smooth edge between two facets: below it the two
#: triangles are one plane however the facets were cut (a flat face whose triangles were split
#: from a drifting facet by :func:`_facet_planes`). Far below any facet angle a CAD exporter
#: produces (0.01 degree: 36,000 segments per turn).
SMOOTH_DIHEDRAL_MIN = np.radians(0.01)

_FCL_CACHE: dict[str, Any] = {}
_MANIFOLD_CACHE: dict[str, Any] = {}
# the solids freed before the interpreter's teardown: nanobind (manifold3d's binding) prints
# a warning for each instance still alive when its module goes (a Dask worker's normal end)
atexit.register(_MANIFOLD_CACHE.clear)
_GEOMETRY_CACHE: dict[tuple[str, float, float], PartGeometry] = {}
_TRIANGLE_CACHE: dict[str, tuple[np.ndarray, Any]] = {}


def clear_caches() -> None:
    """Forget every cached BVH, manifold, triangle R-tree or hierarchy and part geometry."""
    _FCL_CACHE.clear()
    _MANIFOLD_CACHE.clear()
    _TRIANGLE_CACHE.clear()
    forget_hierarchies()
    _GEOMETRY_CACHE.clear()


def triangle_index(part: Part) -> tuple[np.ndarray, rtree.index.Index]:
    """The part's triangles ``(f, 3, 3)`` (assembly frame) and an R-tree of their boxes
    (:func:`box_tree`, ids = triangle indices), built once per :attr:`Part.hash` (the
    tolerances do not enter): the order of its hits is the contacts' order of triangle
    pairs (:func:`ndbg_cli.contacts.contacts3d._tree_rank`); the queries themselves go
    through :func:`triangle_hierarchy`."""
    got = _TRIANGLE_CACHE.get(part.hash)
    if got is None:
        tri = np.asarray(part.mesh.triangles, dtype=np.float64)
        got = _TRIANGLE_CACHE[part.hash] = (tri, box_tree(tri.min(axis=1), tri.max(axis=1)))
    return got


def fcl_model(part: Part) -> fcl.BVHModel:
    """The part's mesh as an ``fcl.BVHModel`` in the assembly frame, built once per
    :attr:`Part.hash` and reused by every later stage (contacts, sweeps, distance queries)."""
    model = _FCL_CACHE.get(part.hash)
    if model is None:
        mesh = part.mesh
        model = fcl.BVHModel()
        model.beginModel(len(mesh.vertices), len(mesh.faces))
        model.addSubModel(np.asarray(mesh.vertices, dtype=np.float64),
                          np.asarray(mesh.faces, dtype=np.int32))
        model.endModel()
        _FCL_CACHE[part.hash] = model
    return model


def fcl_object(part: Part) -> fcl.CollisionObject:
    """A collision object for the cached BVH of ``part`` at the identity transform (the mesh is
    already placed in the assembly frame)."""
    return fcl.CollisionObject(fcl_model(part), fcl.Transform())


def one_thread_manifold() -> None:
    """Start manifold3d's task scheduler (oneTBB, linked into it) with no worker thread, once
    per process, before its first solid.

    Why: ndbg forks its workers (:mod:`ndbg_cli.core.pools`), and a process forked while a
    TBB worker thread was in its task arena (just after a boolean: the parent's nested-part
    volumes, :func:`ndbg_cli.contacts.contacts3d.analyze_contacts`) inherits an arena that
    waits for that thread forever: the child's next boolean hung (seen on the engine GLB).
    With one thread there is nothing to wait for, and the processes are the parallelism
    (two TBB threads per worker only oversubscribed the cores; with ``--jobs 1`` a boolean
    takes one core, as the rest of the run does). oneTBB sizes its pool from
    the CPU affinity of the thread that starts it, so this thread is pinned to one CPU
    while a solid starts it (13,824 half-edges: past the 10,000 elements below which
    manifold's algorithms skip the scheduler; 7 ms), then given its CPUs back; forked children
    inherit the one-thread scheduler. This rests on oneTBB's behaviour, which
    ``tests/test_contacts.py`` checks (no thread more after a large boolean). Where affinity
    cannot be set, or the scheduler already started (a caller's own solids), nothing
    changes. ndbg makes its solids in each process's main thread."""
    global _ONE_THREAD
    if _ONE_THREAD:
        return
    _ONE_THREAD = True
    try:
        cpus = os.sched_getaffinity(0)
    except (AttributeError, OSError):
        return
    try:
        os.sched_setaffinity(0, {min(cpus)})
    except (OSError, ValueError):
        return
    try:
        manifold3d.Manifold.sphere(1.0, 96).volume()
    finally:
        os.sched_setaffinity(0, cpus)


#: Whether :func:`one_thread_manifold` ran in this process (forked children inherit it).
_ONE_THREAD = False


def closed(part: Part) -> bool:
    """Whether the part's mesh bounds a solid (watertight, consistently wound): what
    manifold3d needs, and what the overlap bounds' ray arguments
    (:mod:`ndbg_cli.contacts.overlap_bounds`) need."""
    return bool(part.check.watertight and part.check.winding_consistent)


def manifold_model(part: Part) -> manifold3d.Manifold | None:
    """The part as a ``manifold3d.Manifold`` (float64 vertices), cached by :attr:`Part.hash`;
    ``None`` when the mesh is not a closed, consistently wound 2-manifold."""
    if part.hash in _MANIFOLD_CACHE:
        return _MANIFOLD_CACHE[part.hash]
    one_thread_manifold()
    solid = None
    if closed(part):
        mesh = part.mesh
        try:
            cand = manifold3d.Manifold(manifold3d.Mesh64(
                vert_properties=np.asarray(mesh.vertices, dtype=np.float64),
                tri_verts=np.asarray(mesh.faces, dtype=np.uint64)))
            if cand.status() == manifold3d.Error.NoError and not cand.is_empty():
                solid = cand
        except (RuntimeError, ValueError, TypeError):
            solid = None
    _MANIFOLD_CACHE[part.hash] = solid
    return solid


@dataclass(frozen=True, eq=False)
class PartGeometry:
    """Triangle-level data of one part (``f`` triangles, ``F`` planar facets).

    * ``triangles`` ``(f, 3, 3)`` (= ``vertices[faces]``), ``normals`` ``(f, 3)`` unit outward
      normals, ``areas`` ``(f,)``;
    * ``lo``/``hi`` ``(f, 3)``: each triangle's bounding box;
    * ``facet`` ``(f,)``: the planar facet each triangle belongs to. A facet is a connected set
      of triangles whose normals agree within the angular tolerance and whose vertices all lie
      within the length tolerance of the facet's plane; ``facet_normal`` ``(F, 3)`` and
      ``facet_offset`` ``(F,)`` give that plane ``n . x = d``;
    * ``smooth_angle`` ``(f,)``: the largest dihedral angle (radians) at the triangle's edges
      that is at most :data:`SMOOTH_DIHEDRAL_MAX` (0 for a triangle with only flat or sharp
      neighbours): the facet angle ``2 pi / N`` of an ``N``-segment tessellated curved surface;
    * ``sag`` ``(f,)``: the chord sag of that tessellation, ``(h / 2) tan(theta / 4)`` for the
      triangle's height ``h`` across a smooth edge of dihedral angle ``theta``. For a circle of
      radius ``r`` cut in ``N`` chords this is exactly ``r (1 - cos(pi / N))``: how far the flat
      triangle departs from the surface it stands for (unit).
    """

    triangles: np.ndarray
    faces: np.ndarray  # (f, 3) vertex indices
    vertices: np.ndarray  # (v, 3)
    normals: np.ndarray
    areas: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    facet: np.ndarray
    facet_normal: np.ndarray
    facet_offset: np.ndarray
    smooth_angle: np.ndarray
    sag: np.ndarray
    adjacency: np.ndarray  # (e, 2) pairs of triangles sharing an edge
    tree: Any  # rtree.index.Index of the triangles' bounding boxes, ids = triangle indices
    boxes: BoxHierarchy  # the same boxes' compiled hierarchy (:func:`triangle_hierarchy`)


def part_geometry(part: Part, tolerance: float, angle_tolerance: float) -> PartGeometry:
    """The :class:`PartGeometry` of ``part`` for these tolerances (cached)."""
    key = (part.hash, float(tolerance), float(angle_tolerance))
    geo = _GEOMETRY_CACHE.get(key)
    if geo is None:
        tri, tree = triangle_index(part)
        geo = _GEOMETRY_CACHE[key] = _assemble(part.mesh, tri, tree, triangle_hierarchy(
            part)[1], _derived(part.mesh, tri, tolerance, angle_tolerance))
    return geo


def part_geometries(parts: Sequence[Part], tolerance: float, angle_tolerance: float, *,
                    meanwhile: Callable[[], Any] | None = None,
                    fork_above: int | None = None) -> list[PartGeometry]:
    """:func:`part_geometry` of each of ``parts``, with ``meanwhile()`` called here once.

    When the parts not cached yet hold at least ``fork_above`` triangles, their facets, sags,
    adjacency and box hierarchies are computed in a forked child
    (:class:`~ndbg_cli.core.pools.Forked`: the same code on the same arrays, so the same
    values) while this process calls ``meanwhile`` (e.g. python-fcl's BVHs, which cannot
    cross processes) and builds their triangle R-trees."""
    from ..core.pools import Forked

    tol, ang = float(tolerance), float(angle_tolerance)
    first: dict[str, Part] = {}  # one part per hash, the first (as the caches keep it)
    for p in parts:
        if (p.hash, tol, ang) not in _GEOMETRY_CACHE:
            first.setdefault(p.hash, p)
    todo = list(first.values())
    fork = fork_above is not None and bool(todo) \
        and sum(len(p.mesh.faces) for p in todo) >= fork_above
    # without the fork (``enabled`` false), ``result()`` computes them here, after ``meanwhile``
    with Forked(_derived_of, todo, tol, ang, enabled=fork) as job:
        if meanwhile is not None:
            meanwhile()
        for p in todo:
            triangle_index(p)
        for p, (derived, boxes) in zip(todo, job.result(), strict=True):
            tri, tree = triangle_index(p)
            boxes = triangle_hierarchy(p, boxes)[1]
            _GEOMETRY_CACHE[(p.hash, tol, ang)] = _assemble(p.mesh, tri, tree, boxes, derived)
    return [part_geometry(p, tol, ang) for p in parts]


def _derived_of(parts: Sequence[Part], tol: float, ang: float
                ) -> list[tuple[tuple, BoxHierarchy]]:
    """:func:`_derived` and the box hierarchy of each part (its triangles taken as
    :func:`triangle_index` takes them, without the R-tree, which stays in the caller's
    process)."""
    out = []
    for p in parts:
        tri, boxes = triangle_hierarchy(p)
        out.append((_derived(p.mesh, tri, tol, ang), boxes))
    return out


def _assemble(mesh: Any, tri: np.ndarray, tree: Any, boxes: BoxHierarchy, derived: tuple
              ) -> PartGeometry:
    """The :class:`PartGeometry` of a part: its triangles ``tri``, their R-tree ``tree``
    (:func:`triangle_index`) and hierarchy ``boxes`` (:func:`triangle_hierarchy`), and what
    :func:`_derived` made of them."""
    normals, areas, facet, fn, fd, smooth, sag, adj = derived
    return PartGeometry(triangles=tri, faces=np.asarray(mesh.faces, dtype=np.int64),
                        vertices=np.asarray(mesh.vertices, dtype=np.float64), normals=normals,
                        areas=areas, lo=boxes.lo, hi=boxes.hi, facet=facet,
                        facet_normal=fn, facet_offset=fd, smooth_angle=smooth, sag=sag,
                        adjacency=adj, tree=tree, boxes=boxes)


def _derived(mesh: Any, tri: np.ndarray, tol: float, ang: float) -> tuple:
    """The facet, sag and adjacency data of :class:`PartGeometry` for the triangles ``tri``
    of ``mesh``: ``(normals, areas, facet, facet_normal, facet_offset, smooth_angle, sag,
    adjacency)``."""
    twice = cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(twice, axis=1)
    normals = twice / np.where(area2 > 0, area2, 1.0)[:, None]
    areas = area2 / 2.0
    nf = len(tri)
    adj = np.asarray(mesh.face_adjacency, dtype=np.int64).reshape(-1, 2)
    smooth = np.zeros(nf)
    sag = np.zeros(nf)
    keep = np.zeros(len(adj), dtype=bool)
    angles = np.zeros(len(adj))
    if len(adj):
        angles = np.asarray(mesh.face_adjacency_angles, dtype=np.float64)
        verts = np.asarray(mesh.vertices, dtype=np.float64)
        # coplanar neighbours: normals within the angular tolerance and each triangle's far
        # vertex within the length tolerance of the other's plane
        unshared = np.asarray(mesh.face_adjacency_unshared)
        d0 = np.abs(np.einsum("ij,ij->i", normals[adj[:, 0]],
                              verts[unshared[:, 1]] - tri[adj[:, 0], 0]))
        d1 = np.abs(np.einsum("ij,ij->i", normals[adj[:, 1]],
                              verts[unshared[:, 0]] - tri[adj[:, 1], 0]))
        keep = (angles <= ang) & (d0 <= tol) & (d1 <= tol)
    facet = graph_components(nf, adj[keep])
    facet, fn, fd, split = _facet_planes(tri, normals, areas, facet, tol, ang)
    if len(adj):
        # A smooth edge joins two facets at a small dihedral angle. Judged after the facets
        # are fitted, not by the angle alone: a surface tessellated finer than the angular
        # tolerance (a cylinder of a fine STEP export, facet angle below 1 degree) passes the
        # local coplanarity test edge by edge, but its facet drifts off any plane and is split
        # back (``_facet_planes``): its triangles are then curved, as at a coarser tessellation.
        is_smooth = ((facet[adj[:, 0]] != facet[adj[:, 1]]) & (angles > SMOOTH_DIHEDRAL_MIN)
                     & (angles <= SMOOTH_DIHEDRAL_MAX))
        edges = np.asarray(mesh.face_adjacency_edges)
        length = np.linalg.norm(verts[edges[:, 0]] - verts[edges[:, 1]], axis=1)
        for side in (0, 1):
            f = adj[:, side]
            h = 2.0 * areas[f] / np.maximum(length, 1e-300)
            s = np.where(is_smooth, 0.5 * h * np.tan(angles / 4.0), 0.0)
            np.maximum.at(sag, f, s)
            np.maximum.at(smooth, f, np.where(is_smooth, angles, 0.0))
        # a triangle of a split facet is curved however its own edges read: at thousands of
        # facets per turn, rounding (float32 files, a 2^-16 mm grid) tilts some edges of a
        # fine ring below SMOOTH_DIHEDRAL_MIN, and a flat-read facet there would pair as
        # planar with its hole's, cutting the curved contact into pieces
        smooth = np.where(split & (smooth == 0.0) & (np.bincount(adj.ravel(), minlength=nf)
                                                     > 0), SMOOTH_DIHEDRAL_MIN, smooth)
    return normals, areas, facet, fn, fd, smooth, sag, adj


def box_tree(lo: np.ndarray, hi: np.ndarray) -> rtree.index.Index:
    """An R-tree over boxes ``[lo, hi]`` (each ``(n, 3)``), ids ``0..n-1``, bulk-loaded from
    the arrays (libspatialindex >= 2.1; else inserted one by one)."""
    prop = rtree.index.Property()
    prop.dimension = 3
    ids = np.arange(len(lo), dtype=np.int64)
    lo, hi = np.ascontiguousarray(lo, dtype=np.float64), np.ascontiguousarray(hi, dtype=np.float64)
    try:
        return rtree.index.Index((ids, lo, hi), properties=prop)
    except NotImplementedError:
        return rtree.index.Index(((int(k), (*a, *b), None) for k, a, b in zip(ids, lo, hi)),
                                 properties=prop)


def graph_components(n: int, edges: np.ndarray) -> np.ndarray:
    """Connected-component label ``(n,)`` of a graph on ``n`` nodes with ``(e, 2)`` edges."""
    if len(edges) == 0:
        return np.arange(n)
    g = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def _facet_planes(tri: np.ndarray, normals: np.ndarray, areas: np.ndarray, facet: np.ndarray,
                  tol: float, ang: float
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Area-weighted plane of each facet; a facet that drifts off its plane by more than ``tol``
    or whose triangles turn more than ``ang`` from its normal (a finely tessellated curve grown
    edge by edge; a whole ring of a fine hole, whose normals sum to nothing) is split back into
    single triangles."""
    split = np.zeros(len(tri), dtype=bool)
    for _ in range(2):
        _, facet = np.unique(facet, return_inverse=True)
        nfac = int(facet.max()) + 1
        w = np.maximum(areas, 1e-300)[:, None]
        fn = np.zeros((nfac, 3))
        np.add.at(fn, facet, normals * w)
        fn /= np.maximum(np.linalg.norm(fn, axis=1), 1e-300)[:, None]
        cen = tri.mean(axis=1)
        fd = np.zeros(nfac)
        np.add.at(fd, facet, np.einsum("ij,ij->i", fn[facet], cen) * w[:, 0])
        wsum = np.zeros(nfac)
        np.add.at(wsum, facet, w[:, 0])
        fd /= wsum
        dev = np.abs(np.einsum("ikj,ij->ik", tri, fn[facet]) - fd[facet][:, None]).max(axis=1)
        worst = np.zeros(nfac)
        np.maximum.at(worst, facet, dev)
        turned = np.zeros(nfac, dtype=bool)
        np.logical_or.at(turned, facet, np.einsum("ij,ij->i", normals, fn[facet]) < np.cos(ang))
        bad = (worst > tol)[facet] | (turned[facet] & (np.bincount(facet, minlength=nfac)
                                                        > 1)[facet])
        if not bad.any():
            break
        facet = np.where(bad, nfac + np.arange(len(tri)), facet)
        split |= bad
    return facet, fn, fd, split


# -- triangle predicates (compiled: :mod:`ndbg_cli.kernels._triangle_kernels`) ------------

def sat_gap(ta: np.ndarray, tb: np.ndarray) -> np.ndarray:
    """Largest separation ``(p,)`` of triangle pairs ``ta``, ``tb`` ``(p, 3, 3)`` along the 11
    separating axes of the triangle-triangle test (both normals and the 9 edge-edge cross
    products; an axis shorter than 1e-9 of the pair's longest is left out). It is a lower
    bound of the pair's distance (any unit axis gives one): ``<= 0`` for intersecting or
    touching triangles, exact for parallel facing triangles, and at most a small factor
    below the true distance for skew ones. Unit: the assembly unit.

    >>> ta = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> sat_gap(ta, ta + [0, 0, 0.5]).tolist()  # parallel, half a unit apart
    [0.5]
    """
    return loaded("_triangle_kernels").sat_gap(ta, tb)


def point_triangle_distance(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Euclidean distance ``(n,)`` from points ``p`` ``(n, 3)`` to triangles ``t`` ``(n, 3, 3)``
    (closest-point regions of Ericson, *Real-Time Collision Detection* 5.1.5).

    >>> t = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> point_triangle_distance(np.array([[2.0, 0, 0]]), t).tolist()  # beyond a vertex
    [1.0]
    """
    return np.linalg.norm(p - closest_on_triangle(p, t), axis=1)


def closest_on_triangle(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The point ``(n, 3)`` of each triangle ``t`` ``(n, 3, 3)`` closest to ``p`` ``(n, 3)``
    (:func:`point_triangle_distance`)."""
    return loaded("_triangle_kernels").closest_on_triangle(p, t)


def segment_distance(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Closest approach of segments ``p1q1`` and ``p2q2`` (each ``(n, 3)``): the distance
    ``(n,)`` and the midpoint ``(n, 3)`` of the two closest points (Ericson 5.1.9)."""
    c1, c2 = segment_closest(p1, q1, p2, q2)
    return np.linalg.norm(c1 - c2, axis=1), (c1 + c2) / 2.0


def segment_closest(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The closest points ``(n, 3)`` of segments ``p1q1`` and ``p2q2``, on each
    (:func:`segment_distance`; a segment of length 0 is its point)."""
    return loaded("_triangle_kernels").segment_closest(p1, q1, p2, q2)


def triangle_gap(ta: np.ndarray, tb: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance ``(p,)`` between triangles ``ta`` and ``tb`` ``(p, 3, 3)``, the unit
    direction ``(p, 3)`` from A's closest point to B's (the normal of the plane that
    separates them best) and the midpoint ``(p, 3)`` of the two closest points. The closest
    pair of points of two disjoint triangles is a vertex and a point of the other triangle
    or two edges' closest points, so the 6 + 9 candidates are exact, unless an edge of one
    crosses the other's interior (an edge's ends strictly on either side of the other's
    plane, crossing it inside or on that triangle); triangles that meet get distance 0 and
    direction 0. Unit: the assembly unit.

    >>> ta = np.array([[[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]])
    >>> gap, direction, mid = triangle_gap(ta, ta + [0, 0, 2.0])
    >>> gap.tolist(), direction.tolist()  # stacked 2 apart: along +z
    ([2.0], [[0.0, 0.0, 1.0]])
    """
    return loaded("_triangle_kernels").triangle_gap(ta, tb)


#: Box tests per numpy block of :func:`box_pairs` (bounds memory to a few MB).
_BOX_BLOCK = 1_000_000


def box_pairs(qlo: np.ndarray, qhi: np.ndarray, tlo: np.ndarray, thi: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray]:
    """All pairs ``(q, t)`` of query boxes ``[qlo, qhi]`` ``(m, 3)`` and target boxes
    ``[tlo, thi]`` ``(n, 3)`` that meet (closed boxes, the R-tree's test), sorted by ``q``
    then ``t``. The ``m x n`` tests run in blocks of :data:`_BOX_BLOCK`, densely along the
    two most selective axes (smallest mean box width over the common extent), then on the
    third axis for the pairs left."""
    if len(qlo) == 0 or len(tlo) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    ext = np.maximum(qhi.max(axis=0), thi.max(axis=0)) - np.minimum(qlo.min(axis=0),
                                                                    tlo.min(axis=0))
    width = (qhi - qlo).mean(axis=0) + (thi - tlo).mean(axis=0)
    axes = np.argsort(width / np.maximum(ext, 1e-300)).tolist()
    ql, qh = np.ascontiguousarray(qlo.T), np.ascontiguousarray(qhi.T)
    tl, th = np.ascontiguousarray(tlo.T), np.ascontiguousarray(thi.T)
    step = max(1, _BOX_BLOCK // max(len(tlo), 1))
    out_q, out_t = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for s in range(0, len(qlo), step):
        hit = None
        for d in axes[:2]:
            m = ql[d, s:s + step, None] <= th[d, None, :]
            m &= qh[d, s:s + step, None] >= tl[d, None, :]
            hit = m if hit is None else hit & m
        qi, ti = np.nonzero(hit)
        d = axes[2]
        ok = (ql[d, s:s + step][qi] <= th[d, ti]) & (qh[d, s:s + step][qi] >= tl[d, ti])
        out_q.append(qi[ok] + s)
        out_t.append(ti[ok])
    return np.concatenate(out_q), np.concatenate(out_t)



def min3(x: np.ndarray) -> np.ndarray:
    """Minimum over the last axis (of length 3) of ``x``, element by element."""
    return np.minimum(np.minimum(x[..., 0], x[..., 1]), x[..., 2])


def max3(x: np.ndarray) -> np.ndarray:
    """Maximum over the last axis (of length 3) of ``x``, element by element."""
    return np.maximum(np.maximum(x[..., 0], x[..., 1]), x[..., 2])


def origin_distance_2d(t: np.ndarray) -> np.ndarray:
    """Distance ``(k,)`` from the origin to each plane triangle ``(k, 3, 2)`` (0 when the
    origin is inside or on it; a triangle seen edge-on, collinear with the origin, counts as
    containing it: the answer is then too small, never too large)."""
    a, b, c = t[:, 0], t[:, 1], t[:, 2]
    s = np.stack([_cross2(b - a, -a), _cross2(c - b, -b), _cross2(a - c, -c)], axis=1)
    inside = (s >= 0).all(axis=1) | (s <= 0).all(axis=1)
    d = np.minimum(np.minimum(_origin_segment(a, b), _origin_segment(b, c)),
                   _origin_segment(c, a))
    return np.where(inside, 0.0, d)


def _cross2(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    return p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]


def _origin_segment(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Distance from the origin to each segment ``p q`` (``(k, 2)`` each)."""
    d = q - p
    dd = (d * d).sum(axis=1)
    t = np.clip(-(p * d).sum(axis=1) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    return np.linalg.norm(p + t[:, None] * d, axis=1)
