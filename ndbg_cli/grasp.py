"""Prismatic form-closure grasp of order 1 (paper section 7.2).

A finger is a point-plane contact on a face of some part, fixed in space: it blocks that part
translating along ``d`` iff ``d . n > 0`` (``n`` the face's outward normal). The grasp must make,
in every DBG of the NDBG, each sink strong component of the condensation (a set of parts that
could translate along ``d`` on its own, the whole product included when it is one component)
contain a part held by a finger with ``d . n > 0``; then no subassembly can translate relative
to the others and the fingers (order 1: one internal motion at a time).

Face data is not in the NDBG, so the caller passes the candidate faces as
``(part index, outward normal, point or None)`` (exterior faces of the parts). The NDBG has no
cell geometry either: coverage is required at every region's representative direction (all
regions, including 1- and 0-dimensional ones; a finger with ``d . n = 0`` does not count), the
finite form of the paper's refinement of the arrangement by the fingers' planes.

Placement is the paper's scan made greedy: the requirements are the pairs (region, sink
component); each step places the finger that covers the most uncovered requirements (ties:
lowest part, then face order). The count is not guaranteed minimal (neither is the paper's).
"""

from __future__ import annotations

import heapq
from collections.abc import Sequence

import numpy as np

from .dbg import bit_rows, bits, condensation
from .ndbg import NDBG

Face = tuple[int, Sequence[float], Sequence[float] | None]


def requirements(ndbg: NDBG, mask: int | None = None) -> list[tuple[int, int]]:
    """``(region, sink component)`` pairs to cover, in region order."""
    m = (1 << ndbg.n) - 1 if mask is None else mask
    out = []
    for k, r in enumerate(ndbg.regions):
        if r.direction is None:
            continue
        comps, comp_succ = condensation(r.dbg, m)
        for c, s in zip(comps, comp_succ):
            if s == 0:
                out.append((k, c))
    return out


#: Largest number of (requirement, candidate face) tests :func:`grasp` makes: the first
#: gains cost one test per requirement and face of a part in its sink component. Beyond it
#: the grasp is not computed (``"skipped"``), as for a display model with 10^5 regions and
#: 10^4 distinct face normals.
GRASP_BUDGET = 2_000_000_000

#: Tests per numpy block when computing gains (bounds memory to ~100 MB).
_BLOCK = 4_000_000


def grasp(ndbg: NDBG, faces: Sequence[Face], mask: int | None = None, *,
          tol: float = 1e-9, budget: int = GRASP_BUDGET) -> dict:
    """Fingers for a prismatic form-closure grasp of order 1 of ``mask`` (default: all parts).

    Returns ``{"value": number of fingers, "fingers": [{"part", "normal", "point",
    "covers"}...], "uncovered": [{"region", "parts"}...], "complete": bool, "why"}``; when
    the first gains would take more than ``budget`` tests, ``{"value": None, "skipped":
    True, "why"}`` instead.

    The greedy choice is made lazily (a heap of gains, each re-counted only when it comes
    to the top: gains only fall as requirements are covered), which picks exactly the
    fingers of the plain greedy scan without its requirements x faces matrix.
    """
    m = (1 << ndbg.n) - 1 if mask is None else mask
    reqs = requirements(ndbg, m)
    part_of = np.array([p for p, _, _ in faces], dtype=np.intp)
    normals = (np.array([np.asarray(nv, dtype=float) for _, nv, _ in faces]) if faces
               else np.zeros((0, ndbg.space_dimension)))
    dirs = np.array([ndbg.regions[k].direction for k, _ in reqs], dtype=float)
    inside = bit_rows([c for _, c in reqs], ndbg.n) if reqs else np.zeros((0, ndbg.n), bool)
    # per part: the requirements whose sink component holds it, and its faces
    holds = {p: np.flatnonzero(inside[:, p]) for p in np.unique(part_of).tolist()}
    by_part = {p: np.flatnonzero(part_of == p) for p in holds}
    work = sum(len(holds[p]) * len(by_part[p]) for p in holds)
    if work > budget:
        return {"value": None, "skipped": True, "fingers": [], "uncovered": [],
                "complete": False, "parts": [ndbg.ids[i] for i in bits(m)],
                "why": (f"skipped: {len(reqs)} (region, sink component) requirements x "
                        f"candidate faces need {work} tests, over the budget of {budget}")}

    def hits(f: int, q: np.ndarray) -> np.ndarray:
        """Requirements among ``q`` that finger ``f`` holds (its part is in each of them)."""
        return q[dirs[q] @ normals[f] > tol]

    gain = np.zeros(len(faces), dtype=np.int64)
    for p, q in holds.items():
        fs = by_part[p]
        if len(q) == 0 or len(fs) == 0:
            continue
        step = max(1, _BLOCK // len(q))
        for s in range(0, len(fs), step):
            gain[fs[s:s + step]] = (dirs[q] @ normals[fs[s:s + step]].T > tol).sum(axis=0)
    # most uncovered requirements first; ties: lowest part, then first face
    rank = np.empty(len(faces), dtype=np.int64)
    rank[np.lexsort((np.arange(len(faces)), part_of))] = np.arange(len(faces))
    heap = [(-int(g), int(r), f) for f, (g, r) in enumerate(zip(gain, rank)) if g > 0]
    heapq.heapify(heap)
    left = np.ones(len(reqs), dtype=bool)
    chosen: list[int] = []
    while heap and left.any():
        neg, r, f = heapq.heappop(heap)
        q = holds[int(part_of[f])]
        got = hits(f, q[left[q]])
        if len(got) == -neg:
            chosen.append(f)
            left[got] = False
        elif len(got):
            heapq.heappush(heap, (-len(got), r, f))
    fingers = []
    for f in chosen:
        part, normal, point = faces[f]
        fingers.append({"part": ndbg.ids[part], "normal": [float(x) for x in normal],
                        "point": None if point is None else [float(x) for x in point],
                        "covers": len(hits(f, holds[part]))})
    uncovered = [{"region": reqs[q][0], "parts": ndbg.names(reqs[q][1])}
                 for q in np.flatnonzero(left).tolist()]
    why = (f"{len(fingers)} finger(s) hold every sink component of all "
           f"{len({k for k, _ in reqs})} directional DBGs ({len(reqs)} requirements)")
    if uncovered:
        why = (f"incomplete: {len(uncovered)} (region, sink component) pair(s) have no candidate "
               f"face with positive inner product; {len(fingers)} finger(s) placed")
    return {"value": len(fingers), "fingers": fingers, "uncovered": uncovered,
            "complete": not uncovered, "why": why, "parts": [ndbg.ids[i] for i in bits(m)]}
