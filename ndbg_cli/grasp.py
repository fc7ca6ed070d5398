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


def grasp(ndbg: NDBG, faces: Sequence[Face], mask: int | None = None, *,
          tol: float = 1e-9) -> dict:
    """Fingers for a prismatic form-closure grasp of order 1 of ``mask`` (default: all parts).

    Returns ``{"value": number of fingers, "fingers": [{"part", "normal", "point",
    "covers"}...], "uncovered": [{"region", "parts"}...], "complete": bool, "why"}``.
    """
    m = (1 << ndbg.n) - 1 if mask is None else mask
    reqs = requirements(ndbg, m)
    # cover[q, f]: finger f holds requirement q (its part in the sink component, d . n > 0)
    part_of = np.array([p for p, _, _ in faces], dtype=np.intp)
    cover = np.zeros((len(reqs), len(faces)), dtype=bool)
    if reqs and faces:
        dirs = np.array([ndbg.regions[k].direction for k, _ in reqs], dtype=float)
        normals = np.array([np.asarray(nv, dtype=float) for _, nv, _ in faces])
        inside = bit_rows([c for _, c in reqs], ndbg.n)
        cover = inside[:, part_of] & (dirs @ normals.T > tol)
    left = np.ones(len(reqs), dtype=bool)
    chosen: list[int] = []
    # most uncovered requirements first; ties: lowest part, then first face
    tie = np.lexsort((np.arange(len(faces)), part_of))
    while left.any() and faces:
        gain = cover[left].sum(axis=0)
        best = int(tie[np.argmax(gain[tie])])
        if gain[best] == 0:
            break
        chosen.append(best)
        left &= ~cover[:, best]
    fingers = []
    for f in chosen:
        part, normal, point = faces[f]
        fingers.append({"part": ndbg.ids[part], "normal": [float(x) for x in normal],
                        "point": None if point is None else [float(x) for x in point],
                        "covers": int(cover[:, f].sum())})
    uncovered = [{"region": reqs[q][0], "parts": ndbg.names(reqs[q][1])}
                 for q in np.flatnonzero(left).tolist()]
    why = (f"{len(fingers)} finger(s) hold every sink component of all "
           f"{len({k for k, _ in reqs})} directional DBGs ({len(reqs)} requirements)")
    if uncovered:
        why = (f"incomplete: {len(uncovered)} (region, sink component) pair(s) have no candidate "
               f"face with positive inner product; {len(fingers)} finger(s) placed")
    return {"value": len(fingers), "fingers": fingers, "uncovered": uncovered,
            "complete": not uncovered, "why": why, "parts": [ndbg.ids[i] for i in bits(m)]}
