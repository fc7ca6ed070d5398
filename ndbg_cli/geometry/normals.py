"""Clustering of unit normals: one flat contact gives one normal, not one per triangle.

:func:`cluster_normals` groups unit vectors greedily: each cluster is seeded by the first
(lexicographically) unclustered vector and takes every remaining vector within the angular
tolerance (radians) of that seed; each cluster is replaced by its (weighted) mean direction.
Neighbours are found at once (all pairs for small sets, a k-d tree above), then the greedy pass
walks neighbour lists; the result is deterministic and independent of the input order.
"""

from __future__ import annotations

import numpy as np

from .vectors import close_pairs, unique_rows

#: Up to this many vectors, :func:`_greedy_clusters` compares all pairs and runs its greedy
#: pass directly (cheaper than a k-d tree and a component analysis at that size).
_DENSE = 32


def cluster_normals(normals: np.ndarray, angle_tol: float,
                    weights: np.ndarray | None = None) -> np.ndarray:
    """Distinct unit normals ``(k, 3)``: greedy clusters of ``normals`` ``(n, 3)`` whose members
    lie within ``angle_tol`` (radians) of the cluster's seed, each replaced by its (weighted)
    mean direction; sorted lexicographically for determinism.

    Identical normals (rounded to 1e-9) are merged first, weights summed. The greedy pass then
    takes, in lexicographic order of the distinct normals, the first one not yet clustered as a
    seed, and gives it every unclustered normal ``m`` with ``m . seed >= cos(angle_tol)``.
    The neighbours are found all at once and the pass walks lists of them
    (:func:`_greedy_clusters`): the clusters and numbers of the one-seed-at-a-time loop, which
    also never ended on a zero normal (a degenerate triangle's); that is a cluster of its own.

    Why greedy and not single linkage (:func:`ndbg_cli.geometry.sphere.merge_directions`):
    the contact tolerance is large (1 degree), and every member here lies within it of its
    seed, so one cluster spans at most twice the tolerance. Single linkage chains: the facet
    normals of a finely tessellated cylinder, each within the tolerance of the next, would
    become one normal and the contact would lose its curvature (and its constraints).
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    if len(n) == 0:
        return n
    w = np.ones(len(n)) if weights is None else np.asarray(weights, dtype=float)
    # identical normals (the triangles of one flat face) are merged first, weights summed
    r = np.round(n, 9)
    first, inv = unique_rows(r)
    out = _merge_clusters(r[first], np.bincount(inv, weights=w, minlength=len(first)),
                          np.cos(angle_tol))
    if out is None:
        # a cluster whose weighted sum is zero is reported as its seed row; rows equal but for
        # the sign of a zero are one row, and which of them np.unique keeps decides that sign
        u, inv = np.unique(r, axis=0, return_inverse=True)
        out = _merge_clusters(u, np.bincount(inv.ravel(), weights=w, minlength=len(u)),
                              np.cos(angle_tol), zero_sums=True)
    return out


def _merge_clusters(n: np.ndarray, w: np.ndarray, cos: float,
                    zero_sums: bool = False) -> np.ndarray | None:
    """The clusters of :func:`cluster_normals` over its distinct rounded normals ``n`` (in
    lexicographic order) with summed weights ``w``: their normalised weighted sums, sorted.
    ``None`` when a sum is zero and ``zero_sums`` is false (the caller then decides which of
    equal rows stands for it).

    Each cluster's members are summed in index order from +0.0 (``np.add.at``) and normalised
    by their BLAS dot product (``matmul`` of a row by a column), as ``sum(axis=0)`` and
    ``np.linalg.norm`` do one cluster at a time: the same numbers to the last bit."""
    if len(n) == 1 or (n @ n[0]).min() >= cos:
        m = w @ n
        if np.linalg.norm(m) > 0:
            return (m / np.linalg.norm(m))[None, :]
        return n[:1] if zero_sums else None
    seed, label = _greedy_clusters(n, cos)
    m = np.zeros((len(seed), 3))
    np.add.at(m, label, n * w[:, None])
    norm = np.sqrt(np.matmul(m[:, None, :], m[:, :, None])[:, 0, 0])
    if not zero_sums and not norm.all():
        return None
    out = np.where((norm > 0)[:, None], m / np.where(norm > 0, norm, 1.0)[:, None], n[seed])
    return out[np.lexsort(np.round(out, 9).T[::-1])]


def one_cluster(normals: np.ndarray, angle_tol: float) -> bool:
    """Whether :func:`cluster_normals` gives ``normals`` ``(n, 3)`` a single cluster: all the
    distinct normals lie within ``angle_tol`` (radians) of the lexicographically first, its
    own first test (when that test fails, the greedy pass opens at least two clusters)."""
    r = np.round(np.asarray(normals, dtype=float).reshape(-1, 3), 9)
    if len(r) == 0:
        return False
    n = r[unique_rows(r)[0]]  # the distinct rows in np.unique's order
    return len(n) == 1 or bool((n @ n[0]).min() >= np.cos(angle_tol))


def _greedy_clusters(n: np.ndarray, cos: float) -> tuple[np.ndarray, np.ndarray]:
    """The greedy clustering of :func:`cluster_normals` over distinct vectors ``n`` ``(k, 3)``:
    ``(seed, label)``, the seed index of each cluster (ascending: the order the greedy pass
    opens them) and each vector's cluster. A vector is always a member of its own cluster.

    Neighbours (``a . b >= cos``) are found all at once: up to :data:`_DENSE` vectors from all
    their dot products, beyond with a k-d tree on the chord length (``|a - b|^2 <= 2 max|n|^2
    - 2 cos`` when ``a . b >= cos``, padded by 1e-8) and their dot products. Pairs within 1e-12
    of ``cos`` are re-evaluated as the sequential pass does (``n @ seed``, a BLAS matrix-vector
    product), so that rounding decides borderline pairs exactly as it would there. Vectors
    without a neighbour are clusters of their own; the greedy pass then visits those with one
    in index order, over lists of neighbours (a few each: plain Python is cheapest)."""
    k = len(n)
    if k <= _DENSE:
        p, q = np.triu_indices(k, 1)
        dot = (n @ n.T)[p, q]
    else:
        big = float(np.max(np.einsum("ij,ij->i", n, n)))
        p, q = close_pairs(n, float(np.sqrt(max(2.0 * big - 2.0 * cos, 0.0) + 1e-8)))
        dot = np.einsum("ij,ij->i", n[p], n[q])
    fwd = dot >= cos  # q is within reach of seed p
    bwd = fwd.copy()  # p is within reach of seed q
    for e in np.nonzero(np.abs(dot - cos) <= 1e-12)[0].tolist():
        fwd[e] = bool((n @ n[p[e]])[q[e]] >= cos)
        bwd[e] = bool((n @ n[q[e]])[p[e]] >= cos)
    if not (fwd.any() or bwd.any()):
        return np.arange(k), np.arange(k)
    reach: dict[int, list[int]] = {}
    for x, y in zip(np.concatenate([p[fwd], q[bwd]]).tolist(),
                    np.concatenate([q[fwd], p[bwd]]).tolist()):
        reach.setdefault(x, []).append(y)
    linked = set(reach)
    for ys in reach.values():
        linked.update(ys)
    seed_of = list(range(k))
    taken = [False] * k
    for x in sorted(linked):
        if taken[x]:
            continue
        taken[x] = True
        for y in reach.get(x, ()):
            if not taken[y]:
                taken[y] = True
                seed_of[y] = x
    seed_of = np.array(seed_of)
    is_seed = seed_of == np.arange(k)
    return np.flatnonzero(is_seed), (np.cumsum(is_seed) - 1)[seed_of]
