"""Candidate partitionings with both sides connected, without enumerating every free set.

A DBG with few arcs has exponentially many free sets, most of which fall apart in the contact
graph; :func:`connected_partitionings` lists only the splits ``{S, m \\ S}`` with ``S`` free in
some DBG of an NDBG and both sides connected in an undirected graph (the contact graph), by a
branching search over connected sets that is polynomial per set found (see
:func:`_closed_sets`). It returns what filtering :func:`ndbg_cli.ndbg.model.partitionings` by
connectivity would, in the same order. Pure graph code over bitmasks: part ``i`` is bit ``i``.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence

from .dbg import DBG, bits, closure_table, reach
from .model import NDBG, Partitioning

#: Cap on the candidate partitionings listed (and checked) per call.
DEFAULT_CANDIDATE_LIMIT = 200
#: Cap on the nodes of the search for contact-connected candidate partitionings, over all
#: the distinct DBGs of one call (:func:`connected_partitionings`).
DEFAULT_SEARCH_BUDGET = 50_000


def _predecessors(succ: Sequence[int], m: int) -> list[int]:
    """The reversed arcs of ``succ`` inside ``m`` (bitmask lists over all parts)."""
    pred = [0] * len(succ)
    for i in bits(m):
        for j in bits(succ[i] & m):
            pred[j] |= 1 << i
    return pred


def connected_free_sets(succ: Sequence[int], nb: Sequence[int], m: int, budget: list[int],
                        avoid: int = 0, down: dict[int, int] | None = None) -> Iterator[int]:
    """Free sets ``S`` of the DBG ``succ`` inside ``m`` (proper, non-empty) such that ``S``
    and ``m \\ S`` are both connected in the graph ``nb``; ``budget[0]`` (search nodes) is
    decremented and the search stops at 0, setting it to -1 when work was left (the list
    is then cut). With ``avoid`` (a part bitmask, e.g. the fixed base), only the sets
    disjoint from it, searched directly (:func:`_closed_sets`).
    ``down``: ``closure_table(succ, m)`` when the caller has it.

    Otherwise a pivot part ``p`` (most neighbours in ``m``) splits them: the sets without
    ``p`` are searched directly, those with ``p`` as the complements of the sets without
    ``p`` that are closed under the reversed arcs (``S`` is free iff ``m \\ S`` is closed
    under predecessors). The side without the pivot, usually the base, is the small one,
    which keeps the search short.

    When ``m`` itself is not connected in ``nb``, no search: with two components they are
    the only split with both sides connected, with more there is none."""
    first = reach(m & -m, nb, m)
    if first != m:
        other = m & ~first
        if reach(other & -other, nb, other) == other:  # exactly two components
            g = DBG(tuple(succ))
            yield from (s for s in (first, other) if not s & avoid and g.is_free(s, m))
        return
    # what each part drags along, and what drags it along
    down = closure_table(succ, m) if down is None else down
    up = closure_table(_predecessors(succ, m), m)
    if avoid & m:
        yield from _closed_sets(down, up, nb, m, avoid & m, budget)
        return
    pivot = max(bits(m), key=lambda i: ((nb[i] & m).bit_count(), -i))
    yield from _closed_sets(down, up, nb, m, 1 << pivot, budget)
    for t in _closed_sets(up, down, nb, m, 1 << pivot, budget):
        yield m & ~t


def _closed_sets(down: dict[int, int], up: dict[int, int], nb: Sequence[int], m: int,
                 excluded: int, budget: list[int]) -> Iterator[int]:
    """Sets ``S`` inside ``m`` closed under a relation (``down[i]``: the closure of part
    ``i``; ``up[i]``: the parts whose closure holds ``i``), disjoint from ``excluded``, with
    ``S`` and ``m \\ S`` connected in ``nb``.

    Binary search over the parts adjacent to the growing set ``IN`` (started at each part
    ``r`` as the lowest index of ``S``, so each set comes once): a part goes in (with its
    closure) or out (with every part whose closure holds it, which must stay out of a closed
    set). A branch is cut when ``IN`` meets ``OUT`` or ``OUT`` is split over several
    components of ``m \\ IN``; a node with no undecided neighbour of ``IN`` is a set."""
    below = 0  # what the parts before r drag along
    for i in bits(excluded):
        below |= up[i]
    # a node's neighbours are those of the closures it took in (an OR of ORs), carried
    # along the search
    near: dict[int, int] = {}
    comps: dict[tuple[int, int], int] = {}
    for r in bits(m):
        out = below
        below |= up[r]
        if excluded >> r & 1:
            continue
        inside = down[r]
        if inside & ((m & ((1 << r) - 1)) | excluded) or out & inside:
            continue
        stack = [(inside, out, _neighbours(r, down, nb, near))]
        while stack:
            if budget[0] <= 0:
                budget[0] = -1  # out of budget with work left (0 alone: all done)
                return
            budget[0] -= 1
            inside, out, around = stack.pop()
            # the part of the rest holding out's first part, once per (rest, part): the
            # siblings that only add to out share it
            rest, low = m & ~inside, out & -out
            part = comps.get((rest, low))
            if part is None:
                part = comps[(rest, low)] = reach(low, nb, rest)
            if out & ~part:
                continue  # the rest would fall apart
            frontier = around & rest & ~out
            if not frontier:
                if reach(inside & -inside, nb, inside) == inside and (
                        part == rest if out else reach(rest & -rest, nb, rest) == rest):
                    yield inside
                continue
            f = (frontier & -frontier).bit_length() - 1
            out2 = out | up[f]
            if not out2 & inside:
                stack.append((inside, out2, around))
            in2 = inside | down[f]
            if not in2 & out:
                stack.append((in2, out, around | _neighbours(f, down, nb, near)))


def _neighbours(p: int, down: dict[int, int], nb: Sequence[int], memo: dict[int, int]
                ) -> int:
    """The neighbours in ``nb`` of the parts of ``down[p]`` (kept in ``memo``)."""
    got = memo.get(p)
    if got is None:
        got = 0
        for i in bits(down[p]):
            got |= nb[i]
        memo[p] = got
    return got


def connected_partitionings(ndbg: NDBG, neighbours: Sequence[int], mask: int | None = None, *,
                            limit: int | None = DEFAULT_CANDIDATE_LIMIT,
                            budget: int = DEFAULT_SEARCH_BUDGET
                            ) -> tuple[list[Partitioning], bool]:
    """The candidate partitionings of :func:`ndbg_cli.ndbg.model.partitionings` with both sides
    connected in the undirected graph ``neighbours`` (e.g. :func:`contact_neighbours`), found
    without enumerating every free set: per distinct DBG, a search over connected sets
    (:func:`connected_free_sets`), polynomial per set found; a DBG whose reverse is also
    one (a motion and its opposite) is searched once, the reverse's sets being the
    complements. Returns ``(list, truncated)`` sorted by (size, mask), like
    ``partitionings``; ``truncated`` when ``limit`` sets were found or the search ran out of
    its ``budget`` of nodes (the list is then partial, and the regions listed per set may be
    too).

    With a ``limit``, the free single parts (complement connected) of every DBG are taken
    first, as ``partitionings`` does."""
    m = (1 << ndbg.n) - 1 if mask is None else mask
    if not m:
        return [], False
    members = list(bits(m))
    groups: dict[tuple[int, ...], list[int]] = {}
    for k, r in enumerate(ndbg.regions):
        groups.setdefault(tuple(r.dbg.succ[i] & m for i in members), []).append(k)
    found: dict[int, set[int]] = {}
    left = [budget]

    def take(s: int, region_ids: list[int]) -> bool:
        if s in found:
            found[s].update(region_ids)
            return True
        if limit is not None and len(found) >= limit:
            return False
        found[s] = set(region_ids)
        return True

    truncated = False
    dbgs = [(ndbg.regions[ids[0]].dbg.succ, ids) for ids in groups.values()]
    if limit is not None:
        alone = [i for i in members  # the rest holds together without part i
                 if (c := m & ~(1 << i)) and reach(c & -c, neighbours, c) == c]
        for succ, ids in dbgs:
            for i in alone:
                if not succ[i] & m and not take(1 << i, ids):
                    truncated = True
                    break
            if truncated:
                break
    done: set[tuple[int, ...]] = set()
    for succ, ids in dbgs:
        key = tuple(succ[i] & m for i in members)
        if truncated or key in done:
            continue
        done.add(key)
        pred = _predecessors(succ, m)
        back = tuple(pred[i] for i in members)
        back_ids = groups.get(back) if back not in done else None
        if back_ids is not None:
            done.add(back)
        for s in connected_free_sets(succ, neighbours, m, left):
            if not take(s, ids) or (back_ids is not None and not take(m & ~s, back_ids)):
                truncated = True
                break
        if left[0] < 0:
            truncated = True
    out = [Partitioning(moved=s, rest=m & ~s, family=ndbg.family,
                        regions=tuple(sorted(regs))) for s, regs in found.items()]
    out.sort(key=lambda p: (p.moved.bit_count(), p.moved))
    return out, truncated
