"""Directional blocking graphs (DBGs) as bitsets.

A DBG on ``n`` parts is stored as one successor bitmask per part (a Python ``int``, so any
``n`` works): bit ``j`` of ``succ[i]`` is set iff part ``j`` blocks the motion of part ``i``
(arc ``i -> j``, paper section 4.1). Subassemblies are bitmasks over the same part indices, and
the DBG of a subassembly ``S`` is the subgraph induced by ``S``: every function here takes an
optional ``mask`` and never needs a new graph, so planning never recomputes geometry.

A subassembly ``S`` is *free* in a DBG iff no arc leaves it (``succ[i] & ~S == 0`` for ``i``
in ``S``): with translations, ``S`` can move along ``d`` while the rest stays. The free
subassemblies are exactly the successor-closed sets, i.e. the down-closed sets of the
condensation DAG; :func:`free_subsets` enumerates them with polynomial delay.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np


def bits(mask: int) -> Iterator[int]:
    """Indices of the set bits of ``mask``, ascending."""
    while mask:
        low = mask & -mask
        yield low.bit_length() - 1
        mask ^= low


def reach(x: int, adj: Sequence[int], within: int) -> int:
    """Everything reachable from the parts of ``x`` inside ``within`` along ``adj`` (one
    bitmask of neighbours per part), ``x & within`` included: closures in a DBG, connected
    components of the contact graph. Breadth-first on bitsets, the bits looped inline (the
    hot loop of connected plans)."""
    seen = x & within
    frontier = seen
    while frontier:
        new = 0
        while frontier:
            low = frontier & -frontier
            new |= adj[low.bit_length() - 1]
            frontier ^= low
        new &= within & ~seen
        seen |= new
        frontier = new
    return seen


def closure_table(adj: Sequence[int], m: int) -> dict[int, int]:
    """Reflexive-transitive closure of ``adj`` inside ``m``, per part (Warshall on
    bitsets)."""
    members = list(bits(m))
    out = {i: (adj[i] & m) | (1 << i) for i in members}
    for k in members:
        bit, via = 1 << k, out[k]
        for i in members:
            if out[i] & bit:
                out[i] |= via
    return out


def bit_rows(masks: Sequence[int], n: int) -> np.ndarray:
    """``(len(masks), n)`` bool array: bit ``i`` of each bitmask (any ``n``)."""
    width = max((n + 7) // 8, 1)
    raw = np.frombuffer(b"".join(m.to_bytes(width, "little") for m in masks),
                        dtype=np.uint8).reshape(len(masks), width)
    return np.unpackbits(raw, axis=1, bitorder="little")[:, :n].astype(bool)


def mask_of(indices: Iterable[int]) -> int:
    m = 0
    for i in indices:
        m |= 1 << i
    return m


def popcount(mask: int) -> int:
    return mask.bit_count()


@dataclass(frozen=True)
class DBG:
    """A directional blocking graph: ``succ[i]`` is the bitmask of parts blocking part ``i``."""

    succ: tuple[int, ...]

    @property
    def n(self) -> int:
        return len(self.succ)

    @classmethod
    def empty(cls, n: int) -> DBG:
        return cls((0,) * n)

    @classmethod
    def from_arcs(cls, n: int, arcs: Iterable[tuple[int, int]]) -> DBG:
        succ = [0] * n
        for i, j in arcs:
            if i != j:
                succ[i] |= 1 << j
        return cls(tuple(succ))

    @classmethod
    def from_matrix(cls, matrix: Sequence[Sequence[bool]]) -> DBG:
        return cls.from_arcs(len(matrix), ((i, j) for i, row in enumerate(matrix)
                                           for j, b in enumerate(row) if b))

    def arcs(self, mask: int | None = None) -> list[tuple[int, int]]:
        """Arcs ``(i, j)`` of the subgraph induced by ``mask`` (all parts if ``None``)."""
        m = self.full if mask is None else mask
        return [(i, j) for i in bits(m) for j in bits(self.succ[i] & m)]

    @property
    def full(self) -> int:
        return (1 << self.n) - 1

    def reversed(self) -> DBG:
        """The DBG with every arc reversed (for infinitesimal translations: ``G(-d)``)."""
        pred = [0] * self.n
        for i, j in self.arcs():
            pred[j] |= 1 << i
        return DBG(tuple(pred))

    def union(self, other: DBG) -> DBG:
        return DBG(tuple(a | b for a, b in zip(self.succ, other.succ)))

    def is_free(self, subset: int, mask: int | None = None) -> bool:
        """Whether no arc leaves ``subset`` inside the subassembly ``mask``."""
        m = self.full if mask is None else mask
        outside = m & ~subset
        return all(self.succ[i] & outside == 0 for i in bits(subset & m))

    def blockers(self, subset: int, mask: int | None = None) -> int:
        """Bitmask of the parts of ``mask`` outside ``subset`` that block some part of it."""
        m = self.full if mask is None else mask
        out = 0
        for i in bits(subset & m):
            out |= self.succ[i]
        return out & m & ~subset

    def closure(self, subset: int, mask: int | None = None) -> int:
        """Smallest free set containing ``subset``: everything ``subset`` drags along."""
        return reach(subset, self.succ, self.full if mask is None else mask)

    def is_acyclic(self, mask: int | None = None) -> bool:
        comps = strong_components(self, mask)
        return all(c & (c - 1) == 0 for c in comps)


def strong_components(g: DBG, mask: int | None = None) -> list[int]:
    """Strong components of the subgraph induced by ``mask``, as bitmasks, in reverse
    topological order (a component's successors come before it: sinks first)."""
    return tarjan(g.succ, g.full if mask is None else mask)[0]


def tarjan(succ: Sequence[int], mask: int) -> tuple[list[int], list[int]]:
    """Strong components of the DBG ``succ`` (successor bitmasks) induced on ``mask``, in
    reverse topological order (sinks first), and each part's component index (``-1`` outside
    ``mask``). Iterative Tarjan, ``O(n + arcs)``, on bitsets with list-indexed state: the one
    implementation behind :func:`strong_components`, :func:`condensation` and
    :func:`ndbg_cli.ndbg.components.condense` (the hot loop of the AND/OR graph)."""
    n = len(succ)
    index = [-1] * n
    low = [0] * n
    comp_of = [-1] * n
    onstack = bytearray(n)  # a flag per part: O(1), where a bitmask costs O(n) a change
    stack: list[int] = []
    comps: list[int] = []
    counter = 0
    for root in bits(mask):
        if index[root] >= 0:
            continue
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        onstack[root] = 1
        work = [[root, succ[root] & mask]]
        while work:
            top = work[-1]
            v, rem = top
            if rem:  # next successor of v, lowest first
                b = rem & -rem
                top[1] = rem ^ b
                w = b.bit_length() - 1
                if index[w] < 0:
                    index[w] = low[w] = counter
                    counter += 1
                    stack.append(w)
                    onstack[w] = 1
                    work.append([w, succ[w] & mask])
                elif onstack[w] and index[w] < low[v]:
                    low[v] = index[w]
                continue
            work.pop()
            if work:
                u = work[-1][0]
                if low[v] < low[u]:
                    low[u] = low[v]
            if low[v] == index[v]:  # v roots a component: pop it
                comp = 0
                k = len(comps)
                while True:
                    w = stack.pop()
                    onstack[w] = 0
                    comp |= 1 << w
                    comp_of[w] = k
                    if w == v:
                        break
                comps.append(comp)
    return comps, comp_of


def component_successors(succ: Sequence[int], mask: int, comps: Sequence[int],
                         comp_of: Sequence[int]) -> list[int]:
    """For each component of ``comps`` (part bitmasks inside ``mask``; ``comp_of[i]`` the
    index of part ``i``'s), the bitmask over component indices of the components it has arcs
    to in the DBG ``succ`` induced on ``mask``."""
    out = []
    for c in comps:
        r = 0
        for i in bits(c):
            r |= succ[i]
        s = 0
        for j in bits(r & mask & ~c):
            s |= 1 << comp_of[j]
        out.append(s)
    return out


def condensation(g: DBG, mask: int | None = None) -> tuple[list[int], list[int]]:
    """The condensation DAG of the subgraph induced by ``mask``.

    Returns ``(components, comp_succ)``: component bitmasks in reverse topological order and,
    for each, the bitmask (over component indices) of the components it has arcs to; every
    successor index is smaller than its predecessor's.
    """
    m = g.full if mask is None else mask
    comps, comp_of = tarjan(g.succ, m)
    return comps, component_successors(g.succ, m, comps, comp_of)


def free_subsets(g: DBG, mask: int | None = None, *, limit: int | None = None,
                 proper: bool = True) -> Iterator[int]:
    """Enumerate the free subassemblies (successor-closed subsets) of the subgraph ``mask``.

    Output-sensitive: backtracking over the condensation DAG in reverse topological order,
    where a component may be taken only once all its successors are; every leaf of the search
    is a distinct free set, so the delay between two outputs is ``O(components)``. With
    ``proper`` the empty set and ``mask`` itself are skipped. Stops after ``limit`` outputs.
    """
    m = g.full if mask is None else mask
    comps, comp_succ = condensation(g, m)
    k = len(comps)
    count = 0
    # Iterative DFS over decisions; state: (position, chosen component bitmask, part mask).
    stack = [(0, 0, 0)]
    while stack:
        pos, chosen, parts = stack.pop()
        if pos == k:
            if proper and (parts == 0 or parts == m):
                continue
            yield parts
            count += 1
            if limit is not None and count >= limit:
                return
            continue
        # Push "exclude" first so that "include" is explored first (larger sets earlier).
        stack.append((pos + 1, chosen, parts))
        if comp_succ[pos] & ~chosen == 0:
            stack.append((pos + 1, chosen | (1 << pos), parts | comps[pos]))


def minimal_free_subsets(g: DBG, mask: int | None = None) -> list[int]:
    """The free sets that are single sink components of the condensation (the minimal ones
    containing a given part are the successor closures; these are the minimal overall)."""
    m = g.full if mask is None else mask
    comps, comp_succ = condensation(g, m)
    return [c for c, s in zip(comps, comp_succ) if s == 0 and c != m]
