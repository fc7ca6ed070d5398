"""The NDBG for infinitesimal translations (paper sections 4.2-4.5 and 5.1), in 2D and 3D.

Input: for every pair of parts in contact, the set ``N_ab`` of contact normals out of ``a``
into ``b``. Part ``b`` blocks ``a`` moving along ``d`` (arc ``a -> b``) iff
``max_{n in N_ab} d . n > 0``, and ``a`` blocks ``b`` iff ``min_n d . n < 0``, with the angular
tolerance ``tol`` (:data:`ANGLE_TOL_RAD`): ``d . n > tol`` is positive, ``|d . n| <= tol``
zero. ``a`` is locally free relative to ``b`` exactly in the closed convex cone
``F_ab = {d : d . n <= 0 for all n}``. 3D: regions of an arrangement of great circles
(:func:`build_ndbg_3d`); 2D: points and arcs of S^1 visited with the crossing rule
(:func:`iter_regions_2d`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence

import numpy as np

from ...core.constants import ANGLE_TOL_RAD, INFINITESIMAL
from ...geometry.directions import TWO_PI, merge_directions
from ...geometry.sphere import (
    angle_of,
    arrangement_s2,
    cluster_angles,
    cone_boundary_circles,
    free_cone_2d,
    signs,
    snap_normals,
)
from ...geometry.vectors import unit
from ..dbg import DBG
from ..model import NDBG, ConnectivityTest, Partitioning, Region, partitionings

#: A contact constraint ``(a, b, normals (k, dim))`` or ``(a, b, normals, "any" | "all")``.
PairNormals = tuple


def normalise_pairs(pairs: Iterable[PairNormals], dim: int,
                    snap_tol: float | None = None) -> list[PairNormals]:
    """Group contact normals by unordered pair into constraints ``(a, b, unit normals, mode)``
    with ``a < b`` and normals out of ``a`` into ``b`` (a reversed input pair has its normals
    negated), sorted by pair. ``mode`` is ``"any"`` (the default for 3-tuples: ``a`` penetrates
    ``b`` iff ``d . n > 0`` for some ``n``; all the ``"any"`` normals of a pair become one
    constraint) or ``"all"`` (an edge or point contact from :mod:`ndbg_cli.contacts.contacts3d`: iff
    ``d . n > 0`` for every ``n`` of that contact; kept one constraint per contact). With
    ``snap_tol`` each entry's normals (one contact) go through :func:`snap_normals` first."""
    anys: dict[tuple[int, int], list[np.ndarray]] = {}
    alls: dict[tuple[int, int], list[np.ndarray]] = {}
    for entry in pairs:
        a, b, normals = entry[:3]
        mode = entry[3] if len(entry) > 3 else "any"
        if mode not in ("any", "all"):
            raise ValueError(f"unknown blocking mode {mode!r}")
        n = unit(np.asarray(normals, dtype=float).reshape(-1, dim))
        n = n[np.linalg.norm(n, axis=1) > 0]
        if a == b or len(n) == 0:
            continue
        if snap_tol is not None and dim == 3:
            n = snap_normals(n, snap_tol)
        key, n = ((a, b), n) if a < b else ((b, a), -n)
        (anys if mode == "any" else alls).setdefault(key, []).append(n)
    out: list[PairNormals] = []
    for key in sorted(set(anys) | set(alls)):
        if key in anys:
            out.append((*key, np.vstack(anys[key]), "any"))
        out += [(*key, n, "all") for n in alls.get(key, [])]
    return out


def dbg_at(n: int, pairs: Sequence[PairNormals], d: np.ndarray,
           tol: float = ANGLE_TOL_RAD) -> DBG:
    """The DBG for direction ``d`` computed from scratch from the contact normals (entries
    ``(a, b, normals[, mode])`` as in :func:`normalise_pairs`)."""
    d = np.asarray(d, dtype=float)
    succ = [0] * n
    for entry in pairs:
        a, b, normals = entry[:3]
        dots = unit(np.asarray(normals, dtype=float).reshape(-1, len(d))) @ d
        fwd, back = blocking_sides(dots, entry[3] if len(entry) > 3 else "any", tol)
        if fwd:
            succ[a] |= 1 << b
        if back:
            succ[b] |= 1 << a
    return DBG(tuple(succ))


def blocking_sides(dots: np.ndarray, mode: str, tol) -> tuple[np.ndarray, np.ndarray]:
    """Whether a contact pair ``(a, b)`` blocks ``a`` (``fwd``: ``b`` in the way) and ``b``
    (``back``), from ``dots`` ``(..., k)``: its ``k`` unit normals (out of ``a``) dotted with a
    direction. ``"any"``: one normal facing the motion by more than ``tol`` blocks; ``"all"``
    (a curved contact's facets): every one must. ``tol`` (radians, about) is a scalar or
    broadcasts against ``dots.shape[:-1]``."""
    if mode == "all":
        return dots.min(axis=-1) > tol, dots.max(axis=-1) < -tol
    return dots.max(axis=-1) > tol, dots.min(axis=-1) < -tol


def _direction(v) -> tuple[float, ...]:
    """A representative direction as a tuple, with rounding noise below 1e-12 set to zero."""
    v = np.asarray(v, dtype=float).copy()
    v[np.abs(v) < 1e-12] = 0.0
    return tuple(float(x) for x in v / np.linalg.norm(v))


def _stats(regions: Sequence[Region], **extra) -> dict:
    counts: dict[str, int] = {}
    for r in regions:
        counts[str(r.dimension)] = counts.get(str(r.dimension), 0) + 1
    distinct = len({r.dbg.succ for r in regions})
    return {"regions_by_dimension": counts, "regions": len(regions),
            "distinct_dbgs": distinct, **extra}


# -- 3D --------------------------------------------------------------------------------------

def build_ndbg_3d(ids: Sequence[str], pairs: Iterable[PairNormals], *,
                  tol: float = ANGLE_TOL_RAD, refine: bool = True) -> NDBG:
    """The 3D NDBG for infinitesimal translations from per-pair contact normals.

    ``ids`` are the part ids (node order); ``pairs`` yields ``(a, b, normals)`` with part
    indices and ``(k, 3)`` normals out of ``a`` into ``b``. Regions: every vertex, edge and
    face of the arrangement, in that order, each with its DBG.

    The arrangement is that of the great circles ``n . d = 0`` on S^2
    (:mod:`ndbg_cli.geometry.sphere`; normals merged within ``tol``, ``n`` and ``-n`` one
    circle). With ``refine`` only the circles needed to bound every ``F_ab`` are drawn (the
    paper's refinement, :func:`~ndbg_cli.geometry.sphere.cone_boundary_circles`; a peg in a
    facetted hole gives 2 circles, not one per facet); a pair with ``"all"`` contacts (edge and
    point contacts) keeps all its circles; with ``refine=False`` every normal's circle is
    drawn (exact by sign constancy). Each region's DBG is computed from *all* the normals at
    its representative direction.

    Exactness of the refinement: ``F_ab`` and ``-F_ab`` are unions of regions of the kept
    circles' arrangement (each boundary point of ``F_ab`` lies on a kept circle and its
    isolated points are vertices), and pair ``(a, b)``'s arcs depend on ``d`` only through
    ``d in F_ab`` and ``d in -F_ab``; so the DBG is constant on every region. (A connected
    region meeting both ``F`` and its complement contains a boundary point ``p`` of ``F``; the
    constraints violated near ``p`` are tight at ``p``, so their circles pass through ``p`` and
    cut the region, which has constant signs on kept circles: contradiction.)
    """
    n = len(ids)
    groups = normalise_pairs(pairs, 3, snap_tol=tol)
    ends = sorted({(g[0], g[1]) for g in groups})
    if not groups:
        region = Region(2, (0.0, 0.0, 1.0), DBG.empty(n))
        return NDBG(INFINITESIMAL, tuple(ids), (region,), 3,
                    _stats([region], circles=0, normals=0, pairs=0, angle_tolerance=tol,
                           refined=refine), geometry=arrangement_s2(np.zeros((0, 3)), tol))
    pair_index = {e: k for k, e in enumerate(ends)}
    group_pair = np.array([pair_index[(g[0], g[1])] for g in groups])
    group_all = np.array([g[3] == "all" for g in groups])
    all_n = np.vstack([g[2] for g in groups])
    group_of = np.repeat(np.arange(len(groups)), [len(g[2]) for g in groups])
    circles, idx, sgn = merge_directions(all_n, tol)
    # Distinct merged normals per constraint group: (group, circle, sign).
    key = np.unique(np.column_stack([group_of, idx, sgn]), axis=0)
    kg, kc, ks = key[:, 0], key[:, 1], key[:, 2]
    merged = circles[kc] * ks[:, None]
    starts = np.flatnonzero(np.r_[True, kg[1:] != kg[:-1]])
    stops = np.r_[starts[1:], len(kg)]
    pair_starts = np.flatnonzero(np.r_[True, group_pair[1:] != group_pair[:-1]])
    if refine:
        used: set[int] = set()
        cache: dict[bytes, set[int]] = {}  # identical joints (same merged normals) share
        for g0, g1 in zip(pair_starts.tolist(), np.r_[pair_starts[1:], len(groups)].tolist()):
            if g1 - g0 == 1 and not group_all[g0]:
                s0, s1 = starts[g0], stops[g0]
                key_g = key[s0:s1, 1:].tobytes()
                if key_g not in cache:
                    cache[key_g] = cone_boundary_circles(merged[s0:s1], kc[s0:s1], tol)
                used |= cache[key_g]
            else:  # "all" constraints: keep every circle of the pair (sign-constant cells)
                used |= set(kc[starts[g0]:stops[g1 - 1]].tolist())
        keep = np.array(sorted(used), dtype=np.int64)
    else:
        keep = np.arange(len(circles))
    arr = arrangement_s2(circles[keep], tol)
    dims, reps = arr.representatives()
    drawn = _region_signs(arr, reps)
    pos = np.full(len(circles), -1, dtype=np.int64)
    pos[keep] = np.arange(len(keep))
    on_drawn = pos[kc] >= 0
    off_circ, off_inv = np.unique(kc[~on_drawn], return_inverse=True)
    ab = np.zeros((len(reps), len(ends)), dtype=bool)
    ba = np.zeros_like(ab)
    chunk = max(1, 4_000_000 // max(1, len(merged)))  # bounds the sign matrix
    for r0 in range(0, len(reps), chunk):
        rows = slice(r0, r0 + chunk)
        # Signs of d . n: combinatorial on drawn circles (zero exactly on incident ones),
        # the tolerance test on the circles the refinement left out.
        val = np.empty((len(reps[rows]), len(kc)), dtype=np.int8)
        val[:, on_drawn] = drawn[rows][:, pos[kc[on_drawn]]]
        val[:, ~on_drawn] = signs(reps[rows], circles[off_circ], tol)[:, off_inv]
        val *= ks.astype(np.int8)
        hi = np.maximum.reduceat(val, starts, axis=1)
        lo = np.minimum.reduceat(val, starts, axis=1)
        fwd = np.where(group_all, lo > 0, hi > 0)
        back = np.where(group_all, hi < 0, lo < 0)
        ab[rows] = np.logical_or.reduceat(fwd, pair_starts, axis=1)
        ba[rows] = np.logical_or.reduceat(back, pair_starts, axis=1)
    graphs = _dbgs_from_blocking(n, ends, ab, ba)
    reps = reps.copy()
    reps[np.abs(reps) < 1e-12] = 0.0
    reps = unit(reps)
    regions = tuple(Region(dm, tuple(d), g)
                    for dm, d, g in zip(dims.tolist(), reps.tolist(), graphs))
    stats = _stats(regions, circles=int(len(keep)), circles_total=int(len(circles)),
                   normals=int(len(all_n)), pairs=len(ends), angle_tolerance=tol,
                   refined=refine, arrangement_circles=arr.circles.tolist())
    return NDBG(INFINITESIMAL, tuple(ids), regions, 3, stats, geometry=arr)


def _region_signs(arr, reps: np.ndarray) -> np.ndarray:
    """Sign vectors of the regions over the arrangement's circles, combinatorially exact:
    zero on the circles incident to the region (a vertex's circles, an edge's circle), the
    strict sign of ``d . m`` elsewhere (regions are open cells, away from other circles)."""
    out = signs(reps, arr.circles, 0.0)
    nv = len(arr.vertices)
    if nv:
        rows = np.repeat(np.arange(nv), [len(c) for c in arr.vertex_circles])
        cols = np.array([c for vc in arr.vertex_circles for c in vc], dtype=np.int64)
        out[rows, cols] = 0
    ne = len(arr.edge_mid)
    if ne:
        out[nv + np.arange(ne), arr.edge_circle] = 0
    return out


def _dbgs_from_blocking(n: int, ends: Sequence[tuple[int, int]], ab: np.ndarray,
                        ba: np.ndarray) -> list[DBG]:
    """One DBG per row of the blocking matrices (``ab[r, p]``: arc ``a_p -> b_p``), built once
    per distinct row."""
    full = np.hstack([ab, ba])
    packed = np.packbits(full, axis=1)
    seen: dict[bytes, int] = {}
    inverse, rep_rows = [], []
    for r, row in enumerate(packed):
        key = row.tobytes()
        k = seen.get(key)
        if k is None:
            k = seen[key] = len(rep_rows)
            rep_rows.append(r)
        inverse.append(k)
    rows = full[rep_rows]
    p = len(ends)
    a_arr = [e[0] for e in ends]
    b_arr = [e[1] for e in ends]
    built = []
    for row in rows:
        succ = [0] * n
        for q in np.flatnonzero(row[:p]).tolist():
            succ[a_arr[q]] |= 1 << b_arr[q]
        for q in np.flatnonzero(row[p:]).tolist():
            succ[b_arr[q]] |= 1 << a_arr[q]
        built.append(DBG(tuple(succ)))
    return [built[i] for i in inverse]


# -- 2D --------------------------------------------------------------------------------------

def _pairs_2d(pairs: Iterable[PairNormals], tol: float) -> list[PairNormals]:
    """Normalised pairs with each pair's normals merged within ``tol`` (2D unit rows)."""
    out = []
    for a, b, normals, mode in normalise_pairs(pairs, 2):
        if mode != "any":
            raise ValueError("2D contacts block with 'any' normals only")
        dirs, _, _ = merge_directions(normals, tol, antipodal=False)
        out.append((a, b, dirs))
    return out


def iter_regions_2d(n: int, pairs: Iterable[PairNormals], *,
                    tol: float = ANGLE_TOL_RAD) -> Iterator[Region]:
    """The regular regions of S^1 in counter-clockwise order with their DBGs, computed one
    after the other with the crossing rule (paper section 4.5).

    The sequence starts at the cone-boundary point of smallest angle in ``[0, 2 pi)`` and
    alternates point, open arc, point, ...; without any boundary point (no contact, or every
    pair blocked in all directions) it is the whole circle, one closed 1D region. Each
    contact normal ``n`` of pair ``(a, b)`` is an arc weight of ``a -> b`` on the open half
    circle where ``d . n > 0`` and of ``b -> a`` on the opposite one; weights change only at
    the diameters orthogonal to the normals, and the DBG (arcs of positive weight) only at
    the cone-boundary diameters (at most two per pair: the paper's ``O(r)`` refinement). Each
    normal is touched twice; as a generator it lets later stages stream the regions.
    """
    prs = _pairs_2d(pairs, tol)
    # Directed weight entries: (arc index q = 2 p (a->b) or 2 p + 1 (b->a), angle of normal).
    q_list, phi_list, boundary_angles = [], [], []
    for p, (_a, _b, normals) in enumerate(prs):
        phi = angle_of(normals)
        q_list += [2 * p] * len(phi) + [2 * p + 1] * len(phi)
        phi_list += list(phi) + list(phi + np.pi)
        for i in free_cone_2d(normals, tol).boundary:
            boundary_angles += [phi[i] + np.pi / 2, phi[i] - np.pi / 2]
    if not boundary_angles:
        dbg = dbg_at(n, prs, np.array([1.0, 0.0]), tol)
        yield Region(1, (1.0, 0.0), dbg)
        return
    q_arr = np.array(q_list, dtype=np.int64)
    phi_arr = np.array(phi_list)
    m = len(q_arr)
    # Every weight's open positive half circle (phi - pi/2, phi + pi/2): enter, then leave.
    centres, label = cluster_angles(np.r_[phi_arr - np.pi / 2, phi_arr + np.pi / 2,
                                          np.array(boundary_angles)], tol)
    c = len(centres)
    enter, leave = label[:m], label[m:2 * m]
    refined = np.zeros(c, dtype=bool)
    refined[label[2 * m:]] = True
    ref_idx = np.flatnonzero(refined)
    s0 = int(ref_idx[0])
    # Weights just at the start point: entries whose open interval strictly contains it.
    inside = ((s0 - enter) % c > 0) & ((s0 - enter) % c < (leave - enter) % c)
    weight = np.bincount(q_arr[inside], minlength=2 * len(prs)).tolist()
    ends = [(a, b) for a, b, _ in prs]
    succ = [0] * n
    for q, w in enumerate(weight):
        if w:
            a, b = ends[q // 2]
            succ[a if q % 2 == 0 else b] |= 1 << (b if q % 2 == 0 else a)
    enters: list[list[int]] = [[] for _ in range(c)]
    leaves: list[list[int]] = [[] for _ in range(c)]
    for e, (ce, cl) in enumerate(zip(enter.tolist(), leave.tolist())):
        enters[ce].append(int(q_arr[e]))
        leaves[cl].append(int(q_arr[e]))

    def bump(q: int, delta: int) -> None:
        # The crossing rule: add or retract 1; an arc exists while its weight is positive.
        a, b = ends[q // 2]
        i, j = (a, b) if q % 2 == 0 else (b, a)
        weight[q] += delta
        if weight[q] == 0:
            succ[i] &= ~(1 << j)
        elif weight[q] == 1 and delta > 0:
            succ[i] |= 1 << j

    next_ref = {int(r): int(ref_idx[(k + 1) % len(ref_idx)]) for k, r in enumerate(ref_idx)}
    for step in range(c):
        t = (s0 + step) % c
        if step > 0:
            for q in leaves[t]:
                bump(q, -1)
        if refined[t]:
            ang = centres[t]
            yield Region(0, _direction([np.cos(ang), np.sin(ang)]), DBG(tuple(succ)))
        for q in enters[t]:
            bump(q, +1)
        if refined[t]:
            nxt = next_ref[t]
            end = centres[nxt] if nxt != t else centres[t] + TWO_PI
            if end <= centres[t]:
                end += TWO_PI
            mid = 0.5 * (centres[t] + end)
            yield Region(1, _direction([np.cos(mid), np.sin(mid)]), DBG(tuple(succ)))


def build_ndbg_2d(ids: Sequence[str], pairs: Iterable[PairNormals], *,
                  tol: float = ANGLE_TOL_RAD) -> NDBG:
    """The 2D NDBG for infinitesimal translations: every region of :func:`iter_regions_2d`."""
    prs = _pairs_2d(pairs, tol)
    regions = tuple(iter_regions_2d(len(ids), prs, tol=tol))
    # Boundary points come in antipodal pairs, one pair per diameter.
    diameters = sum(1 for r in regions if r.dimension == 0) // 2
    lines = [[-r.direction[1], r.direction[0]] for r in regions if r.dimension == 0]
    stats = _stats(regions, diameters=diameters, arrangement_circles=lines[:diameters],
                   normals=int(sum(len(p[2]) for p in prs)), pairs=len(prs),
                   angle_tolerance=tol, refined=True)
    return NDBG(INFINITESIMAL, tuple(ids), regions, 2, stats)


# -- assemblies --------------------------------------------------------------------------------

def contact_pairs(asm, contacts=None) -> list[PairNormals]:
    """Per-pair contact normals of an assembly as ``(a, b, normals)`` with part indices.

    2D: from :func:`ndbg_cli.contacts.contacts2d.find_contacts_2d`; 3D: from
    ``ndbg_cli.contacts.contacts3d.analyze_contacts(asm).normals_by_pair()`` (keys may be part ids
    or indices). ``contacts`` may be given: a list of ``Contact2D`` or a ``ContactAnalysis``.
    """
    if asm.dimension == 2:
        from ...contacts.contacts2d import find_contacts_2d

        found = find_contacts_2d(asm) if contacts is None else contacts
        return [(c.a, c.b, c.normals) for c in found]
    if contacts is None:
        from ...contacts.contacts3d import analyze_contacts  # type: ignore[import-not-found]

        contacts = analyze_contacts(asm)
    out: list[PairNormals] = []
    for c in contacts.contacts:
        ia = asm.index(c.a) if isinstance(c.a, str) else int(c.a)
        ib = asm.index(c.b) if isinstance(c.b, str) else int(c.b)
        out.append((ia, ib, np.asarray(c.normals, dtype=float), getattr(c, "blocking", "any")))
    return out


def infinitesimal_ndbg(asm, contacts=None, *, tol: float | None = None,
                       refine: bool = True) -> NDBG:
    """The NDBG for infinitesimal translations of an :class:`~ndbg_cli.core.assembly.Assembly`.

    ``tol`` (radians) defaults, in 3D, to the contact analysis' own ``angle_tolerance`` (its
    normals are already clustered at that tolerance and carry tessellation noise of that
    order: AS1's cylinder normals lean up to 0.09 degrees off their axis' plane), and in 2D
    (exact polygon edges) to :data:`ANGLE_TOL_RAD`.
    """
    if asm.dimension == 2:
        pairs = contact_pairs(asm, contacts)
        return build_ndbg_2d(asm.ids, pairs, tol=ANGLE_TOL_RAD if tol is None else tol)
    if contacts is None:
        from ...contacts.contacts3d import analyze_contacts

        contacts = analyze_contacts(asm)
    if tol is None:
        tol = float(getattr(contacts, "angle_tolerance", ANGLE_TOL_RAD))
    pairs = contact_pairs(asm, contacts)
    return build_ndbg_3d(asm.ids, pairs, tol=tol, refine=refine)


def locate_region(ndbg: NDBG, d: Sequence[float]) -> int:
    """Index of the region of ``ndbg`` containing the direction ``d``: the region with the same
    sign vector over the drawn great circles (3D) or diameters (2D), ``stats
    ["arrangement_circles"]`` (their unit normals), using the NDBG's angular tolerance.
    ``-1`` if there is none (``d`` within the tolerance of a circle but off every region)."""
    tol = ndbg.stats.get("angle_tolerance", ANGLE_TOL_RAD)
    circles = np.asarray(ndbg.stats.get("arrangement_circles", []), dtype=float)
    if len(circles) == 0:
        return 0 if len(ndbg.regions) == 1 else -1
    reps = np.array([r.direction for r in ndbg.regions])
    want = signs(unit(np.asarray(d, dtype=float)[None]), circles, tol)[0]
    hits = np.flatnonzero((signs(reps, circles, tol) == want).all(axis=1))
    return int(hits[0]) if len(hits) else -1


def contact_graph(ndbg: NDBG) -> list[int]:
    """Neighbour bitmasks of the contact graph, recovered from the NDBG: two parts in contact
    block each other in some direction, so they share an arc in some region's DBG."""
    nb = [0] * ndbg.n
    for g, _ in ndbg.distinct():
        for i, j in g.arcs():
            nb[i] |= 1 << j
            nb[j] |= 1 << i
    return nb


def candidate_partitionings(ndbg: NDBG, mask: int | None = None, *,
                            max_partitions: int | None = None, connected: bool = False,
                            contacts: Iterable[tuple[int, int]] | None = None
                            ) -> tuple[list[Partitioning], bool]:
    """Candidate partitionings (paper 4.4) of ``mask`` (default: the whole assembly): every
    ``(moved, rest)`` with ``moved`` locally free along some region. ``max_partitions`` caps
    the number; ``connected`` keeps only those with both sides connected in the contact
    graph, given by ``contacts`` (part index pairs, e.g. ``ContactAnalysis.pairs()``) or else
    recovered from the NDBG (:func:`contact_graph`). Returns ``(partitionings, truncated)``,
    sorted by (size of ``moved``, ``moved``)."""
    test = None
    if connected:
        if contacts is None:
            nb = contact_graph(ndbg)
        else:
            nb = [0] * ndbg.n
            for i, j in contacts:
                nb[i] |= 1 << j
                nb[j] |= 1 << i
        test = ConnectivityTest(nb)
    return partitionings(ndbg, mask, limit=max_partitions, connected=test)


# -- report ------------------------------------------------------------------------------------


