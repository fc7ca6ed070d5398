"""The NDBG for infinite translations (paper section 5.3).

Part ``P_j`` blocks the infinite translation of ``P_i`` along ``d`` when the volume ``P_i``
sweeps from its place to infinity along ``d`` meets the interior of ``P_j``. The blocked set
``B_ij`` is the radial projection onto S^2 of the interior of the Minkowski difference
``P_j - P_i``; the NDBG is the arrangement of all ``B_ij`` boundaries with one DBG per region.

Exact route (no sampling of directions)
---------------------------------------
For closed polyhedral parts, a generic blocking ray leaves ``P_i`` through the relative
interior of a triangle ``t_i`` (``n_i . d > 0``) and enters ``P_j`` through a triangle ``t_j``
(``n_j . d < 0``), possibly at the same point (a face contact). Hence

    B_ij = union over triangle pairs of  cone(t_j - t_i) ∩ {n_i . d > 0} ∩ {n_j . d < 0},

each term an open convex polyhedral cone, i.e. a convex spherical polygon, i.e. a convex
polygon on each face of the gnomonic cube map (:mod:`ndbg_cli.cubemap`). Pairs that cannot
face each other (``t_j`` wholly behind ``t_i``'s plane or ``t_i`` wholly behind ``t_j``'s) are
pruned exactly, vectorised; every pair of parts is processed, since distant parts block too
(each unordered pair once: ``B_ji = -B_ij``),
but the triangle pairs whose terms lie strictly inside the terms already kept are skipped
wholesale by a walk over bounding-box trees (:func:`ndbg_cli.blocking_cones.
pruned_pair_cones`; same union, same open cones, same contact circles). Two convex parts
more than ``4 eps`` apart need no terms: ``B_ij`` is the one open cone spanned by their
Minkowski difference (:func:`ndbg_cli.blocking_cones.convex_pair_cone`, the same set).

Tolerance (``eps = asm.length_tolerance``)
------------------------------------------
For *near* triangle pairs (bounding boxes closer than ``4 eps``) both triangles are moved
inward by ``1.5 eps`` along their normals: the parts are eroded by about ``eps``. Contact then
never blocks by itself: a part blocks only if the sweep penetrates it deeper than about
``eps``, sliding along a contact face is free, tessellation overlaps below ``eps`` are
ignored, and the directions through a zero-clearance slot or bore form a thin free region of
angular width about ``eps / L`` (``L`` the contact length). Regions whose width in the chart is
below the angular tolerance ``eta = ANGULAR_FACTOR * eps / diagonal`` are reported as
1-dimensional, those smaller than ``eta`` in every direction as 0-dimensional, with the
representative direction inside them; for such a thin region round a bore's axis, the point
where the contacts' circles meet, if its DBG is the region's (:func:`_snap_to_circles`: the
direction the direct sweep test, which erodes nothing, finds free too). *Far* pairs use the
exact triangles, with closed polygons: a direction grazing a distant part with exactly zero
clearance counts as blocked.

The arrangement is computed per cube face with shapely: the union ``U_ij`` of each pair's
polygons, all their boundaries noded (collinear pieces merged first) and polygonized; each face
of the overlay is a region, and its DBG is read at a point inside it; each chain of boundary
between two nodes is a 1-dimensional cell, each node a 0-dimensional one. Regions cut by the
cube edges are counted once per cube face (the DBG is constant on each piece, so the NDBG stays
exact; region counts are those of the arrangement refined by the 12 cube-edge arcs). 2D
assemblies are extruded to prisms and the arrangement is read on the equator (S^1) from the
open cones themselves (:mod:`ndbg_cli.equator`).
"""

from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field

import numpy as np
import shapely

from . import equator
from .arrangement import Cell, arrangement_cells
from .assembly import Assembly, content_hash
from .blocking_cones import (
    GRID,
    convex_entries,
    convex_pairs,
    far_convex,
    pair_cones,
    part_triangles,
    unique_circles,
    with_trees,
)
from .cache import PairCache
from .cubemap import face_of
from .dbg import DBG
from .domain import domain_polygons
from .errors import NdbgError
from .infinite_report import FAMILY, infinite_section, infinite_text, partitioning_records
from .ndbg import NDBG, Region
from .pair_workers import pair_sets
from .progress import progress as bar

#: Regions thinner than ``ANGULAR_FACTOR * length_tolerance / diagonal`` (chart units, about
#: radians) are reported as lower-dimensional.
ANGULAR_FACTOR = 50.0


@dataclass
class BlockedSets:
    """The blocked-direction sets ``B_ij`` on the six cube faces.

    ``geoms[f]`` maps an ordered part pair ``(i, j)`` to the shapely geometry (chart
    coordinates of face ``f``) of the closure of ``B_ij`` there; pairs absent from the dict
    are never blocked on that face. ``eta`` is the angular tolerance (chart units).
    """

    n: int
    geoms: list[dict[tuple[int, int], object]]
    eta: float
    cones: dict[tuple[int, int], np.ndarray] = field(default_factory=dict)
    trees: list[dict[tuple[int, int], tuple]] = field(default_factory=list)
    circles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    space_dimension: int = 3
    stats: dict = field(default_factory=dict)
    #: Per face, the chart geometry of the directions where the sets are right (``None``
    #: entries: none on that face), or ``None`` for all directions (:mod:`ndbg_cli.domain`).
    domain: list | None = None
    #: 2D assemblies: each ordered pair's open arcs on the equator (radians,
    #: :func:`ndbg_cli.equator.cone_arcs`), set by :func:`build_infinite`.
    arcs: dict | None = None
    _by_face: list = field(default_factory=lambda: [None] * 6, repr=False,
                           compare=False)

    def blocked_pairs(self, d: np.ndarray) -> list[tuple[np.ndarray, int, int]]:
        """For directions ``d`` ``(m, 3)``: list of ``(index, i, j)``, ``index`` the sorted
        indices ``k`` of the directions ``d[k]`` along which ``P_j`` blocks ``P_i``."""
        d = np.atleast_2d(np.asarray(d, dtype=float))
        f, st = face_of(d)
        out: dict[tuple[int, int], list[np.ndarray]] = {}
        for face in range(6):
            sel = np.nonzero(f == face)[0]
            if not len(sel) or not self.geoms[face]:
                continue
            keys, geoms = self._face_pairs(face)
            x, y = st[sel, 0], st[sel, 1]
            # each pair's exact test only on the directions inside its bounding box
            gi, pt = shapely.STRtree(shapely.points(x, y)).query(geoms)
            if np.any(gi[1:] < gi[:-1]):  # shapely lists them by pair already
                order = np.argsort(gi, kind="stable")
                gi, pt = gi[order], pt[order]
            starts = np.flatnonzero(np.r_[True, gi[1:] != gi[:-1]]) if len(gi) else []
            ends = np.r_[starts[1:], len(gi)] if len(gi) else []
            for a, b in zip(starts, ends):
                k = pt[a:b]
                hit = shapely.contains_xy(geoms[gi[a]], x[k], y[k])
                if hit.any():
                    out.setdefault(keys[gi[a]], []).append(sel[k[hit]])
        return [(np.sort(np.concatenate(v)), i, j) for (i, j), v in sorted(out.items())]

    def _face_pairs(self, face: int) -> tuple[list[tuple[int, int]], np.ndarray]:
        """The pairs with a set on ``face`` and their geometries (an array, made once)."""
        if self._by_face[face] is None:
            keys = list(self.geoms[face])
            self._by_face[face] = (keys, np.array([self.geoms[face][k] for k in keys],
                                                  dtype=object))
        return self._by_face[face]

    def dbgs(self, d: np.ndarray, exact: bool = False) -> list[DBG]:
        """The DBG at each direction of ``d`` ``(m, 3)`` (region lookup, vectorised).

        The chart lookup tests the interior of the closure of ``B_ij``; it is right for every
        direction off the contact circles. With ``exact``, a direction inside that closure is
        re-tested against the open cones themselves (the open-set semantics of ``B_ij``),
        which is what the 1- and 0-dimensional cells need: a slot, a bore or a sliding face
        leaves free directions on seams between blocked cones.
        """
        d = np.atleast_2d(np.asarray(d, dtype=float))
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        # successor bits, packed as they are set (a (m, n, n) bool matrix would take
        # 270 MB for a 100-box grid's 26,694 regions)
        bits = np.zeros((len(d), self.n, (self.n + 7) // 8), dtype=np.uint8)
        for k, i, j in self.blocked_pairs(d):
            if exact:
                k = self._exact(k, i, j, d)
            bits[k, i, j >> 3] |= np.uint8(1 << (j & 7))
        return [DBG(row) for row in succ_from_bits(bits)]

    def _exact(self, sel: np.ndarray, i: int, j: int, d: np.ndarray) -> np.ndarray:
        """Re-test the directions ``d[sel]`` (indices) against the open cones of pair
        ``(i, j)`` whose chart polygons may contain them (STR-tree, by bounding box: a
        superset); returns the sorted indices of those inside one.

        A direction deep in ``B_ij`` lies in hundreds of overlapping cones and one suffices:
        each direction's candidates are tested in turn up to its first hit
        (:func:`ndbg_cli.kernels.open_hits`). Only the directions in no open cone (seams,
        boundaries) test all their candidates."""
        from . import kernels
        out = np.zeros(len(d), dtype=bool)
        f, st = face_of(d[sel])
        cones = self.cones[(i, j)]
        for face in np.unique(f):
            entry = self.trees[face].get((i, j))
            if entry is None:
                continue
            tree, index = entry
            rows = sel[np.nonzero(f == face)[0]]
            if tree is None:  # one piece (convex parts): every direction is a candidate
                pt, item = np.arange(len(rows)), np.zeros(len(rows), dtype=np.int64)
            else:
                pt, item = tree.query(shapely.points(st[f == face]))
            if not len(pt):
                continue
            if np.any(pt[1:] < pt[:-1]):  # shapely lists them by point already
                order = np.argsort(pt, kind="stable")
                pt, item = pt[order], item[order]
            pos = np.flatnonzero(np.r_[True, pt[1:] != pt[:-1]])  # each direction's run
            end = np.r_[pos[1:], len(pt)]
            who = rows[pt[pos]]
            out[who[kernels.open_hits(cones, np.ascontiguousarray(d[who]), pos, end,
                                      np.ascontiguousarray(index[item]), OPEN_TOL)]] = True
        return np.flatnonzero(out)


#: Directions within this (radians, about) of a cone's facet count as outside the open cone.
OPEN_TOL = 1e-6


def succ_from_bits(bits: np.ndarray) -> list[tuple[int, ...]]:
    """Successor bitmasks from packed adjacency rows ``(m, n, ceil(n / 8))`` (bit ``j`` of row
    ``i``, little-endian: ``j`` succeeds ``i``). Regions share DBGs (a 100-box grid: 9,100
    among 26,694): each distinct one is converted once."""
    m, n, width = bits.shape
    flat = bits.reshape(m, n * width)
    seen: dict[bytes, tuple[int, ...]] = {}
    out = []
    for row in flat:
        key = row.tobytes()
        got = seen.get(key)
        if got is None:
            got = seen[key] = tuple(int.from_bytes(key[i * width:(i + 1) * width], "little")
                                    for i in range(n))
        out.append(got)
    return out


#: Against the budget, a pair of convex parts far apart (one cone, about 0.3 ms) counts as
#: this many triangle pairs (each 20-70 microseconds through the terms), plus one per
#: :data:`CONVEX_DIFFERENCES_PER_PAIR` difference vectors (``|V_i| |V_j|``).
CONVEX_PAIR_COST = 16
CONVEX_DIFFERENCES_PER_PAIR = 128


def closed_parts(asm: Assembly) -> list[bool]:
    """Whether each part's mesh is watertight and consistently wound (2D parts: extruded
    polygons, always): the convex route needs a closed surface."""
    return [asm.dimension == 2 or (p.check.watertight and p.check.winding_consistent)
            for p in asm.parts]


def triangle_pairs(asm: Assembly) -> int:
    """Number of (moving, blocking) triangle pairs over all ordered pairs of parts: the cost
    driver, twice what the builder examines (it computes each unordered pair once) and an
    upper bound of even that, since the pruning walk skips most of them. An ordered pair of
    convex parts more than ``4 eps`` apart, whose set is one cone
    (:func:`~ndbg_cli.blocking_cones.far_convex` decides), counts as
    :data:`CONVEX_PAIR_COST` plus one per :data:`CONVEX_DIFFERENCES_PER_PAIR` difference
    vectors. The CLI skips the NDBG with a warning above
    ``--infinite-budget`` (AS1: 1.1e8 pairs; a grid of 100 separate boxes: 1.4e6 triangle
    pairs, 1.6e5 counted)."""
    t = np.array([p.check.triangles if asm.dimension == 3 else 4 * p.check.vertices
                  for p in asm.parts], dtype=float)
    total = t.sum() ** 2 - (t ** 2).sum()
    if asm.dimension == 3 and len(t) > 1:
        verts, pairs = far_convex(part_triangles(asm), closed_parts(asm),
                                  asm.length_tolerance)
        if len(pairs):
            i, j = pairs[:, 0], pairs[:, 1]
            diffs = np.array([len(verts[a]) * len(verts[b]) for a, b in pairs.tolist()],
                             dtype=float)
            # each unordered pair stands for both ordered ones
            total -= 2.0 * float((t[i] * t[j]).sum())
            total += 2.0 * (CONVEX_PAIR_COST * len(pairs)
                            + float(diffs.sum()) / CONVEX_DIFFERENCES_PER_PAIR)
    return int(total)


def blocked_sets(asm: Assembly, cache: PairCache | None = None,
                 domain: np.ndarray | None = None, workers: int = 1,
                 progress: bool = False) -> BlockedSets:
    """``B_ij`` for every ordered pair of parts, on the cube map. Each unordered pair is
    computed once, the part with fewer triangles moving, and the other order is its antipodal
    image (:func:`reverse_entries`; exact: ``B_ji = -B_ij``). With ``cache``, each computed
    pair's cones and chart polygons are looked up by the two parts' content hashes and the
    tolerance (:mod:`ndbg_cli.cache`). With ``domain`` (``(6, r, r)`` bool cube-map cells,
    symmetric under ``d -> -d``, :func:`ndbg_cli.domain.free_domain`) the sets are right only
    inside those cells, and computed only there. ``workers``: processes computing the pairs
    (:func:`ndbg_cli.pair_workers.pair_sets`; the result does not depend on it); ``progress``:
    a bar over the pairs on stderr (a terminal only)."""
    if domain is not None and not antipodal_symmetric(domain):
        # B_ji is made from B_ij on the opposite face: both must lie in the domain
        raise ValueError("the domain must be symmetric under d -> -d")
    t0 = time.perf_counter()
    tris = part_triangles(asm)
    eps = asm.length_tolerance
    n = len(asm.parts)
    geoms: list[dict[tuple[int, int], object]] = [{} for _ in range(6)]
    npieces = 0
    t_cones = t_union = 0.0
    all_cones: dict[tuple[int, int], np.ndarray] = {}
    trees: list[dict[tuple[int, int], tuple]] = [{} for _ in range(6)]
    circles: list[np.ndarray] = []
    # content hashes of the triangles actually used (validated, placed, 2D extruded)
    gkeys = [content_hash(t, nrm) for t, nrm in tris] if cache is not None else []
    sizes = [len(t) for t, _ in tris]

    def store(a: int, b: int, cones: np.ndarray, entries: list) -> None:
        # B_ab and its antipodal image B_ba
        nonlocal npieces
        for pair, c, ent in (((a, b), cones, entries), ((b, a), -cones,
                                                        reverse_entries(entries))):
            all_cones[pair] = c
            npieces += len(c)
            for face, entry in enumerate(ent):
                if entry is not None:
                    geoms[face][pair] = entry[0]
                    trees[face][pair] = entry[1:]

    # convex parts far apart: one cone per pair, made and clipped all at once
    tc = time.perf_counter()
    fast = convex_pairs(tris, sizes, eps, closed_parts(asm))
    for (a, b), cone, entries in zip(fast, fast.values(), convex_entries(list(fast.values()))):
        store(a, b, cone, entries)
    t_cones += time.perf_counter() - tc
    # B_ji = -B_ij: one orientation is computed, the smaller part moving (its walk prunes
    # better), and the other is its antipodal image
    order = [(i, j) if sizes[i] <= sizes[j] else (j, i)
             for i in range(n) for j in range(i + 1, n)]
    found: dict[tuple[int, int], tuple] = {}
    keys: dict[tuple[int, int], str] = {}
    extra = () if domain is None or cache is None else (
        hashlib.sha256(np.packbits(domain).tobytes()).hexdigest(),)
    for a, b in order:
        if (a, b) in fast or cache is None:
            continue
        # 2D parts are extruded to the assembly's diagonal: that enters the result. "pruned-3":
        # unions checked for lost area (blocking_cones.robust_union); older entries may lack some
        keys[(a, b)] = cache.key("infinite", "pruned-3", gkeys[a], gkeys[b], eps,
                                 asm.dimension, asm.diagonal if asm.dimension == 2 else None,
                                 *extra)
        got = cache.get("infinite", keys[(a, b)], _thaw)
        if got is not None:
            found[(a, b)] = got
    todo = [p for p in order if p not in fast and p not in found]
    # each pair cached as soon as it is done (an interrupted run keeps them); the times are
    # summed over the workers (CPU seconds, not wall time, with several)
    done = pair_sets(tris, todo, eps, domain, workers)
    for k, (cones, circ, faces, dt_cones, dt_union) in bar(done, len(todo), "part pairs",
                                                           quiet=not progress):
        entries = with_trees(faces)
        found[todo[k]] = (cones, circ, entries)
        t_cones += dt_cones
        t_union += dt_union
        if cache is not None:
            cache.put("infinite", keys[todo[k]], _freeze(cones, circ, entries))
    for a, b in order:
        if (a, b) in found:
            cones, circ, entries = found[(a, b)]
            circles.append(circ)
            store(a, b, cones, entries)
    dom = None if domain is None else domain_polygons(domain)
    if dom is not None:
        # only the domain's part is right (and needed): the arrangement is built there
        for face, fd in enumerate(geoms):
            if dom[face] is None:
                fd.clear()
                continue
            for pair in list(fd):
                g = shapely.intersection(fd[pair], dom[face], grid_size=GRID)
                if g.is_empty or g.area <= 0:
                    del fd[pair]
                else:
                    fd[pair] = g
    for fd in geoms:
        for g in fd.values():
            shapely.prepare(g)
    eta = ANGULAR_FACTOR * eps / max(asm.diagonal, 1e-300)
    stats = {"pieces": npieces, "convex_pairs": len(fast),
             "time_cones_s": t_cones, "time_union_s": t_union,
             "time_blocked_sets_s": time.perf_counter() - t0}
    circ = unique_circles(np.concatenate(circles)) if circles else np.zeros((0, 3))
    stats["contact_circles"] = len(circ)
    return BlockedSets(n=n, geoms=geoms, eta=eta, cones=all_cones, trees=trees, circles=circ,
                       space_dimension=asm.dimension, stats=stats, domain=dom)


def antipodal_symmetric(domain: np.ndarray) -> bool:
    """Whether the cube-map cells ``domain`` ``(6, r, r)`` are symmetric under ``d -> -d``
    (cell ``(row, col)`` of face ``f`` maps to ``(r-1-col, r-1-row)`` of face ``f ^ 1``,
    see :data:`_ANTIPODAL`)."""
    return all(np.array_equal(domain[f ^ 1], domain[f].T[::-1, ::-1]) for f in range(6))


#: The chart map of the antipodal map ``d -> -d``: a direction at ``(s, t)`` on face ``f``
#: goes to ``(-t, -s)`` on the opposite face ``f ^ 1``, the same for all six faces (their
#: chart axes are paired that way, see :data:`ndbg_cli.cubemap.FACES`).
_ANTIPODAL = np.array([[0.0, -1.0], [-1.0, 0.0]])


def reverse_entries(entries: list) -> list:
    """The per-face chart geometry of ``B_ji`` from that of ``B_ij``
    (:func:`~ndbg_cli.blocking_cones.cones_to_face_geoms`): ``P_i`` moving along ``d`` meets
    ``P_j`` exactly when ``P_j`` moving along ``-d`` meets ``P_i``, so ``B_ji = -B_ij``, and
    the antipodal map is a chart isometry onto the opposite cube face. The cone index of each
    piece is unchanged (the cones of ``B_ji`` are the negated cones of ``B_ij``, in order)."""
    def flip(g):
        return shapely.transform(g, lambda xy: xy @ _ANTIPODAL.T)

    out: list = [None] * 6
    for face, e in enumerate(entries):
        if e is None:
            continue
        union, tree, index = e
        out[face ^ 1] = (flip(union),
                         None if tree is None else shapely.STRtree(flip(tree.geometries)), index)
    return out


def _freeze(cones: np.ndarray, circ: np.ndarray, entries: list) -> tuple:
    """A pair's result in cacheable form: arrays and WKB (exact double coordinates)."""
    faces = []
    for e in entries:
        if e is None:
            faces.append(None)
            continue
        union, tree, index = e
        faces.append((shapely.to_wkb(union), [shapely.to_wkb(g) for g in tree.geometries],
                      index))
    return cones, circ, faces


def _thaw(value: tuple) -> tuple[np.ndarray, np.ndarray, list]:
    """Inverse of :func:`_freeze`; raises on anything malformed (a cache miss)."""
    cones, circ, faces = value
    if not (isinstance(cones, np.ndarray) and cones.ndim == 3 and isinstance(circ, np.ndarray)
            and len(faces) == 6):
        raise ValueError("malformed blocked-set entry")
    entries: list = []
    for f in faces:
        if f is None:
            entries.append(None)
            continue
        union, polys, index = f
        polys = shapely.from_wkb(np.array(polys, dtype=object))
        entries.append((shapely.from_wkb(union), shapely.STRtree(polys), index))
    return cones, circ, entries


# --------------------------------------------------------------------------------------------
# The arrangement and the NDBG
# --------------------------------------------------------------------------------------------

#: Most cells re-tested with the open-set semantics (0-dimensional first, then seams, then
#: 1-dimensional cells on contact circles); the others keep the closed sets' DBG, which has
#: more arcs: a partitioning may be missed there, none is made up. The section says how many.
EXACT_CELLS = 2000


#: Largest size in bytes of the table of DBGs read at the regions' directions (regions x
#: parts x parts / 8, packed): a 1000-box grid's 789,702 regions would need 92 GiB.
MAX_DBG_BYTES = 1 << 30


class TooLarge(NdbgError):
    """The NDBG has too many regions x parts to hold (:data:`MAX_DBG_BYTES`)."""


def _regions_3d(bs: BlockedSets) -> tuple[list[Region], int]:
    """The regions of S^2 (:func:`~ndbg_cli.arrangement.arrangement_cells`), each with its DBG,
    the seam candidates kept where the open-set semantics frees something; and the number of
    lower-dimensional cells whose exact re-test was skipped (:data:`EXACT_CELLS`).
    :class:`TooLarge` when their DBGs would pass :data:`MAX_DBG_BYTES`."""
    cells = arrangement_cells(bs)
    need = len(cells) * bs.n * ((bs.n + 7) // 8)
    if need > MAX_DBG_BYTES:
        raise TooLarge(f"its arrangement has {len(cells):,} regions over {bs.n} parts: their "
                       f"DBGs would take {need / 2**30:.1f} GiB (limit "
                       f"{MAX_DBG_BYTES / 2**30:.0f} GiB)")
    dirs = np.array([c.direction for c in cells]) if cells else np.zeros((0, 3))
    dbgs = bs.dbgs(dirs) if len(dirs) else []
    # Seam candidates: keep those where the open-set semantics frees something.
    seam = np.array([c.seam for c in cells], dtype=bool)
    dims = np.array([c.dimension for c in cells], dtype=int)
    lower = dims < 2
    counts = sliding_counts(bs.circles, dirs)  # per cell; the kept ones' are the regions'
    on_circle = counts > 0
    recheck = np.nonzero(seam | (lower & on_circle))[0]
    keep = ~seam
    skipped = 0
    if len(recheck) > EXACT_CELLS:
        order = np.lexsort((recheck, ~seam[recheck], dims[recheck]))
        skipped = len(recheck) - EXACT_CELLS
        recheck = np.sort(recheck[order[:EXACT_CELLS]])
    if len(recheck):
        for k, g in zip(recheck, bs.dbgs(dirs[recheck], exact=True)):
            if seam[k] and g.succ != dbgs[k].succ:
                keep[k] = True
            dbgs[k] = g
    cells = [c for c, ok in zip(cells, keep) if ok]
    dbgs = [g for g, ok in zip(dbgs, keep) if ok]
    dirs = np.array([c.direction for c in cells]).reshape(-1, 3)
    sliding = counts[keep]
    lower = np.array([c.dimension < 2 for c in cells], dtype=bool)
    dirs, sliding = _snap_to_circles(bs, dirs, sliding, dbgs, lower)
    regions = [Region(dimension=c.dimension, direction=tuple(float(x) for x in d),
                      dbg=g, sliding=int(k)) for c, d, g, k in zip(cells, dirs, dbgs, sliding)]
    return regions, skipped


#: How far (chart units, about radians, times ``eta``) from a lower-dimensional region's
#: direction the contact circles are looked for by :func:`_snap_to_circles`.
SNAP_ETA = 2.0


def _snap_to_circles(bs: BlockedSets, dirs: np.ndarray, sliding: np.ndarray,
                     dbgs: list[DBG], lower: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Move the direction of each lower-dimensional region (``lower``) to the point where the
    contact circles near it meet, when that point lies on more circles (within
    :data:`ON_CIRCLE`) and has the region's DBG (exact lookup).

    A thin free band round a bore's axis is a few ``eps / L`` wide: its cells' directions
    (centroids, chain midpoints) lie anywhere in it, off the axis, where the direct sweep test
    blocks (it does not erode contacts). The bore's facets' circles all pass through the axis
    (to the mesh's rounding): their least-squares common point, refined on the circles
    through it, is the axis. Returns the new ``(dirs, sliding)``. Not done with a domain
    (restricted to small caps where thousands of circles meet, the family is then used for
    the whole assembly's partitionings only, not for plans)."""
    dirs, sliding = dirs.copy(), sliding.copy()
    n = bs.circles
    if len(n) < 2 or bs.domain is not None:
        return dirs, sliding
    near_tol = SNAP_ETA * bs.eta
    low = np.flatnonzero(lower)
    cand: list[tuple[int, np.ndarray, int]] = []
    for s0 in range(0, len(low), 4096):
        ks = low[s0:s0 + 4096]
        near_all = np.abs(dirs[ks] @ n.T) < near_tol
        for k, mask in zip(ks, near_all):
            count = int(mask.sum())
            if count < 2 or count <= sliding[k]:
                continue
            d, near = dirs[k], n[mask]
            p = d
            for _ in range(2):  # least squares, then again on the circles through that point
                _, v = np.linalg.eigh(near.T @ near)
                p = v[:, 0] * (1.0 if v[:, 0] @ d >= 0 else -1.0)
                on = near[np.abs(near @ p) < 1e-6]
                if len(on) < 2:
                    break
                near = on
            if np.arccos(np.clip(p @ d, -1.0, 1.0)) > near_tol:
                continue
            on_p = int(sliding_counts(n, p[None])[0])
            if on_p > sliding[k]:
                cand.append((k, p, on_p))
    if cand:
        got = bs.dbgs(np.array([p for _, p, _ in cand]), exact=True)
        for (k, p, on_p), g in zip(cand, got):
            if g.succ == dbgs[k].succ:
                dirs[k] = p
                sliding[k] = on_p
    return dirs, sliding


#: ``|n . d|`` below which a direction slides along a contact of normal ``n`` (unit vectors):
#: the test of the lower-dimensional cells on the contact circles.
ON_CIRCLE = 1e-7


def sliding_counts(circles: np.ndarray, dirs: np.ndarray) -> np.ndarray:
    """``(m,)`` the number of contact normals ``circles`` ``(c, 3)`` perpendicular to each
    of ``dirs`` ``(m, 3)`` (within :data:`ON_CIRCLE`)."""
    out = np.zeros(len(dirs), dtype=np.int64)
    if not len(circles) or not len(dirs):
        return out
    # in blocks of directions: AS1's 15,755 cells x 2,639 circles made a 330 MB temporary
    # (1.7 s a call; 0.4 s so)
    ct = np.ascontiguousarray(np.asarray(circles, float).T)
    for lo in range(0, len(dirs), SLIDING_BLOCK):
        p = dirs[lo:lo + SLIDING_BLOCK] @ ct
        np.abs(p, out=p)
        out[lo:lo + SLIDING_BLOCK] = np.count_nonzero(p < ON_CIRCLE, axis=1)
    return out


#: Directions per block of :func:`sliding_counts`.
SLIDING_BLOCK = 1024


def build_infinite(asm: Assembly, cache: PairCache | None = None,
                   domain: np.ndarray | None = None, workers: int = 1,
                   progress: bool = False) -> NDBG:
    """The NDBG for infinite translations of ``asm``: one region per cell of the arrangement
    (2/1/0-dimensional on S^2; 1/0 on S^1 for 2D assemblies), each with its DBG. ``cache``
    reuses per-pair blocked sets (:func:`blocked_sets`). With ``domain`` (3D only; cube-map
    cells, :func:`ndbg_cli.domain.free_domain`) only the cells of the arrangement inside it
    are regions, cut by its boundary: right for the whole assembly's partitionings (none lies
    outside), not for its subassemblies'; the stats say ``restricted``. ``progress``: a bar on
    stderr over the part pairs (:mod:`ndbg_cli.progress`: on a terminal only)."""
    t0 = time.perf_counter()
    bs = blocked_sets(asm, cache, domain if asm.dimension == 3 else None, workers, progress)
    t1 = time.perf_counter()
    skipped = 0
    if asm.dimension == 2:
        bs.arcs = {pair: equator.cone_arcs(c, OPEN_TOL) for pair, c in sorted(bs.cones.items())}
        regs = equator.equator_regions(bs.arcs, bs.n, bs.eta,
                                       equator.sliding_angles(bs.circles))
        t2 = time.perf_counter()
        # the prisms' caps are contacts too (normal along z): every direction slides on them
        dirs = np.array([[np.cos(phi), np.sin(phi), 0.0] for _, phi, _ in regs])
        sliding = sliding_counts(bs.circles[equator.in_plane(bs.circles)], dirs)
        regions = [Region(dimension=dim, direction=equator.direction(phi), dbg=g,
                          sliding=int(k)) for (dim, phi, g), k in zip(regs, sliding)]
    else:
        regions, skipped = _regions_3d(bs)
        t2 = time.perf_counter()
    t3 = time.perf_counter()
    ndbg = NDBG(family=FAMILY, ids=tuple(asm.ids), regions=tuple(regions),
                space_dimension=asm.dimension, stats={}, geometry=bs)
    counts = ndbg.region_counts()
    ndbg.stats.update({
        "regions_by_dimension": counts, "regions": len(regions),
        "distinct_dbgs": len(ndbg.distinct()), "pieces": bs.stats["pieces"],
        "length_tolerance": asm.length_tolerance, "angular_tolerance": bs.eta,
        "time_blocked_sets_s": t1 - t0, "time_arrangement_s": t2 - t1,
        "time_dbgs_s": t3 - t2, "time_total_s": t3 - t0,
        "restricted": bs.domain is not None, "exact_cells_skipped": skipped,
    })
    if bs.domain is not None:
        ndbg.stats["domain_area"] = float(sum(g.area for g in bs.domain if g is not None))
    return ndbg


def lookup(ndbg: NDBG, d: np.ndarray, exact: bool = False) -> list[DBG]:
    """DBGs at directions ``d`` (``(m, 3)``; ``(m, 2)`` in 2D) from the NDBG's blocked sets:
    a vectorised point location in the arrangement, no geometry of the parts. With
    ``exact`` the open-set semantics is applied too (right on the contact circles, e.g.
    exactly along a bore's axis; slower). Threaded pairs the NDBG's regions block
    (``stats["threaded_pairs"]``, :func:`ndbg_cli.generalized.block_threads`) block here too."""
    bs = _blocked(ndbg)
    d = np.atleast_2d(np.asarray(d, dtype=float))
    if bs.arcs is not None:  # 2D: the open arcs on S^1 (always the open-set semantics)
        out = equator.arc_dbgs(bs.arcs, bs.n, np.arctan2(d[:, 1], d[:, 0]))
    else:
        out = bs.dbgs(d, exact=exact)
    extra = ndbg.mutual_blocks(ndbg.stats.get("threaded_pairs", ()))
    return out if extra is None else [g.union(extra) for g in out]


def _blocked(ndbg: NDBG) -> BlockedSets:
    """The blocked sets :func:`build_infinite` keeps on ``ndbg.geometry``."""
    bs = ndbg.geometry
    if not isinstance(bs, BlockedSets):
        raise ValueError(f"not an NDBG built by build_infinite (family {ndbg.family!r})")
    return bs


def boundary_distance(ndbg: NDBG, d: np.ndarray) -> np.ndarray:
    """Chart distance ``(m,)`` from each direction to the nearest ``B_ij`` boundary on its
    face (about the angle in radians, within a factor 3; 2D: the angle on S^1): where the
    lookup is robust."""
    bs = _blocked(ndbg)
    d = np.atleast_2d(np.asarray(d, dtype=float))
    if bs.arcs is not None:  # 2D: radians to the nearest arc end
        return equator.boundary_distance(bs.arcs, np.arctan2(d[:, 1], d[:, 0]))
    f, st = face_of(d)
    out = np.full(len(d), np.inf)
    for face in range(6):
        sel = np.nonzero(f == face)[0]
        if not len(sel) or not bs.geoms[face]:
            continue
        lines = shapely.union_all([shapely.boundary(g) for g in bs.geoms[face].values()])
        out[sel] = shapely.distance(lines, shapely.points(st[sel]))
    return out


def free_directions(ndbg: NDBG, moved: int, mask: int | None = None
                    ) -> list[tuple[int, tuple[float, ...]]]:
    """``(dimension, direction)`` of every region in which the part set ``moved`` (bitmask)
    is free inside ``mask`` (default all parts)."""
    return [(r.dimension, r.direction) for r in ndbg.regions if r.dbg.is_free(moved, mask)]


__all__ = ["BlockedSets", "Cell", "FAMILY", "blocked_sets", "build_infinite", "lookup",
           "boundary_distance", "infinite_section", "infinite_text", "partitioning_records",
           "free_directions", "arrangement_cells", "pair_cones", "triangle_pairs"]
