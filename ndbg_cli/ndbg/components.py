"""Strong components and free sets of a DBG given as successor bitmasks (``succ[i]``: the
parts that part ``i`` runs into), induced on a part bitmask: the hot loops of the AND/OR graph
(:mod:`ndbg_cli.planning.andor`) and of the classes. Plain ints as bitsets, no graph objects.
Tarjan itself is :func:`ndbg_cli.ndbg.dbg.tarjan` (also behind the :class:`~ndbg_cli.ndbg.dbg.DBG`
functions); :func:`condense` adds a reachability path for dense DBGs, whose components need not
come in topological order."""

from __future__ import annotations

import heapq
from collections.abc import Iterator, Sequence

from .dbg import bits, component_successors, reach, tarjan


def strongly_connected(succ: Sequence[int], mask: int) -> bool:
    """Whether the DBG induced on ``mask`` is strongly connected: forward and backward reach of
    the lowest part, on bitsets (``O(n)`` word operations per sweep, cheap on dense graphs)."""
    v = mask & -mask
    return reach(v, succ, mask) == mask and _reached_from(v, succ, mask) == mask


def _reached_from(x: int, succ: Sequence[int], within: int) -> int:
    """The parts of ``within`` from which ``x`` (a part bitmask inside it) is reachable,
    ``x`` included: the backward counterpart of :func:`ndbg_cli.ndbg.dbg.reach`, grown until no
    part of ``within`` has a successor in the set."""
    seen = x
    grew = True
    while grew:
        grew = False
        for i in bits(within & ~seen):
            if succ[i] & seen:
                seen |= 1 << i
                grew = True
    return seen


def condense(succ: Sequence[int], mask: int) -> tuple[list[int], list[int]]:
    """Strong components of the DBG ``succ`` induced on ``mask`` (bitmasks, any order) and, for
    each, the bitmask over component indices of the components it has arcs to: Tarjan
    (:func:`ndbg_cli.ndbg.dbg.tarjan`, reverse topological order) on sparse DBGs, forward-
    backward reachability (:func:`_condense_dense`, by lowest part) on dense ones."""
    arcs = sum((succ[i] & mask).bit_count() for i in bits(mask))
    if arcs > 4 * mask.bit_count():
        return _condense_dense(succ, mask)
    comps, comp_of = tarjan(succ, mask)
    return comps, component_successors(succ, mask, comps, comp_of)


def _condense_dense(succ: Sequence[int], mask: int) -> tuple[list[int], list[int]]:
    """:func:`condense` by forward-backward reachability on bitsets: each component is the set
    of parts reachable from a seed that also reach it. ``O(n)`` word operations per sweep
    instead of ``O(arcs)`` per part, which wins on dense DBGs."""
    comps: list[int] = []
    rem = mask
    while rem:
        v = rem & -rem
        comp = _reached_from(v, succ, reach(v, succ, rem))
        comps.append(comp)
        rem &= ~comp
    out_of = []  # each component's successors outside it
    for c in comps:
        r = 0
        for i in bits(c):
            r |= succ[i]
        out_of.append(r & mask & ~c)
    comp_succ = [sum(1 << b for b, cb in enumerate(comps) if r & cb) for r in out_of]
    return comps, comp_succ


def free_sets(comps: list[int], comp_succ: list[int], avoid: int = 0) -> Iterator[int]:
    """Every successor-closed union of components (free set), the empty set and the whole
    included, by binary branching on the lowest *available* component (all its successors
    already taken): both branches always lead to outputs, so the search visits fewer than two
    nodes per output. With ``avoid`` (a part bitmask, e.g. the fixed base), only the sets
    disjoint from it are enumerated (its components and all their ancestors are never taken),
    so a caller's limit counts useful sets only."""
    k = len(comps)
    comp_pred = [0] * k
    sinks = 0
    for a in range(k):
        if comp_succ[a] == 0:
            sinks |= 1 << a
        for b in bits(comp_succ[a]):
            comp_pred[b] |= 1 << a
    banned = 0
    if avoid:
        frontier = sum(1 << a for a in range(k) if comps[a] & avoid)
        while frontier:
            banned |= frontier
            nxt = 0
            for a in bits(frontier):
                nxt |= comp_pred[a]
            frontier = nxt & ~banned
    stack = [(0, 0, sinks & ~banned)]
    while stack:
        chosen, parts, avail = stack.pop()
        if not avail:
            yield parts
            continue
        c = avail & -avail
        ci = c.bit_length() - 1
        rest = avail ^ c
        stack.append((chosen, parts, rest))
        taken = chosen | c
        for p in bits(comp_pred[ci] & ~banned):
            if comp_succ[p] & ~taken == 0:
                rest |= 1 << p
        stack.append((taken, parts | comps[ci], rest))


def balanced_free_set(comps: list[int], comp_succ: list[int], target: int,
                      avoid: int = 0, neighbours: Sequence[int] | None = None) -> int:
    """A free set (successor-closed union of the components ``comps``, :func:`condense`'s
    output) of at most ``target`` parts, disjoint from ``avoid``, found by first fit: the
    components are taken sinks first, in a topological order (lowest index among those whose
    successors are all taken), each one that still fits. With ``neighbours`` (part adjacency
    bitmasks, e.g. the contact graph), a ready component touching the set taken so far goes
    first, so the set grows connected where it can. ``O((k + arcs) log k)`` for ``k``
    components (and the adjacencies); ``0`` when nothing fits.

    Not the largest such set (that is a knapsack over a partial order), but on the DBGs of
    real products (chains and layers of small components) it comes within a component of
    ``target``: a near-balanced candidate partitioning without enumerating the free sets
    (:func:`free_sets` lists them all, exponentially many).

    Examples
    --------
    >>> # a chain 0 -> 1 -> 2 -> 3 (each part runs into the next): free sets are its tails
    >>> succ = [0b0010, 0b0100, 0b1000, 0]
    >>> comps, comp_succ = condense(succ, 0b1111)
    >>> bin(balanced_free_set(comps, comp_succ, 2))
    '0b1100'
    """
    k = len(comps)
    waiting = [c.bit_count() for c in comp_succ]  # successors not taken yet
    comp_pred: list[list[int]] = [[] for _ in range(k)]
    for a in range(k):
        for b in bits(comp_succ[a]):
            comp_pred[b].append(a)
    comp_of = {i: a for a in range(k) for i in bits(comps[a])} if neighbours else {}
    ready = [a for a in range(k) if waiting[a] == 0]
    heapq.heapify(ready)
    near: list[int] = []  # ready components touching the set (pushed again when they do)
    done = [False] * k  # taken or skipped
    out = size = 0
    while ready or near:
        a = heapq.heappop(near if near else ready)
        if done[a]:
            continue
        done[a] = True
        n = comps[a].bit_count()
        if comps[a] & avoid or size + n > target:
            continue  # skipped: its ancestors never become ready
        out |= comps[a]
        size += n
        touch = 0
        for i in bits(comps[a]) if neighbours else ():
            touch |= neighbours[i]
        for p in comp_pred[a]:
            waiting[p] -= 1
            if waiting[p] == 0:
                heapq.heappush(ready, p)
                if neighbours and any(neighbours[i] & out for i in bits(comps[p])):
                    heapq.heappush(near, p)
        for i in bits(touch & ~out):  # ready components the new one touches
            b = comp_of.get(i)
            if b is not None and not done[b] and waiting[b] == 0:
                heapq.heappush(near, b)
    return out
