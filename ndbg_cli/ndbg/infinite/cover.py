"""An inner approximation of a union of open cones on the cube map, for pruning tests: a
raster of chart cells per cube face, a cell *covered* when it lies wholly inside one of the
cones' chart polygons eroded by :data:`SHRINK` (see :class:`Cover`)."""

from __future__ import annotations

import numpy as np

from ...kernels.compiled import loaded
from .cubemap import SQUARE_MARGIN, clip_halfplanes

#: Erosion of the kept polygons in the pruning test (chart units, about radians): a pruned
#: direction is at least this far inside a kept cone, far above the 1e-6 of the open test.
SHRINK = 1e-5
#: Cells per side of the pruning raster of each cube face (:class:`Cover`).
RASTER = 512


def run_offsets(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For runs of lengths ``counts`` ``(n,)`` laid end to end: the run of each position and
    its offset within the run (two ``(counts.sum(),)`` arrays)."""
    run = np.repeat(np.arange(len(counts)), counts)
    return run, np.arange(len(run)) - (np.cumsum(counts) - counts)[run]


def cells_window(cells: np.ndarray, row0: int = 0, col0: int = 0, r: int | None = None
                 ) -> tuple[float, float, float, float] | None:
    """The chart rectangle ``(x0, y0, x1, y1)`` round the marked cells of an ``r x r`` raster
    of one cube face (``cells[row, col]``, row = ``t``; on cell boundaries, the chart
    square's margin where it reaches the face's border so that cube edges stay inside on
    both faces), or ``None`` when none is marked. ``cells`` may be the block of the raster
    from row ``row0`` and column ``col0`` (``r``: the raster's size, the block's when
    ``None``) holding every marked cell."""
    rows = np.nonzero(cells.any(axis=1))[0]
    if not len(rows):
        return None
    cols = np.nonzero(cells.any(axis=0))[0] + col0
    rows = rows + row0
    r = cells.shape[0] if r is None else r
    m = 1.0 + SQUARE_MARGIN
    h = 2.0 / r
    lo = [-m if c == 0 else -1.0 + c * h for c in (cols[0], rows[0])]
    hi = [m if c == r else -1.0 + c * h for c in (cols[-1] + 1, rows[-1] + 1)]
    return lo[0], lo[1], hi[0], hi[1]


_last_raster: list = [None] * 5  # (domain key, raster, cells, blocks, any) made last


def _outside_raster(domain: np.ndarray, raster: int) -> tuple[np.ndarray, list, bool]:
    """The cells ``(6, raster, raster)`` outside ``domain`` (``(6, c, c)``, ``c`` dividing
    ``raster``), per face the ``(row0, row1, col0, col1)`` block holding every cell inside it
    (``None``: none), and whether any cell is outside. Every pair's walk (two covers each)
    starts from the same domain: the last one is kept (do not write to it)."""
    key = (domain.tobytes(), domain.shape)
    if _last_raster[0] != key or _last_raster[1] != raster:
        k = raster // domain.shape[1]
        cells = ~domain.repeat(k, axis=1).repeat(k, axis=2)
        blocks: list = []
        for face in range(6):
            rows = np.nonzero(~cells[face].all(axis=1))[0]
            cols = np.nonzero(~cells[face].all(axis=0))[0]
            blocks.append(None if not len(rows) else (
                int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1))
        _last_raster[:] = key, raster, cells, blocks, bool(cells.any())
    return _last_raster[2], _last_raster[3], _last_raster[4]


class Cover:
    """An inner approximation of the union of the kept terms, for the pruning test: per cube
    face, a raster of :data:`RASTER` x :data:`RASTER` chart cells, a cell being *covered* when
    it lies wholly inside some kept term's polygon eroded by :data:`SHRINK`. A cone whose
    polygon's bounding box meets only covered cells, on every face it meets, is therefore
    strictly inside the kept union (by at least ``SHRINK``): :meth:`covers`.

    Adding a term costs a few array operations per raster row it spans (cross-sections of a
    convex polygon at the grid lines), a test one summed-area-table lookup per face: unlike an
    exact polygon union, neither grows with the number of terms kept. The price is a margin of
    about one cell (``2 / RASTER`` chart units) along the union's boundary where nothing is
    pruned; what is computed there is exact."""

    def __init__(self, raster: int = RASTER, domain: np.ndarray | None = None) -> None:
        self.r = raster
        self.h = 2.0 / raster
        self.covered = np.zeros((6, raster, raster), dtype=bool)
        # summed-area tables of each face's block (below; every cell outside it is covered),
        # made when first needed, then brought up to date from the first row marked since
        # (rows counted from the block's first)
        self.sat: np.ndarray | None = None
        self.stale = [0] * 6
        self.win: list = [False] * 6  # windows (:meth:`window`); False: not computed yet
        # per face the (row0, row1, col0, col1) block holding every cell that may be open
        self.block: list = [(0, raster, 0, raster)] * 6
        self._pyramids: dict[int, tuple] = {}  # per face: (window, corners, sides)
        self._args: tuple | None = None  # what _windows gave, until a cell is marked
        self._pyrs: tuple | None = None  # the windows' corners and sides, until then too
        self.empty = True
        if domain is not None:
            # Cells outside the domain ((6, c, c), c dividing the raster) need no terms: they
            # count as covered from the start, so whatever lies only there is pruned.
            # the cells left open lie in a block per face: windows are sought there only
            outside, blocks, some = _outside_raster(domain, raster)
            self.covered = outside.copy()
            self.block = list(blocks)
            self.empty = not some

    def window(self, face: int) -> tuple[float, float, float, float] | None:
        """The chart rectangle ``(x0, y0, x1, y1)`` of the cells of ``face`` not yet covered
        (their bounding box, on cell boundaries; the chart square's margin on its border), or
        ``None`` when every cell is covered. Cones are clipped to it only: outside it there
        is nothing to mark or to test."""
        if self.win[face] is False:
            kernels = loaded("_cover_kernels")
            b = self.block[face]
            got = None if b is None else kernels.open_window(self.covered[face], *b,
                                                             1.0 + SQUARE_MARGIN)
            self.win[face] = got[1:] if got is not None and got[0] else None
        return self.win[face]

    def add(self, cones: np.ndarray) -> None:
        """Mark the cells wholly inside the eroded polygons of the open cones ``(p, k, 3)``."""
        for face in range(6):
            win = self.window(face)
            if win is None:
                continue
            poly, cnt = clip_halfplanes(cones, face, shrink=SHRINK, rect=win)
            keep = cnt >= 3
            if keep.any():
                self._mark(face, poly[keep], cnt[keep])

    def _mark(self, face: int, poly: np.ndarray, cnt: np.ndarray) -> None:
        """Mark the cells of ``face`` wholly inside the convex polygons ``poly`` ``(p, m, 2)``
        (``cnt`` vertices each; :func:`~ndbg_cli.kernels._cover_kernels.mark_cells`)."""
        kernels = loaded("_cover_kernels")
        first = kernels.mark_cells(np.ascontiguousarray(poly, dtype=float),
                                   np.ascontiguousarray(cnt, dtype=np.int64), self.h,
                                   self.covered[face])
        if first < self.r:
            self.stale[face] = min(self.stale[face], max(first - self.block[face][0], 0))
            self.win[face] = False
            self._args = self._pyrs = None
            self.empty = False

    def _table(self, face: int) -> None:
        """Bring the summed-area table of the covered cells of ``face``'s block up to date:
        ``sat[face, :rows + 1, :cols + 1]``, the block's own rows and columns counted from its
        corner (:func:`~ndbg_cli.kernels._cover_kernels.update_sat`). A box of cells is
        covered when its part in the block is
        (:func:`~ndbg_cli.kernels._cover_kernels.box_covered`): with a domain of a few hundred
        cells the tables are that small, not 513 x 513 per face."""
        kernels = loaded("_cover_kernels")
        if self.sat is None:
            size = [(b[1] - b[0], b[3] - b[2]) for b in self.block if b is not None]
            self.sat = np.zeros((6, max([s[0] for s in size], default=0) + 1,
                                 max([s[1] for s in size], default=0) + 1), dtype=np.int32)
        b = self.block[face]
        if b is not None and self.stale[face] < b[1] - b[0]:
            kernels.update_sat(self.covered[face, b[0]:b[1], b[2]:b[3]],
                               self.sat[face, :b[1] - b[0] + 1, :b[3] - b[2] + 1],
                               self.stale[face])
            self.stale[face] = b[1] - b[0]

    def covers_spanned(self, gens: np.ndarray,
                       pairs: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
        """``(p,)`` whether each closed cone spanned by generators ``gens`` ``(p, g, 3)`` lies in
        covered cells on every face it meets. On a face whose axis ``e`` has ``g . e > 0`` for every
        generator, the cone's chart image is the convex hull of the generators' charts, so their
        bounding box is used (no clipping); a face with no generator in front of it is missed. A
        cone with generators on both sides of some face's plane is clipped (:meth:`covers` of its
        H-representation; ``pairs``: the generator pairs that can span its facets, as
        :func:`~ndbg_cli.ndbg.infinite.cubemap.cone_normals` takes them)."""
        kernels = loaded("_cover_kernels")
        if self.empty:
            return np.zeros(len(gens), dtype=bool)
        a, b = np.triu_indices(gens.shape[1], k=1) if pairs is None else pairs
        return kernels.covers_spanned(np.ascontiguousarray(gens, dtype=float),
                                      np.asarray(a, dtype=np.int64),
                                      np.asarray(b, dtype=np.int64), *self._windows())

    def _windows(self) -> tuple:
        """The faces with a window ``(w,)``, their corner directions ``(w, 4, 3)``, chart
        rectangles ``(w, 4)``, the blocks' summed-area tables (up to date), the blocks
        ``(6, 4)`` (``row0, row1, col0, col1``), the cell width and the raster size: what
        the compiled tests (:func:`ndbg_cli.kernels._cover_kernels.covers`) take."""
        if self._args is not None:  # nothing marked since: the tables are up to date
            return self._args
        faces = [f for f in range(6) if self.window(f) is not None]
        for f in faces:
            self._table(f)
        sat = self.sat if self.sat is not None else np.zeros((6, 2, 2), dtype=np.int32)
        blocks = np.array([(0, 0, 0, 0) if b is None else b for b in self.block],
                          dtype=np.int64)
        self._args = (np.array(faces, dtype=np.int64),
                      self.pyramids()[0],
                      np.array([self.window(f) for f in faces], dtype=float).reshape(-1, 4),
                      sat, blocks, self.h, self.r)
        return self._args

    def _outside(self, cones: np.ndarray, face: int) -> np.ndarray | None:
        """``(p,)`` whether each open cone ``(p, k, 3)`` misses the window of ``face``
        (:meth:`window`): one of its half-spaces has the window's four corner directions
        strictly outside (a quick test, no clipping); ``None`` when the face has no
        window."""
        kernels = loaded("_cover_kernels")
        pyr = self._window_pyramid(face)
        if pyr is None:
            return None
        return kernels.outside(np.ascontiguousarray(cones, dtype=float), pyr[0])

    def _window_pyramid(self, face: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The window of ``face`` as a cone: its four corner directions ``(4, 3)`` (in turn
        round it) and the inward normals of its four sides ``(4, 3)``; ``None`` without a
        window. Made once per window (the quick tests ask for it on every batch)."""
        win = self.window(face)
        if win is None:
            return None
        got = self._pyramids.get(face)
        if got is None or got[0] != win:
            kernels = loaded("_cover_kernels")
            got = self._pyramids[face] = (win, *kernels.window_pyramid(face, *win))
        return got[1], got[2]

    def misses_spanned_open(self, gens: np.ndarray, facing: np.ndarray) -> np.ndarray:
        """``(p,)`` whether each term, the cone spanned by ``gens`` ``(p, g, 3)`` cut by the
        open half-spaces ``facing`` ``(p, f, 3)`` (``{d : m . d > 0}``), misses every window
        (so every cell not yet covered), by two quick tests per window, no facet computed:
        every generator strictly outside one side of the window's cone, or the four corners
        outside one of the half-spaces."""
        kernels = loaded("_cover_kernels")
        return kernels.misses_spanned_open(np.ascontiguousarray(gens, dtype=float),
                                           np.ascontiguousarray(facing, dtype=float),
                                           *self.pyramids())

    def pyramids(self) -> tuple[np.ndarray, np.ndarray]:
        """The windows as cones, face by face (those with a window): their corner directions
        ``(w, 4, 3)`` and the inward normals of their sides ``(w, 4, 3)``
        (:meth:`_window_pyramid`), kept until a cell is marked."""
        if self._pyrs is None:
            pyrs = [p for p in map(self._window_pyramid, range(6)) if p is not None]
            self._pyrs = (np.array([p[0] for p in pyrs]).reshape(-1, 4, 3),
                          np.array([p[1] for p in pyrs]).reshape(-1, 4, 3))
        return self._pyrs

    def misses_open(self, cones: np.ndarray) -> np.ndarray:
        """``(p,)`` whether each open cone ``(p, k, 3)`` (zero rows allowed) misses every
        cell not yet covered (the window test of :meth:`_outside` on every face): it then
        lies in covered cells or nowhere, as :meth:`covers` would find, without clipping."""
        out = np.ones(len(cones), dtype=bool)
        for face in range(6):
            miss = self._outside(cones, face)
            if miss is not None:
                out &= miss
        return out

    def covers(self, cones: np.ndarray) -> np.ndarray:
        """``(p,)`` whether each closed cone ``(p, k, 3)`` lies in covered cells on every
        face it meets."""
        kernels = loaded("_cover_kernels")
        if self.empty:
            return np.zeros(len(cones), dtype=bool)
        return kernels.covers(np.ascontiguousarray(cones, dtype=float), *self._windows())


_last_domain_cover: list = [None, None]  # (domain key, Cover)


def domain_cover(domain: np.ndarray) -> Cover:
    """The :class:`Cover` of ``domain`` alone (its outside cells covered, nothing marked),
    shared: the same object while the domain is the same (every pair's walk tests its near
    node pairs against it). Do not add to it."""
    key = (domain.tobytes(), domain.shape)
    if _last_domain_cover[0] != key:
        _last_domain_cover[:] = key, Cover(domain=domain)
    return _last_domain_cover[1]
