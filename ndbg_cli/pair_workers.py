"""The blocked sets of many part pairs, in worker processes or not (:func:`pair_sets`).

Each pair's set (:func:`one_pair`: the pruned terms, their chart polygons and union) is a pure
function of the two parts' triangles, the tolerance and the domain, so the results do not
depend on how many workers compute them, nor on which: :func:`pair_sets` returns them in the
order asked, and the NDBG built from them is byte-identical for any ``workers``. A pool is
started only when the work is worth it (:data:`MIN_PARALLEL_PAIRS` triangle pairs); workers
leave Ctrl-C to the parent, which waits for the pairs under way before it stops.
"""

from __future__ import annotations

import signal
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import shapely

from .blocking_cones import cones_to_face_geoms, pruned_pair_cones, tri_tree

#: Fewest (moving x blocking) triangle pairs, summed over the pairs to compute, for which
#: worker processes are started (below it their start-up costs more than they save).
MIN_PARALLEL_PAIRS = 1_000_000

_STATE: dict = {}


def one_pair(tris: list[tuple[np.ndarray, np.ndarray]], trees: list, a: int, b: int,
             eps: float, domain: np.ndarray | None) -> tuple:
    """``B_ab``: ``(cones, circles, faces, seconds_cones, seconds_union)``, ``faces`` per cube
    face ``None`` or ``(union, pieces, index)`` (:func:`~ndbg_cli.blocking_cones.
    cones_to_face_geoms` without its search tree, which does not pickle). ``trees`` caches
    each part's pruning tree (``None`` until built)."""
    t0 = time.perf_counter()
    for k in (a, b):
        if trees[k] is None:
            trees[k] = tri_tree(tris[k][0])
    cones, circ = pruned_pair_cones(tris[a][0], tris[a][1], trees[a], tris[b][0], tris[b][1],
                                    trees[b], eps, domain=domain)
    t1 = time.perf_counter()
    faces = [None if e is None else (e[0], np.asarray(e[1].geometries), e[2])
             for e in cones_to_face_geoms(cones)]
    return cones, circ, faces, t1 - t0, time.perf_counter() - t1


def entries_of(faces: list) -> list:
    """The entries of :func:`~ndbg_cli.blocking_cones.cones_to_face_geoms` from
    :func:`one_pair`'s ``faces`` (the search trees built again, over the same pieces)."""
    return [None if f is None else (f[0], shapely.STRtree(f[1]), f[2]) for f in faces]


def _init(tris: list, eps: float, domain: np.ndarray | None) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    _STATE.update(tris=tris, eps=eps, domain=domain, trees=[None] * len(tris))


def _work(pair: tuple[int, int]) -> tuple:
    return one_pair(_STATE["tris"], _STATE["trees"], pair[0], pair[1], _STATE["eps"],
                    _STATE["domain"])


def pair_sets(tris: list[tuple[np.ndarray, np.ndarray]], pairs: list[tuple[int, int]],
              eps: float, domain: np.ndarray | None = None, workers: int = 1) -> list[tuple]:
    """:func:`one_pair` for each ordered pair ``(a, b)`` of ``pairs``, in that order, with
    up to ``workers`` processes (one: in this process)."""
    cost = sum(len(tris[a][0]) * len(tris[b][0]) for a, b in pairs)
    if workers <= 1 or len(pairs) < 2 or cost < MIN_PARALLEL_PAIRS:
        trees: list = [None] * len(tris)
        return [one_pair(tris, trees, a, b, eps, domain) for a, b in pairs]
    # the costliest pairs first, so that no worker is left with a long one at the end
    order = sorted(range(len(pairs)), key=lambda k: -len(tris[pairs[k][0]][0])
                   * len(tris[pairs[k][1]][0]))
    with ProcessPoolExecutor(max_workers=min(workers, len(pairs)), initializer=_init,
                             initargs=(tris, eps, domain)) as pool:
        done = list(pool.map(_work, [pairs[k] for k in order]))
    out: list = [None] * len(pairs)
    for k, r in zip(order, done):
        out[k] = r
    return out
