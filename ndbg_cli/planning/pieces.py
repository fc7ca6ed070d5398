"""Convex pieces of an NDBG's regions: each region's extent as relatively open convex cones, and
their split by a plane (for :mod:`ndbg_cli.planning.grasp`, which must hold every direction of a
region, not its representative only).

A piece is given by unit generators (the extreme rays of its closure, in cyclic order): one
(a point), two (the open arc between them, shorter than ``pi``) or three and more (an open
convex spherical polygon inside an open hemisphere); it is the set of strictly positive
combinations of its generators. On S^1 (2D assemblies) the generators are 2-vectors.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry.directions import circle_frames
from ..geometry.vectors import cross, unit
from ..ndbg.model import NDBG

#: Arcs and polygon edges longer than this (radians) are cut (arcs) or given inner vertices
#: (polygons), so that no generator is near the antipode of its neighbour.
LONG = 2.0 * math.pi / 3.0


def _turn(a: np.ndarray, axis: np.ndarray | None) -> np.ndarray:
    """The unit tangent at ``a`` turning counter-clockwise (2D) or about ``axis`` (3D)."""
    if len(a) == 2:
        return np.array([-a[1], a[0]])
    return unit(cross(axis, a))


def _arc(a: np.ndarray, theta: float, axis: np.ndarray | None = None,
         b: np.ndarray | None = None) -> list[np.ndarray]:
    """Pieces of the open arc from ``a`` turning by ``theta`` radians (about ``axis`` in 3D;
    ends at ``b`` when given): one arc if not longer than :data:`LONG`, else equal sub-arcs
    and the points between them."""
    k = max(1, math.ceil(theta / LONG - 1e-12))
    u = _turn(a, axis)
    pts = [a] + [math.cos(t) * a + math.sin(t) * u for t in np.arange(1, k) * theta / k]
    pts.append(b if b is not None else math.cos(theta) * a + math.sin(theta) * u)
    out = [np.stack([p, q]) for p, q in zip(pts, pts[1:])]
    return out + [p[None] for p in pts[1:-1]]


def _densify(cycle: np.ndarray) -> np.ndarray:
    """A convex polygon's cycle with inner vertices on edges longer than :data:`LONG`."""
    out = []
    for a, b in zip(cycle, np.roll(cycle, -1, axis=0)):
        out.append(a)
        theta = math.acos(min(1.0, max(-1.0, float(a @ b))))
        k = math.ceil(theta / LONG - 1e-12)
        for j in range(1, k):  # slerp: the shorter arc
            t = j / k
            out.append(unit(math.sin((1 - t) * theta) * a + math.sin(t * theta) * b))
    return np.array(out)


def _orthants(fixed: list[np.ndarray], free: list[np.ndarray]) -> list[np.ndarray]:
    """Pieces of the open cone of the strictly positive combinations of ``fixed`` plus any
    combination of ``+-free``: one per sign vector over ``free`` (0 leaves it out)."""
    out = []
    for signs in np.ndindex(*(3,) * len(free)):
        gens = list(fixed) + [(s - 1) * f for s, f in zip(signs, free) if s != 1]
        if not gens:
            continue
        g = np.array(gens)
        if len(g) == 2 and float(g[0] @ g[1]) < math.cos(LONG):
            out += _arc(g[0], math.acos(max(-1.0, float(g[0] @ g[1]))), cross(g[0], g[1])
                        if g.shape[1] == 3 else None, g[1])
        else:
            out.append(_densify(g) if len(g) >= 3 else g)
    return out


def _axes(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing the unit ``m`` to a right-handed orthonormal basis."""
    e1, e2 = circle_frames(m)
    return e1[0], e2[0]


def _arrangement_pieces(ndbg: NDBG) -> list[list[np.ndarray]] | None:
    """Pieces of the infinitesimal 3D NDBG's regions from its arrangement (vertices, edges,
    faces, in that order), or ``None`` when it is absent or does not fit the regions."""
    arr = ndbg.geometry
    if arr is None or not hasattr(arr, "face_vertices"):
        return None
    nv, ne, nf = len(arr.vertices), len(arr.edge_mid), len(arr.face_rep)
    if nv + ne + nf != len(ndbg.regions):
        return None
    verts, circles = arr.vertices, arr.circles
    out: list[list[np.ndarray]] = [[np.asarray(r.direction, float)[None]]
                                   for r in ndbg.regions[:nv]]
    for e in range(ne):
        m = circles[arr.edge_circle[e]]
        a, b = int(arr.edge_start[e]), int(arr.edge_end[e])
        if a < 0:  # a closed circle (one circle drawn)
            out.append(_orthants([], list(_axes(m))))
            continue
        va, vb = verts[a], verts[b]
        theta = math.atan2(float(cross(va, vb) @ m), float(va @ vb)) % (2 * math.pi)
        out.append(_arc(va, theta or 2 * math.pi, m, vb))
    for f in range(nf):
        cyc = arr.face_vertices[f]
        rep = arr.face_rep[f]
        if len(cyc) == 0:  # the whole sphere, or a hemisphere of one circle
            if len(circles) == 0:
                out.append(_orthants([], list(np.eye(3))))
            else:
                m = circles[0] * (1.0 if rep @ circles[0] > 0 else -1.0)
                out.append(_orthants([m], list(_axes(m))))
        elif len(cyc) == 2:  # a lune of a pencil of circles through +-p
            p = verts[cyc[0]]
            e1, e2 = _axes(p)
            rays = unit(cross(p[None], circles))
            rays = np.vstack([rays, -rays])
            ang = np.arctan2(rays @ e2, rays @ e1)
            at = math.atan2(float(rep @ e2), float(rep @ e1))
            off = np.mod(ang - at, 2 * math.pi)
            b1, b2 = rays[int(np.argmax(off))], rays[int(np.argmin(off))]
            out.append(_orthants([b1, b2], [p]))
        else:
            out.append([_densify(verts[list(cyc)])])
    return out


def _s1_pieces(spans: list[tuple[float, float, bool, bool]]) -> list[list[np.ndarray]]:
    """Pieces of regions of S^1 given as ``(lo, hi, lo_closed, hi_closed)`` angles."""
    out = []
    for lo, hi, lo_in, hi_in in spans:
        if hi - lo >= 2 * math.pi - 1e-12:
            out.append(_orthants([], [np.array([1.0, 0.0]), np.array([0.0, 1.0])]))
            continue
        a, b = (np.array([math.cos(t), math.sin(t)]) for t in (lo, hi))
        pieces = [a[None]] if lo_in else []
        if hi_in and hi > lo:
            pieces.append(b[None])
        if hi > lo:
            pieces += _arc(a, hi - lo, None, b)
        out.append(pieces)
    return out


def _sequence_spans(ndbg: NDBG) -> list[tuple[float, float, bool, bool]] | None:
    """The 2D infinitesimal regions' extents: points and the open arcs between them
    alternate round S^1 (:func:`ndbg_cli.ndbg.infinitesimal.build.iter_regions_2d`)."""
    regs = ndbg.regions
    if len(regs) == 1:
        return [(0.0, 2 * math.pi, True, False)]
    if len(regs) % 2 or any(r.dimension != k % 2 for k, r in enumerate(regs)):
        return None
    phi = [math.atan2(r.direction[1], r.direction[0]) % (2 * math.pi) for r in regs[::2]]
    out = []
    for k, t in enumerate(phi):
        nxt = phi[(k + 1) % len(phi)]
        out += [(t, t, True, True), (t, t + ((nxt - t) % (2 * math.pi) or 2 * math.pi),
                                     False, False)]
    return out


def _cell_pieces(ndbg: NDBG) -> list[list[np.ndarray]] | None:
    """Pieces of the infinite 3D NDBG's regions from their chart cells, kept by the build."""
    import shapely

    from ..ndbg.infinite.cubemap import direction_of

    bs = ndbg.geometry
    cells, at = bs.cells, bs.region_cells
    if cells is None or at is None or len(at) != len(ndbg.regions):
        return None
    out = []
    for r, i in zip(ndbg.regions, at):
        c, d = cells[i], np.asarray(r.direction, float)
        # a thin cell's centroid may lie outside it: lower-dimensional ones keep theirs
        pieces = [d[None]] if r.dimension < 2 or float(d @ c.direction) < 1 - 1e-12 else []
        kind = shapely.get_type_id(c.geom)
        if kind == 0:
            pieces.append(c.direction[None])
        elif kind in (1, 5):  # a chain: its segments and inner vertices
            for line in shapely.get_parts(c.geom):
                p = direction_of(c.face, shapely.get_coordinates(line))
                pieces += [np.stack([a, b]) for a, b in zip(p, p[1:])]
                pieces += [q[None] for q in p[1:-1]]
        else:  # polygons: open triangles and the inner diagonals between them
            seen: dict[tuple, int] = {}
            for tri in shapely.get_parts(shapely.constrained_delaunay_triangles(c.geom)):
                xy = shapely.get_coordinates(tri)[:3]
                u, w = xy[1] - xy[0], xy[2] - xy[0]
                if u[0] * w[1] - u[1] * w[0] == 0:  # a flat triangle
                    continue
                pieces.append(direction_of(c.face, xy))
                for a, b in ((0, 1), (1, 2), (2, 0)):
                    key = tuple(sorted((tuple(xy[a]), tuple(xy[b]))))
                    seen[key] = seen.get(key, 0) + 1
            pieces += [direction_of(c.face, np.array(k)) for k, n in seen.items() if n == 2]
        out.append(pieces)
    return out


def region_pieces(ndbg: NDBG) -> list[list[np.ndarray]] | None:
    """Every region's extent as convex pieces: per region a list of ``(g, dim)`` arrays of
    unit generators; ``None`` when the NDBG keeps no geometry its regions can be matched to
    (then only their representatives are known). The extents come from:

    * infinitesimal 3D: :attr:`NDBG.geometry`, the arrangement of great circles (vertices,
      arcs between vertices, faces' vertex cycles); cells that are not pointed (the whole
      sphere, a hemisphere, the lunes of a pencil of circles, a whole circle) are cut into
      pointed pieces by planes through the axes (or the pencil's axis), long arcs into
      shorter ones;
    * infinitesimal 2D: the regions themselves (points and open arcs alternate round S^1);
    * infinite 2D: the runs of :func:`ndbg_cli.ndbg.infinite.equator.equator_extents` (ends
      open or closed);
    * infinite 3D: the cells of :func:`ndbg_cli.ndbg.infinite.arrangement.arrangement_cells`
      that the build kept with each region (``BlockedSets.cells``); chart polygons are
      triangulated (open triangles and their inner diagonals), chains cut into segments and
      inner vertices; a lower-dimensional region's representative (moved onto contact
      circles, or a thin cell's centroid, which may lie outside it) is a point piece too;
    * otherwise (hand-built NDBGs): ``None``; the grasp then holds the representatives only
      and says ``"coverage": "representatives"``. Generalized suggested motions are single
      motions, not directions: they make no requirement."""
    from ..core.constants import INFINITE, INFINITESIMAL

    if not ndbg.regions or any(r.direction is None for r in ndbg.regions):
        return None
    if ndbg.family == INFINITESIMAL:
        if ndbg.space_dimension == 3:
            return _arrangement_pieces(ndbg)
        spans = _sequence_spans(ndbg) if "diameters" in ndbg.stats else None
        return None if spans is None else _s1_pieces(spans)
    if ndbg.family == INFINITE:
        from ..ndbg.infinite.blocked_sets import BlockedSets

        bs = ndbg.geometry if isinstance(ndbg.geometry, BlockedSets) else None
        if bs is not None and bs.arcs is not None:
            from ..ndbg.infinite.equator import direction, equator_extents, sliding_angles

            ext = equator_extents(bs.arcs, bs.n, bs.eta, sliding_angles(bs.circles))
            if len(ext) != len(ndbg.regions) or any(
                    dm != r.dimension or direction(phi) != tuple(r.direction)
                    for (dm, phi, _, _), r in zip(ext, ndbg.regions)):
                return None
            return _s1_pieces([e[3] for e in ext])
        if bs is not None:
            return _cell_pieces(ndbg)
    return None


def split_piece(g: np.ndarray, v: np.ndarray, tol: float) -> list[np.ndarray]:
    """The pieces of the open piece ``g`` a finger with values ``v = g . n`` (some above
    ``tol``, some below ``-tol``) leaves unblocked: the part with ``d . n < 0`` and the chord
    on its circle ``d . n = 0``."""
    s = np.where(v > tol, 1, np.where(v < -tol, -1, 0))
    if len(g) == 2:
        c = unit(abs(v[0]) * g[1] + abs(v[1]) * g[0])
        return [np.stack([c, g[int(np.argmin(v))]]), c[None]]
    out, on = [], []
    for i in range(len(g)):
        j = (i + 1) % len(g)
        if s[i] <= 0:
            out.append(g[i])
            if s[i] == 0:
                on.append(g[i])
        if s[i] * s[j] == -1:
            c = unit(abs(v[i]) * g[j] + abs(v[j]) * g[i])
            out.append(c)
            on.append(c)
    on_a = np.array(on)
    dots = on_a @ on_a.T
    a, b = np.unravel_index(int(np.argmin(dots)), dots.shape)
    pieces = [_densify(np.array(out))]
    if dots[a, b] >= 1 - 1e-15:
        return pieces + [on_a[a][None]]
    axis = cross(on_a[a], on_a[b]) if g.shape[1] == 3 else None
    return pieces + _arc(on_a[a], math.acos(max(-1.0, float(dots[a, b]))), axis, on_a[b])
