"""Small vector helpers shared by every stage: unit vectors, cross products, a line's
sign-fixed direction, a plane's orthonormal basis, the distinct rows of an array and the pairs
of points within a distance.

Lowest of the geometry modules (numpy and scipy only): the clusterings of normals, contacts,
the NDBG builders and planning import these instead of writing their own.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def unit(v: np.ndarray) -> np.ndarray:
    """Rows (last axis) of ``v`` scaled to unit length; a zero row stays zero.

    The zero guard: a zero vector has no direction (a degenerate triangle's normal, the sum of
    two opposite normals), and returning it unchanged lets callers test ``norm > 0`` afterwards
    instead of meeting NaNs. For nonzero rows the result is ``v / np.linalg.norm(v, axis=-1)``
    to the last bit.
    """
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > 0)


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross(a, b)`` of 3-vectors (last axis; broadcast like ``np.cross``), equal to it
    to the last bit (the same products and differences in the same order), without its axis
    handling: half of ``np.cross``'s 20 us a call on the small arrays the contacts and the
    grasps pass it tens of thousands of times.

    >>> cross(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])).tolist()
    [0.0, 0.0, 1.0]
    """
    a, b = np.asarray(a), np.asarray(b)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape), dtype=np.result_type(a, b))
    np.subtract(a1 * b2, a2 * b1, out=out[..., 0])
    np.subtract(a2 * b0, a0 * b2, out=out[..., 1])
    np.subtract(a0 * b1, a1 * b0, out=out[..., 2])
    return out


def line_direction(v: np.ndarray) -> np.ndarray:
    """The unit vector of the line along ``v`` ``(k,)`` with its sign fixed: first nonzero
    component positive (``v`` and ``-v`` give the same result; a zero vector stays zero).

    >>> line_direction(np.array([0.0, -3.0, 4.0])).tolist()
    [0.0, 0.6, -0.8]
    """
    u = unit(v)
    nz = np.flatnonzero(u)
    return (-u if len(nz) and u[nz[0]] < 0 else u) + 0.0


def plane_basis(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal ``(e1, e2)`` spanning the plane orthogonal to the unit vector ``m`` ``(3,)``
    (or to each row of ``m`` ``(k, 3)``; the results have ``m``'s shape), with ``e1 x e2 = m``
    (so ``(e1, e2, m)`` is right-handed and angles measured with them turn counter-clockwise
    about ``m``).

    ``e1`` is ``m`` crossed with the coordinate axis along ``m``'s smallest component (the
    first such, on ties): that axis is at least ``acos(1 / sqrt(3))`` from ``m``, so the cross
    product never nearly vanishes.
    """
    m = np.asarray(m, dtype=float)
    helper = np.eye(3)[np.argmin(np.abs(m), axis=-1)]
    e1 = unit(cross(m, helper))
    return e1, cross(m, e1)


def unique_rows(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(first, inverse)`` of the distinct rows of ``x`` ``(n, k)`` (finite), exactly as
    ``np.unique(x, axis=0, return_index=True, return_inverse=True)`` gives them: rows in
    lexicographic order, equal meaning equal values (-0.0 == 0.0), ``first`` the lowest index
    of each. One stable lexicographic sort, several times faster than ``np.unique`` on rows."""
    order = np.lexsort(x.T[::-1])
    xs = x[order]
    new = np.ones(len(x), dtype=bool)
    new[1:] = xs[1:, 0] != xs[:-1, 0]
    for d in range(1, x.shape[1]):
        new[1:] |= xs[1:, d] != xs[:-1, d]
    inv = np.empty(len(x), dtype=np.int64)
    inv[order] = np.cumsum(new) - 1
    return order[new], inv


def close_pairs(points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """``(p, q)`` int64 ``(m,)``: the index pairs ``p < q`` of rows of ``points`` at Euclidean
    distance at most ``radius`` (a k-d tree's ``query_pairs``, in its order)."""
    pq = cKDTree(points).query_pairs(radius, output_type="ndarray")
    pq = pq.astype(np.int64).reshape(-1, 2)
    return pq[:, 0], pq[:, 1]
