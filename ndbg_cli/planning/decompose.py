"""Decomposition searches over an NDBG: the polynomial decomposition by sink components
behind the exact yes/no classes, the minimum number of directions, and the exact minimum
tree height by iterative deepening without the whole AND/OR graph (paper section 7.2).

Freeness is hereditary (see :mod:`andor`): a subassembly's candidate partitioning in a region
stays one, restricted, in every smaller subassembly. So a sink component of a DBG's
condensation that avoids the base can always be moved (:func:`sink_split`), and decomposing
by such splits at every node (:func:`sink_decompose`) finds a candidate tree whenever one
exists, in polynomial time; its failure names a subassembly with no partitioning at all.
:mod:`classes` turns these into the report's measures.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from ..core.gc_pause import gc_paused
from ..core.memo import kept
from ..ndbg.components import balanced_free_set, condense, strongly_connected
from ..ndbg.dbg import DBG, bits
from ..ndbg.model import NDBG, ConnectivityTest
from .andor import (
    AndOrGraph,
    Budget,
    Hyperarc,
    Meter,
    _groups_of,
    _hyperarcs,
    greedy_tree,
    lower_bound_depth,
    node_splits,
    tree_depth,
)


@dataclass
class DepthResult:
    """Outcome of :func:`min_depth_search`: ``depth`` is exact when ``exact``; otherwise
    ``lower <= optimum <= upper`` (``upper`` from the best tree found). ``choice`` holds the
    hyperarcs of an optimal (or best found) tree; ``expanded`` counts nodes whose splits were
    enumerated."""

    depth: int | None
    exact: bool
    lower: int
    upper: int | None
    choice: dict[int, Hyperarc]
    expanded: int
    why: str = ""


@gc_paused()
def min_depth_search(ndbg: NDBG, mask: int | None = None, *, base: int | None = None,
                     connected: ConnectivityTest | None = None, budget: Budget | None = None,
                     graph: AndOrGraph | None = None) -> DepthResult:
    """Exact minimum tree height by iterative deepening without building the whole graph.

    First a balanced tree built without listing any partitioning (:func:`balanced_tree`): when
    it is ``ceil(log2 n)`` deep, no tree is shallower, and that is the answer.

    ``fits(M, d)``: a tree of height ``<= d`` exists iff some hyperarc has both sides of at most
    ``2^(d-1)`` parts that fit in ``d - 1``; memoized per subassembly as the largest refuted and
    smallest proven height. Starts at ``ceil(log2 n)`` and stops at the greedy balanced tree's
    height (an upper bound), so a proven optimum usually costs far fewer nodes than the full
    AND/OR graph. Anytime: when the budget runs out, returns the bounds reached. With
    ``graph`` (same ``base`` and ``connected``), its memoized hyperarcs are used and its cut
    partitioning lists count as cuts of this search.
    """
    budget = budget or Budget()
    root = (1 << ndbg.n) - 1 if mask is None else mask
    memo: dict[int, list[Hyperarc]] = {}
    trunc_splits = False

    def get(m: int, meter: Meter) -> list[Hyperarc]:
        nonlocal trunc_splits
        got = memo.get(m)
        if got is None:
            if graph is not None:
                got = graph.expand(m, meter)
            else:
                got, t = node_splits(ndbg, m, base=base, connected=connected,
                                     limit=budget.split_limit, meter=meter)
                trunc_splits |= t
            memo[m] = got
        return got

    def cut() -> bool:
        return trunc_splits or (graph is not None and graph.split_truncated)

    lower = lower_bound_depth(root)
    # a balanced tree found without listing any partitioning: when it is as shallow as any
    # binary tree over these parts can be, the search has nothing left to prove
    quick = balanced_tree(ndbg, root, base=base, connected=connected)
    if quick is not None and tree_depth(quick, root) == lower:
        return DepthResult(lower, True, lower, lower, quick, 0,
                           f"exact: a candidate tree of depth {lower} = ceil(log2 n), the "
                           "least of any binary tree over these parts")
    greedy = greedy_tree(ndbg, root, base=base, connected=connected, budget=budget, arcs=get)
    if not greedy.found:
        exact = not greedy.truncated and not cut()
        return DepthResult(None, exact, lower, None, {}, len(memo))
    upper = greedy.depth()
    best_choice = dict(greedy.choice)
    proven: dict[int, int] = {}
    refuted: dict[int, int] = {}
    choice: dict[int, Hyperarc] = {}
    meter = budget.meter()

    class _Stop(Exception):
        pass

    def fits(m: int, d: int) -> bool:
        if m.bit_count() == 1:
            return True
        if d < lower_bound_depth(m) or refuted.get(m, -1) >= d:
            return False
        if proven.get(m, 1 << 30) <= d:
            return True
        if len(memo) > budget.max_nodes or meter.spent() is not None:
            raise _Stop
        cap = 1 << (d - 1)
        for h in get(m, meter):
            if h.left.bit_count() <= cap and h.right.bit_count() <= cap and \
                    fits(h.left, d - 1) and fits(h.right, d - 1):
                proven[m] = d
                choice[m] = h
                return True
        refuted[m] = max(d, refuted.get(m, -1))
        return False

    d = lower
    try:
        while d < upper:
            if fits(root, d):
                upper = d
                best_choice = _tree_choice(root, choice)
                break
            d += 1
    except _Stop:
        return DepthResult(None, False, lower if cut() else d, upper, best_choice, len(memo))
    # Refutations over cut partitioning lists prove nothing: then only ceil(log2 n) bounds
    # the optimum from below (and proves it when the tree found reaches it).
    exact = not cut() or upper == lower
    return DepthResult(upper if exact else None, exact, upper if exact else lower, upper,
                       best_choice, len(memo))


def balanced_tree(ndbg: NDBG, mask: int | None = None, *, base: int | None = None,
                  connected: ConnectivityTest | None = None) -> dict[int, Hyperarc] | None:
    """A candidate tree of ``mask`` whose every node takes the most balanced of the near-
    balanced free sets (:func:`~ndbg_cli.ndbg.components.balanced_free_set`) of its distinct
    induced DBGs, or a sink component where none fits in half: ``{node: hyperarc}`` (each with
    both orientations where free, and every region freeing each, as
    :func:`~ndbg_cli.planning.andor.node_splits` lists them), ``None`` when some subassembly has no
    partitioning avoiding the base. By heredity (module docstring) that is exactly when no
    candidate tree exists; ``O(n * DBGs * (n + arcs))``, without enumerating the free sets.
    With ``connected``, the balanced sets grow along its graph and only splits whose both
    sides pass it are taken; ``None`` then only says that these few sets did not give a tree
    (heredity does not hold for it).

    Examples
    --------
    >>> import ndbg_cli
    >>> from ndbg_cli.pipeline.stages import find_contacts, build_ndbg
    >>> asm = ndbg_cli.load("assemblies/hover.yaml")
    >>> nd = build_ndbg(asm, "infinitesimal_translation", find_contacts(asm)).ndbg
    >>> tree = balanced_tree(nd)
    >>> from ndbg_cli.planning.andor import tree_depth
    >>> tree_depth(tree, (1 << nd.n) - 1)
    2
    """
    root = (1 << ndbg.n) - 1 if mask is None else mask
    groups = _groups_of(ndbg)
    return _walk(root, lambda m: _balanced_split(groups.of(m), m, 0 if base is None else
                                                 (1 << base) & m, connected))


def _balanced_split(induced: list, m: int, avoid: int, connected: ConnectivityTest | None
                    ) -> Hyperarc | None:
    """:func:`balanced_tree`'s split of ``m`` from its distinct induced DBGs ``induced``."""
    best: tuple[int, int] | None = None
    for succ, _ in induced:
        comps, comp_succ = condense(succ, m)
        if len(comps) < 2:
            continue
        sets = [balanced_free_set(comps, comp_succ, m.bit_count() // 2, avoid=avoid,
                                  neighbours=None if connected is None
                                  else connected.neighbours)]
        sets += [c for c, cs in zip(comps, comp_succ) if cs == 0 and not c & avoid]
        s = next((x for x in sets if x and (connected is None or (
            connected(x) and connected(m & ~x)))), 0)
        size = max(s.bit_count(), (m & ~s).bit_count())
        if s and (best is None or size < best[0]):
            best = (size, s)
    if best is None:
        return None
    s = best[1]
    # the split's orientations and regions, all of them (a plan picks its region there)
    found: dict[int, list[int]] = {}
    for moved in (s, m & ~s):
        if not moved & avoid:
            for succ, regs in induced:
                if DBG(succ).is_free(moved, m):
                    found.setdefault(moved, []).extend(regs)
    return _hyperarcs(m, found)[0]


def _walk(root: int, split: Callable[[int], Hyperarc | None]) -> dict[int, Hyperarc] | None:
    """The tree of ``root`` that ``split`` (subassembly -> its hyperarc) gives, node by node
    from the root: ``{node: hyperarc}``, or ``None`` as soon as ``split`` has none."""
    out: dict[int, Hyperarc] = {}
    stack = [root]
    while stack:
        m = stack.pop()
        if m.bit_count() < 2:
            continue
        h = split(m)
        if h is None:
            return None
        out[m] = h
        stack.extend((h.left, h.right))
    return out


def _tree_choice(root: int, choice: dict[int, Hyperarc]) -> dict[int, Hyperarc]:
    """The hyperarcs of the tree rooted at ``root`` in ``choice``."""
    got = _walk(root, choice.__getitem__)
    assert got is not None
    return got



def sink_split(ndbg: NDBG, mask: int, regions: Sequence[int] | None = None, *,
               base: int | None = None, linear: bool = False, balanced: bool = True
               ) -> tuple[int, int] | None:
    """A candidate partitioning of ``mask`` as ``(moved, region)``, or ``None`` if none exists
    in ``regions`` (default: all): in the first region that has one, a near-balanced free set
    (:func:`~ndbg_cli.ndbg.components.balanced_free_set`) when ``balanced``, else (or when
    none fits in half) a sink component, a minimal free set.

    Every nonempty free set contains a sink component of the condensation, so a proper free set
    avoiding the base exists iff some sink component avoids it; with ``linear`` one side must
    be a single part: a singleton sink component (moved), or a part with no incoming arc whose
    complement moves (only if that part is the base or the base is absent).
    """
    if mask.bit_count() < 2:
        return None
    if regions is None:
        # the classes and the plans decompose the same subassemblies over all the regions
        # (the engine: 622 calls, 247 distinct): each answer is kept on the NDBG
        memo = kept(ndbg, "_sink_splits", dict)
        key = (mask, base, linear, balanced)
        if key not in memo:
            memo[key] = _sink_split(ndbg, mask, range(len(ndbg.regions)), base, linear,
                                    balanced)
        return memo[key]
    return _sink_split(ndbg, mask, regions, base, linear, balanced)


def _sink_split(ndbg: NDBG, mask: int, order: Sequence[int], base: int | None, linear: bool,
                balanced: bool) -> tuple[int, int] | None:
    """:func:`sink_split` over the regions ``order``."""
    base_bit = 0 if base is None else (1 << base) & mask
    group = ndbg.dbg_group()
    tried: set[int] = set()  # regions with equal DBGs induce equal ones: the first in order
    seen: set[tuple[int, ...]] = set()
    members = list(bits(mask))
    for r in order:
        if group[r] in tried:
            continue
        tried.add(group[r])
        g = ndbg.regions[r].dbg
        succ = g.succ
        key = tuple([succ[i] & mask for i in members])
        if key in seen:
            continue
        seen.add(key)
        # one strong component (a stuck subassembly's every DBG): found by two reaches on
        # bitsets, far cheaper than its condensation
        if strongly_connected(succ, mask):
            continue
        comps, comp_succ = condense(succ, mask)
        if balanced and not linear:
            # near-balanced: the decomposition then takes O(n log n) part visits over a
            # chain of parts, not O(n^2) by one sink component at a time
            half = balanced_free_set(comps, comp_succ, mask.bit_count() // 2, avoid=base_bit)
            if half:
                return half, r
        for c, s in zip(comps, comp_succ):
            if s == 0 and not c & base_bit and (not linear or c.bit_count() == 1):
                return c, r
        if linear:
            incoming = 0
            for i in bits(mask):
                incoming |= g.succ[i] & mask & ~(1 << i)
            for p in bits(mask & ~incoming):
                if not base_bit or base_bit == 1 << p:
                    return mask & ~(1 << p), r
    return None


def sink_decompose(ndbg: NDBG, mask: int | None = None, regions: Sequence[int] | None = None,
                   *, base: int | None = None, linear: bool = False, balanced: bool = True
                   ) -> tuple[dict[int, tuple[int, int]], int | None]:
    """Decompose ``mask`` by :func:`sink_split` at every node: ``(choice, stuck)`` with
    ``choice[m] = (moved, region)``. By heredity this is exact: ``stuck`` (a subassembly with no
    partitioning, hence a proof of failure) is ``None`` iff a candidate tree (a linear one with
    ``linear``) exists using only ``regions``; of several met, the smallest. ``balanced``:
    near-balanced splits (a shallow tree, ``O(n log n)`` part visits over a chain of parts),
    else minimal ones (sink components: mostly one-part steps, the fewest nonlinear ones).
    Polynomial: ``O(n * regions * (n + arcs))``."""
    root = (1 << ndbg.n) - 1 if mask is None else mask
    choice: dict[int, tuple[int, int]] = {}
    stuck: list[int] = []
    stack = [root]
    while stack:
        m = stack.pop()
        if m.bit_count() < 2:
            continue
        got = sink_split(ndbg, m, regions, base=base, linear=linear, balanced=balanced)
        if got is None:
            # go on past it: of the stuck subassemblies met, the smallest (then first by part
            # names, not by index) is named, the most telling to a user and the cheapest to
            # confirm, and one that does not follow the parts' order
            stuck.append(m)
            continue
        choice[m] = got
        stack.extend((m & ~got[0], got[0]))
    if not stuck:
        return choice, None
    return choice, min(stuck, key=lambda m: (m.bit_count(), sorted(ndbg.names(m))))



def set_string(ndbg: NDBG, mask: int) -> str:
    """``{a, b, c}``: the part ids of ``mask``."""
    return "{" + ", ".join(ndbg.names(mask)) + "}"


def tree_string(ndbg: NDBG, choice: dict[int, tuple[int, int]], mask: int) -> str:
    """Compact nested rendering ``(moved | rest)`` of a decomposition ``choice[m] = (moved,
    region)``."""
    if mask.bit_count() < 2:
        return ndbg.names(mask)[0]
    moved, _ = choice[mask]
    return f"({tree_string(ndbg, choice, moved)} | {tree_string(ndbg, choice, mask & ~moved)})"


def regions_named(ndbg: NDBG, regions) -> list[dict]:
    """``{"region", "direction", "motion"}`` per region index (direction and motion when the
    region has them), for the report."""
    out = []
    for r in regions:
        reg = ndbg.regions[r]
        d: dict = {"region": r}
        if reg.direction is not None:
            d["direction"] = [float(x) for x in reg.direction]
        if reg.motion is not None:
            d["motion"] = reg.motion
        out.append(d)
    return out


def dominant_regions(ndbg: NDBG, mask: int) -> list[int]:
    """One region per distinct DBG induced on ``mask``, dropping any whose arc set contains
    another's (its free sets are a subset of the other's, so it is never needed)."""
    reps: dict[tuple[int, ...], int] = {}
    for _, regs in ndbg.distinct():  # one region per distinct DBG, the first
        k = regs[0]
        key = tuple(ndbg.regions[k].dbg.succ[i] & mask for i in bits(mask))
        if key not in reps:
            reps[key] = k
    keys = list(reps)
    keep = []
    for a in keys:
        dominated = any(b != a and all(x & y == y for x, y in zip(a, b)) for b in keys)
        if not dominated:
            keep.append(reps[a])
    return sorted(keep)


def min_directions(ndbg: NDBG, *, base: int | None = None, budget: Budget | None = None,
                   mask: int | None = None) -> dict:
    """Minimum number of distinct regions (translation directions, or suggested motions) a
    candidate algorithm needs, where each instruction may use any region in which its moved
    side is free (moving ``S`` along ``d`` and the rest along ``-d`` count as different
    directions).

    Exact by search: subsets of the non-dominated distinct DBGs are tried by increasing size,
    each tested in polynomial time by :func:`sink_decompose` (heredity), until
    ``budget.max_nodes`` tests or its work budget; beyond that the answer is an upper
    bound from a greedy cover (``exact`` False, ``lower_bound`` the largest size fully refuted).
    """
    budget = budget or Budget()
    root = (1 << ndbg.n) - 1 if mask is None else mask
    if root.bit_count() < 2:
        return {"value": 0, "exact": True, "lower_bound": 0, "regions": [],
                "why": "a single part needs no instruction"}
    choice, stuck = sink_decompose(ndbg, root, base=base)
    if stuck is not None:
        return {"value": None, "exact": True, "lower_bound": None, "regions": None,
                "stuck": stuck, "why": f"no candidate algorithm: {set_string(ndbg, stuck)} cannot "
                "be partitioned in any region"}
    cands = dominant_regions(ndbg, root)
    meter = budget.meter()
    tests = 0
    refuted = 0
    for k in range(1, len(cands) + 1):
        for combo in itertools.combinations(cands, k):
            tests += 1
            if tests > budget.max_nodes or meter.spent() is not None:
                return _greedy_directions(ndbg, root, base, cands, refuted, choice)
            # a test decomposes at most n - 1 subassemblies, each over the k DBGs
            meter.charge(k * root.bit_count())
            ch, st = sink_decompose(ndbg, root, list(combo), base=base)
            if st is None:
                used = sorted({r for _, r in ch.values()})
                return {"value": len(used), "exact": True, "lower_bound": len(used),
                        "regions": used, "directions": regions_named(ndbg, used),
                        "why": ("exact: one region suffices" if k == 1 else
                                f"exact: no set of {k - 1} region(s) suffices") +
                        f"; regions {used} give the tree {tree_string(ndbg, ch, root)}"}
        refuted = k
    raise AssertionError("the full region set decomposes, so some subset must")


def _greedy_directions(ndbg: NDBG, root: int, base: int | None, cands: list[int],
                       refuted: int, choice: dict[int, tuple[int, int]]) -> dict:
    """Upper bound: grow a region set greedily, adding the region that lets the decomposition
    go furthest (fewest parts left in stuck subassemblies), until nothing is stuck."""
    chosen: list[int] = []
    while True:
        best = None
        for r in cands:
            if r in chosen:
                continue
            ch, st = sink_decompose(ndbg, root, chosen + [r], base=base)
            score = 0 if st is None else _stuck_weight(ndbg, root, chosen + [r], base)
            if best is None or (score, r) < best[:2]:
                best = (score, r, ch, st)
        assert best is not None
        chosen.append(best[1])
        if best[3] is None:
            used = sorted({r for _, r in best[2].values()})
            exact = len(used) == refuted + 1  # the bounds meet: proven all the same
            what = "exact: the bounds meet" if exact else "upper bound"
            return {"value": len(used), "exact": exact, "lower_bound": refuted + 1,
                    "regions": used, "directions": regions_named(ndbg, used),
                    "why": f"{what} (search budget exhausted after all sets of "
                    f"{refuted} region(s) failed): regions {used} give the tree "
                    f"{tree_string(ndbg, best[2], root)}"}


def _stuck_weight(ndbg: NDBG, root: int, regions: list[int], base: int | None) -> int:
    """Parts inside stuck subassemblies when decomposing with ``regions`` as far as possible."""
    total = 0
    stack = [root]
    while stack:
        m = stack.pop()
        if m.bit_count() < 2:
            continue
        got = sink_split(ndbg, m, regions, base=base)
        if got is None:
            total += m.bit_count()
            continue
        stack.extend((got[0], m & ~got[0]))
    return total
