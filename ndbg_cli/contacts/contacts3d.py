"""Contact analysis: which parts touch, where, and with which normals (paper section 5.1).

:func:`analyze_contacts` finds every pair of touching parts of a 3D assembly and describes each
contact by the unit normals that block part A's translations (``d . n > 0`` penetrates B) and by
contact points for generalized (6D) motion constraints ``n . (v + w x p) >= 0``. Pairs that
interfere get no contacts; parts wholly inside another are found by overlap volume when both
are closed. The numpy shortcuts taken for speed (dense box tests, batched distance calls,
vectorised clustering) reproduce the straightforward computation exactly, order included.
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import fcl
import numpy as np

from ..core.assembly import Assembly, content_hash
from ..core.cache import PairCache
from ..core.constants import CONTACT_ANGLE_TOL_RAD
from ..core.errors import InputError
from ..core.pools import ForkMapper, Helper, Mapper, spare_workers
from ..geometry.vectors import plane_basis
from ..kernels.compiled import loaded
from ._pair_work import INTERFERENCE, SURFACE, WHOLE, PairWork, clashing_parts, pair_results
from .bvh import BoxHierarchy
from .facets import (
    PartGeometry,
    box_tree,
    fcl_model,
    fcl_object,
    manifold_model,
    part_geometries,
    part_geometry,
    sat_gap,
    triangle_gap,
)
from .features import classify_pairs, curved_contacts, edge_point_contacts
from .interference import Interference, interference, meshes_intersect
from .planar import coplanar_facets, planar_contacts

__all__ = ["Contact", "ContactAnalysis", "analyze_contacts"]

#: Candidate search (:func:`_triangle_candidates`): the most query x target triangles for
#: which a pair whose targets are partly left out takes the R-tree's order of all the
#: target's triangles (above, that of an R-tree of the others; the order, kept from when
#: pairs up to this size were compared densely with numpy, costs in benchmarks/NOTES.md).
_SUBTREE_PAIRS = 16_000_000

#: Per part geometry: the R-tree traversal rank of each triangle (:func:`_tree_rank`) and the
#: box of the triangles (:func:`_tri_box`).
_TREE_RANK: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_TRI_BOX: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
#: Per pair of part geometries (in index order): the broad phase's ``(crossing, near)``
#: (:func:`_confirmed`), kept for the units' second analysis, which meets every pair of the
#: parts no clash merged again (0.05 s of python-fcl queries on the engine).
_BROAD: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


@dataclass(frozen=True)
class Contact:
    """One contact between parts ``a < b`` (indices in ``asm.parts``).

    ``kind``: ``"planar" | "curved" | "edge" | "point"``. ``normals`` ``(k, 3)``: distinct unit
    normals pointing out of A into B (clustered within the angular tolerance). For planar and
    curved contacts A translating along ``d`` penetrates B iff ``d . n > 0`` for some ``n``
    (``blocking == "any"``). For edge and point contacts they generate the cone of admissible
    separating normals, and A penetrates B iff ``d . n > 0`` for all of them
    (``blocking == "all"``; treating them as ``"any"`` is conservative).
    ``points`` ``(m, 3)`` (assembly frame and unit): planar = contact polygon's convex-hull
    vertices; curved = facet centroids of both sides of the patch; edge = the two endpoints;
    point = the point. ``point_normals`` ``(m, 3)``: the normal (out of A) at each point.
    ``area``: unit^2 (curved: the smaller side's patch area, an upper bound; edge/point: 0).
    Curved contacts recognised as ``surface`` ``"cylinder"``/``"cone"`` carry a unit ``axis``,
    a ``center`` on it and the ``radius``; ``"sphere"`` carries ``center`` and ``radius``.
    """

    a: int
    b: int
    kind: str
    normals: np.ndarray
    points: np.ndarray
    point_normals: np.ndarray
    area: float
    axis: np.ndarray | None = None
    center: np.ndarray | None = None
    radius: float | None = None
    surface: str | None = None
    blocking: str = "any"


@dataclass(frozen=True)
class ContactAnalysis:
    """The result of :func:`analyze_contacts`. ``contacts`` sorted by ``(a, b, kind, normals,
    points)``; ``interferences`` by ``(a, b)``; ``tolerance`` in the assembly unit;
    ``angle_tolerance`` in radians; ``stats`` counts and phase timings (seconds)."""

    contacts: tuple[Contact, ...]
    interferences: tuple[Interference, ...]
    tolerance: float
    angle_tolerance: float
    stats: dict = field(default_factory=dict)

    def pairs(self) -> list[tuple[int, int]]:
        """Touching part pairs ``(a, b)``, ``a < b``, sorted."""
        return sorted({(c.a, c.b) for c in self.contacts})

    def normals_by_pair(self) -> dict[tuple[int, int], np.ndarray]:
        """All contact normals ``(k, 3)`` of each touching pair (out of ``a`` into ``b``)."""
        out: dict[tuple[int, int], list[np.ndarray]] = {}
        for c in self.contacts:
            out.setdefault((c.a, c.b), []).append(c.normals)
        return {k: np.concatenate(v) for k, v in sorted(out.items())}


def analyze_contacts(asm: Assembly, *, tolerance: float | None = None,
                     angle_tolerance: float = CONTACT_ANGLE_TOL_RAD,
                     cache: PairCache | None = None, workers: int = 1,
                     meanwhile: Callable[[], Any] | None = None,
                     mapper: Mapper | None = None, units_later: bool = False
                     ) -> ContactAnalysis:
    """Find the contacts and interferences between the parts of a 3D assembly.

    ``tolerance`` (assembly unit) overrides ``asm.length_tolerance``; ``angle_tolerance`` is in
    radians. With ``cache``, each
    candidate pair's narrow-phase result is looked up by the two parts' content hashes and the
    tolerances (:mod:`ndbg_cli.core.cache`). The pairs not in the cache are tested by ``mapper``
    (:class:`~ndbg_cli.core.pools.Mapper`; default: ``workers`` forked processes, when the pairs
    hold :data:`MIN_PARALLEL_TRIANGLES` triangles or ``meanwhile`` is given); the result does
    not depend on it;
    ``meanwhile`` is called here while they work. Raises :class:`InputError` for a 2D assembly
    or a non-positive tolerance.

    ``units_later``: the caller makes each group of clashing parts one unit and analyses the
    units again (:mod:`ndbg_cli.pipeline.units`). The contacts of a clashing part are then
    not listed (the interferences all are), and the pairs whose surfaces cross go first,
    so that once their interference tests tell the clashes, the other pairs of a clashing
    part are no longer computed.

    Tolerance model (lengths in the assembly unit):

    * ``tol``: ``asm.length_tolerance`` unless given (the manifest's or command line's, else
      1e-4 times the model's size, so a change of unit or frame changes no answer). Planes
      closer than ``tol`` coincide, gaps up to ``tol`` touch, contact polygons thinner than
      ``tol`` are edges.
    * chord sag: a tessellated curved surface departs from the true one by the sag
      ``r (1 - cos(pi / N))`` (per triangle, :class:`ndbg_cli.contacts.facets.PartGeometry`).
      Two tessellations of one nominal surface (a 24-facet shaft in a 64-facet hole) leave
      gaps up to the coarser side's sag and cross by up to the finer side's. So triangles
      ``i``, ``j`` touch when at most ``tol + sag_i + sag_j`` apart, and an overlap is an
      interference only when thicker than ``tol + min(sag_A, sag_B)``
      (:mod:`ndbg_cli.contacts.interference`).
    * ``angle_tolerance``: normals closer than this are one; faces whose normals are opposite
      within it can be coplanar. Curved contacts keep the facet normals themselves (clustered
      within it): for a facetted shaft in a hole they are the blocking cone.

    ``stats`` times the phases (seconds): ``bvh_s`` (python-fcl BVH, R-tree and triangle data
    per part, cached by part hash), ``broad_s`` (box pruning, ``fcl.collide`` and, unless the
    triangle boxes prove the parts apart, ``fcl.distance``), ``narrow_s`` (triangle pairs whose
    boxes meet, in R-tree order; plane and separating-axis tests; :mod:`ndbg_cli.contacts.features`)
    and ``interference_s`` (manifold3d overlap volumes, or the open-mesh fallback).
    """
    if asm.dimension != 3:
        raise InputError("contact analysis needs a 3D assembly", file=asm.source or None)
    tol = float(asm.length_tolerance if tolerance is None else tolerance)
    ang = float(angle_tolerance)
    if not tol > 0 or not 0 < ang < np.pi / 2:
        raise InputError(f"tolerances must be positive (got {tol}, {ang} rad)",
                         file=asm.source or None)
    stats: dict = {"parts": len(asm), "triangles": int(sum(p.check.triangles for p in asm))}
    t0 = time.perf_counter()
    # with a second core free (not taken by the interlock job already), the parts' facets
    # and sags are found there while python-fcl builds their BVHs here
    geos = part_geometries(asm.parts, tol, ang,
                           meanwhile=lambda: [fcl_model(p) for p in asm.parts],
                           fork_above=MIN_PARALLEL_TRIANGLES if spare_workers(workers) > 0
                           else None)
    t1 = time.perf_counter()
    pairs, nested = _broad_phase(asm, geos, tol, workers)
    t2 = time.perf_counter()
    contacts: list[Contact] = []
    interferences: list[Interference] = []
    approx: list[tuple[str, str]] = []
    tri_pairs = 0
    t_int = 0.0
    # content hashes of the validated, placed meshes (what this stage really reads), once each
    gkeys = ([content_hash(np.asarray(p.mesh.vertices), np.asarray(p.mesh.faces))
              for p in asm.parts] if cache is not None else [])
    size = [len(geos[a].triangles) + len(geos[b].triangles) for a, b, _ in pairs]
    # few triangles are not worth the workers' start, unless this process has work of its
    # own meanwhile (numba's start when the kernels are not built ahead of time), which
    # their time then hides (``PairWork.run``)
    work = PairWork(_narrow_phase, (asm, tol, ang), pairs, size,
                    lambda triangles: triangles < MIN_PARALLEL_TRIANGLES,
                    ForkMapper(workers) if mapper is None else mapper, cache, gkeys,
                    (tol, ang), _check_entry)
    ti = time.perf_counter()
    inside = _nested(asm, nested, tol)
    t_int += time.perf_counter() - ti
    results, clashing = pair_results(
        work, clashing_parts(inside) if units_later else None, meanwhile)
    for k, (a, b, _) in enumerate(pairs):
        if clashing is not None and (a in clashing or b in clashing):
            # left to the units' analysis (its interference test kept, or None: left out)
            found, approximate, _, _, seconds = results[k] or (None, False, [], 0, 0.0)
            results[k] = (found, approximate, [], 0, seconds)
    for (a, b, _), (found, approximate, cs, count, seconds) in zip(pairs, results):
        if approximate:
            approx.append((asm.parts[a].id, asm.parts[b].id))
        if found is not None:
            interferences.append(found)
        contacts += cs
        tri_pairs += count
        t_int += seconds
    interferences += inside
    t3 = time.perf_counter()
    contacts.sort(key=_sort_key)
    stats.update({
        "candidate_pairs": len(pairs), "triangle_pairs": tri_pairs,
        "touching_pairs": len({(c.a, c.b) for c in contacts}), "contacts": len(contacts),
        "by_kind": {k: sum(1 for c in contacts if c.kind == k)
                    for k in ("planar", "curved", "edge", "point")},
        "interferences": len(interferences),
        "interference_approximate_pairs": [list(p) for p in approx],
        "interference_method": ("manifold3d overlap volume; open meshes: fcl crossing-triangle "
                                "depth (approximate)"),
        "bvh_s": t1 - t0, "broad_s": t2 - t1, "narrow_s": max(t3 - t2 - t_int, 0.0),
        "interference_s": t_int,
    })
    return ContactAnalysis(tuple(contacts), tuple(sorted(interferences, key=lambda x: (x.a, x.b))),
                           tol, ang, stats)


def _narrow_phase(context: tuple[Assembly, float, float], pair: tuple) -> tuple:
    """:func:`_pair_result` of the candidate pair ``(a, b, crossing, part)`` (``part``:
    which of its narrow phase, :mod:`ndbg_cli.contacts._pair_work`), as a
    :class:`~ndbg_cli.core.pools.Mapper` computes it: ``context`` is ``(asm, tol, ang)``. The
    parts' geometry comes from :func:`~ndbg_cli.contacts.facets.part_geometry`'s per-process
    cache: the caller's in its forked workers, built once per part in a cluster's worker."""
    asm, tol, ang = context
    a, b, crossing, part = pair
    return _pair_result(asm, part_geometry(asm.parts[a], tol, ang),
                        part_geometry(asm.parts[b], tol, ang), a, b, crossing, tol, ang, part)


def _pair_result(asm: Assembly, ga: PartGeometry, gb: PartGeometry, a: int, b: int,
                 crossing: bool, tol: float, ang: float, part: str = WHOLE
                 ) -> tuple[Interference | None, bool, list[Contact], int, float]:
    """One candidate pair's narrow phase (``ga``, ``gb``: the parts' geometry): ``(interference
    or None, approximate, contacts, triangle pairs, seconds of the interference test)``. A pair
    whose surfaces cross is tested for interference first; one that interferes gets its fit's
    contacts only. ``part``: :data:`~ndbg_cli.contacts._pair_work.INTERFERENCE`, the test alone;
    :data:`~ndbg_cli.contacts._pair_work.SURFACE`, the surface contacts alone (the test found
    no interference)."""
    found, approximate, contacts, count, seconds = None, False, [], 0, 0.0
    if crossing and part != SURFACE:
        ti = time.perf_counter()
        allowance = tol + min(float(ga.sag.max()), float(gb.sag.max()))
        found, approximate = interference(a, b, asm.parts[a], asm.parts[b], ga, gb,
                                          allowance, tol)
        seconds = time.perf_counter() - ti
        if found is not None:
            contacts += fit_contacts(found)
    if found is None and part != INTERFERENCE:
        faces, skip_a, skip_b = coplanar_facets(ga, gb, tol, ang)
        i, j, offsets = _plane_filter(ga, gb, *_triangle_candidates(ga, gb, tol, skip_a,
                                                                    skip_b), tol)
        count = len(i)
        if len(i) or faces:
            contacts += _pair_contacts(a, b, ga, gb, i, j, tol, ang, offsets, faces)
    return found, approximate, contacts, count, seconds


#: Fewest triangles (summed over the parts of the pairs to test) for which
#: :func:`analyze_contacts` hands the pairs to worker processes (``workers``) when it has
#: nothing to do ``meanwhile``: below it their start costs more than they save.
MIN_PARALLEL_TRIANGLES = 20_000

#: Radial normals standing for a press fit's cylindrical contact (:func:`fit_contacts`).
PRESS_NORMALS = 8


def fit_contacts(found: Interference) -> list[Contact]:
    """The contact a classified interference stands for (:mod:`ndbg_cli.contacts.fits`): a
    press fit, a cylindrical contact about its axis (:data:`PRESS_NORMALS` radial normals:
    only the axis is free); an overlap, a face contact whose normal (out of ``a`` into ``b``)
    is opposite the separating direction; a clash, none (the pipeline keeps its parts
    together)."""
    fit = found.fit
    if fit is None or fit.kind == "clash":
        return []
    if fit.kind == "press_fit":
        axis, c = np.asarray(fit.axis), np.asarray(fit.center)
        u, v = plane_basis(axis)
        t = 2 * np.pi * np.arange(PRESS_NORMALS) / PRESS_NORMALS
        n = np.cos(t)[:, None] * u + np.sin(t)[:, None] * v
        return [Contact(found.a, found.b, "curved", n, c + fit.radius * n, n, 0.0,
                        axis=axis, center=c, radius=fit.radius, surface="cylinder")]
    n = -np.asarray(fit.direction, dtype=float)[None, :]
    p = np.asarray(fit.center, dtype=float)[None, :]
    return [Contact(found.a, found.b, "planar", n, p, n, 0.0)]


def _check_entry(value):
    """A cached pair result, validated (any mismatch raises: a cache miss)."""
    found, approximate, cs, count = value
    if found is not None and not isinstance(found, Interference):
        raise TypeError("not an interference")
    if not all(isinstance(c, Contact) for c in cs):
        raise TypeError("not contacts")
    return found, bool(approximate), list(cs), int(count)


def _broad_phase(asm: Assembly, geos: list[PartGeometry], tol: float, workers: int = 1
                 ) -> tuple[list[tuple[int, int, bool]], list[tuple[int, int]]]:
    """Part pairs ``(a, b, crossing)``, ``a < b``, whose distance is within the gap allowance
    ``tol + max sag_a + max sag_b``: their bounding boxes inflated by ``tol + max sag`` overlap
    (numpy), then python-fcl confirms: ``fcl.collide`` (``crossing``: the surfaces meet, touching
    included) or else ``fcl.distance``. Also returns the pairs farther apart whose boxes nest
    (one part may lie wholly inside the other).

    Before ``fcl.distance``, :func:`_apart` proves most distant pairs apart from the triangle
    boxes alone (a lower bound of the distance, so the answer is the same). With a core to
    spare of ``workers`` and at least :data:`SHARED_CONFIRMATIONS` pairs to confirm, a forked
    helper confirms every other pair (:class:`~ndbg_cli.core.pools.Helper`: the BVHs reach it
    through fork)."""
    n = len(asm)
    if n < 2:
        return [], []
    reach = np.array([tol + (g.sag.max() if len(g.sag) else 0.0) for g in geos])
    tri_box = [_tri_box(g) if len(g.lo) else None for g in geos]
    b = np.array([p.bounds for p in asm.parts])
    lo, hi = b[:, 0] - reach[:, None], b[:, 1] + reach[:, None]
    overlap = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    inside = np.all((b[:, None, 0] >= b[None, :, 0]) & (b[:, None, 1] <= b[None, :, 1]), axis=2)
    ia, ib = np.nonzero(np.triu(overlap, 1))
    candidates = list(zip(ia.tolist(), ib.tolist()))
    memos = []
    for a, _ in candidates:
        memo = _BROAD.get(geos[a])
        if memo is None:
            memo = _BROAD[geos[a]] = weakref.WeakKeyDictionary()
        memos.append(memo)
    todo = [(a, c, float(reach[a] + reach[c] - tol)) for (a, c), memo in zip(candidates, memos)
            if geos[c] not in memo]
    if todo:
        context = (asm, geos, tri_box)
        if len(todo) >= SHARED_CONFIRMATIONS and spare_workers(workers) > 0:
            with Helper(_confirmed_pair, context) as helper:
                got = helper.share(todo)
        else:
            got = [_confirmed_pair(context, x) for x in todo]
        for (a, c, _), value in zip(todo, got):
            _BROAD[geos[a]][geos[c]] = value
    out, nested = [], []
    for (a, c), memo in zip(candidates, memos):
        crossing, near = memo[geos[c]]
        if crossing or near:
            out.append((a, c, crossing))
        elif inside[a, c] or inside[c, a]:
            nested.append((a, c))
    return out, nested


#: Fewest part pairs to confirm for which :func:`_broad_phase` shares them with a helper
#: process: a confirmation costs about 0.35 ms and the helper's start (a fork of this
#: process) and exchange about 0.02 s, so half of fewer pairs saves less than it costs.
SHARED_CONFIRMATIONS = 128


def _confirmed_pair(context: tuple, item: tuple[int, int, float]) -> tuple[bool, bool]:
    """:func:`_confirmed` of ``item`` ``(a, c, allowed)``, ``context`` ``(asm, geos,
    tri_box)``: as :class:`~ndbg_cli.core.pools.Helper` calls it."""
    asm, geos, tri_box = context
    a, c, allowed = item
    return _confirmed(asm, geos, a, c, allowed, tri_box)


def _confirmed(asm: Assembly, geos: list[PartGeometry], a: int, c: int, allowed: float,
               tri_box: list) -> tuple[bool, bool]:
    """python-fcl's word on two parts whose inflated boxes meet: ``(crossing, near)``, the
    surfaces meet (touching included), else they lie within ``allowed``."""
    if meshes_intersect(asm.parts[a], asm.parts[c]):
        return True, True
    if tri_box[a] is not None and tri_box[c] is not None and _apart(
            geos[a], geos[c], tri_box[c], allowed):
        return False, False
    return False, fcl.distance(fcl_object(asm.parts[a]), fcl_object(asm.parts[c]),
                               fcl.DistanceRequest(), fcl.DistanceResult()) <= allowed


def _apart(ga: PartGeometry, gb: PartGeometry, box_b: tuple[np.ndarray, np.ndarray],
           gap: float) -> bool:
    """Whether the triangle boxes alone prove parts A and B more than ``gap`` apart (``box_b``:
    the box of B's triangles). Two triangles within ``gap`` have boxes within ``gap`` on every
    axis, so a close pair needs a triangle of A near B's box and then a triangle of B near the
    box of those; when either set is empty the distance exceeds ``gap``. Costs two numpy box
    tests, far cheaper than ``fcl.distance``."""
    sa = _near_box(ga, box_b[0] - gap, box_b[1] + gap)
    if len(sa) == 0:
        return True
    lo, hi = ga.lo[sa].min(axis=0), ga.hi[sa].max(axis=0)
    return len(_near_box(gb, lo - gap, hi + gap)) == 0


def _reach(ga: PartGeometry, gb: PartGeometry, tol: float) -> float:
    """How far apart two triangles of the pair may be and still be candidates
    (:func:`_triangle_candidates`' boxes are grown by it): ``tol`` plus both parts' largest
    chord sags, the most any pair's own allowance can be."""
    return tol + float(ga.sag.max()) + float(gb.sag.max())


def _triangle_candidates(ga: PartGeometry, gb: PartGeometry, tol: float,
                         skip_a: np.ndarray | None = None, skip_b: np.ndarray | None = None
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Triangle pairs ``(i, j)`` whose boxes, inflated by the largest possible gap allowance,
    overlap: each part's triangles near the other's box, the fewer of them querying the other
    part's triangles, grouped by query triangle (ascending) and in each group in the order the
    other part's R-tree reports its hits.

    The pairs are found by a compiled box hierarchy (the R-tree's pairs, at a third of its
    cost or less: benchmarks/NOTES.md, stop 55): the target part's, or, when some of its
    triangles are left out (``skip``: slivers whose boxes meet nearly every query), one of
    the others, so that no query lists them. They are then put in the part's R-tree order
    (:func:`_tree_rank`), except for a pair with left-out targets over
    :data:`_SUBTREE_PAIRS` query x target triangles, which takes the order of an R-tree of
    the others."""
    reach = _reach(ga, gb, tol)
    (lo_a, hi_a), (lo_b, hi_b) = _tri_box(ga), _tri_box(gb)
    sa = _near_box(ga, lo_b - reach, hi_b + reach)
    sb = _near_box(gb, lo_a - reach, hi_a + reach)
    if skip_a is not None:  # triangles of facets already in contact (coplanar_facets)
        sa = sa[~skip_a[sa]]
    if skip_b is not None:
        sb = sb[~skip_b[sb]]
    if len(sa) == 0 or len(sb) == 0:
        return sa[:0], sb[:0]
    swap = len(sa) > len(sb)
    q, qs, t, ts = (gb, sb, ga, sa) if swap else (ga, sa, gb, sb)
    skip_t = skip_a if swap else skip_b
    qlo, qhi = q.lo[qs] - reach, q.hi[qs] + reach
    skipping = skip_t is not None and bool(skip_t.any())
    if skipping and len(qs) * len(ts) > _SUBTREE_PAIRS:
        sub = box_tree(t.lo[ts], t.hi[ts])
        ids, counts = sub.intersection_v(qlo, qhi)
        rows = np.repeat(qs, np.asarray(counts, dtype=np.int64))
        cols = ts[np.asarray(ids, dtype=np.int64)]
    else:
        if skipping:  # a hierarchy of the others
            r, c = BoxHierarchy.build(t.lo[ts], t.hi[ts]).meeting(qlo, qhi)
            cols = ts[c]
        else:  # every hit is near q's box: in ts
            r, cols = t.boxes.meeting(qlo, qhi)
        # by query (as found), then in R-tree order within each query
        order = np.lexsort((_tree_rank(t)[cols], r))
        rows, cols = qs[r[order]], cols[order]
    rows, cols = rows.astype(np.int64), cols.astype(np.int64)
    return (cols, rows) if swap else (rows, cols)


def _tri_box(g: PartGeometry) -> tuple[np.ndarray, np.ndarray]:
    """The box ``(lo, hi)`` of the triangles of ``g`` (once per part geometry)."""
    box = _TRI_BOX.get(g)
    if box is None:
        box = _TRI_BOX[g] = (g.lo.min(axis=0), g.hi.max(axis=0))
    return box


def _tree_rank(g: PartGeometry) -> np.ndarray:
    """Rank ``(f,)`` of each triangle of ``g`` in the order its R-tree reports query hits.

    The R-tree (libspatialindex) walks its nodes depth first in a fixed order and skips the
    subtrees a query box misses, so any query lists its hits in the order a query covering
    everything lists all triangles. Computed once per part geometry (cheap: benchmarks/NOTES.md);
    ``tests/test_contacts.py`` checks it against the R-tree's own answers."""
    rank = _TREE_RANK.get(g)
    if rank is None:
        ids, _ = g.tree.intersection_v(np.full((1, 3), -np.inf), np.full((1, 3), np.inf))
        rank = np.empty(len(g.lo), dtype=np.int64)
        rank[np.asarray(ids, dtype=np.int64)] = np.arange(len(ids))
        _TREE_RANK[g] = rank
    return rank


def _near_box(g: PartGeometry, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices of the triangles of ``g`` whose boxes meet the box ``[lo, hi]``."""
    # one axis at a time: ``np.all(..., axis=1)`` over (f, 3) is several times slower
    near = (g.lo[:, 0] <= hi[0]) & (g.hi[:, 0] >= lo[0])
    for d in (1, 2):
        near &= g.lo[:, d] <= hi[d]
        near &= g.hi[:, d] >= lo[d]
    return np.nonzero(near)[0]


def _plane_filter(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                  tol: float) -> tuple[np.ndarray, np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """Candidate pairs ``(i, j)`` not separated by more than ``g = tol + sag_i + sag_j`` along
    either triangle's normal (the two cheapest separating axes). Also returns, for the pairs
    kept, how far (unit) B's vertices reach from A's plane and A's from B's (the largest
    absolute signed distance): :func:`ndbg_cli.contacts.features.classify_pairs` reuses them.
    A's plane is tested first, and B's only on the pairs that pass it (most candidates fail
    the first test); compiled (:mod:`ndbg_cli.kernels._triangle_kernels`)."""
    keep, off_b, off_a = loaded("_triangle_kernels").plane_filter(
        ga.triangles, ga.normals, ga.sag, gb.triangles, gb.normals, gb.sag, i, j, tol)
    return i[keep], j[keep], (off_b, off_a)


def _touching(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray, tol: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``(i, j)`` whose separation along all 11 separating axes is at most
    ``g = tol + sag_i + sag_j`` (:func:`ndbg_cli.contacts.facets.sat_gap`). Returns ``i, j, g`` of
    those touching pairs."""
    g = tol + ga.sag[i] + gb.sag[j]
    ok = sat_gap(ga.triangles[i], gb.triangles[j]) <= g
    return i[ok], j[ok], g[ok]


def _nested(asm: Assembly, nested: list[tuple[int, int]], tol: float) -> list[Interference]:
    """Interferences of part pairs whose surfaces are apart but where one part's box lies
    inside the other's: one part may sit wholly inside the other (closed parts only: the
    overlap volume decides, as in :func:`ndbg_cli.contacts.interference.interference`)."""
    out = []
    for a, b in nested:
        ma, mb = manifold_model(asm.parts[a]), manifold_model(asm.parts[b])
        if ma is None or mb is None:
            continue
        overlap = ma ^ mb
        vol, area = float(overlap.volume()), float(overlap.surface_area())
        depth = 2.0 * vol / area if area > 0 else 0.0
        if depth > tol:
            out.append(Interference(a, b, vol, depth, "volume"))
    return out


def _pair_contacts(a: int, b: int, ga: PartGeometry, gb: PartGeometry, i: np.ndarray,
                   j: np.ndarray, tol: float, ang: float,
                   offsets: tuple[np.ndarray, np.ndarray] | None = None,
                   faces: list[dict] | None = None) -> list[Contact]:
    """The contact features between parts ``a`` and ``b`` from their candidate triangle pairs
    (those passing :func:`_plane_filter`, with the plane offsets it measured). Facing pairs go
    to the planar and curved features as they are (their polygons are intersected exactly; for
    them the plane test is the separation test); the others must also pass the full
    separating-axis test. ``faces``: the planar contacts found facet by facet, whose
    triangles are not among the pairs (:func:`ndbg_cli.contacts.planar.coplanar_facets`)."""
    planar, curved = classify_pairs(ga, gb, i, j, tol, ang, offsets)
    # the curved pairs, whatever the frame: the plane filter only asks each triangle to cross
    # the other's slab, so which pairs it sees depends on the candidate boxes, which a turn
    # of the model enlarges (the engine gained a curved contact of two parts 0.39 mm apart
    # after a turn). Every pair within the boxes' reach is a candidate in any frame: the
    # pairs farther apart are dropped (those nearer, a tessellated rim's next facets, stay)
    k = np.flatnonzero(curved)
    if len(k):
        far = triangle_gap(ga.triangles[i[k]], gb.triangles[j[k]])[0] > _reach(ga, gb, tol)
        curved[k[far]] = False
    feats, used = planar_contacts(ga, gb, i[planar], j[planar], tol, ang)
    feats = list(faces or []) + feats  # the facet-level planar contacts (coplanar_facets)
    planar_used = np.zeros(len(i), dtype=bool)
    planar_used[np.nonzero(planar)[0][used]] = True
    feats += curved_contacts(ga, gb, i[curved], j[curved], ang, tol)
    # pairs with a triangle of a planar or curved contact are that contact's rim (an edge of
    # B lying on A's contact face adds no normal the face does not already give)
    in_patch = planar_used | curved
    patch_a = np.zeros(len(ga.normals), dtype=bool)
    patch_b = np.zeros(len(gb.normals), dtype=bool)
    patch_a[i[in_patch]] = True
    patch_b[j[in_patch]] = True
    rest = ~in_patch & ~patch_a[i] & ~patch_b[j]
    ri, rj, gap = _touching(ga, gb, i[rest], j[rest], tol)
    feats += edge_point_contacts(ga, gb, ri, rj, gap, ang, list(feats), tol)
    return [Contact(a=a, b=b, **{k: v for k, v in f.items() if not k.startswith("_")})
            for f in feats]


def _sort_key(c: Contact) -> tuple:
    return (c.a, c.b, c.kind, tuple(np.round(c.normals, 9).ravel()),
            tuple(np.round(c.points, 9).ravel()))


# -- report ---------------------------------------------------------------------------------


