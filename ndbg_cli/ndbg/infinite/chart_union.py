"""Chart polygons of open cones on a cube face and their unions: the closed sets ``B_ij`` as
the arrangement (:mod:`ndbg_cli.ndbg.infinite.arrangement`) and the region lookup
(:class:`ndbg_cli.ndbg.infinite.blocked_sets.BlockedSets`) use them.

A cone's chart polygon is its central projection onto a cube face, clipped to the face's
square or to a window of it. Of a pair's thousands of overlapping convex pieces only those
inside no other single piece enter the union (:func:`face_pieces`, a compiled scan); it is
made largest first, leaving out the pieces already covered (:func:`union`), with GEOS's
overlay checked and redone on a snapping grid where it fails (:func:`robust_union`). Every
piece's bounding box is kept for the open re-test of lower-dimensional cells.
"""

from __future__ import annotations

import numpy as np
import shapely

from ...kernels.compiled import loaded
from .cubemap import SQUARE_MARGIN, clip_halfplanes

#: Snapping grid of the arrangement linework, chart units.
GRID = 1e-10


def face_polygons(cones: np.ndarray, face: int, max_vertices: int = 48,
                  rect: tuple[float, float, float, float] | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Chart polygons of ``cones`` ``(p, k, 3)`` on ``face`` (convex) and the index of the
    cone of each; cones missing the face and pieces of area below ``GRID**2`` are left
    out. ``max_vertices``, ``rect`` (clip to that chart rectangle of the face only): see
    :func:`~ndbg_cli.ndbg.infinite.cubemap.clip_halfplanes`."""
    if not len(cones):
        return np.zeros(0, dtype=object), np.zeros(0, dtype=np.int64)
    poly, cnt = clip_halfplanes(cones, face, max_vertices=max_vertices, rect=rect)
    keep = cnt >= 3
    if not keep.any():
        return np.zeros(0, dtype=object), np.zeros(0, dtype=np.int64)
    index = np.nonzero(keep)[0]
    poly, cnt = poly[keep], cnt[keep]
    k = np.arange(poly.shape[1])[None, :] < cnt[:, None]
    rings = shapely.linearrings(poly[k], indices=np.repeat(np.arange(len(cnt)), cnt))
    # The pieces are convex: their hull is the same polygon, and always valid.
    polys = shapely.convex_hull(shapely.polygons(rings))
    big = (shapely.area(polys) > GRID * GRID) & (shapely.get_type_id(polys) == 3)
    return polys[big], index[big]


def clipped_pieces(cones: np.ndarray, face: int,
                   rect: tuple[float, float, float, float] | None = None,
                   max_vertices: int = 48) -> tuple[np.ndarray, ...]:
    """The chart pieces of ``cones`` ``(p, k, 3)`` on ``face`` clipped to ``rect`` (the chart square
    when ``None``): vertices ``(p, w, 2)`` (counter-clockwise), counts ``(p,)``, areas ``(p,)`` and
    bounding boxes ``(p, 4)`` (:func:`~ndbg_cli.kernels._union_kernels.piece_boxes`), and
    whether each has area above ``GRID**2`` ``(p,)``."""
    kernels = loaded("_union_kernels")
    poly, cnt = clip_halfplanes(cones, face, max_vertices=max_vertices, rect=rect)
    cnt = np.minimum(cnt, poly.shape[1])
    area, boxes = kernels.piece_boxes(poly, cnt)
    return poly, cnt, area, boxes, area > GRID * GRID


def face_pieces(cones: np.ndarray, face: int,
                rect: tuple[float, float, float, float] | None = None,
                max_vertices: int = 48) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The chart pieces of ``cones`` ``(p, k, 3)`` on ``face``, clipped to ``rect`` (the
    chart square when ``None``), those of area at most ``GRID**2`` left out: the polygons of
    those inside no other single piece, largest first (:func:`union_pieces`), whose union
    is the union of all; and every piece's bounding box ``(q, 4)`` (``x0, y0, x1, y1``) and
    cone index ``(q,)`` (ascending)."""
    if not len(cones):
        return union_pieces(np.zeros((0, 3, 2)), *_NO_PIECES)
    poly, cnt, area, boxes, big = clipped_pieces(cones, face, rect, max_vertices)
    index = np.nonzero(big)[0]
    return union_pieces(poly[index], cnt[index], area[index], boxes[index], index)


_NO_PIECES = (np.zeros(0, dtype=np.int64), np.zeros(0), np.zeros((0, 4)),
              np.zeros(0, dtype=np.int64))


def union_pieces(poly: np.ndarray, cnt: np.ndarray, area: np.ndarray, boxes: np.ndarray,
                 index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`face_pieces` of pieces already clipped (:func:`clipped_pieces`' vertices,
    counts, areas and boxes, of area above ``GRID**2`` only) with the cone index of each
    ``(q,)``, ascending: the polygons of those inside no other single piece
    (:func:`~ndbg_cli.kernels._union_kernels.maximal_pieces`), largest first, and ``boxes``,
    ``index``."""
    kernels = loaded("_union_kernels")
    if not len(index):
        return np.zeros(0, dtype=object), np.zeros((0, 4)), np.zeros(0, dtype=np.int64)
    order = np.argsort(-area, kind="stable")
    keep = kernels.maximal_pieces(poly, cnt, boxes, order)
    top = order[keep[order]]
    k = np.arange(poly.shape[1])[None, :] < cnt[top][:, None]
    rings = shapely.linearrings(poly[top][k], indices=np.repeat(np.arange(len(top)), cnt[top]))
    # The pieces are convex: their hull is the same polygon, and always valid.
    polys = shapely.convex_hull(shapely.polygons(rings))
    polys = polys[shapely.get_type_id(polys) == 3]
    return polys, boxes, index


def cones_to_face_geoms(cones: np.ndarray, windows: list | None = None,
                        pieces: list | None = None) -> list[tuple | None]:
    """Per cube face, the polygons of ``cones`` (``(p, k, 3)``): 6 entries, ``None`` where
    empty, else ``(union, boxes, index)``: the union (closed polygons in chart coordinates),
    the pieces' bounding boxes ``(q, 4)`` (``x0, y0, x1, y1``) and the cone index of each
    piece ``(q,)`` (:func:`face_pieces`). With ``windows`` (per face a chart rectangle or
    ``None``, :func:`ndbg_cli.ndbg.infinite.domain.domain_windows`) only the part inside each face's
    rectangle is made, none where ``None``: the sets are then right inside the windows
    only. ``pieces``: per face, the cones' pieces clipped to its window, as
    :func:`union_pieces` takes them (a pruning walk made them,
    :func:`ndbg_cli.ndbg.infinite.blocking_cones.pruned_pair_cones`), else they are clipped here."""
    out: list[tuple | None] = []
    for face in range(6):
        if windows is not None and windows[face] is None:
            out.append(None)
            continue
        rect = None if windows is None else windows[face]
        if pieces is not None:
            polys, boxes, index = union_pieces(*pieces[face])
        else:
            polys, boxes, index = face_pieces(cones, face, rect=rect)
        if not len(polys):
            out.append(None)
            continue
        g = union(polys, rect=rect)
        out.append(None if g.is_empty else (g, boxes, index))
    return out


def union(polys: np.ndarray, seed: int = 64,
          rect: tuple[float, float, float, float] | None = None) -> object:
    """Union of many overlapping convex polygons: the largest first, then only those not
    already covered (exact ``covers`` tests against the partial union), repeatedly.

    ``rect`` (chart units; the chart square with its margin when ``None``) is the rectangle
    the pieces were clipped to. The ``covers`` tests are made against the partial union
    without its points inside straight runs along the rectangle's sides
    (:func:`off_rect_runs`: the same point set, far faster to test), while the unions are
    made from the partial union as GEOS gave it, so that the result does not depend on it."""
    if rect is None:
        r = 1.0 + SQUARE_MARGIN
        rect = (-r, -r, r, r)
    polys = polys[np.argsort(-shapely.area(polys), kind="stable")]
    acc, test = robust_union(polys[:seed], polys[:seed], rect)
    rest = polys[seed:]
    while len(rest):
        shapely.prepare(test)
        rest = rest[~shapely.covers(test, rest)]
        if not len(rest):
            break
        take = max(seed, len(rest) // 8)
        batch, rest = rest[:take], rest[take:]
        acc, test = robust_union(np.concatenate([[acc], batch]),
                                 np.concatenate([[test], batch]), rect)
    return acc


def off_rect_runs(g: object, rect: tuple[float, float, float, float]) -> object:
    """``g`` (polygonal, chart units) without the ring points lying, with both neighbours, on
    the same side of ``rect`` (exactly: the pieces were clipped to it): the same point set.

    Every piece clipped to a window's side leaves two points on it in the union, and GEOS
    keeps them all (hundreds of points around a small hole), and a prepared ``covers`` test
    of a piece touching a side falls back to a full relate over all of them, an order of
    magnitude slower (benchmarks/NOTES.md)."""
    x0, y0, x1, y1 = rect
    polys = []
    changed = False
    for part in shapely.get_parts(g):
        if shapely.get_type_id(part) != 3:
            return g
        rings = []
        for ring in (part.exterior, *part.interiors):
            xy = shapely.get_coordinates(ring)[:-1]
            prev, nxt = np.roll(xy, 1, axis=0), np.roll(xy, -1, axis=0)
            run = np.zeros(len(xy), dtype=bool)
            for axis, v in ((0, x0), (0, x1), (1, y0), (1, y1)):
                run |= (xy[:, axis] == v) & (prev[:, axis] == v) & (nxt[:, axis] == v)
            changed |= bool(run.any())
            rings.append(xy[~run])
        polys.append(shapely.Polygon(rings[0], rings[1:]))
    if not changed:
        return g
    return polys[0] if len(polys) == 1 else shapely.MultiPolygon(polys)


def robust_union(polys: np.ndarray, same: np.ndarray,
                 rect: tuple[float, float, float, float]) -> tuple[object, object]:
    """``union_all`` of ``polys``, and that union without its runs along ``rect``
    (:func:`off_rect_runs`, for the ``covers`` tests), falling back to snap-rounding on
    :data:`GRID` (then both the same) when floating-point overlay fails: GEOS topology
    exceptions on nearly coincident edges, a union smaller than one of its pieces (GEOS 3.14
    returns the smaller of two polygons one ulp apart at a vertex, one inside the other,
    instead of the larger), or a union some piece sticks out of (:func:`loses_area`: GEOS
    3.14.1 drops faces of the overlay, 0.03 of 1.2 chart units on 64 pieces of a box pair's
    set, where the first 63 pieces' union was right). ``same``: ``polys`` with the same
    point sets, faster to test (the partial union without its runs), for that check."""
    try:
        out = shapely.union_all(polys)
    except shapely.errors.GEOSException:
        out = None
    if out is not None:
        test = off_rect_runs(out, rect)
        biggest = float(shapely.area(polys).max()) if len(polys) else 0.0
        if not (out.area < biggest * (1.0 - 1e-9) - GRID * GRID or loses_area(test, same)):
            return out, test
    out = shapely.union_all(shapely.make_valid(polys), grid_size=GRID)
    return out, out


#: Area (chart units squared) of a piece outside the union of all the pieces above which
#: the union is wrong (:func:`loses_area`). The bell's rounding slivers reach 1.3e-13; its
#: two real losses were 5e-6 and 1e-4 (a patch 0.6 degrees across).
LOST_AREA = 1e-12


def loses_area(out: object, polys: np.ndarray) -> bool:
    """Whether some of ``polys`` lies outside their union ``out`` by more than
    :data:`LOST_AREA` (the pieces not covered exactly are measured: rounding leaves a few)."""
    shapely.prepare(out)
    # a convex piece whose inset by LOST_AREA / perimeter is covered sticks out by at most
    # LOST_AREA (the band it leaves has no more area): most pieces pass this way, the exact
    # test failing on them by rounding only
    rest = polys[~_inset_covered(out, polys)]
    out_of = rest[~shapely.covers(out, rest)]
    if not len(out_of):
        return False
    # Each piece against the union cut to its box grown by CLIP_MARGIN (the same difference:
    # the cuts lie off the piece), not against the whole union, which is slower. A cut
    # GEOS's fast rectangle clip leaves invalid is not used.
    lo_x, lo_y, hi_x, hi_y = (shapely.bounds(out_of) + CLIP_MARGIN * np.array([-1, -1, 1, 1])).T
    near = np.array([shapely.clip_by_rect(out, *box) for box in zip(lo_x, lo_y, hi_x, hi_y)])
    near = np.where(shapely.is_valid(near), near, out)
    try:
        return bool((shapely.area(shapely.difference(out_of, near)) > LOST_AREA).any())
    except shapely.errors.GEOSException:
        return True


def _inset_covered(out: object, polys: np.ndarray) -> np.ndarray:
    """``(p,)`` whether each of ``polys`` is a convex polygon whose inset by ``LOST_AREA / 2`` over
    its perimeter (:func:`~ndbg_cli.kernels._union_kernels.inset_convex`) is covered by
    ``out`` (prepared)."""
    kernels = loaded("_union_kernels")
    ok = np.zeros(len(polys), dtype=bool)
    simple = np.flatnonzero((shapely.get_type_id(polys) == 3)
                            & (shapely.get_num_interior_rings(polys) == 0))
    if not len(simple):
        return ok
    rings = shapely.get_exterior_ring(polys[simple])
    xy, which = shapely.get_coordinates(rings, return_index=True)
    n = np.bincount(which, minlength=len(simple))
    start = np.r_[0, np.cumsum(n)[:-1]]
    delta = 0.5 * LOST_AREA / np.maximum(shapely.length(rings), 1e-300)
    # the rings are closed: their last point is left out
    inner, cnt = kernels.inset_convex(xy, start, np.maximum(n - 1, 0), delta)
    has = np.flatnonzero(cnt >= 3)
    if not len(has):
        return ok
    k = np.arange(inner.shape[1])[None, :] < cnt[has][:, None]
    shrunk = shapely.polygons(shapely.linearrings(
        inner[has][k], indices=np.repeat(np.arange(len(has)), cnt[has])))
    ok[simple[has]] = shapely.covers(out, shrunk)
    return ok


#: Chart units the box of a piece is grown by before the union is cut to it
#: (:func:`loses_area`): far above the coordinates' rounding, far below the pieces.
CLIP_MARGIN = 1e-6


#: The chart map of the antipodal map ``d -> -d``: a direction at ``(s, t)`` on face ``f``
#: goes to ``(-t, -s)`` on the opposite face ``f ^ 1``, the same for all six faces (their
#: chart axes are paired that way, see :data:`ndbg_cli.ndbg.infinite.cubemap.FACES`).
ANTIPODAL = np.array([[0.0, -1.0], [-1.0, 0.0]])


def reverse_entries(entries: list) -> list:
    """The per-face chart geometry of ``B_ji`` from that of ``B_ij``
    (:func:`~ndbg_cli.ndbg.infinite.chart_union.cones_to_face_geoms`): ``P_i`` moving along ``d``
    meets ``P_j`` exactly when ``P_j`` moving along ``-d`` meets ``P_i``, so ``B_ji = -B_ij``, and
    the antipodal map is a chart isometry onto the opposite cube face. The cone index of each piece
    is unchanged (the cones of ``B_ji`` are the negated cones of ``B_ij``, in order)."""
    out: list = [None] * 6
    for face, e in enumerate(entries):
        if e is None:
            continue
        union, boxes, index = e
        # the box (x0, y0, x1, y1) of the image is (-y1, -x1, -y0, -x0), exactly
        out[face ^ 1] = (antipodal(union), None if boxes is None else -boxes[:, ::-1], index)
    return out


def antipodal(g: object) -> object:
    """The chart geometry ``g`` (one geometry or an array of them) of a face mapped onto the
    opposite face by ``d -> -d`` (:data:`ANTIPODAL`; exact: coordinates swapped and negated)."""
    return shapely.transform(g, lambda xy: xy @ ANTIPODAL.T)


def cut_to_domain(g: object, dom: object, memo: dict, key: bytes | None = None
                  ) -> object | None:
    """``g`` (a set's polygons on one face) cut to the domain's polygons ``dom`` there, snapped
    to :data:`GRID`; ``None`` when nothing of area remains. ``memo`` (WKB -> cut) keeps the
    cuts made: many sets are the same polygon there (the whole window, a half-plane's part),
    each distinct one is cut once. ``key``: ``g``'s WKB, when the caller has it."""
    key = shapely.to_wkb(g) if key is None else key
    if key not in memo:
        cut = shapely.intersection(g, dom, grid_size=GRID)
        memo[key] = None if cut.is_empty or cut.area <= 0 else cut
    return memo[key]
