"""Complexity classes and measures of a product from its NDBGs (paper sections 7.1-7.2).

Every measure is ``{"value": ..., "why": "..."}`` (plus ``exact``/bounds where relevant),
computed per motion family from that family's NDBG (:func:`classify`), and says what its value
is worth (:func:`label`): ``holds_for`` names the family's motions (:data:`HOLDS_FOR`) and
``evidence`` is ``"proven"``, ``"candidate"`` or ``"bound"`` (:func:`evidence`). Also here:
:func:`andor_section` (the report's AND/OR section); the searches behind the measures are in
:mod:`decompose`.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL, TRANSLATION
from ..ndbg.components import condense
from ..ndbg.model import NDBG
from .andor import AndOrGraph, Budget, contains, greedy_tree, lower_bound_depth
from .decompose import (
    DepthResult,
    dominant_regions,
    min_depth_search,
    min_directions,
    regions_named,
    set_string,
    sink_decompose,
    sink_split,
    tree_string,
)

#: AND/OR graph budget when none is given (the CLI's --max-nodes / --time-limit defaults).
DEFAULT_BUDGET = Budget(max_nodes=2_000)

#: The motions a family's verdicts are about (every measure's ``holds_for``): one translation
#: to infinity per moved set (paper 5.3), any translations (4-5.1: a candidate of the
#: infinitesimal NDBG is necessary for every sequence of translations), translations plus the
#: suggested rotations and screws (5.2, 6).
HOLDS_FOR = {INFINITE: "single translations", INFINITESIMAL: "translations",
             GENERALIZED: "translations and suggested motions"}

#: Families whose candidates are only a necessary condition (paper 7.2): their yes and their
#: minima over candidates prove nothing about real algorithms beyond a lower bound.
NECESSARY_ONLY = (INFINITESIMAL, GENERALIZED)

#: Measures that are minima over algorithms (lower/upper bounds apply).
MINIMA = ("min_depth", "min_nonlinear", "min_directions")


def evidence(family: str, key: str, entry: dict) -> str:
    """What ``entry`` (measure ``key`` of ``family``) proves: ``"proven"``, ``"candidate"``,
    ``"bound"`` or ``"undecided"`` (no value, nothing shown).

    * ``"proven"``: true of the product for the family's motions (a yes of the infinite
      translations is a real algorithm, so it holds without restriction; a no holds only for
      those motions: "no 1-handed monotone algorithm with single translations" says nothing
      of two translations);
    * ``"candidate"``: a necessary condition only (infinitesimal families): a yes means
      candidate algorithms exist, and a minimum over candidates is only a lower bound;
    * ``"bound"``: ``lower_bound <= optimum <= upper_bound`` for real algorithms with those
      motions (a search cut by its budget, a greedy grasp).

    A yes (or a minimum) of a necessary-only family is a candidate; a no of any family is
    proven, but only for that family's motions (``holds_for``). Interlocking is decided by
    its LP, but the yes of an LP reading edge or point contacts as every normal of their cone
    (``exact`` false: more than they block) is a candidate (a necessary condition); a
    greedy grasp is an upper bound when complete, and bounds nothing when some requirement is
    left (its budget ran out, or no candidate face holds a direction): the fingers placed do
    not hold the product."""
    v = entry.get("value")
    if key == "interlocked":
        if v is None:
            return "undecided"
        # an LP reading some contacts as more than they block (``exact`` false): its yes is
        # a necessary condition only, its no (a motion found) still a proof
        return "candidate" if v is True and entry.get("exact", True) is False else "proven"
    if key == "grasp":
        return "bound" if v is not None and entry.get("complete", True) else "undecided"
    if key in MINIMA:
        if v is None:
            # no candidate at all is a proof (no algorithm with these motions); a cut search
            # that found nothing proves nothing
            return "proven" if entry.get("exact", False) else "undecided"
        if family in NECESSARY_ONLY:
            return "candidate"
        return "proven" if entry.get("exact", True) else "bound"
    if v is None:
        return "undecided"
    if v is True and family in NECESSARY_ONLY:
        return "candidate"
    return "proven"


def label(family: str, key: str, entry: dict) -> dict:
    """``entry`` with its ``holds_for`` (:data:`HOLDS_FOR`) and ``evidence`` added."""
    return {**entry, "holds_for": HOLDS_FOR.get(family, family),
            "evidence": evidence(family, key, entry)}


def verdict(key: str, entry: dict) -> str:
    """The value of a labelled measure as the text report shows it, limited to what its
    evidence shows: ``no (with single translations)``, ``yes (candidate only)``, ``3 (lower
    bound: minimum over candidates)``, ``5 (upper bound)``."""
    v = entry.get("value")
    ev = entry.get("evidence")
    scope = entry.get("holds_for")
    if isinstance(v, bool):
        vs = "yes" if v else "no"
        if ev == "candidate":
            return vs + " (candidate only: a necessary condition)"
        # a no of a class the paper defines for every motion is limited to these motions
        if not v and scope and key in ("one_handed_monotone", "linearizable"):
            return f"no (with {scope})"
        return vs
    if v is None:
        if ev == "proven" and key in MINIMA:
            return f"none (no algorithm with {scope})"
        return "undecided"
    if ev == "undecided":  # e.g. an incomplete grasp: the fingers placed so far
        return f"undecided ({v} placed, incomplete)"
    if ev == "candidate":
        return f"{v} (lower bound: minimum over candidates with {scope})"
    if ev == "bound" or not entry.get("exact", True):
        return f"{v} (upper bound)"
    if scope and key in MINIMA:
        return f"{v} (with {scope})"
    return str(v)


def classify(ndbg: NDBG, *, base: int | None = None, budget: Budget | None = None,
             graph: AndOrGraph | None = None,
             contained: Sequence[tuple[str, dict]] = ()) -> dict:
    """All NDBG-based measures of one motion family. The default budget keeps the AND/OR
    graph to 2,000 nodes and the default work units (bounds are reported beyond).

    * ``one_handed_monotone``: a candidate algorithm exists. Exact and polynomial (heredity,
      see :mod:`andor`): decompose by sink components; the witness is a tree, the failure
      proof a subassembly whose every induced DBG is strongly connected. For infinitesimal
      translations a candidate is only necessary (False is a guarantee); for infinite
      translations it is a real 1-handed monotone 1-prismatic algorithm;
    * ``prismatic``: 1-handed monotone 1-prismatic, decided by the infinite-translation NDBG
      (True there is guaranteed); the infinitesimal NDBG can only refute it; ``None`` for
      generalized;
    * ``linearizable`` (exact, polynomial) and ``min_nonlinear`` (exact from the AND/OR graph,
      else an upper bound): the minimum number of nonlinear instructions, ``p + 1`` assembly
      lines;
    * ``min_depth``: minimum candidate tree height (exact from the AND/OR graph; else bounds);
    * ``stack_product``: one DBG on the whole product is acyclic (every subassembly then
      splits along that single region);
    * ``min_directions`` (:func:`min_directions`), and ``interlocked`` and ``grasp`` when their
      inputs are supplied (:mod:`interlock`, :mod:`grasp`).

    ``contained``: ``(family, measures)`` of families whose every DBG is a DBG of ``ndbg``
    (:func:`andor.contains`; the generalized hybrid holds the infinitesimal translations), as
    this function returned them for the same ``base``. Every tree of such a family is then a
    tree of this one, so when its exact minimum depth already equals ``ceil(log2 n)``, no
    tree can be shallower and this family's is the same, exact, without a search.
    """
    budget = budget or DEFAULT_BUDGET
    fam = ndbg.family
    full = (1 << ndbg.n) - 1
    out: dict = {}
    choice, stuck = sink_decompose(ndbg, full, base=base)
    ohm = stuck is None
    if ohm:
        # only the infinite translations' trees are real algorithms
        why = ("tree " if fam == INFINITE else "candidate tree ") + tree_string(ndbg, choice, full)
    else:
        why = (f"subassembly {set_string(ndbg, stuck)}: every one of the "
               f"{len(dominant_regions(ndbg, stuck))} non-dominated distinct DBGs induced on it "
               "admits no proper free subset" + (" avoiding the base" if base is not None
                                                  else " (all strongly connected)"))
    if fam == INFINITESIMAL:
        why += ("" if not ohm else " (necessary condition only: infinitesimal translations)")
    out["one_handed_monotone"] = {"value": ohm, "why": why}

    if fam == INFINITE:
        out["prismatic"] = {"value": ohm, "why": ("guaranteed 1-handed monotone 1-prismatic: "
                                                  if ohm else "no 1-prismatic algorithm: ")
                            + why}
    elif fam == INFINITESIMAL:
        out["prismatic"] = {"value": False if not ohm else None,
                            "why": ("not 1-handed monotone prismatic: " + why) if not ohm else
                            "undecided by infinitesimal translations (candidates exist); see "
                            "the infinite_translation classes"}
    else:
        out["prismatic"] = {"value": None, "why": "not decided by generalized motions"}

    lin_choice, lin_stuck = sink_decompose(ndbg, full, base=base, linear=True)
    if lin_stuck is None:
        order = _linear_order(ndbg, lin_choice, full)
        out["linearizable"] = {"value": True, "why": "parts added one at a time: "
                               + ", ".join(order)}
    else:
        out["linearizable"] = {"value": False, "why": f"subassembly {set_string(ndbg, lin_stuck)}: "
                               "no single part can be separated from the rest in any region"}

    if graph is None:
        graph = AndOrGraph(ndbg, base=base, budget=budget).build()
    if not ohm:
        for k in ("min_nonlinear", "min_depth"):
            out[k] = {"value": None, "exact": True, "why": "no candidate algorithm"}
    elif graph.complete:
        p = graph.min_nonlinear()
        out["min_nonlinear"] = {"value": p, "exact": True, "assembly_lines": p + 1,
                                "why": f"exact over {graph.node_count} AND/OR nodes"}
        d = graph.min_depth()
        out["min_depth"] = {"value": d, "exact": True, "lower_bound": d, "upper_bound": d,
                            "why": f"exact over {graph.node_count} AND/OR nodes"}
    else:
        r = _depth_from_contained(contained, full)
        if r is None:
            r = min_depth_search(ndbg, full, base=base, budget=budget, graph=graph)
        if lin_stuck is None:
            out["min_nonlinear"] = {"value": 0, "exact": True, "lower_bound": 0,
                                    "assembly_lines": 1,
                                    "why": "exact: linearizable (a linear tree exists)"}
        else:
            g_lin = greedy_tree(ndbg, full, base=base, chooser=_linear_first, budget=budget)
            # else the sink decomposition by minimal free sets: mostly one-part steps
            ub_p, src = (g_lin.nonlinear(), "a greedy linear-first tree") if g_lin.found \
                else (_choice_nonlinear(sink_decompose(ndbg, full, base=base, balanced=False)[0],
                                        full), "the sink decomposition's tree")
            out["min_nonlinear"] = {"value": ub_p, "exact": False, "lower_bound": 1,
                                    "assembly_lines": ub_p + 1,
                                    "why": f"upper bound from {src} (AND/OR graph truncated)"}
        out["min_depth"] = _depth_entry(r, _choice_depth(choice, full))

    out["stack_product"] = stack_product(ndbg, base=base)
    md = min_directions(ndbg, base=base, budget=budget)
    out["min_directions"] = {k: v for k, v in md.items() if k != "stuck"}
    return out


def _choice_depth(choice: dict[int, tuple[int, int]], m: int) -> int:
    """Height of the tree a decomposition ``choice[m] = (moved, region)`` gives ``m``."""
    if m.bit_count() < 2:
        return 0
    moved = choice[m][0]
    return 1 + max(_choice_depth(choice, moved), _choice_depth(choice, m & ~moved))


def _choice_nonlinear(choice: dict[int, tuple[int, int]], m: int) -> int:
    """Nonlinear instructions (both sides of two or more parts) of that tree."""
    if m.bit_count() < 2:
        return 0
    moved = choice[m][0]
    rest = m & ~moved
    here = int(moved.bit_count() > 1 and rest.bit_count() > 1)
    return here + _choice_nonlinear(choice, moved) + _choice_nonlinear(choice, rest)


def _depth_entry(r: DepthResult, sink_depth: int) -> dict:
    """The ``min_depth`` entry from a search that did not finish the AND/OR graph: its
    bounds, the upper one also bounded by the sink decomposition's tree (``sink_depth``; a
    candidate tree, found in polynomial time whatever the budget). Exact when the search
    says so or the bounds meet."""
    upper = sink_depth if r.upper is None else min(r.upper, sink_depth)
    exact = r.exact or upper == r.lower
    if r.why and r.upper is not None and r.upper <= sink_depth:
        why = r.why
    elif exact and not r.exact:
        why = (f"exact: the sink decomposition's tree has depth {upper}, the lower bound "
               f"(ceil(log2 n) or refuted heights over {r.expanded} subassemblies)")
    else:
        src = ("the sink decomposition's tree" if r.upper is None or sink_depth < r.upper
               else "the best tree found")
        why = ("exact" if exact else f"upper bound from {src}, lower bound {r.lower}") + \
            f" by iterative deepening over {r.expanded} subassemblies (AND/OR graph truncated)"
    return {"value": upper, "exact": exact, "lower_bound": r.lower if not exact else upper,
            "upper_bound": upper, "why": why}


def stack_regions(ndbg: NDBG, *, base: int | None = None) -> list[int]:
    """Regions whose DBG alone yields a candidate algorithm: every instruction moves the side
    without the base along that region's direction (paper 7.1: all instructions along the same
    direction; 7.2: the algorithm is extracted from a single DBG).

    Convention, the same as :func:`min_directions`: a direction is that of the moved side, the
    one without the base, relative to the other; moving ``S`` along ``d`` and the rest along
    ``-d`` are different directions. Without a base either side may move, and the test is the
    paper's "the DBG is acyclic" (every subassembly of an acyclic graph has a sink part to
    move). With a base it is stricter: the base may not be the only sink, e.g. a stack of boxes
    on a middle base needs up for the boxes above it and down for those below (two
    directions, no stack product).

    Decided in ``O(n + arcs)`` per distinct DBG (what :func:`sink_decompose` on that one
    region decides, in ``O(n (n + arcs))``): a DBG with a cycle never separates the parts of
    the cycle; an acyclic one decomposes every subassembly without a base (each has a sink),
    and with a base iff no part is blocked by the base. If ``x -> base``, the pair ``{x,
    base}`` has the base as its only sink; if no arc enters the base, any subassembly holding
    it and another part has a sink among the others (their induced graph is acyclic, and none
    of them points at the base)."""
    full = (1 << ndbg.n) - 1
    out = []
    for dbg, regions in ndbg.distinct():
        # the O(n) test first: the condensation is the costly one
        if base is not None and any(s >> base & 1 for i, s in enumerate(dbg.succ) if i != base):
            continue
        comps, _ = condense(dbg.succ, full)
        if not any(c & (c - 1) for c in comps):
            out += regions
    return sorted(out)


def stack_product(ndbg: NDBG, *, base: int | None = None) -> dict:
    """The ``stack_product`` measure of one family (see :func:`stack_regions`); ``None`` for
    generalized motions, where the paper does not define it."""
    fam = ndbg.family
    if fam == GENERALIZED:
        return {"value": None, "why": "stack products are defined for translations"}
    found = stack_regions(ndbg, base=base)
    moved = "the side without the base" if base is not None else "one side"
    if not found:
        return {"value": False, "why": f"none of the {len(ndbg.regions)} DBGs alone "
                f"decomposes the product (moving {moved} along its direction)"}
    k = min(found, key=lambda r: (-ndbg.regions[r].dimension, r))
    note = "" if fam == INFINITE else " (candidate: infinitesimal only)"
    return {"value": True, "region": k, "direction": regions_named(ndbg, [k])[0].get("direction"),
            "why": f"the DBG of region {k} decomposes every subassembly: {moved} always "
            "comes apart along that one direction" + note}


def interlock_hands(lock: dict, ndbgs: dict[str, NDBG]) -> dict:
    """``lock`` (an :func:`interlock.interlock` result) with the fewest moved sets (hands) an
    infinitesimal translation of the whole product needs to separate or slide something:
    ``hands`` (``None`` unless exact), ``hands_lower_bound``, ``hands_exact``.

    The LP's motion uses ``moved_set_count`` sets, only an upper bound (it maximises the total
    separation, which moves many sets). One set suffices iff some DBG has a proper free subset
    of the whole product (:func:`sink_split`, no base: a relative motion, either side may be the
    fixed one); only the infinitesimal NDBG can refute that (an infinite-translation
    partitioning still proves it). Not a bound on the product's hands: later steps may need
    more, and other motions fewer."""
    out = dict(lock)
    k = lock.get("moved_set_count")
    if lock.get("value") is not False or not k:
        return {**out, "hands": None, "hands_lower_bound": None, "hands_exact": False}
    one, src = None, None
    for fam in TRANSLATION:
        nd = ndbgs.get(fam)
        if nd is not None and nd.n >= 2 and one is None:
            one, src = sink_split(nd, (1 << nd.n) - 1, balanced=False), nd
    refuted = one is None and INFINITESIMAL in ndbgs
    low = 2 if refuted else 1
    exact = one is not None or (refuted and k == 2)
    if one is not None and src is not None:
        note = (f"; one moved set suffices: {set_string(src, one[0])} is free in region {one[1]} "
                f"of the {src.family} NDBG")
    elif refuted:
        note = ("; no single subassembly is free in any direction, so at least 2 moved sets"
                + (" (exactly 2)" if exact else f", at most {k}"))
    else:
        note = ""
    return {**out, "why": out.get("why", "") + note, "hands": (1 if one is not None else k)
            if exact else None, "hands_lower_bound": low, "hands_exact": exact}


def _depth_from_contained(contained: Sequence[tuple[str, dict]], full: int
                          ) -> DepthResult | None:
    """The minimum depth when a contained family's is exact and equals the lower bound
    ``ceil(log2 n)`` (see :func:`classify`), else ``None`` (search needed)."""
    d = lower_bound_depth(full)
    for fam, measures in contained:
        md = measures.get("min_depth") or {}
        if md.get("value") == d and md.get("exact"):
            return DepthResult(d, True, d, d, {}, 0,
                               why=f"exact: the {fam} family, whose DBGs are all DBGs of this "
                               f"one, has a tree of height {d} = ceil(log2 n), the lower bound")
    return None


def _linear_first(arcs):
    from .andor import prefer_linear

    return prefer_linear(arcs)


def _linear_order(ndbg: NDBG, choice: dict[int, tuple[int, int]], mask: int) -> list[str]:
    """Assembly order of a linear decomposition (first two parts, then one at a time)."""
    order: list[str] = []
    m = mask
    while m.bit_count() >= 2:
        moved, _ = choice[m]
        single = moved if moved.bit_count() == 1 else m & ~moved
        order.append(ndbg.names(single)[0])
        m &= ~single
    order.append(ndbg.names(m)[0])
    return order[::-1]


def classes_section(ndbgs, *, base: int | None = None, budget: Budget | None = None,
                    interlock: dict | None = None, grasps: dict | None = None,
                    graphs: dict | None = None) -> dict:
    """``{family: {measure: {"value", "why", ...}}}`` for every NDBG in ``ndbgs`` (a list or a
    family-keyed mapping). ``interlock`` (an :func:`interlock.interlock` result section) is
    added under ``infinitesimal_translation`` (created if absent); ``grasps`` maps family to a
    :func:`grasp.grasp_section` result. ``graphs``, when given, receives each family's AND/OR
    graph (built once, reused by the planner)."""
    items = ndbgs.values() if isinstance(ndbgs, dict) else ndbgs
    out: dict = {}
    built: list[AndOrGraph] = []
    done: dict[str, dict] = {}
    # the translational families first: a graph they cut by its size (nodes, partitionings
    # per node) need not be built for a family holding their DBGs (the generalized hybrid),
    # see AndOrGraph.cut_as_supergraph_of; a cut by the clock proves nothing
    for nd in sorted(items, key=lambda x: (len(x.regions), x.family)):
        graph = AndOrGraph(nd, base=base, budget=budget or DEFAULT_BUDGET)
        inside = [g for g in built if contains(nd, g.ndbg)]
        sub = next((g for g in inside if g.cut_by_size), None)
        if sub is not None:
            graph.cut_as_supergraph_of(sub)
        else:
            graph.build()
        built.append(graph)
        if graphs is not None:
            graphs[nd.family] = graph
        done[nd.family] = classify(nd, base=base, budget=budget, graph=graph,
                                   contained=[(g.ndbg.family, done[g.ndbg.family])
                                              for g in inside])
    for fam in sorted(done):  # the section lists the families alphabetically
        out[fam] = done[fam]
    # every value says which motions it holds for and what it proves (see evidence())
    out = {fam: {k: label(fam, k, m) if isinstance(m, dict) and "value" in m else m
                 for k, m in measures.items()} for fam, measures in out.items()}
    return with_interlock_and_grasps(out, list(items), interlock, grasps)


def with_interlock_and_grasps(classes: dict, ndbgs: Sequence[NDBG], interlock: dict | None,
                              grasps: dict | None) -> dict:
    """``classes`` (a :func:`classes_section`) with the interlock LP's section (``interlock``,
    under ``infinitesimal_translation``, :func:`interlock_hands`) and the grasps (family ->
    :func:`grasp.grasp_section` result) added and labelled, as :func:`classes_section` adds
    them when given: for a caller that computes them apart (in parallel)."""
    out = {fam: dict(m) for fam, m in classes.items()}
    added = []
    if interlock is not None:
        nds = {nd.family: nd for nd in ndbgs}
        added.append((INFINITESIMAL, "interlocked", interlock_hands(interlock, nds)))
    added += [(fam, "grasp", g) for fam, g in (grasps or {}).items()]
    for fam, key, m in added:
        out.setdefault(fam, {})[key] = (label(fam, key, m) if isinstance(m, dict)
                                        and "value" in m else m)
    return out


