"""The NDBG for infinite translations (paper section 5.3).

``P_j`` blocks the infinite translation of ``P_i`` along ``d`` when the volume ``P_i`` sweeps
to infinity along ``d`` meets the interior of ``P_j``. ``B_ij``, the radial projection of the
interior of the Minkowski difference ``P_j - P_i``, is computed exactly as a union of open
cones (:mod:`ndbg_cli.ndbg.infinite.blocking_cones`; no sampling of directions) for every pair
of parts, since distant parts block too (each unordered pair once: ``B_ji = -B_ij``). The NDBG
is the arrangement of their boundaries (:mod:`ndbg_cli.ndbg.infinite.arrangement`, per cube
face; on S^1 for 2D assemblies, :mod:`ndbg_cli.ndbg.infinite.equator`) with one DBG per region.
Near parts are eroded by about the length tolerance so that contact never blocks by itself
(see the comment at :func:`build_infinite`).
"""

from __future__ import annotations

import time

import numpy as np
import shapely

from ...core.assembly import Assembly
from ...core.cache import PairCache
from ...core.constants import INFINITE
from ...core.errors import NdbgError
from ...core.gc_pause import gc_paused
from ...core.pools import Mapper
from ..dbg import DBG
from ..model import NDBG, Region
from . import equator
from .arrangement import arrangement_cells
from .blocked_sets import (
    OPEN_TOL,
    BlockedSets,
    blocked_sets,
    succ_from_bits,
    transposed_bits,
)
from .cubemap import face_of

# --------------------------------------------------------------------------------------------
# The arrangement and the NDBG
# --------------------------------------------------------------------------------------------

#: Most cells re-tested with the open-set semantics (0-dimensional first, then seams, then
#: 1-dimensional cells on contact circles), counted on the even cube faces (the odd faces'
#: cells are their antipodal images and share the answer); the others keep the closed sets'
#: DBG, which has more arcs: a partitioning may be missed there, none is made up. The section
#: says how many.
EXACT_CELLS = 2000


#: Largest size in bytes of the table of DBGs read at the regions' directions (regions x
#: parts x parts / 8, packed): a 1000-box grid's 789,702 regions would need 92 GiB.
MAX_DBG_BYTES = 1 << 30


class TooLarge(NdbgError):
    """The NDBG has too many regions x parts to hold (:data:`MAX_DBG_BYTES`)."""


def _regions_3d(bs: BlockedSets, workers: int = 1) -> tuple[list[Region], int, float]:
    """The regions of S^2 (:func:`~ndbg_cli.ndbg.infinite.arrangement.arrangement_cells`), each with
    its DBG, the seam candidates kept where the open-set semantics frees something; the number of
    lower-dimensional cells whose exact re-test was skipped (:data:`EXACT_CELLS`); and the
    ``perf_counter`` time when the arrangement was done (its DBGs are read after). :class:`TooLarge`
    when their DBGs would pass :data:`MAX_DBG_BYTES`.

    Each face of the overlay is a region whose DBG is read at a point inside it; each chain
    of boundary between two nodes is a 1-dimensional cell, each node a 0-dimensional one.
    Regions cut by the cube edges are counted once per cube face (the DBG is constant on each
    piece, so the NDBG stays exact; region counts are those of the arrangement refined by the
    12 cube-edge arcs)."""
    cells = arrangement_cells(bs, workers)
    t_cells = time.perf_counter()
    size = len(cells) * bs.n * ((bs.n + 7) // 8)
    if size > MAX_DBG_BYTES:
        raise TooLarge(f"its arrangement has {len(cells):,} regions over {bs.n} parts: their "
                       f"DBGs would take {size / 2**30:.1f} GiB (limit "
                       f"{MAX_DBG_BYTES / 2**30:.0f} GiB)")
    # The DBGs are read at the cells made, and reversed for their antipodal images
    # (G(-d) is G(d) reversed, exactly: B_ji = -B_ij).
    mirror = np.array([c.mirror_of for c in cells], dtype=np.int64)
    made = np.flatnonzero(mirror < 0)
    cells_m = [cells[k] for k in made]
    dirs = np.array([c.direction for c in cells_m]).reshape(-1, 3)
    bits = bs.dbg_bits(dirs, workers=workers)
    # Seam candidates: keep those where the open-set semantics frees something.
    seam = np.array([c.seam for c in cells_m], dtype=bool)
    dims = np.array([c.dimension for c in cells_m], dtype=int)
    lower = dims < 2
    counts = sliding_counts(bs.circles, dirs)  # per cell; the kept ones' are the regions'
    on_circle = counts > 0
    need = seam | (lower & on_circle)
    recheck = np.nonzero(need)[0]
    keep = ~seam
    if len(recheck) > EXACT_CELLS:
        order = np.lexsort((recheck, ~seam[recheck], dims[recheck]))
        recheck = np.sort(recheck[order[:EXACT_CELLS]])
    need[recheck] = False  # now: those left with the closed sets' DBG
    if len(recheck):
        exact = bs.dbg_bits(dirs[recheck], exact=True)
        changed = np.any(exact != bits[recheck], axis=(1, 2))
        keep[recheck[seam[recheck] & changed]] = True
        bits[recheck] = exact
    dirs, counts = _snap_to_circles(bs, dirs, counts, bits, lower & keep)
    # the images: each the cell made mapped, in the arrangement's order
    at = np.empty(len(cells), dtype=np.int64)
    at[made] = np.arange(len(made))
    pos = at[np.where(mirror < 0, np.arange(len(cells)), mirror)]
    flip = mirror >= 0
    ks = np.flatnonzero(keep[pos])
    rows = bits[pos[ks]]
    rows[flip[ks]] = transposed_bits(rows[flip[ks]])
    regions = []
    for k, succ in zip(ks.tolist(), succ_from_bits(rows)):
        p = pos[k]
        d = 0.0 - dirs[p] if flip[k] else dirs[p]
        regions.append(Region(dimension=cells[k].dimension, direction=tuple(d.tolist()),
                              dbg=DBG(succ), sliding=int(counts[p])))
    bs.cells, bs.region_cells = cells, ks
    return regions, int(need[pos].sum()), t_cells


#: How far (chart units, about radians, times ``eta``) from a lower-dimensional region's
#: direction the contact circles are looked for by :func:`_snap_to_circles`.
SNAP_ETA = 2.0


def _snap_to_circles(bs: BlockedSets, dirs: np.ndarray, sliding: np.ndarray,
                     bits: np.ndarray, lower: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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
        got = bs.dbg_bits(np.array([p for _, p, _ in cand]), exact=True)
        for (k, p, on_p), g in zip(cand, got):
            if np.array_equal(g, bits[k]):
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
    # in blocks of directions: all cells x all circles at once made a temporary of hundreds
    # of MB (benchmarks/NOTES.md)
    ct = np.ascontiguousarray(np.asarray(circles, float).T)
    for lo in range(0, len(dirs), SLIDING_BLOCK):
        p = dirs[lo:lo + SLIDING_BLOCK] @ ct
        np.abs(p, out=p)
        out[lo:lo + SLIDING_BLOCK] = np.count_nonzero(p < ON_CIRCLE, axis=1)
    return out


#: Directions per block of :func:`sliding_counts`.
SLIDING_BLOCK = 1024


# Tolerance (eps = asm.length_tolerance). For near triangle pairs (boxes closer than 4 eps) both
# triangles move inward by 1.5 eps along their normals (and, where two parts touch at an angle,
# back from their parts' convex sharp edges: ndbg_cli.ndbg.infinite.erosion): the parts are
# eroded by about eps. A part then blocks only if the sweep penetrates it deeper than about
# eps: sliding along a contact face is free, tessellation overlaps below eps are ignored, and
# the directions through a zero-clearance slot or bore form a thin free region about eps / L
# wide (L the contact length). Regions narrower in the chart than eta = ANGULAR_FACTOR * eps /
# diagonal are 1-dimensional, those smaller than eta every way 0-dimensional; a thin region
# round a bore's axis takes the point where the contacts' circles meet (_snap_to_circles).
# Far pairs use the exact triangles with closed polygons: a direction grazing a distant part
# with exactly zero clearance counts as blocked.
def build_infinite(asm: Assembly, cache: PairCache | None = None,
                   domain: np.ndarray | None = None, workers: int = 1,
                   progress: bool = False, mapper: Mapper | None = None) -> NDBG:
    """The NDBG for infinite translations of ``asm``: one region per cell of the arrangement
    (2/1/0-dimensional on S^2; 1/0 on S^1 for 2D assemblies), each with its DBG. ``cache`` reuses
    per-pair blocked sets (:func:`blocked_sets`). With ``domain`` (3D only; cube-map cells,
    :func:`ndbg_cli.ndbg.infinite.domain.free_domain`) only the cells of the arrangement inside it
    are regions, cut by its boundary: right for the whole assembly's partitionings (none lies
    outside), not for its subassemblies'; the stats say ``restricted``. ``progress``: a bar on
    stderr over the part pairs (:mod:`ndbg_cli.core.progress`: on a terminal only). ``mapper``
    computes the part pairs' blocked sets (:class:`~ndbg_cli.core.pools.Mapper`; default:
    ``workers`` forked processes), ``workers`` threads the arrangement here; the NDBG does not
    depend on either."""
    with gc_paused():
        return _build(asm, cache, domain, workers, progress, mapper)


def _build(asm: Assembly, cache: PairCache | None, domain: np.ndarray | None, workers: int,
           progress: bool, mapper: Mapper | None) -> NDBG:
    t0 = time.perf_counter()
    bs = blocked_sets(asm, cache, domain if asm.dimension == 3 else None, workers, progress,
                      mapper)
    t1 = time.perf_counter()
    skipped = 0
    if asm.dimension == 2:
        bs.arcs = {pair: equator.cone_arcs(c, OPEN_TOL) for pair, c in sorted(bs.cones.items())}
        regs = equator.equator_extents(bs.arcs, bs.n, bs.eta,
                                       equator.sliding_angles(bs.circles))
        t2 = time.perf_counter()
        # the prisms' caps are contacts too (normal along z): every direction slides on them
        dirs = np.array([[np.cos(phi), np.sin(phi), 0.0] for _, phi, _, _ in regs])
        sliding = sliding_counts(bs.circles[equator.in_plane(bs.circles)], dirs)
        # thin: a 1-dimensional arc that may be an erosion band (equator's docstring)
        regions = [Region(dimension=dim, direction=equator.direction(phi), dbg=g,
                          sliding=int(k),
                          thin=dim == 1 and equator.narrow(span[1] - span[0], bs.eta))
                   for (dim, phi, g, span), k in zip(regs, sliding)]
    else:
        regions, skipped, t2 = _regions_3d(bs, workers)
    t3 = time.perf_counter()
    ndbg = NDBG(family=INFINITE, ids=tuple(asm.ids), regions=tuple(regions),
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
    """DBGs at directions ``d`` (``(m, 3)``; ``(m, 2)`` in 2D) from the NDBG's blocked sets: a
    vectorised point location in the arrangement, no geometry of the parts. With ``exact`` the
    open-set semantics is applied too (right on the contact circles, e.g. exactly along a bore's
    axis; slower). Threaded pairs the NDBG's regions block (``stats["threaded_pairs"]``,
    :func:`ndbg_cli.ndbg.generalized.build.block_threads`) block here too."""
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


__all__ = ["SNAP_ETA", "TooLarge", "build_infinite", "lookup", "boundary_distance",
           "free_directions"]
