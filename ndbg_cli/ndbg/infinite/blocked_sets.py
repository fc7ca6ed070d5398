"""The blocked-direction sets ``B_ij`` of every ordered pair of parts on the cube map, for the
infinite-translation NDBG (:mod:`ndbg_cli.ndbg.infinite.build`, which gives the route and the
tolerances): :func:`blocked_sets` computes them (each unordered pair once, the other order its
antipodal image; cached per pair; optionally inside a domain of directions only), and
:class:`BlockedSets` holds them and reads the DBG at any direction, with the closed chart sets
or, ``exact``, the open cones themselves. :func:`triangle_pairs` is the cost estimate the
CLI's ``--infinite-budget`` is checked against.
"""

from __future__ import annotations

import hashlib
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
import shapely

from ...core.assembly import Assembly, content_hash
from ...core.cache import PairCache
from ...core.memo import kept
from ...core.pools import ForkMapper, Mapper
from ...core.progress import progress as bar
from ...kernels.compiled import loaded
from ..dbg import DBG
from .blocking_cones import closed_parts, part_triangles, unique_circles
from .chart_union import antipodal, cut_to_domain, reverse_entries
from .convex_cones import convex_entries, convex_pairs, far_convex
from .cubemap import face_of
from .domain import domain_polygons
from .pair_workers import pair_sets

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
    #: Per face, each pair's ``(boxes, index)``: its chart pieces' bounding boxes ``(q, 4)``
    #: (``None``: one piece, the whole face) and the cone of each (``cones[(i, j)]`` rows).
    boxes: list[dict[tuple[int, int], tuple]] = field(default_factory=list)
    circles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    space_dimension: int = 3
    stats: dict = field(default_factory=dict)
    #: Per face, the chart geometry of the directions where the sets are right (``None`` entries:
    #: none on that face), or ``None`` for all directions (:mod:`ndbg_cli.ndbg.infinite.domain`).
    domain: list | None = None
    #: 2D assemblies: each ordered pair's open arcs on the equator (radians,
    #: :func:`ndbg_cli.ndbg.infinite.equator.cone_arcs`), set by :func:`build_infinite`.
    arcs: dict | None = None
    #: 3D assemblies: the arrangement's cells (``arrangement.arrangement_cells``) and, per
    #: region of the NDBG, the index of its cell, set by ``build_infinite``: each region's
    #: whole extent, which the grasp needs (paper section 7.2).
    cells: list | None = None
    region_cells: np.ndarray | None = None
    #: Whether the sets on each odd face are the exact antipodal images of those on the
    #: even one (:func:`blocked_sets` stores them so; the arrangement then maps them).
    paired: bool = False
    _by_face: list = field(default_factory=lambda: [None] * 6, repr=False,
                           compare=False)

    def blocked_pairs(self, d: np.ndarray, workers: int = 1
                      ) -> list[tuple[np.ndarray, int, int]]:
        """For directions ``d`` ``(m, 3)``: list of ``(index, i, j)``, ``index`` the sorted
        indices ``k`` of the directions ``d[k]`` along which ``P_j`` blocks ``P_i``.
        ``workers`` threads take the faces (GEOS releases the GIL; the result is the same)."""
        d = np.atleast_2d(np.asarray(d, dtype=float))
        f, st = face_of(d)
        faces = [(face, np.nonzero(f == face)[0]) for face in range(6)]
        faces = [(face, sel) for face, sel in faces if len(sel) and self.geoms[face]]
        if workers > 1 and len(faces) > 1:
            with ThreadPoolExecutor(max_workers=min(workers, len(faces))) as pool:
                found = list(pool.map(lambda fs: self._face_hits(*fs, st), faces))
        else:
            found = [self._face_hits(face, sel, st) for face, sel in faces]
        out: dict[tuple[int, int], list[np.ndarray]] = {}
        for hits in found:  # face by face, as one thread finds them
            for key, idx in hits:
                out.setdefault(key, []).append(idx)
        return [(np.sort(np.concatenate(v)), i, j) for (i, j), v in sorted(out.items())]

    def _face_hits(self, face: int, sel: np.ndarray, st: np.ndarray
                   ) -> list[tuple[tuple[int, int], np.ndarray]]:
        """The pairs blocking the directions ``sel`` (indices, all on ``face``; chart points
        ``st``), each with the indices of those it blocks, pair by pair."""
        keys, geoms = self._face_pairs(face)
        x, y = st[sel, 0], st[sel, 1]
        # each pair's exact test only on the directions inside its bounding box
        gi, pt = shapely.STRtree(shapely.points(x, y)).query(geoms)
        if np.any(gi[1:] < gi[:-1]):  # shapely lists them by pair already
            order = np.argsort(gi, kind="stable")
            gi, pt = gi[order], pt[order]
        starts = np.flatnonzero(np.r_[True, gi[1:] != gi[:-1]]) if len(gi) else []
        ends = np.r_[starts[1:], len(gi)] if len(gi) else []
        out = []
        for a, b in zip(starts, ends):
            k = pt[a:b]
            hit = shapely.contains_xy(geoms[gi[a]], x[k], y[k])
            if hit.any():
                out.append((keys[gi[a]], sel[k[hit]]))
        return out

    def _face_pairs(self, face: int) -> tuple[list[tuple[int, int]], np.ndarray]:
        """The pairs with a set on ``face`` and their geometries (an array, made once)."""
        if self._by_face[face] is None:
            keys = list(self.geoms[face])
            self._by_face[face] = (keys, np.array([self.geoms[face][k] for k in keys],
                                                  dtype=object))
        return self._by_face[face]

    def dbgs(self, d: np.ndarray, exact: bool = False, workers: int = 1) -> list[DBG]:
        """The DBG at each direction of ``d`` ``(m, 3)`` (region lookup, vectorised).

        The chart lookup tests the interior of the closure of ``B_ij``; it is right for every
        direction off the contact circles. With ``exact``, a direction inside that closure is
        re-tested against the open cones themselves (the open-set semantics of ``B_ij``),
        which is what the 1- and 0-dimensional cells need: a slot, a bore or a sliding face
        leaves free directions on seams between blocked cones. ``workers``: threads for the
        chart lookup (:meth:`blocked_pairs`).
        """
        return [DBG(row) for row in succ_from_bits(self.dbg_bits(d, exact, workers))]

    def dbg_bits(self, d: np.ndarray, exact: bool = False, workers: int = 1) -> np.ndarray:
        """:meth:`dbgs` as packed successor rows ``(m, n, ceil(n / 8))`` (bit ``j`` of row
        ``i``, little-endian: ``P_j`` blocks ``P_i``), before they are made DBGs."""
        d = np.atleast_2d(np.asarray(d, dtype=float))
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        # successor bits, packed as they are set (a (m, n, n) bool matrix would take
        # 270 MB for a 100-box grid's 26,694 regions)
        bits = np.zeros((len(d), self.n, (self.n + 7) // 8), dtype=np.uint8)
        for k, i, j in self.blocked_pairs(d, workers):
            if exact:
                k = self._exact(k, i, j, d)
            bits[k, i, j >> 3] |= np.uint8(1 << (j & 7))
        return bits

    def _exact(self, sel: np.ndarray, i: int, j: int, d: np.ndarray) -> np.ndarray:
        """Re-test the directions ``d[sel]`` (indices) against the open cones of pair
        ``(i, j)`` whose chart pieces' bounding boxes hold them (a superset); returns the
        sorted indices of those inside one.

        A direction deep in ``B_ij`` lies in hundreds of overlapping cones and one suffices: each
        direction's pieces are scanned up to its first hit
        (:func:`ndbg_cli.kernels._cone_kernels.open_hits`; a compiled scan of the boxes, where an
        STR-tree query listed tens of millions of candidates). Only the directions in no open cone
        (seams, boundaries) scan every piece."""
        kernels = loaded("_cone_kernels")
        out = np.zeros(len(d), dtype=bool)
        f, st = face_of(d[sel])
        cones = self.cones[(i, j)]
        for face in np.unique(f):
            entry = self.boxes[face].get((i, j))
            if entry is None:
                continue
            boxes, index = entry
            if boxes is None:  # one piece (convex parts): every direction is a candidate
                boxes = np.array([[-np.inf, -np.inf, np.inf, np.inf]])
            on = f == face
            rows = sel[np.nonzero(on)[0]]
            pts = st[on]
            out[rows[kernels.open_hits(cones, np.ascontiguousarray(d[rows]),
                                       np.ascontiguousarray(pts[:, 0]),
                                       np.ascontiguousarray(pts[:, 1]),
                                       np.ascontiguousarray(boxes, dtype=float),
                                       np.ascontiguousarray(index, dtype=np.int64),
                                       OPEN_TOL)]] = True
        return np.flatnonzero(out)


#: Directions within this (radians, about) of a cone's facet count as outside the open cone.
OPEN_TOL = 1e-6


def transposed_bits(bits: np.ndarray) -> np.ndarray:
    """Packed successor rows ``(m, n, ceil(n / 8))`` (:meth:`BlockedSets.dbg_bits`) with
    every arc reversed: each distinct ``n x n`` bit matrix transposed once (regions share
    DBGs), in blocks of about 16 million bits."""
    m, n, width = bits.shape
    first: dict[bytes, int] = {}
    which = np.array([first.setdefault(row.tobytes(), len(first)) for row in bits],
                     dtype=np.int64).reshape(m)
    uniq = bits[np.unique(which, return_index=True)[1]] if m else bits
    out = np.empty_like(uniq)
    step = max(1, (1 << 24) // max(n * n, 1))
    for lo in range(0, len(uniq), step):
        rows = np.unpackbits(uniq[lo:lo + step], axis=2, count=n, bitorder="little")
        out[lo:lo + step] = np.packbits(rows.transpose(0, 2, 1), axis=2, bitorder="little")
    return out[which]


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


#: Against the budget, a pair of convex parts far apart (one cone) counts as this many
#: triangle pairs: the ratio of the two costs when it was set (benchmarks/NOTES.md; triangle
#: pairs have become cheaper since, so the count errs towards computing them), plus one per
#: :data:`CONVEX_DIFFERENCES_PER_PAIR` difference vectors (``|V_i| |V_j|``).
CONVEX_PAIR_COST = 16
CONVEX_DIFFERENCES_PER_PAIR = 128


def triangle_pairs(asm: Assembly) -> int:
    """Number of (moving, blocking) triangle pairs over all ordered pairs of parts: the cost
    driver, twice what the builder examines (it computes each unordered pair once) and an
    upper bound of even that, since the pruning walk skips most of them. An ordered pair of
    convex parts more than ``4 eps`` apart, whose set is one cone
    (:func:`~ndbg_cli.ndbg.infinite.convex_cones.far_convex` decides), counts as
    :data:`CONVEX_PAIR_COST` plus one per :data:`CONVEX_DIFFERENCES_PER_PAIR` difference
    vectors. The CLI skips the NDBG with a warning above
    ``--infinite-budget`` (example counts in benchmarks/NOTES.md). Kept on ``asm`` (the
    CLI asks twice: to decide, then to say why)."""
    return kept(asm, "_triangle_pairs", lambda: _triangle_pairs(asm))


def _triangle_pairs(asm: Assembly) -> int:
    closed = closed_parts(asm)
    # open shells count twice: their triangles face both ways (part_triangles)
    t = np.array([p.check.triangles * (1 if c else 2) if asm.dimension == 3
                  else 4 * p.check.vertices for p, c in zip(asm.parts, closed)], dtype=float)
    total = t.sum() ** 2 - (t ** 2).sum()
    if asm.dimension == 3 and len(t) > 1:
        verts, pairs = far_convex(part_triangles(asm), closed, asm.length_tolerance)
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
                 progress: bool = False, mapper: Mapper | None = None) -> BlockedSets:
    """``B_ij`` for every ordered pair of parts, on the cube map. Each unordered pair is computed
    once, the part with fewer triangles moving, and the other order is its antipodal image
    (:func:`reverse_entries`; exact: ``B_ji = -B_ij``). With ``cache``, each computed pair's cones
    and chart polygons are looked up by the two parts' content hashes and the tolerance
    (:mod:`ndbg_cli.core.cache`). With ``domain`` (``(6, r, r)`` bool cube-map cells, symmetric
    under ``d -> -d``, :func:`ndbg_cli.ndbg.infinite.domain.free_domain`) the sets are right only
    inside those cells, and computed only there. ``mapper`` computes the pairs
    (:func:`ndbg_cli.ndbg.infinite.pair_workers.pair_sets`; default: ``workers`` forked
    processes; the result does not depend on it); ``progress``: a bar over the pairs on stderr
    (a terminal only)."""
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
    boxes: list[dict[tuple[int, int], tuple]] = [{} for _ in range(6)]
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
                    boxes[face][pair] = entry[1:]

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
        # 2D parts are extruded to the assembly's diagonal: that enters the result. "pruned-6": near
        # triangles inset from their parts' convex sharp edges (ndbg_cli.ndbg.infinite.erosion), and
        # with a domain the terms whose window pieces lie inside kept ones left out; older:
        # "pruned-5", unions of the pieces inside no other one, "pruned-4", the pieces themselves
        # stored rather than their boxes before, and unions not checked for lost area before that
        keys[(a, b)] = cache.key("infinite", "pruned-6", gkeys[a], gkeys[b], eps,
                                 asm.dimension, asm.diagonal if asm.dimension == 2 else None,
                                 *extra)
        got = cache.get("infinite", keys[(a, b)], _thaw)
        if got is not None:
            found[(a, b)] = got
    todo = [p for p in order if p not in fast and p not in found]
    # each pair cached as soon as it is done (an interrupted run keeps them); the times are
    # summed over the workers (CPU seconds, not wall time, with several)
    dom = None if domain is None else domain_polygons(domain)
    done = pair_sets(tris, todo, eps, domain, ForkMapper(workers) if mapper is None else mapper,
                     dom)
    cuts: list[dict] = [{} for _ in range(6)]
    for k, (cones, circ, entries, dt_cones, dt_union, made) in bar(
            done, len(todo), "part pairs", quiet=not progress):
        found[todo[k]] = (cones, circ, entries)
        for face, memo in enumerate(made):
            cuts[face].update(memo)
        t_cones += dt_cones
        t_union += dt_union
        if cache is not None:
            cache.put("infinite", keys[todo[k]], _freeze(cones, circ, entries))
    for a, b in order:
        if (a, b) in found:
            cones, circ, entries = found[(a, b)]
            circles.append(circ)
            store(a, b, cones, entries)
    if dom is not None:
        # only the domain's part is right (and needed): the arrangement is built there
        for face in range(0, 6, 2):
            _cut_face_pair(geoms, face, dom[face], cuts[face])
    for fd in geoms:
        for g in fd.values():
            shapely.prepare(g)
    eta = ANGULAR_FACTOR * eps / max(asm.size, 1e-300)
    stats = {"pieces": npieces, "convex_pairs": len(fast),
             "time_cones_s": t_cones, "time_union_s": t_union,
             "time_blocked_sets_s": time.perf_counter() - t0}
    circ = unique_circles(np.concatenate(circles)) if circles else np.zeros((0, 3))
    stats["contact_circles"] = len(circ)
    return BlockedSets(n=n, geoms=geoms, eta=eta, cones=all_cones, boxes=boxes, circles=circ,
                       space_dimension=asm.dimension, stats=stats, domain=dom, paired=True)


def _cut_face_pair(geoms: list[dict], face: int, dom: object, memo: dict) -> None:
    """Cut the sets on the even ``face`` to the domain's polygons ``dom`` there (``None``: none),
    and set those on the opposite face to their antipodal images: every set there is the image of
    one here (``B_ji = -B_ij``, as :func:`blocked_sets` stores them) and so is the domain
    (:func:`~ndbg_cli.ndbg.infinite.domain.domain_polygons`), so the images are the cuts, made once
    and exactly symmetric. ``memo``: cuts made already (the workers')."""
    fd, od = geoms[face], geoms[face ^ 1]
    if dom is None:
        fd.clear()
        od.clear()
        return
    pairs = list(fd)
    got = [cut_to_domain(fd[p], dom, memo) for p in pairs]
    images = iter(antipodal(np.array([g for g in got if g is not None], dtype=object)))
    for (i, j), g in zip(pairs, got):
        if g is None:
            del fd[(i, j)], od[(j, i)]
        else:
            fd[(i, j)] = g
            od[(j, i)] = next(images)
    if len(od) != len(fd):  # a set there with no image here would stay uncut
        raise RuntimeError("the blocked sets are not antipodally paired")


def antipodal_symmetric(domain: np.ndarray) -> bool:
    """Whether the cube-map cells ``domain`` ``(6, r, r)`` are symmetric under ``d -> -d``
    (cell ``(row, col)`` of face ``f`` maps to ``(r-1-col, r-1-row)`` of face ``f ^ 1``,
    see :data:`ndbg_cli.ndbg.infinite.chart_union.ANTIPODAL`)."""
    return all(np.array_equal(domain[f ^ 1], domain[f].T[::-1, ::-1]) for f in range(6))


def _freeze(cones: np.ndarray, circ: np.ndarray, entries: list) -> tuple:
    """A pair's result in cacheable form: arrays and WKB (exact double coordinates)."""
    faces = [None if e is None else (shapely.to_wkb(e[0]), e[1], e[2]) for e in entries]
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
        union, boxes, index = f
        if not (boxes is None or (isinstance(boxes, np.ndarray) and boxes.ndim == 2
                                  and boxes.shape[1] == 4 and len(boxes) == len(index))):
            raise ValueError("malformed blocked-set entry")
        entries.append((shapely.from_wkb(union), boxes, index))
    return cones, circ, entries
