"""The arrangement of the blocked-direction sets on the cube map: its cells (regions of dimension 2,
1 and 0), face by face, from the chart geometry of
:class:`ndbg_cli.ndbg.infinite.blocked_sets.BlockedSets`, and the seam candidates on the contact
circles.

Chart coordinates are those of :mod:`ndbg_cli.ndbg.infinite.cubemap` (about radians near a face's
centre); linework is snapped to :data:`~ndbg_cli.ndbg.infinite.chart_union.GRID`.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely

from ...kernels.compiled import loaded
from ...kernels.cube_faces import FACES
from .chart_union import GRID, antipodal
from .cubemap import SQUARE_MARGIN, direction_of

if TYPE_CHECKING:
    from .blocked_sets import BlockedSets

#: Chart points at least this close to the square's border (cube edges) are left to the
#: neighbouring face.
_INSIDE = 1.0 - 1e-7


@dataclass(frozen=True)
class Cell:
    """One region of the arrangement on one cube face: its dimension (2, 1 or 0 after the
    thin-region rule), a representative unit direction strictly inside it (``(3,)``), and its
    chart geometry."""

    dimension: int
    direction: np.ndarray
    face: int
    geom: object
    seam: bool = False
    #: The index (in the list of :func:`arrangement_cells`) of the cell this one is the
    #: antipodal image of, or -1: its DBG is that cell's reversed (``G(-d)``).
    mirror_of: int = -1


def arrangement_cells(bs: BlockedSets, workers: int = 1) -> list[Cell]:
    """The regions of the arrangement of all ``B_ij`` boundaries, face by face.

    The boundaries of every ``U_ij`` on a face, with the chart square, are noded (collinear
    pieces merged first, :func:`merged_segments`) and polygonized; each polygon is a region.
    A region thinner than ``eta`` (width ``2 area / perimeter``) is 1-dimensional, one smaller
    than ``eta`` across (bounding box) is 0-dimensional. The noded boundaries give the
    1-dimensional cells (the chains between nodes where other than two pieces meet: a polygon's
    corner is not a node; a closed boundary meeting nothing else is one chain, with one node at
    its first point) and the 0-dimensional ones (their end points). Cells on the contact
    circles but off every boundary are *seam candidates* (``seam=True``):
    :func:`build_infinite` keeps those whose exact DBG differs from the one around them (a
    slot's or a bore's free directions). ``workers`` threads take the faces (GEOS releases
    the GIL; the cells are listed face by face whatever their number).

    With ``bs.paired`` (the sets on each odd face are the exact antipodal images of those on
    the even one, ``B_ji = -B_ij``, and so are the domain and the contact circles), the
    arrangement on an odd face is the image of the even face's: its cells are mapped, not
    computed (``mirror_of`` says from which), which halves the work.
    """
    faces = [f for f in range(6) if bs.domain is None or bs.domain[f] is not None]
    mirrored = [f for f in faces if bs.paired and f & 1 and f ^ 1 in faces]
    made = [f for f in faces if f not in mirrored]
    if workers > 1 and len(made) > 1:
        with ThreadPoolExecutor(max_workers=min(workers, len(made)) + 1) as pool:
            # the crossings are made while the faces' linework is noded; a face waits for
            # them only when it needs them. Just in time the kernel runs without the GIL;
            # built ahead of time it holds it (numba's pycc cannot release it) and the faces
            # wait for it: 0.1 s on AS1's crossings, where numba's start costs 0.5 s
            crossings = pool.submit(circle_crossings, bs.circles, bs.eta, bs.domain, made)
            done = list(pool.map(lambda f: _face_cells(bs, f, crossings), made))
    else:
        crossings = circle_crossings(bs.circles, bs.eta, bs.domain, made)
        done = [_face_cells(bs, f, crossings) for f in made]
    by_face = dict(zip(made, done))
    out: list[Cell] = []
    start: dict[int, int] = {}
    for f in faces:
        if f in mirrored:
            out.extend(mirror_cells(by_face[f ^ 1], start[f ^ 1]))
        else:
            start[f] = len(out)
            out.extend(by_face[f])
    return out


def mirror_cells(cells: list[Cell], first: int) -> list[Cell]:
    """The antipodal images of ``cells`` (one face's, listed from index ``first``) on the
    opposite face: geometry mapped exactly (:func:`~ndbg_cli.ndbg.infinite.chart_union.antipodal`),
    directions negated (``0.0 - d``: no negative zeros)."""
    if not cells:
        return []
    geoms = antipodal(np.array([c.geom for c in cells], dtype=object))
    return [Cell(c.dimension, 0.0 - c.direction, c.face ^ 1, g, c.seam, first + k)
            for k, (c, g) in enumerate(zip(cells, geoms))]


def _face_cells(bs: BlockedSets, face: int, crossings: list | Future) -> list[Cell]:
    """The cells of :func:`arrangement_cells` on ``face`` (``crossings``: the contact
    circles' crossings per face, :func:`circle_crossings`, or a future of them)."""
    r = 1.0 + SQUARE_MARGIN
    square = shapely.box(-r, -r, r, r)
    dom = None if bs.domain is None else bs.domain[face]
    cells: list[Cell] = []
    lines = [shapely.boundary(g) for g in bs.geoms[face].values()]
    lines.append(square.boundary)
    if dom is not None:
        lines.append(shapely.boundary(dom))
    # chains between the nodes of degree other than 2: one 1-dimensional cell each
    noded = shapely.line_merge(shapely.union_all(merged_segments(lines), grid_size=GRID))
    if isinstance(crossings, Future):
        crossings = crossings.result()
    cells.extend(seam_cells(noded, bs.circles, face, dom, crossings[face]))
    faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(noded)))
    faces = faces[shapely.area(faces) > 0]
    if dom is not None and len(faces):
        # the domain's boundary is in the linework: each face is inside it or outside
        faces = faces[shapely.contains(dom, shapely.point_on_surface(faces))]
    if not len(faces):
        if dom is not None:
            cells.extend(_edge_cells(noded, face, dom))
        return cells
    pts = shapely.point_on_surface(faces)
    xy = shapely.get_coordinates(pts)
    area = shapely.area(faces)
    width = 2 * area / np.maximum(shapely.length(faces), 1e-300)
    b = shapely.bounds(faces)
    extent = np.maximum(b[:, 2] - b[:, 0], b[:, 3] - b[:, 1])
    dims = np.where(extent < bs.eta, 0, np.where(width < bs.eta, 1, 2))
    cent = shapely.get_coordinates(shapely.centroid(faces))
    use = np.where((dims == 0)[:, None], cent, xy)
    dirs = direction_of(face, use)
    if len(bs.circles):
        # a region's point may lie on a contact circle (point_on_surface of a square is
        # its centre: an axis, where the contacts of an axis-aligned assembly slide),
        # where the open sets free what the region's DBG blocks: move it off them
        two = np.flatnonzero(dims == 2)
        on = two[(np.abs(dirs[two] @ bs.circles.T) < OFF_CIRCLE).any(axis=1)]
        for k in on:
            p = off_circles(faces[k], bs.circles, face)
            if p is not None:
                dirs[k] = direction_of(face, p)[0]
    for k in range(len(faces)):
        cells.append(Cell(int(dims[k]), dirs[k], face, faces[k]))
    cells.extend(_edge_cells(noded, face, dom))
    return cells


#: ``|n . d|`` below which a 2-dimensional region's point counts as on the contact circle of
#: normal ``n`` (unit vectors) and is moved off it by :func:`off_circles`.
OFF_CIRCLE = 1e-6


def off_circles(region: object, normals: np.ndarray, face: int) -> np.ndarray | None:
    """A chart point ``(1, 2)`` inside the polygon ``region`` of ``face`` off the contact
    circles (normals ``(c, 3)``, unit): of a grid of points over the region's box (16 x 16,
    then 64 x 64 when none lies inside), the inside one farthest from every circle (largest
    ``min |n . d|``); ``None`` when none is farther than :data:`OFF_CIRCLE` (the point
    stays). Vectorised over points and circles: a tessellated bore's thousands of concurrent
    circles made a buffered union of their lines take minutes on a real assembly."""
    x0, y0, x1, y1 = region.bounds
    shapely.prepare(region)
    for k in (16, 64):
        # cell centres: never the box's edges, which the region's boundary may run along
        gx = x0 + (np.arange(k) + 0.5) * (x1 - x0) / k
        gy = y0 + (np.arange(k) + 0.5) * (y1 - y0) / k
        xx, yy = np.meshgrid(gx, gy)
        xx, yy = xx.ravel(), yy.ravel()
        inside = shapely.contains_xy(region, xx, yy)
        if inside.any():
            pts = np.stack([xx[inside], yy[inside]], axis=1)
            d = direction_of(face, pts)
            margin = np.abs(d @ normals.T).min(axis=1)
            best = int(np.argmax(margin))
            return pts[best:best + 1] if margin[best] > OFF_CIRCLE else None
    return None


#: Segments whose supporting lines agree this closely (direction and offset, chart units)
#: are merged as collinear before noding; far below the snapping :data:`GRID`.
COLLINEAR_TOL = 1e-12


def merged_segments(lines: list) -> np.ndarray:
    """The segments of the linework ``lines`` (shapely geometries, chart units) with collinear
    overlapping or touching segments merged: the same point set, as 2-point line strings.

    The boundaries of many ``B_ij`` lie on the same great circles (boxes, faces of one plane,
    the contact circles), whose collinear, overlapping pieces make snap-rounding slow
    (benchmarks/NOTES.md)."""
    parts = shapely.get_parts(shapely.get_parts(np.asarray(lines, dtype=object)))
    xy, idx = shapely.get_coordinates(parts, return_index=True)
    same = idx[1:] == idx[:-1]
    p, q = xy[:-1][same], xy[1:][same]
    d = q - p
    ln = np.hypot(d[:, 0], d[:, 1])
    keep = ln > 0
    p, q, d, ln = p[keep], q[keep], d[keep], ln[keep]
    if not len(p):
        return np.zeros(0, dtype=object)
    u = d / ln[:, None]
    flip = (u[:, 0] < 0) | ((u[:, 0] == 0) & (u[:, 1] < 0))  # one direction per line
    u[flip] *= -1.0
    p, q = np.where(flip[:, None], q, p), np.where(flip[:, None], p, q)
    off = u[:, 0] * p[:, 1] - u[:, 1] * p[:, 0]  # signed distance of the line to the origin
    key = np.round(np.column_stack([u, off]) / COLLINEAR_TOL).astype(np.int64)
    _, line = np.unique(key, axis=0, return_inverse=True)
    line = line.ravel()
    a = (p * u).sum(axis=1)  # positions along the line
    b = (q * u).sum(axis=1)
    order = np.lexsort((a, line))
    line, a, b, p, u = line[order], a[order], b[order], p[order], u[order]
    # the running end per line, exactly: on the ranks of the ends, offset per line in
    # integers so that one accumulate serves all lines
    qs = q[order]
    vals, rank = np.unique(b, return_inverse=True)
    big = len(vals) + 1
    reach = np.maximum.accumulate(rank.ravel() + line * big) - line * big
    start = np.r_[True, (line[1:] != line[:-1]) | (a[1:] > vals[reach[:-1]])]
    first = np.flatnonzero(start)
    # each run ends at the end point of the segment reaching farthest (exact coordinates)
    best = _run_argmax(b, first)
    ends = np.stack([p[first], qs[best]], axis=1)
    return shapely.linestrings(ends)


def _run_argmax(x: np.ndarray, first: np.ndarray) -> np.ndarray:
    """Index of the largest ``x`` in each run ``first[k]:first[k + 1]`` (the last largest)."""
    run = np.repeat(np.arange(len(first)), np.diff(np.r_[first, len(x)]))
    order = np.lexsort((x, run))  # within a run, by value; the run's last is its maximum
    last = np.r_[np.flatnonzero(run[order][1:] != run[order][:-1]), len(x) - 1]
    return order[last]


#: Most circles through one face (inside the domain) whose pieces are seam candidates; with
#: more, only their crossings are.
SEAM_CIRCLES = 256


def seam_cells(noded: object, normals: np.ndarray, face: int, dom: object,
               pts0: np.ndarray) -> list[Cell]:
    """Seam candidates on ``face``: directions on the contact circles (normals ``(c, 3)``)
    off the noded ``B_ij`` boundaries (farther than ``10 GRID``; a crossing of two circles
    off their nodes only, which have cells of their own), where the open-set
    semantics may free what the closed sets block. One per piece of a circle between two
    boundary crossings (its midpoint, 1-dimensional) and one per crossing of two circles
    (0-dimensional: ``pts0`` ``(k, 2)``, this face's entry of :func:`circle_crossings`). Only
    inside ``dom`` when given.

    The circles are not noded with each other: ``k`` circles through one window would cost
    ``k^2`` pieces, and a change of the DBG along a circle happens at a boundary crossing or
    at another circle's crossing, both candidates here."""
    circ = circle_lines(normals, face)
    if dom is not None and circ:
        shapely.prepare(dom)
        meets = shapely.intersects(dom, circ)
        if meets.sum() > SEAM_CIRCLES:
            # past SEAM_CIRCLES the pieces are not used (below), only the crossings: the
            # circles are not cut (benchmarks/NOTES.md)
            circ = [None] * int(meets.sum())
        else:
            circ = [g for g in shapely.intersection(np.asarray(circ, dtype=object)[meets], dom)
                    if not g.is_empty]
    if not circ:
        return []
    mids = []
    # the pieces of a pencil of many circles (a tessellated cylinder's facets, around its
    # axis) are each blocked by the neighbouring facets: past SEAM_CIRCLES only crossings
    for line in circ if len(circ) <= SEAM_CIRCLES else []:
        for seg in shapely.get_parts(line):
            if shapely.get_type_id(seg) != 1 or seg.length <= 0:
                continue
            hit = shapely.get_coordinates(shapely.intersection(seg, noded))
            at = np.sort(np.concatenate([[0.0, seg.length], shapely.line_locate_point(
                seg, shapely.points(hit)) if len(hit) else []]))
            m = 0.5 * (at[1:] + at[:-1])
            m = m[np.diff(at) > 20 * GRID]
            if len(m):
                mids.append(shapely.get_coordinates(shapely.line_interpolate_point(seg, m)))
    pts1 = np.concatenate(mids) if mids else np.zeros((0, 2))
    out: list[Cell] = []
    for dim, pts in ((1, pts1), (0, pts0)):
        if not len(pts):
            continue
        pts = pts[(np.abs(pts) < _INSIDE).all(axis=1)]
        if dom is not None and len(pts):
            pts = pts[shapely.contains_xy(dom, pts[:, 0], pts[:, 1])]
        if len(pts):
            # a crossing is left to the linework's own cells only where one is: at a node
            # (a chain's end); inside a chain (one running along a contact circle that
            # another circle crosses) no cell has its direction
            near = noded if dim == 1 else shapely.multipoints(_ends(_segments(noded)))
            pts = pts[shapely.distance(near, shapely.points(pts)) > 10 * GRID]
        out.extend(Cell(dim, d, face, shapely.Point(p), seam=True)
                   for d, p in zip(direction_of(face, pts), pts))
    return out


def _segments(noded: object) -> np.ndarray:
    """The line pieces of the noded linework (its chains)."""
    segs = shapely.get_parts(shapely.get_parts(noded))
    return segs[shapely.get_type_id(segs) == 1]


def _ends(segs: np.ndarray) -> np.ndarray:
    """``(2 k, 2)`` the first and last points of ``k`` line pieces (the nodes of chains)."""
    if not len(segs):
        return np.zeros((0, 2))
    xy, idx = shapely.get_coordinates(segs, return_index=True)
    last = np.r_[np.flatnonzero(idx[1:] != idx[:-1]), len(idx) - 1]
    first = np.r_[0, last[:-1] + 1]
    return np.concatenate([xy[first], xy[last]])


#: Circle pairs crossed per vectorised chunk in :func:`circle_crossings`.
CROSS_CHUNK = 1_000_000


def circle_crossings(normals: np.ndarray, eta: float, domain: list | None = None,
                     faces: Sequence[int] = range(6)) -> list[np.ndarray]:
    """Per cube face, chart points ``(k, 2)`` of the crossings of two great circles (normals
    ``(c, 3)``; both antipodal points ``+-n_a x n_b``) strictly inside the face's square and,
    with ``domain`` (per face chart geometry or ``None``), inside it. Crossings closer than
    ``eta`` are merged (the first kept), as the nearly concurrent circles of a tessellated
    cylinder's facets all are near its axis. Only on ``faces`` (the others: none)."""
    kernels = loaded("_cone_kernels")
    n = np.ascontiguousarray(normals, dtype=float)
    npairs = len(n) * (len(n) - 1) // 2
    found: list[list[np.ndarray]] = [[] for _ in range(6)]

    def first(pts: np.ndarray) -> np.ndarray:
        # np.unique(axis=0) keeps each rounded point's first occurrence, but sorts rows as
        # structured records (slow on millions); a stable two-key sort gives the same rows
        q = np.round(pts / max(eta, GRID))
        order = np.lexsort((q[:, 1], q[:, 0]))
        qs = q[order]
        new = np.r_[True, np.any(qs[1:] != qs[:-1], axis=1)] if len(qs) else np.zeros(0, bool)
        return pts[np.sort(order[new])]

    # With a domain, each antipodal pair of faces takes only the circles that meet its domain
    # box (a crossing lies on both circles), chunk by chunk of the same pairs, so that the
    # crossings come in the same order and the same ones are kept first.
    groups: list[tuple[np.ndarray, tuple[int, ...]]] = [(np.ones(len(n), dtype=bool),
                                                         tuple(faces))]
    boxes = np.tile([-np.inf, -np.inf, np.inf, np.inf], (6, 1))
    if domain is not None and len(n):
        groups = []
        for f in range(0, 6, 2):
            pair = tuple(g for g in (f, f + 1) if domain[g] is not None and g in faces)
            if pair:
                meets = np.zeros(len(n), dtype=bool)
                for g in pair:
                    e, u, v = FACES[g]
                    x0, y0, x1, y1 = boxes[g] = domain[g].bounds
                    at = np.stack([n @ u * x + n @ v * y + n @ e
                                   for x in (x0, x1) for y in (y0, y1)])
                    # rounding slack: a pair too many only adds crossings outside
                    meets |= (at.min(axis=0) <= 1e-12) & (at.max(axis=0) >= -1e-12)
                groups.append((meets, pair))
    fused = _fused_inputs(groups, boxes, domain, max(eta, GRID), len(n))
    if fused is not None:
        meets, edges, nedges, key_lo, key_n = fused
        pts, lab = kernels.first_crossings(n, meets, _INSIDE, boxes, edges, nedges,
                                           max(eta, GRID), CROSS_CHUNK, key_lo, key_n)
        return [pts[lab == f] for f in range(6)]
    for s0, (meets, pair) in itertools.product(range(0, npairs, CROSS_CHUNK), groups):
        # the crossings of the chunk's pairs on these faces, outside the domain's boxes
        # left out (contains_xy would drop them)
        flags = np.isin(np.arange(6), pair)
        pts, lab = kernels.circle_crossings(n, s0, min(s0 + CROSS_CHUNK, npairs), meets,
                                            flags, _INSIDE, boxes)
        for face in pair:
            st = pts[lab == face]
            if domain is not None and len(st):
                st = st[shapely.contains_xy(domain[face], st[:, 0], st[:, 1])]
            if len(st):
                found[face].append(first(st))
    return [first(np.concatenate(f)) if f else np.zeros((0, 2)) for f in found]


#: Most merge keys (``eta``-cells of the domain's boxes, over the six faces) for which
#: :func:`circle_crossings` takes the one-pass kernel.
FUSED_KEYS = 1 << 24


def _fused_inputs(groups: list, boxes: np.ndarray, domain: list | None, q: float, c: int
                  ) -> tuple | None:
    """What :func:`ndbg_cli.kernels._cone_kernels.first_crossings` takes besides the circles, or
    ``None`` when it cannot replace the chunked path: no domain, a domain polygon with an edge that
    is not axis-parallel (domain polygons are unions of raster cells), or too many keys."""
    if domain is None:
        return None
    meets = np.zeros((6, c), dtype=bool)
    for m, faces in groups:
        meets[list(faces)] = m
    rings = []
    for f in range(6):
        if domain[f] is None or not meets[f].any():
            meets[f] = False
            rings.append(np.zeros((0, 4)))
            continue
        polys = shapely.get_parts(domain[f])
        ring = shapely.get_rings(polys)
        xy, idx = shapely.get_coordinates(ring, return_index=True)
        same = idx[1:] == idx[:-1]
        e = np.column_stack([xy[:-1][same], xy[1:][same]])
        if not np.all((e[:, 0] == e[:, 2]) | (e[:, 1] == e[:, 3])):
            return None
        rings.append(e)
    lo = np.zeros((6, 2), dtype=np.int64)
    size = np.ones((6, 2), dtype=np.int64)
    for f in range(6):
        if meets[f].any():
            x0, y0, x1, y1 = boxes[f]
            lo[f] = np.floor(np.array([x0, y0]) / q) - 1
            size[f] = np.ceil(np.array([x1, y1]) / q) - lo[f] + 2
    if size.prod(axis=1).sum() > FUSED_KEYS:
        return None
    edges = np.zeros((6, max(len(r) for r in rings), 4))
    for f, r in enumerate(rings):
        edges[f, :len(r)] = r
    return meets, edges, np.array([len(r) for r in rings], dtype=np.int64), lo, size


def circle_lines(normals: np.ndarray, face: int) -> list[object]:
    """Chart segments of the great circles ``d . n = 0`` crossing ``face``'s square."""
    e, u, v = FACES[face]
    r = 1.0 + SQUARE_MARGIN
    if not len(normals):
        return []
    # the same scalar products and arithmetic as one circle at a time, then one GEOS call
    abc = np.array([(n @ u, n @ v, n @ e) for n in normals])
    abc = abc[np.maximum(np.abs(abc[:, 0]), np.abs(abc[:, 1])) >= 1e-12]
    a, b, c = abc[:, 0:1], abc[:, 1:2], abc[:, 2:3]
    ends = np.array([-r, r])[None, :]
    by_t = np.abs(a) >= np.abs(b)  # s as a function of t, else t of s
    pts = np.where(by_t[:, :, None],
                   np.stack([-(b * ends + c) / np.where(by_t, a, 1.0),
                             np.broadcast_to(ends, (len(abc), 2))], axis=2),
                   np.stack([np.broadcast_to(ends, (len(abc), 2)),
                             -(a * ends + c) / np.where(by_t, 1.0, b)], axis=2))
    segs = shapely.clip_by_rect(shapely.linestrings(pts), -r, -r, r, r)
    keep = ~shapely.is_empty(segs) & (shapely.length(segs) > 0)
    return list(segs[keep])


def _edge_cells(noded: object, face: int, dom: object = None) -> list[Cell]:
    """The 1- and 0-dimensional cells of a face: the noded boundary segments and their end
    points, leaving out those on the chart square's border (cube-edge artefacts) and, with a
    domain ``dom`` (chart geometry), those not strictly inside it."""
    segs = _segments(noded)
    if not len(segs):
        return []
    mids = shapely.get_coordinates(shapely.line_interpolate_point(segs, 0.5, normalized=True))
    inside = (np.abs(mids) < _INSIDE).all(axis=1)
    if dom is not None:
        inside &= shapely.contains_xy(dom, mids[:, 0], mids[:, 1])
    segs, mids = segs[inside], mids[inside]
    cells = [Cell(1, d, face, g) for d, g in zip(direction_of(face, mids), segs)] \
        if len(segs) else []
    ends = _ends(segs)
    ends = ends[(np.abs(ends) < _INSIDE).all(axis=1)]
    if dom is not None and len(ends):
        ends = ends[shapely.contains_xy(dom, ends[:, 0], ends[:, 1])]
    if len(ends):
        ends = np.unique(np.round(ends / GRID) * GRID, axis=0)
        cells.extend(Cell(0, d, face, shapely.Point(p))
                     for d, p in zip(direction_of(face, ends), ends))
    return cells
