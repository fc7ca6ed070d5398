"""Clustering of unit normals: one flat contact gives one normal, not one per triangle.

:func:`cluster_normals` merges unit vectors within the angular tolerance as the NDBG merges
its circles (:func:`ndbg_cli.geometry.directions.merge_directions`, without antipodes): groups by
single linkage, and a group that chained wider than the tolerance (the facet normals of a
finely tessellated cylinder, each within it of the next) cut into pieces whose members lie
within it of their mean. Each piece becomes its weighted mean direction.

Why not the greedy clusters seeded in lexicographic order used before: which normal seeds
first depends on the frame and on the sign, and a pair's normals point out of the part of
lower index, so permuting the parts flipped them and changed the contact's normals (and
with them the NDBG's regions and the finger count; issue 34). These pieces depend on the set
of normals only: ``cluster_normals(-n) = -cluster_normals(n)``, ``cluster_normals(n R^T) =
cluster_normals(n) R^T``, and the rows' order does not matter.
"""

from __future__ import annotations

import numpy as np

from .directions import merge_directions
from .vectors import unique_rows, unit


def cluster_normals(normals: np.ndarray, angle_tol: float,
                    weights: np.ndarray | None = None) -> np.ndarray:
    """Distinct unit normals ``(k, 3)`` of ``normals`` ``(n, 3)``, merged within
    ``angle_tol`` (radians) and sorted lexicographically (rounded to 1e-9) for determinism.

    Identical normals (rounded to 1e-9) are merged first, weights summed; the distinct ones
    are grouped as the module says, and each piece is replaced by its weighted mean (its
    plain mean when its weights sum to zero). Every piece's members lie within
    ``angle_tol`` of its plain mean, and normals farther apart than ``angle_tol`` from every
    other one stay apart. A zero row (a degenerate triangle's normal) is a piece of its own.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.radians([0.0, 0.1, 10.0])
    >>> cluster_normals(np.c_[np.cos(t), np.sin(t), 0 * t], np.radians(1.0)).round(3)
    array([[0.985, 0.174, 0.   ],
           [1.   , 0.001, 0.   ]])
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    if len(n) == 0:
        return n
    w = np.ones(len(n)) if weights is None else np.asarray(weights, dtype=float)
    r = np.round(n, 9) + 0.0  # + 0.0: -0.0 and 0.0 are one row
    first, inv = unique_rows(r)
    u = r[first]
    wu = np.bincount(inv, weights=w, minlength=len(u))
    index = merge_directions(u, angle_tol, antipodal=False)[1]
    k = int(index.max()) + 1
    weighted = np.zeros((k, 3))
    np.add.at(weighted, index, u * wu[:, None])
    plain = np.zeros((k, 3))
    np.add.at(plain, index, u)
    norm = np.linalg.norm(weighted, axis=1)
    out = np.where((norm > 0)[:, None], unit(weighted), unit(plain)) + 0.0
    return out[np.lexsort(np.round(out, 9).T[::-1])]


def one_cluster(normals: np.ndarray, angle_tol: float) -> bool:
    """Whether :func:`cluster_normals` gives ``normals`` ``(n, 3)`` a single normal (a flat
    side of a contact). False for no normals.

    Examples
    --------
    >>> import numpy as np
    >>> one_cluster(np.array([[0, 0, 1.0], [0, 1e-4, 1.0]]), np.radians(1.0))
    True
    """
    return len(cluster_normals(normals, angle_tol)) == 1
