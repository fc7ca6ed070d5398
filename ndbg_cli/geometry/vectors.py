"""Small vector helpers shared by every stage: unit vectors and a plane's orthonormal basis.

Lowest of the geometry modules (numpy only): contacts, the NDBG builders and planning import
these instead of writing their own.
"""

from __future__ import annotations

import numpy as np


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
    e1 = unit(np.cross(m, helper))
    return e1, np.cross(m, e1)
