"""Which parts must be withdrawn, and in what order, before a given part or subassembly can be
removed (``ndbg remove``; the paper's question of the parts to withdraw to free a
subassembly, answered on one NDBG: every withdrawal moves a free set of what is still in
place out along one region).
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..ndbg.dbg import bits
from ..ndbg.model import NDBG
from .andor import Budget
from .plans import Step, axis_step, free_region, pick_region, step_motion


@dataclass
class Removal:
    """Parts to withdraw before ``target`` comes out: ``steps`` are ``(withdrawn set, region)``
    in order, then ``final_region`` frees the target. ``exact``: ``withdrawn`` is a minimum
    (fewest parts; the steps are merged greedily, not proven fewest); otherwise
    ``lower_bound`` bounds the minimum."""

    target: int
    found: bool
    withdrawn: int
    steps: list[tuple[int, int]]
    final_region: int | None
    exact: bool
    lower_bound: int
    explored: int

    def instructions(self, ndbg: NDBG) -> list[Step]:
        """The withdrawals, then the target's removal, as :class:`Step` s (``mask``: the
        parts still in place)."""
        out, left = [], (1 << ndbg.n) - 1
        for w, r in self.steps:
            out.append(Step(mask=left, moved=w, rest=left & ~w, region=r))
            left &= ~w
        if self.final_region is not None:
            out.append(Step(mask=left, moved=self.target, rest=left & ~self.target,
                            region=self.final_region))
        return out

    def section(self, ndbg: NDBG, frees: Callable[[int, int, np.ndarray], bool] | None = None
                ) -> dict:
        """The ``remove`` report. With ``frees`` (the direct sweep test, as for
        :func:`verify`), a step the test frees along the coordinate axis nearest its region's
        direction (within :data:`AXIS_COS`) states that axis, as a verified plan does."""
        steps = self.instructions(ndbg)
        if frees is not None:
            steps = [axis_step(ndbg, s, frees) for s in steps]
        moves = [step_motion(ndbg, s) for s in steps]
        return {
            "target": ndbg.names(self.target), "found": self.found, "exact": self.exact,
            "withdrawn": ndbg.names(self.withdrawn), "count": self.withdrawn.bit_count(),
            "lower_bound": self.lower_bound, "explored_states": self.explored,
            "steps": [{"step": k, "withdraw": ndbg.names(w), **m}
                      for k, ((w, _), m) in enumerate(zip(self.steps, moves), start=1)],
            "final": None if self.final_region is None else moves[-1],
        }


def remove(ndbg: NDBG, target: int, *, base: int | None = None, budget: Budget | None = None
           ) -> Removal:
    """Which parts must be withdrawn, in which order, before subassembly ``target`` (bitmask)
    can be removed, i.e. becomes free along some region of the remaining assembly.

    Each withdrawal moves a free set of the current assembly avoiding the target (and the base)
    out along one region. Exact search: Dijkstra over remaining assemblies ordered by (parts
    withdrawn, steps), up to ``budget.max_nodes`` states, moving one part's closure in one DBG
    per step (``O(n R)`` moves per state, no enumeration of all free sets), which returns a
    minimum set of withdrawn parts; consecutive withdrawals one region frees together are then
    merged into one step (few steps, not proven fewest). Beyond
    the budget, a greedy (withdraw the smallest free set containing a blocker) gives an upper
    bound; ``lower_bound`` is then ``min over regions of |direct blockers of target|`` (the
    final region must have every direct blocker gone).
    """
    budget = budget or Budget()
    full = (1 << ndbg.n) - 1
    keep = target | (0 if base is None else 1 << base)
    lower = min((r.dbg.blockers(target, full).bit_count() for r in ndbg.regions), default=0)
    groups = ndbg.distinct()
    start = full
    heap: list[tuple[int, int, int]] = [(0, 0, start)]
    prev: dict[int, tuple[int, int, int] | None] = {start: None}
    best: dict[int, tuple[int, int]] = {start: (0, 0)}
    done: set[int] = set()
    explored = 0
    while heap and explored < budget.max_nodes:
        cost, nsteps, m = heapq.heappop(heap)
        if m in done:
            continue
        done.add(m)
        explored += 1
        fr = free_region(ndbg, target, m)
        if fr is not None:
            steps = []
            cur = m
            while prev[cur] is not None:
                p_mask, w, r = prev[cur]
                steps.append((w, r))
                cur = p_mask
            steps.reverse()
            return Removal(target, True, full & ~m, _merge_steps(ndbg, full, steps), fr, True,
                           max(lower, cost), explored)
        # Moves: the closure of one part in one DBG (everything it drags along). Any free set
        # is the union of its parts' closures, withdrawn one after the other along the same
        # region, so these moves reach every state with the same number of parts withdrawn.
        moves: dict[int, list[int]] = {}
        for dbg, regs in groups:
            for p in bits(m & ~keep):
                c = dbg.closure(1 << p, m)
                if c & keep or c in moves and moves[c][0] <= regs[0]:
                    continue
                moves[c] = regs
        for moved in sorted(moves):
            nm = m & ~moved
            key = (cost + moved.bit_count(), nsteps + 1)
            if nm not in best or key < best[nm]:
                best[nm] = key
                prev[nm] = (m, moved, pick_region(ndbg, moves[moved]))
                heapq.heappush(heap, (key[0], key[1], nm))
    exhausted = not heap
    if exhausted:
        return Removal(target, False, 0, [], None, True, lower, explored)
    return _remove_greedy(ndbg, target, keep, lower, explored)


def _merge_steps(ndbg: NDBG, full: int, steps: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """Merge consecutive withdrawals that one region frees together (fewer hand motions)."""
    out: list[tuple[int, int]] = []
    m = full
    before = full
    for w, r in steps:
        if out and ndbg.regions[out[-1][1]].dbg.is_free(out[-1][0] | w, before):
            out[-1] = (out[-1][0] | w, out[-1][1])
        else:
            before = m
            out.append((w, r))
        m &= ~w
    return out


def _remove_greedy(ndbg: NDBG, target: int, keep: int, lower: int, explored: int) -> Removal:
    """Goal-directed withdrawal: ``wanted`` starts as the target's direct blockers; withdraw the
    smallest free set (closure in some region) of a wanted part that avoids the target and
    base; when none exists, add the blockers of the wanted parts to ``wanted``."""
    full = (1 << ndbg.n) - 1
    m = full
    steps: list[tuple[int, int]] = []

    def blockers_of(sub: int) -> int:
        out = 0
        for r in ndbg.regions:
            out |= r.dbg.blockers(sub, m)
        return out & ~keep

    wanted = blockers_of(target)
    while True:
        fr = free_region(ndbg, target, m)
        if fr is not None:
            return Removal(target, True, full & ~m, steps, fr, False, lower, explored)
        best = None
        for b in bits(wanted):
            for k, r in enumerate(ndbg.regions):
                c = r.dbg.closure(1 << b, m)
                if c & keep or c == m:
                    continue
                cand = (c.bit_count(), c, -r.dimension, k)
                if best is None or cand < best:
                    best = cand
        if best is None:
            grown = wanted | blockers_of(wanted)
            if grown == wanted:
                return Removal(target, False, full & ~m, steps, None, False, lower, explored)
            wanted = grown
            continue
        steps.append((best[1], best[3]))
        m &= ~best[1]
        wanted = (wanted & m) | blockers_of(target)
