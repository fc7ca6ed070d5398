"""Prismatic form-closure grasp of order 1 (paper section 7.2).

A finger is a point-plane contact on a face of some part, fixed in space: it blocks that part
translating along ``d`` iff ``d . n > 0`` (``n`` the face's outward unit normal). For every
region of the NDBG, each sink strong component of the region's DBG (parts that could translate
on their own, the whole product when it is one component) must hold a part with a finger
blocking the *whole* region (:class:`_Pieces`); then no subassembly can translate relative to
the others and the fingers. Face data is not in the NDBG, so the caller passes the candidate
faces as ``(part index, outward normal, point or None)``. Placement is the paper's scan made
greedy (:func:`grasp`); the count is not guaranteed minimal (neither is the paper's).
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import numpy as np

from ..geometry.vectors import unit
from ..ndbg.dbg import bit_rows, bits, condensation
from ..ndbg.model import NDBG
from .pieces import region_pieces, split_piece

Face = tuple[int, Sequence[float], Sequence[float] | None]



def requirements(ndbg: NDBG, mask: int | None = None) -> list[tuple[int, int]]:
    """``(region, sink component)`` pairs to cover, in region order."""
    m = (1 << ndbg.n) - 1 if mask is None else mask
    out = []
    sinks: dict[tuple[int, ...], list[int]] = {}  # per distinct DBG (far fewer than regions)
    for k, r in enumerate(ndbg.regions):
        if r.direction is None:
            continue
        got = sinks.get(r.dbg.succ)
        if got is None:
            comps, comp_succ = condensation(r.dbg, m)
            got = sinks[r.dbg.succ] = [c for c, s in zip(comps, comp_succ) if s == 0]
        out.extend((k, c) for c in got)
    return out


# ----------------------------------------------------------------------------- the pieces
class _Pieces:
    """Pieces to cover: each a ``(g, dim)`` array of generators and its requirement; the
    flat array of all generators grows as fingers split pieces.

    A region is an open 2D cell, an open arc or a point, and a finger blocks only its open
    half-space ``d . n > 0``: its great circle may cross the region, so covering the
    representative direction is not enough. Each requirement (region, sink component) is held
    over the region's whole extent, cut into convex *pieces*: relatively open convex cones
    given by unit generators (the extreme rays of the closure, in cyclic order): a point, an
    open arc shorter than ``pi``, or an open convex spherical polygon inside an open
    hemisphere (:mod:`ndbg_cli.planning.pieces` makes them). An open piece is the strictly
    positive combinations of its generators, so a finger blocks all of it iff every generator
    has ``g . n >= 0`` and one ``g . n > 0``. A finger whose circle crosses a piece splits it
    (the paper's refinement by the finger's plane): the positive side is covered; the negative
    side and the chord on the circle (``d . n = 0`` does not block) are still to cover. A
    requirement is met when none of its pieces is left."""

    def __init__(self, dim: int):
        self.chunks: list[np.ndarray] = []
        self.start: list[int] = []
        self.req: list[int] = []
        self.weight: list[int] = []
        self._flat = np.zeros((0, dim))
        self._nflat = 0
        # ``start``, ``weight`` and the chunks' sizes as arrays, made again when pieces are
        # added (gather is called per part and finger: converting the lists each time cost
        # O(pieces) per call, seconds on a 36-part rack)
        self._arrays: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def add(self, gens: np.ndarray, req: int, weight: int) -> int:
        self.start.append(self.start[-1] + len(self.chunks[-1]) if self.chunks else 0)
        self.chunks.append(gens)
        self.req.append(req)
        self.weight.append(weight)
        self._arrays = None
        return len(self.req) - 1

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(start, weight, size)`` per piece, as arrays."""
        if self._arrays is None:
            self._arrays = (np.asarray(self.start, dtype=np.int64),
                            np.asarray(self.weight, dtype=np.int64),
                            np.array([len(c) for c in self.chunks], dtype=np.int64))
        return self._arrays

    def gather(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The generators of the pieces ``q``, one piece after the other, and where each
        piece's start."""
        if self._nflat < len(self.chunks):
            self._flat = np.concatenate([self._flat] + self.chunks[self._nflat:])
            self._nflat = len(self.chunks)
        start, _, sizes = self.arrays()
        size = sizes[q]
        seg = (np.cumsum(size) - size).astype(np.int64)
        idx = np.repeat(start[q] - seg, size) + np.arange(size.sum())
        return self._flat[idx], seg


def _tests(gens: np.ndarray, seg: np.ndarray, normals: np.ndarray, tol: float
           ) -> tuple[np.ndarray, np.ndarray]:
    """``(covered, cut)`` ``(pieces, F)``: whether each finger (``normals`` ``(F, dim)``)
    blocks all of each piece (generators ``gens`` from :meth:`_Pieces.gather`), and whether
    its circle crosses it (:class:`_Pieces`, :func:`tolerance`)."""
    if len(seg) == 0:
        return np.zeros((0, len(normals)), bool), np.zeros((0, len(normals)), bool)
    v = gens @ normals.T
    # a piece's largest product is over tol iff one of them is, and its least under -tol iff
    # one is: an "or" of the comparisons per piece (cheaper than a max and a min per piece)
    blocks = np.logical_or.reduceat(v > tol, seg, axis=0)
    low = np.logical_or.reduceat(v < -tol, seg, axis=0)
    return blocks & ~low, blocks & low


# ------------------------------------------------------------------------------ the grasp
#: Largest number of (generator, candidate face) tests :func:`grasp` makes: one per generator
#: of a piece and face of a part in the piece's sink component. When the first gains alone
#: would take more, the grasp is not computed (``"skipped"``); when the greedy placement
#: reaches it, it stops there (incomplete, and the report says so). A count, so the answer
#: does not depend on the machine (rates and example counts in benchmarks/NOTES.md).
GRASP_BUDGET = 100_000_000

#: A requirement's weight in the gains, shared by its region's pieces (so that a region cut
#: into many pieces counts as one; pieces split by a finger keep their weight).
WEIGHT = 1 << 20

#: Tests per numpy block when computing gains (bounds memory to ~100 MB).
_BLOCK = 4_000_000


def tolerance(ndbg: NDBG) -> float:
    """The angular tolerance of ``ndbg``'s sign tests.

    ``tol`` (a cosine; about radians) is the NDBG's own: the infinitesimal family's
    ``angle_tolerance`` (the contact analysis', 1 degree by default in 3D; 1e-6 rad in 2D), the
    infinite family's :data:`ndbg_cli.ndbg.infinite.build.OPEN_TOL` (1e-6 rad). A generator with
    ``|g . n| <= tol`` is on the finger's circle, as the NDBG reads a direction within ``tol``
    of a contact's circle as sliding: a piece is covered when all its generators have
    ``g . n >= -tol`` and one ``g . n > tol`` (a point: ``d . n > tol``), and cut when some
    have ``g . n > tol`` and others ``g . n < -tol``. The directions of a covered piece that the
    finger does not block lie within ``tol / cos(rho)`` of its circle (``rho``: the angular
    radius of a cap holding the piece); everything else is exact for polyhedral parts."""
    from ..core.constants import ANGLE_TOL_RAD, INFINITE
    from ..ndbg.infinite.blocked_sets import OPEN_TOL

    if ndbg.family == INFINITE:
        return OPEN_TOL
    return float(ndbg.stats.get("angle_tolerance", ANGLE_TOL_RAD))


def grasp(ndbg: NDBG, faces: Sequence[Face], mask: int | None = None, *,
          tol: float | None = None, budget: int = GRASP_BUDGET, exact: bool = True) -> dict:
    """Fingers for a prismatic form-closure grasp of order 1 of ``mask`` (default: all parts),
    each requirement held over its region's whole extent (:class:`_Pieces`; ``tol``: the
    angular tolerance, default :func:`tolerance`). Each step places the finger that covers
    the most of what is left wholly, then the most in part (each requirement weighs
    :data:`WEIGHT`, shared by its region's pieces; ties: first part by name, then face order).

    Returns ``{"value": number of fingers, "fingers": [{"part", "normal", "point", "covers",
    "covers_part"}...], "uncovered": [{"region", "parts", "direction"}...], "complete": bool,
    "coverage": "regions" | "representatives", "why", "parts"}``: ``covers`` counts the
    requirements a finger blocks wholly on its own, ``covers_part`` those it blocks in part;
    ``direction`` is one direction of the region that no finger on those parts blocks. When
    the first gains would take more than ``budget`` tests, ``{"value": None, "skipped":
    True, "why"}`` instead; when the placement's tests pass ``budget``, it stops there
    (``complete`` False, the ``why`` says so).

    The greedy choice is made lazily: a heap of upper bounds of the gains (a piece a finger
    splits may become wholly coverable by another, so the bounds of the fingers on its parts
    are raised by what they get from the new pieces), each re-counted when it comes to the
    top, which picks the fingers of the plain greedy scan without its pieces x faces matrix.

    With ``exact`` (default) the fingers are then those of the exact minimum over the same
    faces (:mod:`ndbg_cli.planning.grasp_exact`: the same count in any frame and part order)
    where its problem is small enough, and ``exact``, ``lower_bound``, ``upper_bound`` say
    which count it is; ``exact=False`` keeps the greedy placement (its tests use it).
    """
    m = (1 << ndbg.n) - 1 if mask is None else mask
    tol = tolerance(ndbg) if tol is None else float(tol)
    reqs = requirements(ndbg, m)
    extents = region_pieces(ndbg) if reqs else None
    coverage = "representatives" if extents is None else "regions"
    pieces = _Pieces(ndbg.space_dimension)
    for q, (k, _) in enumerate(reqs):
        ext = (extents[k] if extents is not None
               else [np.asarray(ndbg.regions[k].direction, float)[None]])
        for g in ext:
            pieces.add(np.asarray(g, float), q, WEIGHT // len(ext))
    greedy = _Greedy(ndbg, faces, reqs, pieces, tol)
    if greedy.work > budget:
        return {"value": None, "skipped": True, "fingers": [], "uncovered": [],
                "complete": False, "parts": [ndbg.ids[i] for i in bits(m)],
                "why": (f"skipped: {len(reqs)} (region, sink component) requirements in "
                        f"{greedy.n0} pieces x candidate faces need {greedy.work} tests, over "
                        f"the budget of {budget}")}
    stopped = greedy.run(budget)
    best = _exact(greedy) if exact and not stopped else None
    return _summary(ndbg, m, greedy, coverage, budget, stopped, best)


#: Most (generator, face) tests of the first gains for which :func:`grasp` also seeks the
#: exact minimum (:mod:`ndbg_cli.planning.grasp_exact`); above it the greedy count is kept,
#: reported as an upper bound. The examples need at most a few hundred thousand.
EXACT_WORK = 5_000_000


def _exact(greedy: _Greedy) -> tuple[list[int] | None, int] | None:
    """The fewest faces that hold what the greedy placement holds, ``(faces, lower
    bound)`` (faces ``None``: the program was cut), or ``None`` when the problem is over
    :data:`EXACT_WORK` or its refinement over the atom budget. The greedy's order of ties
    depends on the frame and the part order; this minimum does not."""
    from .grasp_exact import atoms, blocked, minimum_cover

    if not greedy.chosen or greedy.work > EXACT_WORK:
        return None
    usable = greedy.inside[:, greedy.part_of]  # (requirement, face): a face of its component
    first = [(greedy.pieces.chunks[i], greedy.pieces.req[i]) for i in range(greedy.n0)]
    got = atoms(first, greedy.normals, usable, greedy.tol)
    if got is None:
        return None
    cells, req = got
    cover = blocked(cells, greedy.normals, greedy.tol) & usable[np.asarray(req, dtype=np.intp)]
    return minimum_cover(cover)


class _Greedy:
    """The state of :func:`grasp`'s lazy greedy placement: the pieces still to hold, the
    faces' gain bounds in a heap, and the fingers chosen."""

    def __init__(self, ndbg: NDBG, faces: Sequence[Face], reqs: list[tuple[int, int]],
                 pieces: _Pieces, tol: float) -> None:
        self.ndbg, self.faces, self.reqs, self.pieces, self.tol = ndbg, faces, reqs, pieces, tol
        self.n0 = len(pieces.req)
        self.part_of = np.array([p for p, _, _ in faces], dtype=np.intp)
        self.normals = (np.array([np.asarray(nv, dtype=float) for _, nv, _ in faces]) if faces
                        else np.zeros((0, ndbg.space_dimension)))
        self.inside = (bit_rows([c for _, c in reqs], ndbg.n) if reqs
                       else np.zeros((0, ndbg.n), bool))
        self.piece_req = np.asarray(pieces.req, dtype=np.intp)
        # per part: the pieces whose requirement's sink component holds it, and its faces
        self.holds = {p: np.flatnonzero(self.inside[self.piece_req, p])
                      for p in np.unique(self.part_of).tolist()}
        self.by_part = {p: np.flatnonzero(self.part_of == p) for p in self.holds}
        size = np.array([len(c) for c in pieces.chunks], dtype=np.int64)
        self.work = sum(int(size[self.holds[p]].sum()) * len(self.by_part[p])
                        for p in self.holds)
        self.alive = np.ones(self.n0, dtype=bool)
        self.bound = np.zeros((len(faces), 2), dtype=np.int64)  # gains (covered, cut), or more
        self.taken = np.zeros(len(faces), dtype=bool)
        # most pieces covered wholly first, then cut; ties: the part first by name (not by
        # index: the count must not follow the parts' order), then its first face
        name_rank = np.argsort(np.argsort(np.array(ndbg.ids, dtype=object), kind="stable"))
        self.rank = np.empty(len(faces), dtype=np.int64)
        self.rank[np.lexsort((np.arange(len(faces)), name_rank[self.part_of]))] = \
            np.arange(len(faces))
        self.heap: list[tuple[int, int, int, int]] = []
        self.exact: dict[int, bool] = {}
        self.spent = 0  # tests made (the first gains are the work counted above)
        self.chosen: list[int] = []

    def recount(self, p: int) -> None:
        """Exact gains of all of part ``p``'s faces (in blocks); queued again where they
        rose (a queued key bounds its face's gain from above)."""
        q = self.holds[p] = self.holds[p][self.alive[self.holds[p]]]
        fs = self.by_part[p][~self.taken[self.by_part[p]]]
        got = np.zeros((len(fs), 2), dtype=np.int64)
        if len(q) and len(fs):
            gens, seg = self.pieces.gather(q)
            wq = self.pieces.arrays()[1][q]
            step = max(1, _BLOCK // len(gens))
            self.spent += len(gens) * len(fs)
            for s in range(0, len(fs), step):
                cov, cut = _tests(gens, seg, self.normals[fs[s:s + step]], self.tol)
                got[s:s + step] = np.column_stack([wq @ cov, wq @ cut])
        old = self.bound[fs]
        up = (got[:, 0] > old[:, 0]) | ((got[:, 0] == old[:, 0]) & (got[:, 1] > old[:, 1]))
        self.bound[fs] = got
        for f, w, c in zip(fs[up].tolist(), got[up, 0].tolist(), got[up, 1].tolist()):
            heapq.heappush(self.heap, (-w, -c, int(self.rank[f]), f))
        self.exact[p] = True

    def run(self, budget: int) -> bool:
        """Place fingers until every piece is held or no face gains; True when the budget
        of tests stopped it first."""
        for p in self.holds:
            self.recount(p)
        while self.heap and self.alive.any():
            if self.spent > budget:
                return True
            neg_w, neg_c, r, f = heapq.heappop(self.heap)
            if self.taken[f]:
                continue
            p = int(self.part_of[f])
            if not self.exact[p]:
                self.recount(p)
            w, c = int(self.bound[f, 0]), int(self.bound[f, 1])
            if (w, c) != (-neg_w, -neg_c):  # a stale key: queue the face's current gain
                if w or c:
                    heapq.heappush(self.heap, (-w, -c, r, f))
                continue
            # an exact gain on top: no other face gains more (every key bounds its face's gain)
            self.place(f, p)
        return False

    def place(self, f: int, p: int) -> None:
        """Take face ``f`` (of part ``p``): the pieces it holds wholly or in part are done,
        those it cuts leave their unblocked remainders as new pieces."""
        self.chosen.append(f)
        self.taken[f] = True
        q = self.holds[p]
        cov, cut = (x[:, 0] for x in _tests(*self.pieces.gather(q), self.normals[f][None],
                                             self.tol))
        self.alive[q[cov | cut]] = False
        for pp in np.flatnonzero(self.inside[self.piece_req[q[cov | cut]]].any(axis=0)).tolist():
            self.exact[pp] = False
        new: list[int] = []
        for i in q[cut].tolist():
            g = self.pieces.chunks[i]
            new += [self.pieces.add(h, self.pieces.req[i], self.pieces.weight[i])
                    for h in split_piece(g, g @ self.normals[f], self.tol)]
        if new:  # new pieces may raise other faces' gains: re-count their parts now
            self.alive = np.r_[self.alive, np.ones(len(new), dtype=bool)]
            self.piece_req = np.asarray(self.pieces.req, dtype=np.intp)
            new_a = np.array(new)
            for pp in self.holds:
                mine = new_a[self.inside[self.piece_req[new_a], pp]]
                if len(mine):
                    self.holds[pp] = np.r_[self.holds[pp], mine]
                    self.recount(pp)

    def finger(self, f: int) -> dict:
        """The report record of chosen face ``f``: how many requirements it holds wholly on
        its own (``covers``) and in part (``covers_part``)."""
        part, normal, point = self.faces[f]
        q = np.flatnonzero(self.inside[self.piece_req[:self.n0], part])
        cov, cut = (x[:, 0] for x in _tests(*self.pieces.gather(q), self.normals[f][None],
                                             self.tol))
        n = len(self.reqs)
        per = np.bincount(self.piece_req[q], minlength=n)
        whole = np.bincount(self.piece_req[q], weights=cov, minlength=n)
        some = np.bincount(self.piece_req[q], weights=cov | cut, minlength=n)
        n_whole = int(((per > 0) & (whole == per)).sum())
        return {"part": self.ndbg.ids[part], "normal": [float(x) for x in normal],
                "point": None if point is None else [float(x) for x in point],
                "covers": n_whole, "covers_part": int((some > 0).sum()) - n_whole}


def _summary(ndbg: NDBG, m: int, greedy: _Greedy, coverage: str, budget: int,
             stopped: bool, exact: tuple[list[int] | None, int] | None = None) -> dict:
    """:func:`grasp`'s result from a finished (or stopped) placement, with the exact
    minimum's fingers in place of the greedy's where it was found."""
    reqs, pieces = greedy.reqs, greedy.pieces
    upper = len(greedy.chosen)
    best = exact[0] if exact is not None else None
    # the exact minimum where found, even above the greedy count: the greedy held open
    # pieces only, and may leave directions on their boundaries free (grasp_exact)
    chosen = greedy.chosen if best is None else best
    fingers = [greedy.finger(f) for f in chosen]
    left: dict[int, int] = {}
    for i in np.flatnonzero(greedy.alive).tolist():
        left.setdefault(pieces.req[i], i)
    uncovered = [{"region": reqs[q][0], "parts": ndbg.names(reqs[q][1]),
                  "direction": [float(x) for x in unit(pieces.chunks[i].sum(axis=0))]}
                 for q, i in sorted(left.items())]
    where = ("over each region's whole extent" if coverage == "regions" else
             "at each region's representative direction only (no region geometry)")
    why = (f"{len(fingers)} finger(s) hold every sink component of all "
           f"{len({k for k, _ in reqs})} directional DBGs ({len(reqs)} requirements) {where}")
    if stopped:
        why = (f"incomplete: the budget of {budget:,} face tests ran out after "
               f"{len(fingers)} finger(s), {len(uncovered)} (region, sink component) pair(s) "
               f"not yet held ({where})")
    elif uncovered:
        why = (f"incomplete: {len(uncovered)} (region, sink component) pair(s) have directions "
               f"no candidate face blocks ({where}); {len(fingers)} finger(s) placed")
    out = {"value": len(fingers), "fingers": fingers, "uncovered": uncovered,
           "complete": not uncovered, "coverage": coverage, "why": why,
           "parts": [ndbg.ids[i] for i in bits(m)]}
    if not stopped:
        bounds = _bounds(len(fingers), upper, exact)
        out["why"] += f" ({bounds.pop('minimum')})"
        out.update(bounds)
    return out


def _bounds(value: int, upper: int, exact: tuple[list[int] | None, int] | None) -> dict:
    """``exact``, ``lower_bound``, ``upper_bound`` of the finger count over the candidate
    faces, and what the ``why`` adds: the minimum (exact, the same in any frame and part
    order), or the greedy count with the bound the integer program proved (not exact: its
    placement's ties depend on the frame)."""
    if exact is not None and exact[0] is not None:
        return {"exact": True, "lower_bound": value, "upper_bound": value,
                "minimum": ("exact minimum over the candidate faces, every region held up to "
                            f"its boundary; a greedy placement took {upper}")}
    lower = max(1, exact[1]) if exact is not None and value else min(value, 1)
    why = ("greedy: an upper bound" if exact is None else
           "greedy: an upper bound (the exact minimum's integer program was cut)")
    return {"exact": False, "lower_bound": min(lower, value), "upper_bound": value,
            "minimum": why}
