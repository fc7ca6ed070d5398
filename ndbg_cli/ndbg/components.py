"""Strong components and free sets of a DBG given as successor bitmasks (``succ[i]``: the
parts that part ``i`` runs into), induced on a part bitmask: the hot loops of the AND/OR graph
(:mod:`ndbg_cli.planning.andor`) and of the classes. Plain ints as bitsets, no graph objects; the
:class:`~ndbg_cli.ndbg.dbg.DBG` methods of :mod:`ndbg_cli.ndbg.dbg` are the general versions (their
components in reverse topological order, which these need not keep)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence

from .dbg import bits, reach


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
    each, the bitmask over component indices of the components it has arcs to. Iterative
    Tarjan on bitsets with list-indexed state (the hot loop of the AND/OR graph)."""
    arcs = sum((succ[i] & mask).bit_count() for i in bits(mask))
    if arcs > 4 * mask.bit_count():
        return _condense_dense(succ, mask)
    n = len(succ)
    index = [-1] * n
    low = [0] * n
    comp_of = [-1] * n
    onstack = 0
    stack: list[int] = []
    comps: list[int] = []
    counter = 0
    for root in bits(mask):
        if index[root] >= 0:
            continue
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        onstack |= 1 << root
        work = [[root, succ[root] & mask]]
        while work:
            top = work[-1]
            v, rem = top
            if rem:
                b = rem & -rem
                top[1] = rem ^ b
                w = b.bit_length() - 1
                if index[w] < 0:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    onstack |= b
                    work.append([w, succ[w] & mask])
                elif onstack & b and index[w] < low[v]:
                    low[v] = index[w]
                continue
            work.pop()
            if work:
                u = work[-1][0]
                if low[v] < low[u]:
                    low[u] = low[v]
            if low[v] == index[v]:
                comp = 0
                k = len(comps)
                while True:
                    w = stack.pop()
                    b = 1 << w
                    onstack ^= b
                    comp |= b
                    comp_of[w] = k
                    if w == v:
                        break
                comps.append(comp)
    comp_succ = []
    for c in comps:
        reach = 0
        for i in bits(c):
            reach |= succ[i]
        out = 0
        for j in bits(reach & mask & ~c):
            out |= 1 << comp_of[j]
        comp_succ.append(out)
    return comps, comp_succ


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
