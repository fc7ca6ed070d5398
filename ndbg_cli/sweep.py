"""A direct, per-direction test of blocking for infinite translations, independent of the
arrangement in :mod:`ndbg_cli.infinite` (it shares no code with it).

``P_j`` blocks ``P_i`` along ``d`` when some ray parallel to ``d`` leaves ``P_i`` and then
enters ``P_j``: a triangle of ``P_i`` facing ``d`` (``n_i . d > 0``) and a triangle of ``P_j``
facing against it (``n_j . d < 0``) overlap with positive area in the orthographic projection
along ``d``, and somewhere in the overlap ``t_j`` is not behind ``t_i`` (depth difference
``z_j - z_i > -eps``; 0 for a face contact crossed transversally). A direction parallel to a
contact face (``|n . d| <= FACING_TOL``) does not cross it: sliding does not block.

Cost per direction: every front triangle of ``P_i`` against every back triangle of ``P_j``
after a bounding-box cull; fine for tests and single queries (``ndbg query --direction``),
not for sweeping thousands of directions over large meshes.
"""

from __future__ import annotations

import numpy as np
import shapely

from .assembly import Assembly
from .dbg import DBG, bits

#: ``|n . d|`` below this counts as parallel (a sliding direction), for unit ``n`` and ``d``.
FACING_TOL = 1e-9


def _frame(d: np.ndarray) -> np.ndarray:
    """Orthonormal rows ``(u, v, d)`` for a unit ``d``."""
    d = np.asarray(d, dtype=float)
    d = d / np.linalg.norm(d)
    a = np.eye(3)[np.argmin(np.abs(d))]
    u = np.cross(d, a)
    u /= np.linalg.norm(u)
    return np.array([u, np.cross(d, u), d])


class SweepChecker:
    """Per-part triangles prepared once; :meth:`blocked` and :meth:`dbg` per direction."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        self.eps = asm.length_tolerance
        # the same triangles as the builder (2D parts extruded); the test itself is separate
        from .blocking_cones import part_triangles

        tn = part_triangles(asm)
        self.tris: list[np.ndarray] = [t for t, _ in tn]
        self.normals: list[np.ndarray] = [n for _, n in tn]
        # each part's bounding-box corners (8, 3): a quick miss in projection
        self._corners = []
        for t in self.tris:
            lo, hi = t.reshape(-1, 3).min(axis=0), t.reshape(-1, 3).max(axis=0)
            self._corners.append(np.array([[(lo, hi)[a][0], (lo, hi)[b][1], (lo, hi)[c][2]]
                                           for a in (0, 1) for b in (0, 1) for c in (0, 1)]))

    def blocked(self, i: int, j: int, d: np.ndarray) -> bool:
        """Whether part ``j`` blocks the infinite translation of part ``i`` along ``d``."""
        frame = _frame(np.asarray(d, dtype=float)[:3] if len(d) == 3 else
                       np.array([d[0], d[1], 0.0]))
        dd = frame[2]
        # the parts' boxes seen along d: apart (or j wholly behind i), no ray meets both
        ci, cj = self._corners[i] @ frame.T, self._corners[j] @ frame.T
        if np.any(ci[:, :2].min(axis=0) >= cj[:, :2].max(axis=0)) \
                or np.any(cj[:, :2].min(axis=0) >= ci[:, :2].max(axis=0)) \
                or cj[:, 2].max() <= ci[:, 2].min() - self.eps:
            return False
        ti, tj = self.tris[i], self.tris[j]
        fi = ti[self.normals[i] @ dd > FACING_TOL]
        bj = tj[self.normals[j] @ dd < -FACING_TOL]
        if not len(fi) or not len(bj):
            return False
        pi = fi @ frame.T  # (a, 3, 3): u, v, z
        pj = bj @ frame.T
        if pj[:, :, 2].max() <= pi[:, :, 2].min() - self.eps:
            return False
        lo_i, hi_i = pi[:, :, :2].min(axis=1), pi[:, :, :2].max(axis=1)
        lo_j, hi_j = pj[:, :, :2].min(axis=1), pj[:, :, :2].max(axis=1)
        zmin_i = pi[:, :, 2].min(axis=1)
        zmax_j = pj[:, :, 2].max(axis=1)
        tiny = 1e-9 * max(self.asm.diagonal, 1e-300)
        for s in range(0, len(pi), 256):
            a = slice(s, s + 256)
            ov = ((lo_i[a, None, :] < hi_j[None, :, :] - tiny)
                  & (lo_j[None, :, :] < hi_i[a, None, :] - tiny)).all(axis=2)
            ov &= zmax_j[None, :] > zmin_i[a, None] - self.eps
            ia, jb = np.nonzero(ov)
            if not len(ia):
                continue
            ia = ia + s
            if self._pairs_block(pi[ia], pj[jb]):
                return True
        return False

    def _pairs_block(self, pi: np.ndarray, pj: np.ndarray) -> bool:
        """Projected triangle pairs ``(k, 3, 3)`` (u, v, z): does any pair overlap with positive
        area while ``t_j`` is not behind ``t_i`` somewhere in the overlap?"""
        ga = shapely.polygons(pi[:, :, :2])
        gb = shapely.polygons(pj[:, :, :2])
        inter = shapely.intersection(ga, gb)
        area = shapely.area(inter)
        amin = (1e-6 * self.asm.diagonal) ** 2
        keep = np.nonzero(area > amin)[0]
        if not len(keep):
            return False
        coords, idx = shapely.get_coordinates(inter[keep], return_index=True)
        f = _plane_depth(pj[keep][idx], coords) - _plane_depth(pi[keep][idx], coords)
        tau = 1e-3 * self.eps
        fmax = np.full(len(keep), -np.inf)
        np.maximum.at(fmax, idx, f)
        for k in np.nonzero(fmax > -tau)[0]:
            # Area of the part of the overlap where t_j is not behind t_i (f >= -tau): a
            # single touching point or edge has none; a crossed face contact has all of it.
            sel = idx == k
            if _clipped_area(coords[sel], f[sel] + tau) > self.eps ** 2:
                return True
        return False

    def frees(self, moved: int, rest: int, d: np.ndarray) -> bool:
        """Whether the parts of bitmask ``moved`` translate to infinity along ``d`` without
        meeting the interior of any part of bitmask ``rest``."""
        rs = list(bits(rest))
        return not any(self.blocked(i, j, d) for i in bits(moved) for j in rs)

    def dbg(self, d: np.ndarray) -> DBG:
        """The DBG for infinite translation along ``d``: arc ``i -> j`` iff ``j`` blocks ``i``."""
        n = len(self.tris)
        return DBG.from_arcs(n, [(i, j) for i in range(n) for j in range(n)
                                 if i != j and self.blocked(i, j, d)])


def _clipped_area(pts: np.ndarray, f: np.ndarray) -> float:
    """Area of the polygon ``pts`` ``(k, 2)`` (closed ring, from shapely) where the affine
    function with vertex values ``f`` is non-negative (Sutherland-Hodgman on one line)."""
    out = []
    m = len(pts)
    for a in range(m):
        b = (a + 1) % m
        if f[a] >= 0:
            out.append(pts[a])
        if (f[a] >= 0) != (f[b] >= 0):
            w = f[a] / (f[a] - f[b])
            out.append(pts[a] + w * (pts[b] - pts[a]))
    if len(out) < 3:
        return 0.0
    q = np.asarray(out)
    x, y = q[:, 0], q[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def _plane_depth(tri: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Depth ``z`` at points ``uv`` ``(k, 2)`` of the planes of projected triangles ``(k, 3, 3)``
    (barycentric interpolation of the vertex depths; the triangles are not edge-on)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b[:, :2] - a[:, :2], c[:, :2] - a[:, :2]
    r = uv - a[:, :2]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    det = np.where(det == 0, 1e-300, det)
    w1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
    w2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    return a[:, 2] + w1 * (b[:, 2] - a[:, 2]) + w2 * (c[:, 2] - a[:, 2])


def blocked(asm: Assembly, i: int, j: int, d: np.ndarray) -> bool:
    """Whether part ``j`` blocks the infinite translation of part ``i`` along direction ``d``
    (a 3-vector; in 2D a 2-vector). Builds a :class:`SweepChecker`; reuse one for many calls."""
    return SweepChecker(asm).blocked(i, j, np.asarray(d, dtype=float))


def dbg_at(asm: Assembly, d: np.ndarray) -> DBG:
    """The DBG of ``asm`` for infinite translation along ``d``, computed directly."""
    return SweepChecker(asm).dbg(np.asarray(d, dtype=float))
