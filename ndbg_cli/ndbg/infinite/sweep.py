"""A direct, per-direction test of blocking for infinite translations, independent of the
arrangement in :mod:`ndbg_cli.ndbg.infinite.build` (it shares no code with it).

``P_j`` blocks ``P_i`` along ``d`` when a triangle of ``P_i`` facing ``d`` (``n_i . d > 0``)
and a triangle of ``P_j`` facing against it (``n_j . d < 0``) overlap with positive area in
the orthographic projection along ``d``, and somewhere in the overlap ``t_j`` is not behind
``t_i`` (``z_j - z_i > -eps``). A direction parallel to a contact face
(``|n . d| <= FACING_TOL``) does not cross it: sliding does not block. Every front triangle
is tested against every back triangle after a box cull: fine for tests, single queries
(``ndbg query --direction``) and plan checks, not for sweeping thousands of directions.
"""

from __future__ import annotations

import numpy as np

from ...core.assembly import Assembly
from ...geometry.vectors import plane_basis, unit
from ..dbg import DBG, bits

#: ``|n . d|`` below this counts as parallel (a sliding direction), for unit ``n`` and ``d``.
FACING_TOL = 1e-9


def _frame(d: np.ndarray) -> np.ndarray:
    """Orthonormal rows ``(u, v, d)`` for a unit ``d``."""
    d = unit(d)
    u, v = plane_basis(d)
    return np.array([u, v, d])


class _View:
    """One direction's frame, every part's box seen along it, and the parts' facing
    triangles projected (made as asked for): what :meth:`SweepChecker.blocked` reuses over
    the part pairs of one direction."""

    def __init__(self, checker: SweepChecker, d: np.ndarray) -> None:
        self.checker = checker
        self.frame = _frame(d)
        c = checker._corners @ self.frame.T  # (n, 8, 3)
        self.lo, self.hi = c[:, :, :2].min(axis=1), c[:, :, :2].max(axis=1)
        self.zlo, self.zhi = c[:, :, 2].min(axis=1), c[:, :, 2].max(axis=1)
        self._facing: dict[tuple[int, int], np.ndarray] = {}

    def facing(self, i: int, sense: int) -> np.ndarray:
        """Part ``i``'s triangles facing along ``d`` (``sense`` 1) or against it (-1),
        projected ``(a, 3, 3)`` (u, v, z)."""
        key = (i, sense)
        if key not in self._facing:
            sd = self.checker.normals[i] @ self.frame[2]
            sel = sd > FACING_TOL if sense > 0 else sd < -FACING_TOL
            self._facing[key] = self.checker.tris[i][sel] @ self.frame.T
        return self._facing[key]


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
        corners = []
        for t in self.tris:
            lo, hi = t.reshape(-1, 3).min(axis=0), t.reshape(-1, 3).max(axis=0)
            corners.append([[(lo, hi)[a][0], (lo, hi)[b][1], (lo, hi)[c][2]]
                            for a in (0, 1) for b in (0, 1) for c in (0, 1)])
        self._corners = np.array(corners, dtype=float).reshape(-1, 8, 3)
        self._view: tuple[tuple[float, ...], _View] | None = None

    def view(self, d: np.ndarray) -> _View:
        """The :class:`_View` along ``d`` (a 3-vector, or a 2-vector in the plane), kept
        for the next call with the same direction (its frame, boxes and facing triangles
        serve the next part pair)."""
        d = np.asarray(d, dtype=float)
        d3 = d[:3] if len(d) == 3 else np.array([d[0], d[1], 0.0])
        key = tuple(d3.tolist())
        if self._view is None or self._view[0] != key:
            self._view = (key, _View(self, d3))
        return self._view[1]

    def blocked(self, i: int, j: int, d: np.ndarray) -> bool:
        """Whether part ``j`` blocks the infinite translation of part ``i`` along ``d``."""
        v = self.view(d)
        # the parts' boxes seen along d: apart (or j wholly behind i), no ray meets both
        if np.any(v.lo[i] >= v.hi[j]) or np.any(v.lo[j] >= v.hi[i]) \
                or v.zhi[j] <= v.zlo[i] - self.eps:
            return False
        pi = v.facing(i, 1)
        pj = v.facing(j, -1)
        if not len(pi) or not len(pj):
            return False
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
        area (above ``(1e-6 diagonal)^2``) while ``t_j`` is not behind ``t_i`` over an area
        above ``eps^2`` of the overlap (depth difference ``z_j - z_i >= -1e-3 eps``: a single
        touching point or edge has none; a crossed face contact has all of it)?

        Each ``t_i`` is clipped by the three edges of ``t_j`` and then by the line where the
        depth difference, affine over the overlap, reaches ``-1e-3 eps``, all pairs at once
        (:func:`_clip`)."""
        amin = (1e-6 * self.asm.diagonal) ** 2
        tau = 1e-3 * self.eps
        uv_i, uv_j = pi[:, :, :2], pj[:, :, :2]
        e = np.roll(uv_j, -1, axis=1) - uv_j  # (k, 3, 2) edges of t_j
        orient = np.sign(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
        ok = orient != 0  # an edge-on t_j (zero projected area) overlaps nothing
        if not ok.any():
            return False
        uv_i, uv_j, e, orient = uv_i[ok], uv_j[ok], e[ok], orient[ok]
        pi, pj = pi[ok], pj[ok]
        poly, cnt = uv_i.copy(), np.full(len(uv_i), 3)
        for k in range(3):  # inside t_j: orient * cross(e_k, x - p_k) >= 0
            a = orient[:, None] * np.stack([e[:, k, 1], -e[:, k, 0]], axis=1)
            poly, cnt = _clip(poly, cnt, a, np.einsum("ij,ij->i", a, uv_j[:, k]))
        over = _area(poly, cnt) > amin
        if not over.any():
            return False
        poly, cnt = poly[over], cnt[over]
        ci, cj = _plane(pi[over]), _plane(pj[over])
        # z_j - z_i >= -tau  <=>  -(dc_u u + dc_v v) <= tau + dc_0
        dc = cj - ci
        poly, cnt = _clip(poly, cnt, -dc[:, 1:], tau + dc[:, 0])
        return bool((_area(poly, cnt) > self.eps ** 2).any())

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


def _clip(poly: np.ndarray, cnt: np.ndarray, a: np.ndarray, b: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """Clip convex polygons ``poly`` ``(k, m, 2)`` (the first ``cnt[k]`` vertices of each, in
    order) to the half-planes ``a_k . x <= b_k`` (``a`` ``(k, 2)``, ``b`` ``(k,)``), all at once
    (Sutherland-Hodgman: each edge keeps its start when inside and adds its crossing of the
    line). Returns the clipped polygons (at most ``m + 1`` vertices) and their counts."""
    k, m, _ = poly.shape
    if k == 0 or m == 0:
        return poly, cnt
    col = np.arange(m)
    row = np.arange(k)[:, None]
    valid = col[None, :] < cnt[:, None]
    nxt = (col[None, :] + 1) % np.maximum(cnt, 1)[:, None]
    q = poly[row, nxt]
    s = poly[:, :, 0] * a[:, 0, None] + poly[:, :, 1] * a[:, 1, None] - b[:, None]
    sq = s[row, nxt]
    inside = s <= 0
    keep = valid & inside
    cross = valid & (inside != (sq <= 0))
    w = np.where(cross, s / np.where(cross, s - sq, 1.0), 0.0)
    x = poly + w[:, :, None] * (q - poly)
    pts = np.stack([poly, x], axis=2).reshape(k, 2 * m, 2)
    mask = np.stack([keep, cross], axis=2).reshape(k, 2 * m)
    pos = np.cumsum(mask, axis=1) - 1
    cnt = pos[:, -1] + 1
    out = np.zeros((k, max(int(cnt.max()), 1), 2))
    r, c = np.nonzero(mask)
    out[r, pos[r, c]] = pts[r, c]
    return out, cnt


def _area(poly: np.ndarray, cnt: np.ndarray) -> np.ndarray:
    """Areas ``(k,)`` of the polygons ``poly`` ``(k, m, 2)`` with ``cnt`` vertices (shoelace;
    fewer than 3 vertices: 0)."""
    k, m, _ = poly.shape
    if k == 0 or m == 0:
        return np.zeros(k)
    col = np.arange(m)
    nxt = (col[None, :] + 1) % np.maximum(cnt, 1)[:, None]
    q = np.take_along_axis(poly, nxt[:, :, None], axis=1)
    term = poly[:, :, 0] * q[:, :, 1] - poly[:, :, 1] * q[:, :, 0]
    term = np.where(col[None, :] < cnt[:, None], term, 0.0)
    return np.where(cnt >= 3, 0.5 * np.abs(term.sum(axis=1)), 0.0)


def _plane(tri: np.ndarray) -> np.ndarray:
    """Coefficients ``(k, 3)`` ``(c0, cu, cv)`` of the depth ``z = c0 + cu u + cv v`` of the
    planes of projected triangles ``(k, 3, 3)`` (u, v, z; not edge-on)."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    e1, e2 = b - a, c - a
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    det = np.where(det == 0, 1e-300, det)
    cu = (e1[:, 2] * e2[:, 1] - e2[:, 2] * e1[:, 1]) / det
    cv = (e1[:, 0] * e2[:, 2] - e2[:, 0] * e1[:, 2]) / det
    return np.stack([a[:, 2] - cu * a[:, 0] - cv * a[:, 1], cu, cv], axis=1)


def blocked(asm: Assembly, i: int, j: int, d: np.ndarray) -> bool:
    """Whether part ``j`` blocks the infinite translation of part ``i`` along direction ``d``
    (a 3-vector; in 2D a 2-vector). Builds a :class:`SweepChecker`; reuse one for many calls."""
    return SweepChecker(asm).blocked(i, j, np.asarray(d, dtype=float))


def dbg_at(asm: Assembly, d: np.ndarray) -> DBG:
    """The DBG of ``asm`` for infinite translation along ``d``, computed directly."""
    return SweepChecker(asm).dbg(np.asarray(d, dtype=float))
