"""A direct, per-direction test of blocking for infinite translations, independent of the
arrangement in :mod:`ndbg_cli.ndbg.infinite.build` (it shares no code with it).

``P_j`` blocks ``P_i`` along ``d`` when a triangle of ``P_i`` facing ``d`` (``n_i . d > 0``)
and a triangle of ``P_j`` facing against it (``n_j . d < 0``) overlap with positive area in
the orthographic projection along ``d``, and somewhere in the overlap ``t_j`` is not behind
``t_i`` (``z_j - z_i > -eps``). A direction parallel to a contact face
(``|n . d| <= FACING_TOL``) does not cross it: sliding does not block. Nor does an overlap
narrower than the length tolerance ``eps``: the blocking region (the union, over the triangle
pairs, of where ``t_j`` is in front) must hold a disk of diameter ``eps``, as two parts closer
than ``eps`` touch (a faceted rod in a faceted hole: slivers no wider than the facets'
sagitta; a press fit within tolerance). The triangle pairs whose shadows meet are found on a
grid and tested exactly by the compiled kernels of :mod:`ndbg_cli.kernels` (built ahead of
time when possible): one direction's whole DBG costs milliseconds to a second on real
products, fine for plan proofs (:mod:`ndbg_cli.planning.proven`) and single queries
(``ndbg query --direction``), not for sweeping the whole sphere.
"""

from __future__ import annotations

import numpy as np

from ...core.assembly import Assembly
from ...geometry.vectors import plane_basis, unit
from ...kernels.compiled import loaded
from ..dbg import DBG, bits

# compiled ahead of time when built (no numba start), else numba's just-in-time kernels
_kernels = loaded("_sweep_kernels")
facing = _kernels.facing
clipped_areas = _kernels.clipped_areas
first_blocking = _kernels.first_blocking
front_polygons = _kernels.front_polygons
overlap_centroid = _kernels.overlap_centroid
plane = _kernels.plane

#: ``|n . d|`` below this counts as parallel (a sliding direction), for unit ``n`` and ``d``.
FACING_TOL = 1e-9
#: Directions whose views (projected facing triangles) a :class:`SweepChecker` keeps.
VIEWS_KEPT = 8


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
        self._facing: dict[tuple[int, int], tuple[np.ndarray, ...]] = {}

    def facing(self, i: int, sense: int) -> tuple[np.ndarray, ...]:
        """Part ``i``'s triangles facing along ``d`` (``sense`` 1) or against it (-1),
        projected ``(a, 3, 3)`` (u, v, z), their boxes (the sweep kernels' ``boxes``), and the
        same two of the *wide* ones only: those whose shadow's inradius ``2 A / P`` exceeds
        ``eps / 2``. A convex overlap's area over perimeter is at most its inradius, which is
        at most either triangle's, so only two wide triangles can make a pair that blocks
        alone. One pass of the kernel :func:`facing`."""
        key = (i, sense)
        if key not in self._facing:
            self._facing[key] = facing(self.checker.tris[i], self.checker.normals[i],
                                       self.frame, sense, FACING_TOL, self.checker.eps)
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
        self._views: dict[tuple[float, ...], _View] = {}
        diag = max(asm.size, 1e-300)
        # overlaps below these are edges or points touching (areas: the test's resolution)
        self._amin, self._tiny = (1e-6 * diag) ** 2, 1e-9 * diag

    def view(self, d: np.ndarray) -> _View:
        """The :class:`_View` along ``d`` (a 3-vector, or a 2-vector in the plane); the
        :data:`VIEWS_KEPT` most recently used are kept (their frames, boxes and facing
        triangles serve the next part pairs along the same directions)."""
        d = np.asarray(d, dtype=float)
        d3 = d[:3] if len(d) == 3 else np.array([d[0], d[1], 0.0])
        key = tuple(d3.tolist())
        got = self._views.pop(key, None)
        if got is None:
            got = _View(self, d3)
            if len(self._views) >= VIEWS_KEPT:
                self._views.pop(next(iter(self._views)))
        self._views[key] = got  # most recently used last
        return got

    def blocked(self, i: int, j: int, d: np.ndarray) -> bool:
        """Whether part ``j`` blocks the infinite translation of part ``i`` along ``d``."""
        return self._first(i, j, d) is not None

    def witness(self, i: int, j: int, d: np.ndarray) -> tuple[float, ...] | None:
        """Where part ``j`` blocks part ``i`` along ``d``: a point of ``j``'s surface in front
        of ``i`` (the middle of the first blocking triangle pair's overlap, on ``j``'s
        triangle, assembly frame); ``None`` when ``j`` does not block ``i``."""
        got = self._first(i, j, d)
        if got is None:
            return None
        ti, tj = got
        u, v = overlap_centroid(ti, tj)
        c0, cu, cv = plane(tj)
        p = np.array([u, v, c0 + cu * u + cv * v]) @ self.view(d).frame
        return tuple(float(x) for x in p[:len(np.asarray(d))])

    def _first(self, i: int, j: int, d: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The first blocking pair of projected triangles of ``i`` and ``j`` along ``d``."""
        v = self.view(d)
        return self._pair(v, i, j) if self._near(v, i)[j] else None

    @staticmethod
    def _near(v: _View, i: int) -> np.ndarray:
        """Which parts may block part ``i`` in view ``v`` (bool per part, ``i`` itself not):
        seen along ``d`` their boxes meet ``i``'s and do not lie wholly behind it (else no ray
        meets both)."""
        near = ~((v.lo[i] >= v.hi).any(axis=1) | (v.lo >= v.hi[i]).any(axis=1)
                 | (v.zhi <= v.zlo[i] - v.checker.eps))
        near[i] = False
        return near

    def _pair(self, v: _View, i: int, j: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The kernel on ``i``'s triangles facing ``d`` and ``j``'s facing against it: a
        blocking triangle pair, or ``None``."""
        pi, bi, wpi, wbi = v.facing(i, 1)
        pj, bj, wpj, wbj = v.facing(j, -1)
        if not len(pi) or not len(pj):
            return None
        # a wide pair first, among the wide triangles only: on a fine tessellation most
        # pairs are slivers, and a blocking face is usually met by a wide pair somewhere
        if len(wpi) and len(wpj):
            ki, kj, _, _ = first_blocking(wpi, wpj, wbi, wbj, self.eps, self._amin, self._tiny)
            if ki >= 0:
                return wpi[ki], wpj[kj]
        ki, kj, thin, count = first_blocking(pi, pj, bi, bj, self.eps, self._amin, self._tiny)
        if ki >= 0:
            return pi[ki], pj[kj]
        return self._wide_union(pi, pj, thin[:count]) if count else None

    def _wide_union(self, pi: np.ndarray, pj: np.ndarray, pairs: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray] | None:
        """Whether the narrow overlaps of ``pairs`` (each too narrow alone to hold a disk of
        diameter ``eps``) hold one together: their union, closed over cracks of
        :attr:`_tiny` (adjacent triangles' overlaps, clipped apart in floating point, leave
        cracks that would split it), shrunk by ``eps / 2``. A faceted rod in a faceted hole
        leaves slivers around the rod no wider than the facets' sagitta, within the
        tolerance: it slides; a face tessellated into slivers still blocks. Returns a pair
        of the union where it holds one (the witness), else ``None``."""
        coords, counts = front_polygons(pi, pj, pairs, self._amin, 1e-3 * self.eps)
        kept = np.flatnonzero(counts)
        if not len(kept):
            return None
        hit = _DiskSearch(coords, counts[kept], self.eps, self._tiny).run()
        if hit is None:
            return None
        a, b = pairs[kept[hit]]
        return pi[a], pj[b]

    def blockers(self, i: int, d: np.ndarray, among: int | None = None) -> int:
        """The bitmask of the parts that block part ``i`` along ``d``, of those in bitmask
        ``among`` (default: all; the box culls of every ``j`` in one array operation)."""
        v = self.view(d)
        near = np.flatnonzero(self._near(v, i)).tolist()
        if among is not None:
            near = [j for j in near if among >> j & 1]
        return sum(1 << j for j in near if self._pair(v, i, j) is not None)

    def frees(self, moved: int, rest: int, d: np.ndarray) -> bool:
        """Whether the parts of bitmask ``moved`` translate to infinity along ``d`` without
        meeting the interior of any part of bitmask ``rest``."""
        v = self.view(d)
        for i in bits(moved):
            near = self._near(v, i)
            if any(near[j] and self._pair(v, i, j) is not None for j in bits(rest)):
                return False
        return True

    def dbg(self, d: np.ndarray) -> DBG:
        """The DBG for infinite translation along ``d``: arc ``i -> j`` iff ``j`` blocks ``i``."""
        return DBG(tuple(self.blockers(i, d) for i in range(len(self.tris))))


#: A window of at most this many narrow overlaps is decided by one union; larger ones are
#: split (:class:`_DiskSearch`).
LEAF_OVERLAPS = 64


class _DiskSearch:
    """Whether the union of the convex rings ``coords`` (:func:`front_polygons`'
    output; ``counts``: each ring's vertex count) holds a disk of diameter ``eps`` (closed
    over cracks of ``tiny`` first), searched window by window instead of by one union of all.

    Windows split in two along each side longer than ``4 eps`` into halves that overlap by
    ``eps``, so a disk inside a window lies inside one of its children: the search is exact.
    A window whose clipped overlaps' areas add up to less than the disk's holds none (the
    union's area is at most that sum), so a ring of slivers (a faceted rod in a faceted hole)
    is dismissed window by window, and a face tessellated into slivers is found blocking in
    the first small window it covers: the cost follows one window, not the whole union (one
    union of tens of thousands of fan slivers took seconds per part pair)."""

    def __init__(self, coords: np.ndarray, counts: np.ndarray, eps: float, tiny: float
                 ) -> None:
        self.coords, self.counts = coords, counts
        self.starts = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
        self.eps, self.tiny = eps, tiny
        self.disk = np.pi * (0.5 * eps) ** 2
        self.bounds = np.hstack([np.minimum.reduceat(coords, self.starts),
                                 np.maximum.reduceat(coords, self.starts)])
        self.areas = clipped_areas(coords, self.starts, counts, np.arange(len(counts)),
                                   -np.inf, -np.inf, np.inf, np.inf)

    def run(self) -> int | None:
        """The index of a polygon meeting a held disk, or ``None`` when none is held (the
        whole window's areas are checked first, as every window's are)."""
        b = self.bounds
        window = (b[:, 0].min(), b[:, 1].min(), b[:, 2].max(), b[:, 3].max())
        return self._search(window, np.arange(len(self.counts)))

    def _search(self, w: tuple[float, ...], idx: np.ndarray) -> int | None:
        g = 2.0 * self.tiny  # the closing reaches this far past the window
        box = (w[0] - g, w[1] - g, w[2] + g, w[3] + g)
        area = clipped_areas(self.coords, self.starts, self.counts, idx, *box)
        if float(area.sum()) < self.disk:
            return None
        idx = idx[area > 0]
        halves = [self._halves(w[0], w[2]), self._halves(w[1], w[3])]
        if len(idx) <= LEAF_OVERLAPS or (len(halves[0]) == 1 and len(halves[1]) == 1):
            return self._leaf(idx, box)
        children = [(u0, v0, u1, v1) for u0, u1 in halves[0] for v0, v1 in halves[1]]
        b = self.bounds[idx]
        members = [idx[(b[:, 2] > c[0]) & (b[:, 0] < c[2]) & (b[:, 3] > c[1])
                       & (b[:, 1] < c[3])] for c in children]
        weight = [-float(self.areas[m].sum()) for m in members]
        for k in np.argsort(weight, kind="stable"):
            got = self._search(children[k], members[k]) if len(members[k]) else None
            if got is not None:
                return got
        return None

    def _halves(self, lo: float, hi: float) -> list[tuple[float, float]]:
        """``[lo, hi]`` split into two halves that overlap by ``eps`` (a segment of length
        ``eps`` inside it lies inside one), or kept whole when at most ``4 eps`` long."""
        if hi - lo <= 4.0 * self.eps:
            return [(lo, hi)]
        mid = 0.5 * (lo + hi)
        return [(lo, mid + self.eps), (mid, hi)]

    def _leaf(self, idx: np.ndarray, box: tuple[float, ...]) -> int | None:
        """One window (``box``) decided by the union of its clipped overlaps, closed by
        ``tiny`` and shrunk by ``eps / 2``."""
        import shapely

        # the window's polygons only (shapely's constructors cost more than the search)
        rows = self.starts[idx][:, None] + np.arange(int(self.counts[idx].max()))
        rows = rows[rows < (self.starts[idx] + self.counts[idx])[:, None]]
        polys = shapely.polygons(shapely.linearrings(
            self.coords[rows], indices=np.repeat(np.arange(len(idx)), self.counts[idx])))
        bad = ~shapely.is_valid(polys)  # clipped to slivers with repeated vertices
        polys[bad] = shapely.make_valid(polys[bad])
        clipped = shapely.intersection(polys, shapely.box(*box))
        # mitred offsets: fewer vertices than round ones, and never a smaller closing nor a
        # deeper erosion (a mitre reaches past the disk), so never a wrong "free"
        grow = {"join_style": "mitre", "mitre_limit": 2.0}
        try:
            core = shapely.union_all(clipped).buffer(self.tiny, **grow)
        except shapely.errors.GEOSException:  # a degenerate union: each closed first
            try:
                core = shapely.union_all(shapely.buffer(clipped, self.tiny, **grow))
            except shapely.errors.GEOSException:  # undecided: blocked, never freed wrongly
                return int(idx[0])
        core = core.buffer(-(0.5 * self.eps + self.tiny), **grow)
        if core.is_empty:
            return None
        hit = np.flatnonzero(shapely.intersects(polys, core))
        return int(idx[hit[0]] if len(hit) else idx[0])


def warm_up() -> None:
    """Load this test's kernels now: when they run just in time (not built ahead of time,
    :mod:`ndbg_cli.kernels.compiled`), numba starts and loads them from its cache, about
    0.4 s of CPU that a caller with time to spare takes off the first test; built ahead of
    time, nothing."""
    t = np.zeros((1, 3, 3))
    t[0, 1, 0] = t[0, 2, 1] = 1.0
    t, b, _, _ = facing(t, np.array([[0.0, 0.0, 1.0]]), np.eye(3), 1, FACING_TOL, 1e-9)
    first_blocking(t, t, b, b, 1e-9, 1e-18, 1e-9)
    # the narrow overlaps' union
    coords, counts = front_polygons(t, t, np.zeros((1, 2), np.int64), 0.0, 0.0)
    clipped_areas(coords, np.zeros(1, np.int64), counts, np.zeros(1, np.int64), 0.0, 0.0,
                  1.0, 1.0)


def kernels_loaded() -> bool:
    """Whether :func:`warm_up` (or a first test) has loaded this test's kernels here (always
    when built ahead of time, or with numba's compilation off: ``NUMBA_DISABLE_JIT``)."""
    return _kernels.compiled or bool(getattr(first_blocking, "signatures", True))


def blocked(asm: Assembly, i: int, j: int, d: np.ndarray) -> bool:
    """Whether part ``j`` blocks the infinite translation of part ``i`` along direction ``d``
    (a 3-vector; in 2D a 2-vector). Builds a :class:`SweepChecker`; reuse one for many calls."""
    return SweepChecker(asm).blocked(i, j, np.asarray(d, dtype=float))


def dbg_at(asm: Assembly, d: np.ndarray) -> DBG:
    """The DBG of ``asm`` for infinite translation along ``d``, computed directly."""
    return SweepChecker(asm).dbg(np.asarray(d, dtype=float))
