"""The fewest fingers of a prismatic form-closure grasp, exactly (issue 34): the greedy
placement of :mod:`ndbg_cli.planning.grasp` breaks ties between equal gains by the order of the
parts and faces, which a rotation, a change of units or a new part order changes, and so did its
count (hover 14 -> 13 after a turn, slot-37 6 -> 8). The minimum over the same candidate faces
is a property of the geometry alone.

Each requirement's pieces are refined by the great circle of every candidate face on its sink
component into *atoms*: open pieces no such circle crosses, with their open edges and vertices
(the closure of each region is held), so each face blocks an atom wholly or not at all. A set
of faces then holds the requirement iff it blocks every atom: a set cover, solved as a 0-1
integer program (HiGHS, :func:`scipy.optimize.milp`, deterministic). Atoms no face blocks are
left out (the greedy reports them as uncovered). The refinement and the program are bounded by
counts (:data:`ATOM_BUDGET`, :data:`NODE_LIMIT`), so whether the count is exact does not
depend on the machine; past them the caller keeps the greedy count as an upper bound.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .pieces import split_piece

#: Most atoms the refinement may make (all requirements together) before it gives up: the
#: examples need at most a few thousand; a model with thousands of curved faces would need
#: millions, where the greedy's upper bound is reported instead.
ATOM_BUDGET = 50_000

#: Branch-and-bound nodes HiGHS may explore (a count, not a time: the same answer on any
#: machine). Set covers of this size close at the root or within a few nodes.
NODE_LIMIT = 10_000


def _split_both(g: np.ndarray, v: np.ndarray, tol: float) -> list[np.ndarray]:
    """The open piece ``g`` cut by a circle with values ``v = g . n``: its positive side, its
    negative side and the chord on the circle (the chord is blocked by neither side's
    fingers on that circle, so it stays an atom of its own)."""
    rest = split_piece(g, v, tol)          # negative side, then the chord's pieces
    positive = split_piece(g, -v, tol)[0]  # the negative side of -n is the positive of n
    return [positive, *rest]


def atoms(pieces: Sequence[tuple[np.ndarray, int]], normals: np.ndarray,
          usable: np.ndarray, tol: float, budget: int = ATOM_BUDGET
          ) -> tuple[list[np.ndarray], list[int]] | None:
    """Refine each ``(generators, requirement)`` piece by the circles of the faces usable for
    its requirement (``usable`` ``(requirements, faces)``) that cross it; ``None`` past
    ``budget`` atoms or :data:`SPLIT_BUDGET` (cell, circle) tests (a model with thousands of
    curved faces: minutes of splitting for a count the greedy bounds anyway)."""
    out_g: list[np.ndarray] = []
    out_r: list[int] = []
    # one circle per distinct normal: faces of several parts with one normal cut alike
    lines = np.unique(np.round(normals, 12), axis=0, return_inverse=True)[1].reshape(-1)
    crossing = []
    faces: dict[int, np.ndarray] = {}  # requirement -> its usable faces, one per circle
    for gens, req in pieces:
        idx = faces.get(req)
        if idx is None:
            idx = np.flatnonzero(usable[req])
            _, first = np.unique(lines[idx], return_index=True)
            idx = faces[req] = idx[np.sort(first)]
        v = gens @ normals[idx].T
        crossing.append(idx[(v.max(axis=0) > tol) & (v.min(axis=0) < -tol)])
    # each crossing circle costs at least one test: past the budget already, give up before
    # splitting anything (the beam: seconds of splitting for a count the greedy bounds)
    if sum(len(c) for c in crossing) > SPLIT_BUDGET:
        return None
    work = 0
    for (gens, req), cuts in zip(pieces, crossing):
        cells = [gens]
        for n in normals[cuts]:
            work += len(cells)
            if work > SPLIT_BUDGET:
                return None
            nxt: list[np.ndarray] = []
            for g in cells:
                w = g @ n
                if w.max() > tol and w.min() < -tol:
                    nxt += _split_both(g, w, tol)
                else:
                    nxt.append(g)
            cells = nxt
            if len(out_g) + len(cells) > budget:
                return None
        cells = _with_faces(cells)
        out_g += cells
        out_r += [req] * len(cells)
    return out_g, out_r


#: Most (cell, crossing circle) tests of the refinement (about 8 us each): the examples need
#: at most 19,000 (dowels), the gearbox example 73,000 and the press fit 69,000 (seconds with
#: the program: they keep their greedy counts, as upper bounds), the beam (4,600 curved faces)
#: more than 100,000. The refinement runs beside the planner (a forked side job), and this
#: bounds what it adds there (beam: 0.45 s before the exact count, 1.7 s with a 100,000 budget).
SPLIT_BUDGET = 30_000


def _with_faces(cells: list[np.ndarray]) -> list[np.ndarray]:
    """The open cells and, as atoms of their own, their open edges and their vertices: a
    direction on the boundary between two pieces (the cut of a long arc, the edge of a
    cube-map cell of the infinite family: lines the frame puts anywhere) or between two
    regions must be held too, and a finger whose circle runs along it does not hold it. The
    greedy placement held open pieces only, so such directions were left to chance: held in
    one frame, not in another (fig5-rotation: 4 fingers, leaving the product free along a
    diagonal, 5 after a turn)."""
    out = list(cells)
    for g in cells:
        if len(g) >= 3:
            out += [np.stack([g[i], g[(i + 1) % len(g)]]) for i in range(len(g))]
        if len(g) >= 2:
            out += [v[None] for v in g]
    return out


def blocked(cells: list[np.ndarray], normals: np.ndarray, tol: float) -> np.ndarray:
    """``(cells, faces)``: whether each face blocks all of each atom (every generator at
    ``g . n >= -tol``, one above ``tol``: the greedy's own test)."""
    if not cells:
        return np.zeros((0, len(normals)), dtype=bool)
    sizes = np.array([len(c) for c in cells])
    seg = np.cumsum(sizes) - sizes
    v = np.concatenate(cells) @ normals.T
    return ((np.maximum.reduceat(v, seg, axis=0) > tol)
            & ~(np.minimum.reduceat(v, seg, axis=0) < -tol))


def unique_rows(a: np.ndarray) -> np.ndarray:
    """The distinct rows of the boolean matrix ``a``, sorted: ``np.unique(a, axis=0)``, which
    sorts the rows element by element (1.6 s on a 96-part rack's 6,482 x 1,336 cover), from
    the rows packed into bytes instead (big-endian bits keep their order: 3 ms).

    Examples
    --------
    >>> unique_rows(np.array([[1, 0, 1], [0, 1, 1], [1, 0, 1]], dtype=bool)).astype(int)
    array([[0, 1, 1],
           [1, 0, 1]])
    """
    if a.dtype != bool:
        raise TypeError(f"unique_rows takes a boolean matrix, not {a.dtype}")
    if len(a) == 0:
        return a
    packed = np.ascontiguousarray(np.packbits(a, axis=1))
    keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
    _, first = np.unique(keys, return_index=True)
    return a[first]


def minimum_cover(cover: np.ndarray, node_limit: int = NODE_LIMIT
                  ) -> tuple[list[int] | None, int]:
    """The fewest columns of the boolean ``(rows, columns)`` matrix ``cover`` that meet every
    row that some column meets: ``(columns, lower bound)``; columns ``None`` when the program
    was cut by ``node_limit`` before its optimum was proven."""
    from scipy.optimize import Bounds, LinearConstraint, milp

    rows = cover[cover.any(axis=1)]
    if len(rows) == 0:
        return [], 0
    rows = unique_rows(rows)  # atoms blocked by the same faces: one constraint
    cols = np.flatnonzero(rows.any(axis=0))
    a = rows[:, cols].astype(float)
    res = milp(np.ones(len(cols)), constraints=LinearConstraint(a, lb=1.0, ub=np.inf),
               integrality=np.ones(len(cols)), bounds=Bounds(0.0, 1.0),
               options={"node_limit": node_limit, "presolve": True})
    bound = getattr(res, "mip_dual_bound", None)
    lower = int(np.ceil(bound - 1e-6)) if bound is not None and np.isfinite(bound) else 1
    if res.status != 0 or res.x is None:
        return None, lower
    chosen = cols[np.round(res.x) > 0.5].tolist()
    return chosen, len(chosen)
