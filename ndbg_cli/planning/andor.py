"""The AND/OR graph of all candidate assembly algorithms (paper section 7.2).

Nodes are the distinct subassemblies (part bitmasks) reachable from the whole product by
candidate partitionings; a node's hyperarcs are its candidate partitionings ``{S, M \\ S}``,
each listed once however many regions make it free. :class:`AndOrGraph` builds it
breadth-first with memoization and an explicit, machine-independent :class:`Budget`; when
the budget stops the build the exact counts are ``None`` and :func:`greedy_tree` (or
:func:`classes.min_depth_search`) gives anytime answers.
"""

from __future__ import annotations

import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..core.constants import WORK_LIMIT
from ..core.gc_pause import gc_paused
from ..core.memo import kept
from ..core.pools import Helper, spare_workers
from ..ndbg.candidates import connected_free_sets
from ..ndbg.components import balanced_free_set, condense, free_sets, strongly_connected
from ..ndbg.dbg import bits, closure_table
from ..ndbg.model import NDBG, ConnectivityTest

#: Search nodes per subassembly for its contact-connected partitionings (with a
#: ``split_limit``; see :func:`node_splits`). The search costs a few nodes per set found;
#: on sparse random DBGs over grid-like contact graphs, where most connected sets leave a
#: split rest, it costs far more (benchmarks/NOTES.md).
CONNECTED_SEARCH = 20_000
#: :meth:`AndOrGraph.build` with ``Budget.workers`` over 1 starts its :class:`Helper` once
#: this many subassemblies wait and a process is spare (not while the side job of the
#: interlock LP and the grasps still works: :func:`~ndbg_cli.core.pools.spare_workers`),
#: then expands them this many at a time (half there): a stop mid-batch wastes at most one
#: batch.
HELPER_QUEUE = 16
BATCH = 32


@dataclass(frozen=True)
class Budget:
    """Limits of a search: nodes (for :meth:`AndOrGraph.build`, subassemblies seen; for the
    anytime searches, subassemblies expanded), work units (:data:`WORK_LIMIT`), partitionings
    per node, and wall-clock seconds (``None`` by default: a search cut by the clock gives
    answers that depend on the machine's speed and load, so a report would not be
    reproducible; the node and work counts are)."""

    max_nodes: int = 200_000
    time_limit: float | None = None
    split_limit: int | None = 5_000
    max_work: int | None = WORK_LIMIT
    #: processes :meth:`AndOrGraph.build` may use (a second one is a :class:`Helper`); the
    #: graph does not depend on it
    workers: int = 1

    def meter(self) -> Meter:
        """A fresh :class:`Meter` for one search under this budget."""
        return Meter(self)


class Meter:
    """The work one search has spent (:data:`WORK_LIMIT`'s units) and its deadline when the
    budget has a time limit."""

    __slots__ = ("budget", "work", "deadline")

    def __init__(self, budget: Budget) -> None:
        self.budget = budget
        self.work = 0
        self.deadline = (None if budget.time_limit is None
                         else time.perf_counter() + budget.time_limit)

    def charge(self, units: int) -> None:
        self.work += units

    def spent(self) -> str | None:
        """``"work"`` or ``"time"`` when the search must stop, else ``None``."""
        if self.budget.max_work is not None and self.work > self.budget.max_work:
            return "work"
        if self.deadline is not None and time.perf_counter() > self.deadline:
            return "time"
        return None


class Hyperarc(NamedTuple):
    """A candidate partitioning of ``node`` into ``left`` (the side holding the lowest part of
    ``node``) and ``right``; ``moves`` lists each admissible orientation as ``(moved side,
    regions where it is free)``, sorted by moved mask. (A named tuple: the AND/OR graph of a
    product holds millions of them.)"""

    node: int
    left: int
    right: int
    moves: tuple[tuple[int, tuple[int, ...]], ...]

    @property
    def linear(self) -> bool:
        """Whether one side is a single part (a linear instruction)."""
        return self.left.bit_count() == 1 or self.right.bit_count() == 1

    @property
    def balance(self) -> int:
        """Size of the larger side (smaller is more balanced)."""
        return max(self.left.bit_count(), self.right.bit_count())


def contains(big: NDBG, small: NDBG) -> bool:
    """Whether every DBG of ``small`` is a DBG of ``big`` (same parts): then every candidate
    partitioning of every subassembly under ``small`` is one under ``big`` (e.g. the
    generalized hybrid NDBG holds the infinitesimal-translation regions)."""
    if big.ids != small.ids:
        return False
    have = {r.dbg.succ for r in big.regions}
    return all(r.dbg.succ in have for r in small.regions)


class _Groups:
    """The distinct DBGs of an NDBG, grouped per subassembly by their induced DBG.

    Regions with equal DBGs are merged once (:meth:`NDBG.distinct`); for ``n <= 64`` parts
    the DBGs are rows of a ``(D, n)`` ``uint64`` array, and the DBGs induced on a mask are
    grouped by a hash of the masked rows, checked exactly against each group's first row (a
    collision falls back to exact tuples). Built once per NDBG (:func:`_groups_of`)."""

    def __init__(self, ndbg: NDBG) -> None:
        dist = ndbg.distinct()
        self.succ = [d.succ for d, _ in dist]
        self.regions = [regs for _, regs in dist]
        self.mat = None
        if 0 < ndbg.n <= 64 and dist:
            self.mat = np.array(self.succ, dtype=np.uint64)
            rng = np.random.default_rng(0x9E3779B9)
            self.weights = rng.integers(1, 2**63, size=ndbg.n, dtype=np.uint64) | np.uint64(1)

    def of(self, mask: int) -> list[tuple[tuple[int, ...], list[int]]]:
        """``(succ of a representative DBG, its region ids sorted)`` per distinct DBG induced
        on ``mask``, in order of first region."""
        if self.mat is None or len(self.succ) == 1:
            return self._exact(mask)
        idx = np.fromiter(bits(mask), dtype=np.intp)
        sub = self.mat[:, idx] & np.uint64(mask)
        h = (sub * self.weights[idx]).sum(axis=1)  # wraps modulo 2**64 (a hash)
        _, first, inv = np.unique(h, return_index=True, return_inverse=True)
        if not np.array_equal(sub, sub[first[inv]]):
            return self._exact(mask)  # a hash collision: never seen, but stay exact
        out = []
        for g in np.argsort(first, kind="stable").tolist():
            members = np.flatnonzero(inv == g).tolist()
            regs = list(self.regions[members[0]]) if len(members) == 1 else \
                sorted(k for d in members for k in self.regions[d])
            out.append((self.succ[members[0]], regs))
        return out

    def _exact(self, mask: int) -> list[tuple[tuple[int, ...], list[int]]]:
        groups: dict[tuple[int, ...], list[int]] = {}
        first: dict[tuple[int, ...], int] = {}
        for d, succ in enumerate(self.succ):
            key = tuple([succ[i] & mask for i in bits(mask)])
            first.setdefault(key, d)
            groups.setdefault(key, []).extend(self.regions[d])
        return [(self.succ[first[key]], sorted(regs)) for key, regs in groups.items()]


def _groups_of(ndbg: NDBG) -> _Groups:
    """The :class:`_Groups` of ``ndbg``, kept on the (frozen) instance after the first call."""
    return kept(ndbg, "_andor_groups", lambda: _Groups(ndbg))


def node_splits(ndbg: NDBG, mask: int, *, base: int | None = None,
                connected: ConnectivityTest | None = None,
                limit: int | None = None, avoid: int = 0, meter: Meter | None = None
                ) -> tuple[list[Hyperarc], bool]:
    """The hyperarcs of subassembly ``mask``: candidate partitionings ``{S, mask - S}`` (``S``
    free in the DBG of some region induced on ``mask``) merged by unordered pair, regions
    grouped by identical induced DBG. With ``base`` (a part index) in ``mask``, only
    orientations whose moved side leaves the base (and every part of ``avoid``) out are kept;
    with ``connected`` both sides must pass the test. At most ``limit`` distinct moved sets
    are collected; the parts' minimal free sets (their closures in each DBG) are collected
    first, after a near-balanced free set of each DBG
    (:func:`~ndbg_cli.ndbg.components.balanced_free_set`), so a cut list holds them as far as
    ``limit`` allows (all of them unless there are more than ``limit``), and the greedy and
    deepening searches keep the shallow trees and the linear moves. The work
    done is charged to ``meter`` (:data:`WORK_LIMIT`'s units). Returns ``(hyperarcs sorted by
    (balance, left), truncated)``."""
    if mask.bit_count() < 2:
        return [], False
    groups = _groups_of(ndbg).of(mask)
    # parts that never move: the base, and ``avoid`` (e.g. a target kept in place)
    base_bit = ((0 if base is None else 1 << base) | avoid) & mask
    found: dict[int, list[int]] = {}
    truncated = False

    def ok(s: int) -> bool:
        return connected is None or (connected(s) and connected(mask & ~s))

    # the DBGs with a proper free set (not one strong component), and their closures
    live = [(succ, regs) for succ, regs in groups if not strongly_connected(succ, mask)]
    closures: list[dict[int, int] | None] = [None] * len(live)
    condensed: list | None = None  # each live DBG's condensation, when the cut list made it
    if limit is not None:
        # First a near-balanced free set of each DBG (the least deep trees need them; on a
        # product of hundreds of parts the enumeration below reaches the limit long before),
        # grown along the contact graph when both sides must be connected.
        half = mask.bit_count() // 2
        near = None if connected is None else connected.neighbours
        condensed = [condense(succ, mask) for succ, _ in live]
        for (_, regs), cond in zip(live, condensed):
            s = balanced_free_set(*cond, half, avoid=base_bit, neighbours=near)
            if s in found:
                found[s].extend(regs)
            elif s and len(found) < limit and ok(s):
                found[s] = list(regs)
        # Then every part's minimal free set (its closure) in every DBG (up to ``limit``), so
        # the greedy and deepening searches keep the linear moves.
        for k, (succ, regs) in enumerate(live):
            closures[k] = closure = closure_table(succ, mask)
            for i in bits(mask & ~base_bit):
                c = closure[i]
                if c == mask or c & base_bit:
                    continue
                if c in found:
                    found[c].extend(regs)
                elif len(found) < limit and ok(c):
                    found[c] = list(regs)
    # With the connectivity test, only the sets with both sides connected are searched
    # (candidates.connected_free_sets, polynomial per set found, within a search budget per
    # node); the list is cut when a new set finds it full, or when that budget runs out.
    left = [CONNECTED_SEARCH if limit is not None else 1 << 62]
    searched = left[0]
    for k, ((succ, regs), closure) in enumerate(zip(live, closures)):
        sets = free_sets(*(condensed[k] if condensed else condense(succ, mask)),
                         avoid=base_bit) if connected is None else \
            connected_free_sets(succ, connected.neighbours, mask, left, avoid=base_bit,
                                down=closure)
        for s in sets:
            if s == 0 or s == mask or s & base_bit:
                continue
            got = found.get(s)
            if got is None:
                if limit is not None and len(found) >= limit:
                    truncated = True
                    break
                found[s] = got = []
            got.extend(regs)
        if left[0] < 0:
            truncated = True
        if truncated:
            break
    if meter is not None:
        meter.charge(len(groups) + sum(map(len, found.values()))
                     + (searched - max(left[0], 0) if connected is not None else 0))
    return _hyperarcs(mask, found), truncated


def _splits(context: tuple, mask: int) -> tuple[list[Hyperarc], bool, int]:
    """:func:`node_splits` of ``mask`` with ``context`` ``(ndbg, base, connected, limit)``:
    ``(hyperarcs, truncated, work units spent)``."""
    ndbg, base, connected, limit = context
    meter = Meter(Budget(max_work=None))
    arcs, trunc = node_splits(ndbg, mask, base=base, connected=connected, limit=limit,
                              meter=meter)
    return arcs, trunc, meter.work


def _hyperarcs(mask: int, found: dict[int, list[int]]) -> list[Hyperarc]:
    """Moved sets merged by unordered pair into hyperarcs, sorted by ``(balance, left)``."""
    low = mask & -mask
    merged: dict[int, dict[int, tuple[int, ...]]] = {}
    for s, regs in found.items():
        left = s if s & low else mask & ~s
        merged.setdefault(left, {})[s] = tuple(sorted(set(regs)))
    arcs = [Hyperarc(mask, left, mask & ~left, tuple(sorted(moves.items())))
            for left, moves in merged.items()]
    arcs.sort(key=lambda h: (h.balance, h.left))
    return arcs


class AndOrGraph:
    """Lazily built, memoized AND/OR graph of the candidate algorithms of ``mask`` (default: the
    whole product). Call :meth:`build` to expand everything reachable within ``budget``
    (``max_nodes`` subassemblies seen, ``max_work`` units, ``split_limit`` partitionings per
    node, optional ``time_limit`` seconds; :attr:`cut_by` says which one stopped it,
    :meth:`cut_reason` in words). When it stops the build, ``truncated`` is set.

    What is counted (exact Python ints):

    * ``min_depth``: the minimum height of a candidate assembly tree (a single part: 0);
    * ``tree_count``: distinct binary decomposition trees whose every internal node is a
      candidate partitioning, children unordered (moving side and region ignored);
    * ``linear_count``: orderings ``(p1, ..., pn)`` such that for every ``k >= 2``
      ``{{p_k}, {p1..p_k-1}}`` is a candidate partitioning of ``{p1..p_k}``; both orders of the
      first two parts are counted (distinct linear sequences: half of it, for ``n >= 2``);
    * ``min_nonlinear``: the minimum number of nonlinear instructions (neither side a single
      part) over all candidate trees; 0 iff the product is linearizable."""

    def __init__(self, ndbg: NDBG, mask: int | None = None, *, base: int | None = None,
                 connected: ConnectivityTest | None = None, budget: Budget | None = None):
        self.ndbg = ndbg
        self.root = (1 << ndbg.n) - 1 if mask is None else mask
        self.base = base
        self.connected = connected
        self.budget = budget or Budget()
        self.arcs: dict[int, list[Hyperarc]] = {}
        self.truncated = False
        self.split_truncated = False
        self.elapsed = 0.0
        #: work units the build spent (:data:`WORK_LIMIT`)
        self.work = 0
        #: (subassemblies, hyperarcs) when :meth:`build` ended
        self.built_size = (0, 0)
        #: why :meth:`build` stopped early: ``"nodes"`` (more subassemblies than
        #: ``max_nodes``), ``"work"`` (``max_work``), ``"time"`` (``time_limit``), ``"splits"``
        #: (a node's partitionings were cut at ``split_limit``), or ``None``
        self.cut_by: str | None = None
        self.cut_from: AndOrGraph | None = None
        self._built = False

    def expand(self, mask: int, meter: Meter | None = None,
               splits: tuple[list[Hyperarc], bool, int] | None = None) -> list[Hyperarc]:
        """The hyperarcs of ``mask`` (memoized; the work of computing them is charged to
        ``meter``, the calling search's). ``splits``: :func:`_splits` of ``mask``, when the
        caller has it."""
        got = self.arcs.get(mask)
        if got is None:
            got, trunc, work = splits or _splits(self._context, mask)
            if meter is not None:
                meter.charge(work)
            self.split_truncated |= trunc
            self.truncated |= trunc
            self.arcs[mask] = got
        return got

    @property
    def _context(self) -> tuple:
        return self.ndbg, self.base, self.connected, self.budget.split_limit

    @gc_paused()
    def build(self) -> AndOrGraph:
        """Expand every node reachable from the root, breadth-first (larger subassemblies
        first, the ones the anytime searches ask for when the graph is cut), within the
        budget. The node budget counts every subassembly seen: a graph with more than
        ``max_nodes`` of them cannot be completed, and breadth-first order sees that early."""
        if self._built:
            return self
        start = time.perf_counter()
        meter = self.budget.meter()
        queue = deque([self.root])
        seen = {self.root}
        helper = None
        try:
            while queue:
                if (helper is None and len(queue) >= HELPER_QUEUE
                        and spare_workers(self.budget.workers) > 0):
                    helper = Helper(_splits, self._context)
                batch = [queue.popleft() for _ in range(min(len(queue), BATCH if helper else 1))]
                if not self._grow(batch, self._batch_splits(batch, helper), meter, seen, queue):
                    break
        finally:
            if helper is not None:
                helper.close()
        self.elapsed = time.perf_counter() - start
        self.work = meter.work
        # the size the build reached (the anytime searches may expand more nodes later)
        self.built_size = (self.node_count, self.hyperarc_count)
        self._built = True
        self._dp: dict[str, dict[int, int | None]] = {}
        return self

    def _batch_splits(self, batch: list[int], helper: Helper | None) -> list:
        """:func:`_splits` of the nodes of ``batch`` not expanded yet (else None), half of
        them computed by ``helper`` meanwhile."""
        todo = [m for m in batch if m not in self.arcs]
        # every other node there (neighbours in the queue cost alike)
        got = (helper.share(todo) if helper is not None
               else [_splits(self._context, m) for m in todo])
        found = dict(zip(todo, got))
        return [found.get(m) for m in batch]

    def _grow(self, batch: list[int], splits: list, meter: Meter, seen: set[int],
              queue: deque) -> bool:
        """The nodes of ``batch`` expanded in order (their ``splits``), as one at a time
        would: before each, the budget checked; after it, its children queued. False when
        the build must stop."""
        for m, got in zip(batch, splits):
            # every subassembly seen must be expanded: more than max_nodes of them can
            # never make a complete graph, so stop at once (deterministic, unlike the clock)
            if len(seen) > self.budget.max_nodes or len(self.arcs) >= self.budget.max_nodes:
                self.truncated, self.cut_by = True, "nodes"
                return False
            why = meter.spent()
            if why is not None:
                self.truncated, self.cut_by = True, why
                return False
            arcs = self.expand(m, meter, got)
            if self.split_truncated:
                # A node's partitionings were cut: the graph cannot be complete, so the
                # exact counts are out of reach; stop now and leave the rest to the
                # anytime searches.
                self.truncated, self.cut_by = True, "splits"
                return False
            for h in arcs:
                for child in (h.right, h.left):
                    if child not in seen:
                        seen.add(child)
                        queue.append(child)
        return True

    # ------------------------------------------------------------------ exact measures
    @property
    def complete(self) -> bool:
        return self._built and not self.truncated

    @property
    def cut_by_size(self) -> bool:
        """Whether the build stopped on the graph's size (more subassemblies, or more
        partitionings at one of them, than the budget allows; or as the supergraph of such a
        graph): a fact about the graph, unlike a cut by the clock."""
        return self.cut_by in ("nodes", "splits", "supergraph")

    def cut_as_supergraph_of(self, other: AndOrGraph) -> AndOrGraph:
        """Mark this graph truncated without building it, when ``other`` (built, truncated,
        same root, base and filter) is a subgraph of it: every DBG of ``other``'s NDBG is one
        of this NDBG's (:func:`contains`), so each node of ``other`` is a node here with at
        least its partitionings, and a size budget that cut ``other`` (``cut_by`` ``"nodes"``,
        ``"splits"`` or ``"supergraph"``: more subassemblies, or more partitionings at one
        of them, than the same budget allows) cuts this one too. Not for a cut by the clock,
        which proves nothing. Hyperarcs are still expanded on demand by the anytime
        searches."""
        if not other.cut_by_size:
            raise ValueError(f"not cut by its size: {other.cut_by!r}")
        self.truncated, self.cut_by, self.cut_from = True, "supergraph", other
        self._built = True
        self._dp = {}
        return self

    def cut_reason(self) -> str:
        """Why the graph is truncated, in words that do not depend on the machine's speed
        (the number of nodes expanded before a time limit would)."""
        b = self.budget
        if self.cut_by == "nodes":
            return f"AND/OR graph has over {b.max_nodes} subassemblies (--max-nodes)"
        if self.cut_by == "work":
            return f"AND/OR graph cut by the work budget ({b.max_work:,} units)"
        if self.cut_by == "time":
            return f"AND/OR graph cut by the time limit ({b.time_limit:g} s)"
        if self.cut_by == "supergraph":
            return (f"AND/OR graph not built: it contains the {self.cut_from.ndbg.family} one, "
                    f"which was cut ({self.cut_from.cut_reason()})")
        if self.cut_by == "splits" or self.split_truncated:
            return f"a subassembly has over {b.split_limit} candidate partitionings"
        return "AND/OR graph not built"

    @property
    def node_count(self) -> int:
        """Distinct subassemblies in the graph (expanded nodes, single parts included)."""
        return len(self.arcs)

    @property
    def hyperarc_count(self) -> int:
        return sum(len(v) for v in self.arcs.values())

    def _order(self) -> list[int]:
        return sorted(self.arcs, key=lambda m: (m.bit_count(), m))

    def _table(self, name: str, leaf: int,
               combine: Callable[[Hyperarc, dict[int, int | None]], int | None],
               reduce: Callable[[list[int]], int]) -> dict[int, int | None]:
        if not self.complete:
            raise RuntimeError("AND/OR graph is truncated or not built")
        if name in self._dp:
            return self._dp[name]
        val: dict[int, int | None] = {}
        for m in self._order():
            if m.bit_count() == 1:
                val[m] = leaf
                continue
            cands = [c for c in (combine(h, val) for h in self.arcs[m]) if c is not None]
            val[m] = reduce(cands) if cands else None
        self._dp[name] = val
        return val

    def depths(self) -> dict[int, int | None]:
        """Minimum tree height of every node (``None``: no candidate algorithm)."""
        def comb(h: Hyperarc, v: dict[int, int | None]) -> int | None:
            a, b = v[h.left], v[h.right]
            return None if a is None or b is None else 1 + max(a, b)
        return self._table("depth", 0, comb, min)

    def tree_counts(self) -> dict[int, int | None]:
        def comb(h: Hyperarc, v: dict[int, int | None]) -> int | None:
            return (v[h.left] or 0) * (v[h.right] or 0)
        t = self._table("trees", 1, comb, sum)
        return {m: (c or 0) for m, c in t.items()}

    def linear_counts(self) -> dict[int, int | None]:
        def comb(h: Hyperarc, v: dict[int, int | None]) -> int | None:
            total = 0
            if h.left.bit_count() == 1:
                total += v[h.right] or 0
            if h.right.bit_count() == 1:
                total += v[h.left] or 0
            return total
        t = self._table("linear", 1, comb, sum)
        return {m: (c or 0) for m, c in t.items()}

    def nonlinear_counts(self) -> dict[int, int | None]:
        """Minimum number of nonlinear instructions of a candidate tree of every node."""
        def comb(h: Hyperarc, v: dict[int, int | None]) -> int | None:
            a, b = v[h.left], v[h.right]
            return None if a is None or b is None else a + b + (0 if h.linear else 1)
        return self._table("nonlinear", 0, comb, min)

    def min_depth(self) -> int | None:
        """Exact minimum depth of the root (``None`` if it has no candidate algorithm)."""
        return self.depths()[self.root]

    def tree_count(self) -> int:
        return self.tree_counts()[self.root] or 0

    def linear_count(self) -> int:
        return self.linear_counts()[self.root] or 0

    def min_nonlinear(self) -> int | None:
        return self.nonlinear_counts()[self.root]

    def best_arc(self, mask: int, key: str) -> Hyperarc | None:
        """The hyperarc of ``mask`` achieving the optimum of measure ``key`` ("depth" or
        "nonlinear"), ties broken by the other measure, then balance, then ``left``."""
        d, nl = self.depths(), self.nonlinear_counts()
        best = None
        best_key = None
        for h in self.arcs[mask]:
            da, db, na, nb = d[h.left], d[h.right], nl[h.left], nl[h.right]
            if da is None or db is None or na is None or nb is None:
                continue
            depth = 1 + max(da, db)
            nonlin = na + nb + (0 if h.linear else 1)
            k = ((depth, nonlin) if key == "depth" else (nonlin, depth)) + (h.balance, h.left)
            if best_key is None or k < best_key:
                best, best_key = h, k
        return best


# ---------------------------------------------------------------------- greedy search
Chooser = Callable[[list[Hyperarc]], list[Hyperarc]]


def prefer_balanced(arcs: list[Hyperarc]) -> list[Hyperarc]:
    """Most balanced first (``node_splits`` already sorts that way)."""
    return arcs


def prefer_linear(arcs: list[Hyperarc]) -> list[Hyperarc]:
    """Linear splits (one side a single part) first, then balanced."""
    return sorted(arcs, key=lambda h: (not h.linear, h.balance, h.left))


@dataclass
class GreedyResult:
    """A decomposition found greedily: ``choice[m]`` is the hyperarc used at every internal
    node; ``stuck`` is a subassembly with no usable partitioning when none was found."""

    root: int
    choice: dict[int, Hyperarc] = field(default_factory=dict)
    stuck: int | None = None
    truncated: bool = False

    @property
    def found(self) -> bool:
        return self.stuck is None and not self.truncated

    def depth(self, mask: int | None = None) -> int:
        return tree_depth(self.choice, self.root if mask is None else mask)

    def nonlinear(self, mask: int | None = None) -> int:
        m = self.root if mask is None else mask
        if m.bit_count() == 1:
            return 0
        h = self.choice[m]
        return (0 if h.linear else 1) + self.nonlinear(h.left) + self.nonlinear(h.right)


@gc_paused()
def greedy_tree(ndbg: NDBG, mask: int | None = None, *, base: int | None = None,
                connected: ConnectivityTest | None = None, chooser: Chooser = prefer_balanced,
                budget: Budget | None = None,
                arcs: Callable[[int, Meter], list[Hyperarc]] | None = None) -> GreedyResult:
    """One candidate tree, choosing at each node the first hyperarc in ``chooser`` order whose
    children decompose (depth-first, memoizing failed subassemblies). Freeness in an induced DBG is
    *hereditary* (a set free in ``M`` stays free, restricted, in every ``M' < M``), so without
    ``connected`` the first choice always works and this is polynomial in the number of
    partitionings visited. ``arcs(mask, meter)`` overrides how a node's hyperarcs are obtained (e.g.
    an AND/OR graph's), charging the work to the search's ``meter``; the caller then judges whether
    a failure over its lists proves anything.

    With ``connected`` a subassembly whose partitioning list was cut (``split_limit``) may
    fail only for want of the splits left out, so when the search fails after such a failure
    the result is ``truncated`` (unproven), not a proof that no tree exists."""
    budget = budget or Budget()
    root = (1 << ndbg.n) - 1 if mask is None else mask
    res = GreedyResult(root=root)
    failed: set[int] = set()
    cut: set[int] = set()  # subassemblies whose partitioning list was cut
    unproven = False  # one of them failed
    meter = budget.meter()
    expanded = 0

    def get(m: int) -> list[Hyperarc]:
        if arcs is not None:
            return arcs(m, meter)
        got, trunc = node_splits(ndbg, m, base=base, connected=connected,
                                 limit=budget.split_limit, meter=meter)
        res.truncated |= trunc and not got
        if trunc and connected is not None:  # without the filter, heredity: any split works
            cut.add(m)
        return got

    def solve(m: int) -> bool:
        nonlocal expanded, unproven
        if m.bit_count() == 1 or m in res.choice:
            return True
        if m in failed:
            return False
        expanded += 1
        if expanded > budget.max_nodes or meter.spent() is not None:
            res.truncated = True
            return False
        for h in chooser(get(m)):
            if solve(h.left) and solve(h.right):
                res.choice[m] = h
                return True
            if res.truncated:
                return False
        failed.add(m)
        unproven |= m in cut
        if res.stuck is None or m.bit_count() < res.stuck.bit_count():
            res.stuck = m
        return False

    ok = solve(root)
    if ok:
        res.stuck = None
    elif unproven:
        res.truncated = True
    return res


def tree_depth(choice: dict[int, Hyperarc], mask: int) -> int:
    """Height of the tree that ``choice`` (node -> hyperarc) gives ``mask`` (a single part:
    0), without recursion: a linear tree of a thousand parts is a thousand deep.

    Examples
    --------
    >>> h = Hyperarc(0b111, 0b011, 0b100, ((0b100, (0,)),))
    >>> tree_depth({0b111: h, 0b011: Hyperarc(0b011, 0b001, 0b010, ((0b010, (0,)),))}, 0b111)
    2
    """
    deepest, stack = 0, [(mask, 0)]
    while stack:
        x, d = stack.pop()
        if x.bit_count() < 2:
            deepest = max(deepest, d)
            continue
        h = choice[x]
        stack += [(h.left, d + 1), (h.right, d + 1)]
    return deepest


def lower_bound_depth(mask: int) -> int:
    """``ceil(log2 |mask|)``: no binary tree over ``|mask|`` leaves is shallower."""
    return max(0, (mask.bit_count() - 1).bit_length())
