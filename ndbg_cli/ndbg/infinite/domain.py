"""Where the infinite-translation NDBG can free anything: a conservative raster of directions
(paper sections 5.3 with 4.2).

A contact arc of the infinitesimal DBG is also an arc of the infinite one, so where the
infinitesimal DBG is strongly connected the infinite one is too. The *free domain* is the
closure of the directions where the infinitesimal DBG is not strongly connected; every
partitioning of the whole assembly's infinite NDBG lies in it (not those of subassemblies: a
part of the assembly can be free where the whole is not). :func:`free_domain` marks the
cube-map cells that may meet it, conservatively (a cell is never left out wrongly).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from ...kernels.cube_faces import FACES
from ..dbg import DBG, strong_components
from ..infinitesimal.build import blocking_sides
from .chart_union import antipodal
from .cover import RASTER, cells_window

#: Extra angular margin (radians) around each cell, for the contact normals' own noise.
MARGIN = 1e-3
#: Cells per side of the raster on which the domain is decided first (each maps to a block of
#: the pruning raster, :data:`~ndbg_cli.ndbg.infinite.cover.RASTER`, decided next).
COARSE = 64


def cell_directions(r: int, face: np.ndarray, row: np.ndarray, col: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Unit centre directions ``(m, 3)`` of the chart cells ``(face, row, col)`` (arrays of
    ``m`` indices; row = ``t``, column = ``s``) of an ``r x r`` raster per cube face, and
    their angular radii ``(m,)`` (radians; the largest angle from the centre to a corner,
    which bounds the angle to any point of the cell)."""
    h = 2.0 / r
    s = -1.0 + h * (col + 0.5)
    t = -1.0 + h * (row + 0.5)
    e, u, v = FACES[face, 0], FACES[face, 1], FACES[face, 2]

    def at(ss, tt):
        k = e + ss[:, None] * u + tt[:, None] * v
        return k / np.linalg.norm(k, axis=1, keepdims=True)

    c = at(s, t)
    rad = np.zeros(len(c))
    for ds in (-0.5 * h, 0.5 * h):
        for dt in (-0.5 * h, 0.5 * h):
            cos = np.clip((c * at(s + ds, t + dt)).sum(axis=1), -1.0, 1.0)
            rad = np.maximum(rad, np.arccos(cos))
    return c, rad


def free_domain(n: int, pairs: Sequence[tuple], tol: float, r: int = RASTER,
                coarse: int = COARSE) -> np.ndarray | None:
    """``(6, r, r)`` bool: the cells that may contain a direction where the infinitesimal DBG
    of ``n`` parts with contact ``pairs`` (``(a, b, normals[, mode])`` as in
    :func:`ndbg_cli.ndbg.infinitesimal.build.dbg_at`, tolerance ``tol`` radians) is not strongly
    connected. Decided on a ``coarse`` raster first, then on the cells of ``r`` inside the
    coarse cells kept. Symmetric under ``d -> -d``. ``None`` when it is every cell: at once
    when the contact graph is not connected (a part touching nothing, or two groups touching
    each other nowhere, come apart in every direction).

    Per cell, an arc is *certain* when it holds at every direction within the cell's angular
    radius ``rho`` (plus :data:`MARGIN`) of its centre: with unit normals ``n . d`` moves by at
    most that much, so the test of ``dbg_at`` (``n . d > tol``) is applied at ``tol + rho``. A
    cell whose certain arcs already make a strongly connected DBG is outside the domain."""
    reach = [0] * n  # a DBG holding every arc any direction can give: each contact, both ways
    for entry in pairs:
        reach[entry[0]] |= 1 << entry[1]
        reach[entry[1]] |= 1 << entry[0]
    if n > 1 and len(strong_components(DBG(tuple(reach)))) > 1:
        return None
    f, y, x = np.nonzero(np.ones((6, coarse, coarse), dtype=bool))
    d, rad = cell_directions(coarse, f, y, x)
    keep = np.zeros(len(d), dtype=bool)
    sel = _may_free_children(n, pairs, tol, coarse, f, y, x, d, rad)
    keep[sel] = _may_free(n, pairs, tol, d[sel], rad[sel])
    k = r // coarse
    f, y, x = f[keep], y[keep], x[keep]
    dy, dx = np.divmod(np.arange(k * k), k)  # the k x k fine cells of a coarse one
    f = np.repeat(f, k * k)
    y = (y[:, None] * k + dy).reshape(-1)
    x = (x[:, None] * k + dx).reshape(-1)
    dom = np.zeros((6, r, r), dtype=bool)
    if len(f):
        keep = _may_free(n, pairs, tol, *cell_directions(r, f, y, x))
        dom[f[keep], y[keep], x[keep]] = True
    for g in range(0, 6, 2):  # the antipodal map: (s, t) on face g -> (-t, -s) on g ^ 1
        dom[g] |= dom[g ^ 1][::-1, ::-1].T
        dom[g ^ 1] = dom[g][::-1, ::-1].T
    return None if dom.all() else dom


#: Cells per side of the raster tested before the :data:`COARSE` one (its cells' children
#: are tested only where it may be free: typically a tiny fraction of the coarse cells).
PRE = 8
#: Added to a :data:`PRE` cell's radius (radians) over the rounding of its computation.
PRE_SLACK = 1e-9


def _may_free_children(n: int, pairs: Sequence[tuple], tol: float, r: int, f: np.ndarray,
                       y: np.ndarray, x: np.ndarray, d: np.ndarray, rad: np.ndarray
                       ) -> np.ndarray:
    """The indices of the cells ``(f, y, x)`` of an ``r x r`` raster (centres ``d``, radii
    ``rad``) whose :data:`PRE` x :data:`PRE` parent cell may be free, tested with a radius
    reaching over every child's cap (the angle to the child's centre plus the child's
    radius, plus :data:`PRE_SLACK`). A contact pair blocks at the parent's centre only by
    more than ``tol`` plus that radius, so it blocks at each child's centre by more than
    ``tol`` plus the child's radius: the parent's DBG has a subset of each child's arcs,
    and where it is strongly connected so are the children's. The cells skipped are exactly
    cells :func:`_may_free` would have dropped."""
    if r % PRE or r <= PRE:
        return np.arange(len(d))
    k = r // PRE
    parent = (f * PRE + y // k) * PRE + x // k
    fp, yp, xp = np.nonzero(np.ones((6, PRE, PRE), dtype=bool))
    dp, _ = cell_directions(PRE, fp, yp, xp)
    q = dp[parent]
    ang = np.arctan2(np.linalg.norm(np.cross(q, d), axis=1), (q * d).sum(axis=1))
    reach = np.zeros(len(dp))
    np.maximum.at(reach, parent, ang + rad)
    return np.flatnonzero(_may_free(n, pairs, tol, dp, reach + PRE_SLACK)[parent])


#: Entries (cells x parts x 64-bit words) of the successor table built at once.
CHUNK_ENTRIES = 1 << 21


def _may_free(n: int, pairs: Sequence[tuple], tol: float, d: np.ndarray, rad: np.ndarray
              ) -> np.ndarray:
    """``(m,)`` whether the infinitesimal DBG may be not strongly connected somewhere within
    ``rad`` (``(m,)``, radians) of the directions ``d`` ``(m, 3)``. Any number of parts: each
    part's successor set is a row of 64-bit words; the cells are taken in chunks, and each
    distinct DBG is tested once."""
    words = (n + 63) // 64
    step = max(1, CHUNK_ENTRIES // (n * words))
    normals = []
    for entry in pairs:
        nm = np.asarray(entry[2], dtype=float).reshape(-1, 3)
        normals.append(nm / np.linalg.norm(nm, axis=1, keepdims=True))
    known: dict[bytes, bool] = {}
    out = np.zeros(len(d), dtype=bool)
    for lo in range(0, len(d), step):
        dd, lim = d[lo:lo + step], tol + rad[lo:lo + step] + MARGIN
        succ = np.zeros((len(dd), n, words), dtype=np.uint64)
        for entry, nm in zip(pairs, normals):
            a, b = entry[0], entry[1]
            fwd, back = blocking_sides(dd @ nm.T, entry[3] if len(entry) > 3 else "any", lim)
            succ[fwd, a, b // 64] |= np.uint64(1) << np.uint64(b % 64)
            succ[back, b, a // 64] |= np.uint64(1) << np.uint64(a % 64)
        flat = np.ascontiguousarray(succ.reshape(len(dd), -1))
        # one opaque item per cell: unique() then compares bytes, far faster than axis=0
        keys = flat.view(np.dtype((np.void, flat.shape[1] * 8))).reshape(-1)
        _, first, inv = np.unique(keys, return_index=True, return_inverse=True)
        free = np.zeros(len(first), dtype=bool)
        for k, i in enumerate(first):
            key = keys[i].tobytes()
            if key not in known:
                w = flat[i].reshape(n, words).tolist()
                g = DBG(tuple(sum(x << (64 * i) for i, x in enumerate(ws)) for ws in w))
                known[key] = len(strong_components(g)) > 1
            free[k] = known[key]
        out[lo:lo + step] = free[inv.reshape(-1)]
    return out


def domain_polygons(dom: np.ndarray) -> list[object]:
    """Per face, the chart geometry (shapely, closed) of the domain cells; ``None`` where the
    face has none. A face whose cells are the antipodal image of the opposite face's (a
    symmetric domain, as the infinite NDBG takes) gets that face's geometry mapped exactly
    (:func:`~ndbg_cli.ndbg.infinite.chart_union.antipodal`), so that the sets cut to it, and their
    arrangement, are exact antipodal images too."""
    r = dom.shape[1]
    h = 2.0 / r
    out: list[object] = []
    for f in range(6):
        if f & 1 and np.array_equal(dom[f], dom[f ^ 1].T[::-1, ::-1]):
            out.append(None if out[f ^ 1] is None else antipodal(out[f ^ 1]))
            continue
        # one box per run of domain cells in a row
        pad = np.zeros((r, r + 2), dtype=np.int8)
        pad[:, 1:-1] = dom[f]
        step = np.diff(pad, axis=1)
        y, x0 = np.nonzero(step == 1)
        _, x1 = np.nonzero(step == -1)
        if not len(y):
            out.append(None)
            continue
        boxes = shapely.box(-1.0 + x0 * h, -1.0 + y * h, -1.0 + x1 * h, -1.0 + (y + 1) * h)
        out.append(shapely.union_all(boxes, grid_size=1e-12))
    return out


def domain_windows(dom: np.ndarray) -> list[tuple[float, float, float, float] | None]:
    """Per face, the chart rectangle round the domain cells
    (:func:`ndbg_cli.ndbg.infinite.cover.cells_window`), ``None`` where the face has none: what the
    blocked sets are clipped to before their union (nothing outside it is used). The last domain's
    are kept (every pair's walk asks)."""
    key = (dom.tobytes(), dom.shape)
    if _last_windows[0] != key:
        _last_windows[:] = key, [cells_window(dom[f]) for f in range(6)]
    return list(_last_windows[1])


_last_windows: list = [None, None]  # (domain key, windows)
