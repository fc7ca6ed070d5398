"""The blocked sets of many part pairs, by a :class:`~ndbg_cli.core.pools.Mapper`
(:func:`pair_sets`).

Each pair's set (:func:`one_pair`: the pruned terms, their chart polygons and union) is a pure
function of the two parts' triangles, the tolerance and the domain, so the results do not
depend on how many workers compute them, nor on which, nor where (forked processes here, a
dask cluster), and the NDBG built from them is byte-identical for any. Forked workers are
started only when the work is worth it (:data:`MIN_PARALLEL_PAIRS` triangle pairs).
"""

from __future__ import annotations

import time
from collections.abc import Iterator

import numpy as np
import shapely

from ...core.pools import IN_PROCESS, Mapper
from .blocking_cones import pruned_pair_cones
from .chart_union import antipodal, cones_to_face_geoms, cut_to_domain
from .domain import domain_polygons, domain_windows
from .tritree import LEAF, tri_tree

#: Fewest (moving x blocking) triangle pairs, summed over the pairs to compute, for which
#: worker processes are started (below it their start-up costs more than they save).
MIN_PARALLEL_PAIRS = 1_000_000
#: Leaf size of the triangle trees with a domain (the NDBG restricted to small caps): larger
#: leaves than on the whole sphere, since most of a leaf pair's terms are then dropped by
#: the cheap window tests before their facets are computed, and fewer node pairs are tested
#: (benchmarks/NOTES.md). The whole sphere keeps :data:`~ndbg_cli.ndbg.infinite.tritree.LEAF`.
DOMAIN_LEAF = 16


def one_pair(tris: list[tuple[np.ndarray, np.ndarray]], trees: list, a: int, b: int,
             eps: float, domain: np.ndarray | None, dom: list | None = None,
             memo: list | None = None) -> tuple:
    """``B_ab``: ``(cones, circles, faces, seconds_cones, seconds_union, cuts)``, ``faces`` as
    :func:`~ndbg_cli.ndbg.infinite.chart_union.cones_to_face_geoms` gives them. ``trees`` caches
    each part's pruning tree (``None`` until built). With ``dom`` (the domain's polygons per face,
    :func:`~ndbg_cli.ndbg.infinite.domain.domain_polygons`), ``cuts`` holds per face the memo of
    :func:`~ndbg_cli.ndbg.infinite.chart_union.cut_to_domain` for the faces of ``B_ab`` and
    ``B_ba``: what the caller would cut next, made here in parallel (else empty dicts); ``memo``
    (per face a dict, kept by the caller over its pairs) holds the cuts made so far. Only the even
    faces' cuts are made (the domain is symmetric under ``d -> -d``: the odd faces' are their
    images, :func:`~ndbg_cli.ndbg.infinite.blocked_sets.blocked_sets`)."""
    t0 = time.perf_counter()
    for k in (a, b):
        if trees[k] is None:
            trees[k] = tri_tree(tris[k][0], LEAF if domain is None else DOMAIN_LEAF)
    pieces: list = []
    cones, circ = pruned_pair_cones(tris[a][0], tris[a][1], trees[a], tris[b][0], tris[b][1],
                                    trees[b], eps, domain=domain, pieces=pieces)
    t1 = time.perf_counter()
    # with a domain only its part of the sets is used: the unions are made in its windows,
    # from the pieces the walk clipped to them
    faces = cones_to_face_geoms(cones, None if domain is None else domain_windows(domain),
                                pieces or None)
    cuts: list[dict] = [{} for _ in range(6)]
    if dom is not None:
        memo = memo if memo is not None else [{} for _ in range(6)]
        # the caller cuts the sets on the even faces only, B_ab's and B_ba's (the antipodal
        # image of B_ab's on the odd face), and maps the cuts onto the odd faces
        for face, e in enumerate(faces):
            even = face & ~1
            if e is not None and dom[even] is not None:
                g = e[0] if face == even else antipodal(e[0])
                key = shapely.to_wkb(g)
                cuts[even][key] = cut_to_domain(g, dom[even], memo[even], key)
    return cones, circ, faces, t1 - t0, time.perf_counter() - t1, cuts


def _pair_blocked_sets(context: tuple, pair: tuple[int, int]) -> tuple:
    """:func:`one_pair` of ``pair``, as :func:`pair_sets`'s mapper computes it: ``context`` is
    ``(tris, eps, domain, dom, trees, memo)``, the last two caches filled per process."""
    tris, eps, domain, dom, trees, memo = context
    return one_pair(tris, trees, pair[0], pair[1], eps, domain, dom, memo)


def pair_sets(tris: list[tuple[np.ndarray, np.ndarray]], pairs: list[tuple[int, int]],
              eps: float, domain: np.ndarray | None = None, mapper: Mapper = IN_PROCESS,
              dom: list | None = None) -> Iterator[tuple[int, tuple]]:
    """:func:`one_pair` for each ordered pair ``(a, b)`` of ``pairs``, as ``(k, result)`` for
    ``pairs[k]``, each as soon as it is done (so that a caller can cache it), computed by
    ``mapper`` (:class:`~ndbg_cli.core.pools.Mapper`; default: in this process, in order).
    ``dom``: the domain's polygons (:func:`~ndbg_cli.ndbg.infinite.domain.domain_polygons`)
    when the caller has them, else made here."""
    cost = sum(len(tris[a][0]) * len(tris[b][0]) for a, b in pairs)
    if dom is None and domain is not None:
        dom = domain_polygons(domain)
    # the costliest pairs first, so that no worker is left with a long one at the end
    order = sorted(range(len(pairs)), key=lambda k: -len(tris[pairs[k][0]][0])
                   * len(tris[pairs[k][1]][0]))
    context = (tris, eps, domain, dom, [None] * len(tris), [{} for _ in range(6)])
    yield from mapper.imap(_pair_blocked_sets, context, pairs, order,
                           small=cost < MIN_PARALLEL_PAIRS)
