"""Assembly trees and sequences from an NDBG (paper Fig. 1 and section 4.4).

An assembly tree recursively partitions the product into two subassemblies; every internal
node is an instruction: its ``moved`` side travels along a region's motion away from the
``rest`` (disassembly), i.e. it is inserted along the opposite direction when assembling. In
the output ``removal_direction`` is the region's direction ``d``, ``direction`` the insertion
direction ``-d``; generalized regions give their ``motion`` dict instead. :func:`plan` builds
a tree with one of :data:`STRATEGIES`; :mod:`ndbg_cli.planning.proven` proves its steps (or
another tree's) with an exact test of infinite translation.
With ``base`` (a part index) the base is never moved: it always stays on the ``rest`` side.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..core.constants import TRANSLATION
from ..ndbg.model import NDBG, ConnectivityTest
from .andor import (
    AndOrGraph,
    Budget,
    Hyperarc,
    Meter,
    greedy_tree,
    node_splits,
    prefer_balanced,
    prefer_linear,
)
from .decompose import min_depth_search, min_directions, sink_decompose

STRATEGIES = ("shortest", "linear", "fewest-directions", "balanced")

#: Share of the node budget the ``shortest`` plan's iterative deepening may expand when the
#: AND/OR graph is cut (rod: 2,000 nodes cost 2.3 s and 1,000 give the same bounds, 5 to 7).
DEEPENING_SHARE = 0.5


@dataclass(frozen=True)
class Step:
    """One instruction: ``mask`` splits into ``moved`` (free along ``region``) and ``rest``."""

    mask: int
    moved: int
    rest: int
    region: int | None
    #: the removal direction the step was proven along (exactly as tested, e.g. a coordinate
    #: axis), stated instead of the region's representative (:mod:`ndbg_cli.planning.proven`)
    stated: tuple[float, ...] | None = None
    #: where ``stated`` came from (:data:`ndbg_cli.planning.proven.SOURCES`)
    source: str | None = None

    def removal(self, ndbg: NDBG) -> tuple[float, ...] | None:
        """The removal direction stated for this step: its proven one, else its region's."""
        if self.stated is not None:
            return self.stated
        return None if self.region is None else ndbg.regions[self.region].direction


@dataclass
class Plan:
    """A candidate assembly tree: ``steps[m]`` is the instruction splitting subassembly ``m``.

    ``exact`` says whether the strategy's objective is proven optimal (``False`` when a budget
    forced a greedy answer); ``found`` is False when no candidate algorithm exists, ``stuck``
    then holds a subassembly without any candidate partitioning. ``depth_lower`` is the best
    proven lower bound on the height of any tree under the same filter (the minimum depth
    from a complete AND/OR graph, the deepening's bound), ``None`` when only
    ``ceil(log2 n)`` is known. ``connected``: only splits whose two sides are connected in
    the contact graph were searched (the depth and its bounds are for such trees)."""

    ndbg: NDBG
    root: int
    strategy: str
    steps: dict[int, Step] = field(default_factory=dict)
    exact: bool = True
    found: bool = True
    stuck: int | None = None
    notes: list[str] = field(default_factory=list)
    depth_lower: int | None = None
    connected: bool = False

    def depth(self, mask: int | None = None) -> int:
        """Tree height (a single part has depth 0)."""
        m = self.root if mask is None else mask
        if m.bit_count() < 2:
            return 0
        s = self.steps[m]
        return 1 + max(self.depth(s.moved), self.depth(s.rest))

    def nonlinear(self) -> int:
        """Number of instructions whose sides both have two or more parts."""
        return sum(1 for s in self.steps.values()
                   if s.moved.bit_count() > 1 and s.rest.bit_count() > 1)

    def directions(self) -> int:
        """The number of distinct translation directions of the tree's instructions."""
        return len({s.removal(self.ndbg) for s in self.steps.values()})

    def regions_used(self) -> list[int]:
        return sorted({s.region for s in self.steps.values() if s.region is not None})

    def sequence(self) -> list[Step]:
        """Assembly order (the reverse of a disassembly): children before parents; for each
        instruction the ``rest`` side is built first, then the ``moved`` side."""
        out: list[Step] = []

        def visit(m: int) -> None:
            if m.bit_count() < 2:
                return
            s = self.steps[m]
            visit(s.rest)
            visit(s.moved)
            out.append(s)

        if self.found:
            visit(self.root)
        return out


def pick_region(ndbg: NDBG, regions: tuple[int, ...] | list[int]) -> int:
    """The region reported for an instruction free in several: an open one (full dimension:
    the most robust, unless :attr:`~ndbg_cli.ndbg.model.Region.thin`) first; then the
    lower-dimensional or thin region sliding along the most contacts exactly
    (:attr:`Region.sliding`), then the highest dimension, then the lowest index.

    A thin free band round a bore's axis holds many lower-dimensional cells a few ``eps / L`` wide
    (the eroded contacts, :mod:`ndbg_cli.ndbg.infinite.build`); only the axis itself, on every
    contact circle of the bore, is free for the direct sweep test (``ndbg query``) and for a
    designer. In 2D such bands are 1-dimensional arcs of S^1 (wider than ``eta``), marked thin
    (:mod:`ndbg_cli.ndbg.infinite.equator`): beside a sliding direction the direct test blocks their
    middles. Families without contact counts rank by dimension and index alone."""
    return min(regions, key=lambda r: region_rank(ndbg, r))


#: The least cosine between a coordinate axis and a region's direction for
#: :func:`axis_step` to try the axis (within about 72 degrees).
AXIS_COS = 0.3


def _axes(k: int) -> list[tuple[float, ...]]:
    """The ``2k`` coordinate axes of ``R^k`` (``+e_i`` then ``-e_i``, by ``i``)."""
    eye = [tuple(float(i == j) for j in range(k)) for i in range(k)]
    return eye + [tuple(-x + 0.0 for x in e) for e in eye]


def _axis_for(nd: NDBG, r: int, steps: list[Step],
              frees: Callable[[int, int, np.ndarray], bool]) -> tuple[float, ...] | None:
    """The nearest coordinate axis to region ``r``'s direction (within :data:`AXIS_COS`,
    nearest first) along which ``frees`` frees every step of ``steps``; ``None`` when none
    does or the direction is an axis already."""
    d = nd.regions[r].direction
    if d is None:
        return None
    d = np.asarray(d, dtype=float)
    near = sorted((a for a in _axes(len(d)) if float(np.dot(a, d)) > AXIS_COS),
                  key=lambda a: -float(np.dot(a, d)))
    for a in near:
        if np.array_equal(a, d):
            return None  # the region's direction is that axis already (a near one is tested)
        if all(frees(s.moved, s.rest, np.asarray(a)) for s in steps):
            return a
    return None


def axis_step(nd: NDBG, s: Step, frees: Callable[[int, int, np.ndarray], bool]) -> Step:
    """``s`` stating the axis :func:`_axis_for` finds for it alone, if any."""
    a = _axis_for(nd, s.region, [s], frees)
    return s if a is None else replace(s, stated=a, source="axis")


def free_region(ndbg: NDBG, subset: int, mask: int,
                regions: Sequence[int] | None = None) -> int | None:
    """The region (of ``regions``, default all) :func:`pick_region` prefers among those in
    which ``subset`` is free inside ``mask``; ``None`` when there is none."""
    regs = [r for r in (range(len(ndbg.regions)) if regions is None else regions)
            if ndbg.regions[r].dbg.is_free(subset, mask)]
    return pick_region(ndbg, regs) if regs else None


def region_rank(ndbg: NDBG, r: int) -> tuple[int, int, int, int]:
    """:func:`pick_region`'s order key of region ``r``."""
    reg = ndbg.regions[r]
    if reg.dimension == ndbg.space_dimension - 1 and not reg.thin:
        return (0, 0, 0, r)  # any point of an open region is as good
    return (1, -reg.sliding, -reg.dimension, r)


def orient(ndbg: NDBG, h: Hyperarc, allowed: set[int] | None = None) -> Step:
    """Choose the moved side (the smaller one, then the lower mask) and the region of ``h``."""
    opts = []
    for moved, regions in h.moves:
        regs = [r for r in regions if allowed is None or r in allowed]
        if regs:
            opts.append((moved.bit_count(), moved, pick_region(ndbg, regs)))
    _, moved, region = min(opts)
    return Step(mask=h.node, moved=moved, rest=h.node & ~moved, region=region)


def _restrict(h: Hyperarc, allowed: set[int]) -> Hyperarc | None:
    moves = tuple((m, tuple(r for r in regs if r in allowed)) for m, regs in h.moves)
    moves = tuple((m, regs) for m, regs in moves if regs)
    return Hyperarc(h.node, h.left, h.right, moves) if moves else None


def plan(ndbg: NDBG, strategy: str = "shortest", *, base: int | None = None,
         connected: ConnectivityTest | None = None, budget: Budget | None = None,
         graph: AndOrGraph | None = None, mask: int | None = None) -> Plan:
    """Build an assembly tree of ``mask`` (default: the whole product) with ``strategy``.

    Strategies (all deterministic):

    * ``shortest``: minimum tree height, exact from the AND/OR graph (ties: fewer nonlinear
      steps, balance); when the budget truncates the graph, by iterative deepening
      (:func:`classes.min_depth_search`), exact if its budget suffices, else its best tree;
    * ``linear``: fewest nonlinear instructions (one part at a time when possible), exact from
      the AND/OR graph, else greedy (a linear split whenever one exists: exact for
      linearizable products by heredity);
    * ``fewest-directions``: only the regions of a minimum direction set
      (:func:`classes.min_directions`, which ignores ``connected``), most balanced split first;
    * ``balanced``: greedy, the most balanced split at every node.

    ``graph`` may pass an already built AND/OR graph (same ``base``/``connected``) to reuse."""
    if strategy not in STRATEGIES:
        raise ValueError(f"unknown strategy {strategy!r}; expected one of {STRATEGIES}")
    budget = budget or Budget()
    root = (1 << ndbg.n) - 1 if mask is None else mask
    out = Plan(ndbg=ndbg, root=root, strategy=strategy, connected=connected is not None)
    # Whether any candidate tree exists is polynomial (heredity, classes.sink_decompose); a
    # contact-connected tree is one of them. When none does, no search can find one, and a
    # search would spend its whole budget proving it.
    sink, stuck = sink_decompose(ndbg, root, base=base, balanced=strategy != "linear")
    if stuck is not None:
        out.found, out.stuck = False, stuck
        out.notes.append("no candidate algorithm: subassembly "
                         f"{ndbg.names(stuck)} has no candidate partitioning")
        return out
    if strategy in ("shortest", "linear"):
        g = graph or AndOrGraph(ndbg, root, base=base, connected=connected, budget=budget)
        g.build()
        if g.complete:
            key = "depth" if strategy == "shortest" else "nonlinear"
            if g.depths()[root] is None:
                _fail(out, g, ndbg)
                return out
            out.depth_lower = g.depths()[root]
            stack = [root]
            while stack:
                m = stack.pop()
                if m.bit_count() < 2:
                    continue
                h = g.best_arc(m, key)
                assert h is not None
                s = orient(ndbg, h)
                out.steps[m] = s
                stack.extend((s.rest, s.moved))
            return out
        if strategy == "shortest":
            # the deepening proposes a tree that is proven afterwards (planning.proven, which
            # repairs the steps that fail): half the node budget is enough for its bounds
            deep = replace(budget, max_nodes=max(1, int(budget.max_nodes * DEEPENING_SHARE)))
            r = min_depth_search(ndbg, root, base=base, connected=connected, budget=deep,
                                 graph=g)
            if r.upper is not None:
                out.exact = r.exact
                out.depth_lower = r.lower
                out.notes.append(f"{g.cut_reason()}; " + (r.why or (
                    f"depth by iterative deepening ({r.expanded} nodes): "
                    + ("optimal" if r.exact else f"between {r.lower} and {r.upper}"))))
                for m, h in r.choice.items():
                    out.steps[m] = orient(ndbg, h)
                return out
        out.exact = False
        out.notes.append(f"{g.cut_reason()}; greedy tree "
                         "(an upper bound on the optimum)")
        chooser = prefer_balanced if strategy == "shortest" else prefer_linear
        return _from_greedy(out, ndbg, root, base, connected, chooser, budget, None, sink)
    if strategy == "balanced":
        out.exact = False
        return _from_greedy(out, ndbg, root, base, connected, prefer_balanced, budget, None,
                            sink)
    # fewest-directions
    md = min_directions(ndbg, base=base, budget=budget, mask=root)
    if md["regions"] is None:
        out.found = False
        out.stuck = md.get("stuck")
        out.notes.append(md["why"])
        return out
    out.exact = bool(md["exact"])
    out.notes.append(md["why"])
    within = sink_decompose(ndbg, root, md["regions"], base=base)[0]  # a tree: md proved it
    got = _from_greedy(out, ndbg, root, base, connected, prefer_balanced, budget,
                       set(md["regions"]), within)
    if got.found or connected is None:
        return got
    # the direction count ignores the connectivity filter: fall back to all regions
    why = ("no connected tree within the minimum direction set" if got.exact else
           "no connected tree within the minimum direction set found within the budget")
    out = Plan(ndbg=ndbg, root=root, strategy=strategy, exact=False, connected=True,
               notes=[why + "; all regions used"])
    return _from_greedy(out, ndbg, root, base, connected, prefer_balanced, budget, None, sink)


def _fail(out: Plan, g: AndOrGraph, ndbg: NDBG) -> None:
    out.found = False
    d = g.depths()
    stuck = [m for m, v in d.items() if v is None]
    out.stuck = min(stuck, key=lambda m: (m.bit_count(), m)) if stuck else g.root
    out.notes.append(_stuck_note(ndbg, out.stuck, g.connected is not None))


def _stuck_note(ndbg: NDBG, stuck: int, connected: bool) -> str:
    """Why no tree was found. Under the connectivity filter candidate trees exist (the plan
    checks that first) and ``stuck`` may well have candidate partitionings: none with both
    sides connected leads to single parts."""
    if connected:
        return ("no tree with connected subassemblies: subassembly "
                f"{ndbg.names(stuck)} has no candidate partitioning into two connected "
                "subassemblies that decompose further")
    return ("no candidate algorithm: subassembly "
            f"{ndbg.names(stuck)} has no candidate partitioning")


def _from_greedy(out: Plan, ndbg: NDBG, root: int, base: int | None,
                 connected: ConnectivityTest | None, chooser, budget: Budget,
                 allowed: set[int] | None,
                 sink: dict[int, tuple[int, int]] | None = None) -> Plan:
    """The greedy tree of ``chooser`` (regions limited to ``allowed``); when the budget cuts
    the search before it finds one, the tree of the polynomial sink decomposition ``sink``
    (``classes.sink_decompose``'s choice, any candidate partitionings: used only without a
    ``connected`` filter)."""
    arcs = None
    cut = [False]
    if allowed is not None:
        def arcs(m: int, meter: Meter) -> list[Hyperarc]:
            got, trunc = node_splits(ndbg, m, base=base, connected=connected,
                                     limit=budget.split_limit, meter=meter)
            cut[0] |= trunc
            return [r for r in (_restrict(h, allowed) for h in got) if r is not None]
    res = greedy_tree(ndbg, root, base=base, connected=connected, chooser=chooser,
                      budget=budget, arcs=arcs)
    if not res.found and cut[0]:
        # a list cut by split_limit may have lost every split in the allowed regions: the
        # failure proves nothing
        res.truncated = True
    if not res.found and res.truncated and sink is not None and connected is None:
        out.exact = False
        out.notes.append("search budget exhausted before a tree was found; the sink "
                         "decomposition's tree is given (an upper bound on the optimum)")
        # each step in the region pick_region prefers among those freeing it (the sink
        # decomposition takes the first in index order)
        regs = sorted(allowed) if allowed is not None else None
        out.steps = {}
        for m, (moved, region) in sink.items():
            best = free_region(ndbg, moved, m, regs)
            out.steps[m] = Step(mask=m, moved=moved, rest=m & ~moved,
                                region=region if best is None else best)
        return out
    if not res.found:
        out.found = False
        out.stuck = res.stuck
        out.exact = not res.truncated
        if res.truncated:
            out.notes.append("search budget exhausted before a tree was found")
        elif res.stuck is not None:
            out.notes.append(_stuck_note(ndbg, res.stuck, connected is not None))
        return out
    stack = [root]
    while stack:
        m = stack.pop()
        if m.bit_count() < 2:
            continue
        s = orient(ndbg, res.choice[m], allowed)
        out.steps[m] = s
        stack.extend((s.rest, s.moved))
    return out


# ----------------------------------------------------------------------------- output
def _vec(v) -> list[float] | None:
    return None if v is None else [float(x) for x in v]


def step_motion(ndbg: NDBG, s: Step) -> dict:
    """Family and motion fields of an instruction (see the module docstring)."""
    r = None if s.region is None else ndbg.regions[s.region]
    d: dict = {"family": ndbg.family, "region": s.region}
    if s.stated is not None or (r is not None and r.direction is not None):
        d["removal_direction"] = _vec(s.removal(ndbg))
        d["direction"] = [(-x if x != 0 else 0.0) for x in d["removal_direction"]]
        if s.stated is not None:
            # the direction the step was proven along, which may lie on the region's
            # boundary (a sliding contact) or in a neighbouring region
            d["proof"] = {"test": "sweep", "source": s.source}
    else:
        d["direction"] = None
    if r is not None and r.motion is not None:
        d["motion"] = r.motion
    return d


def tree_json(p: Plan, mask: int | None = None) -> dict:
    """Nested tree: ``{"parts", "moved": subtree, "rest": subtree, ...motion}``; leaves only
    have ``parts``."""
    m = p.root if mask is None else mask
    node: dict = {"parts": p.ndbg.names(m)}
    if m.bit_count() >= 2 and m in p.steps:
        s = p.steps[m]
        node.update(step_motion(p.ndbg, s))
        node["depth"] = p.depth(m)
        node["moved"] = tree_json(p, s.moved)
        node["rest"] = tree_json(p, s.rest)
    return node


def sequence_json(p: Plan) -> list[dict]:
    """Numbered assembly steps: ``moved`` is inserted ``onto`` the rest, producing
    ``produces``."""
    out = []
    for k, s in enumerate(p.sequence(), start=1):
        d = {"step": k, "moved": p.ndbg.names(s.moved), "onto": p.ndbg.names(s.rest),
             "produces": p.ndbg.names(s.mask)}
        d.update(step_motion(p.ndbg, s))
        out.append(d)
    return out


def plan_proves(p: dict) -> dict | None:
    """What a plan section (:func:`plan_section`, with its ``verified`` and ``proofs``)
    proves when every step is proven (a real 1-handed monotone 1-prismatic algorithm,
    :mod:`ndbg_cli.planning.proven`): the classes it shows, and upper bounds on the minimum
    depth, nonlinear steps and directions from it and the proven ``proofs`` trees; ``None``
    without a proven plan of translations. The rules (``ndbg check``) and the text report
    read it."""
    v = p.get("verified") or {}
    if not p.get("found") or v.get("value") is not True \
            or p.get("family") not in TRANSLATION:
        # a proven plan of rotations or screw motions is no algorithm of single translations
        return None
    dirs = {tuple(s["removal_direction"]) for s in p.get("sequence") or []
            if s.get("removal_direction") is not None}
    trees = [{"depth": p.get("depth"), "nonlinear_steps": p.get("nonlinear_steps"),
              "directions": len(dirs)}] + list(p.get("proofs") or [])

    def best(key: str) -> int | None:
        got = [t[key] for t in trees if t.get(key) is not None]
        return min(got) if got else None

    return {"one_handed_monotone": True, "prismatic": True,
            "linearizable": True if best("nonlinear_steps") == 0 else None,
            "min_depth": best("depth"), "min_nonlinear": best("nonlinear_steps"),
            "min_directions": best("directions"),
            "why": f"{p.get('family')} plan, {v.get('why')}"
                   + (f" (also {', '.join(t['strategy'] for t in trees[1:])} trees)"
                      if len(trees) > 1 else "")}
