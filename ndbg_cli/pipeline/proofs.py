"""The plan stage's proofs: the chosen translation plan's steps proven with the direct sweep
test (:mod:`ndbg_cli.planning.proven`), or another tree found that is, or the subassembly
where every direction tried fails, with the blocking pairs and points.

The planner sees only the pairwise test (:class:`~ndbg_cli.ndbg.infinite.sweep.SweepChecker`)
and the candidate directions; this module collects those from the contacts (their normals and
cylinder axes: where a designer expects parts to move) and from the NDBG's regions.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..core.assembly import Assembly
from ..core.constants import INFINITE, INFINITESIMAL
from ..geometry.vectors import line_direction
from ..ndbg.dbg import bits
from ..ndbg.model import NDBG, ConnectivityTest
from ..planning.plans import Plan, Step, region_rank
from ..planning.proven import (
    GREEDY_WIDE,
    Direction,
    Rows,
    chooser,
    directions,
    greedy,
    measures,
    prove,
    prove_tree,
    snap,
    why_stuck,
)

#: Natural directions (axes, then the most shared contact normals and cylinder axes) that the
#: greedy search tries in full at every subassembly; further ones are tried only when these
#: fail (:func:`ndbg_cli.planning.proven.greedy`).
NATURAL_LIMIT = 32
#: Largest product for which a contradicted proof of none (:func:`cross_check`) starts the
#: proven search from scratch: its rows cost a sweep per part and direction (the 115-part
#: engine, 121,000 triangles: over 6 minutes).
CROSS_SEARCH_PARTS = 40
#: ``blocked`` entries given with a proof that no plan exists (:func:`splits_somewhere`).
WITNESSES = 12
#: Stuck subassemblies whose own infinite NDBG is computed before the search gives up.
EXACT_ROUNDS = 3
#: A stuck subassembly's infinite NDBG is computed restricted to its free domain up to this
#: many times ``--infinite-budget`` facing triangle pairs (pelikan: 3 million, 2 s).
EXACT_RESTRICTED = 20


def natural_directions(analysis: Any, dimension: int) -> list[tuple[tuple[float, ...], str]]:
    """The contacts' normals and (3D) cylinder axes, snapped, most shared first (ties by
    value): ``(vector, source)`` for :func:`ndbg_cli.planning.proven.directions`."""
    count: Counter = Counter()
    source: dict[tuple[float, ...], str] = {}
    # each distinct normal snapped once (the engine's 3,041 hold 1,448); a zero's sign does
    # not change a snapped line, so -0.0 and 0.0 may share a key
    lines: dict[tuple[float, ...], tuple[float, ...]] = {}

    def line(v: Any) -> tuple[float, ...]:
        v = tuple(float(x) for x in v)
        got = lines.get(v)
        if got is None:
            got = lines[v] = _line(v)
        return got
    for c in getattr(analysis, "contacts", ()):
        axis = getattr(c, "axis", None)
        if getattr(c, "surface", None) == "cylinder" and axis is not None:
            key = line(axis)
            count[key] += 1
            source.setdefault(key, "cylinder axis")
        for n in np.asarray(c.normals, dtype=float).reshape(-1, dimension):
            if dimension == 2 or c.kind != "curved":
                key = line(n)
                count[key] += 1
                source.setdefault(key, "contact normal")
    ranked = sorted(count, key=lambda k: (-count[k], k))
    return [(k, source[k]) for k in ranked]


def _line(v: Any) -> tuple[float, ...]:
    """``v`` snapped (:func:`~ndbg_cli.planning.proven.snap`), as a line
    (:func:`~ndbg_cli.geometry.vectors.line_direction`): a line's key."""
    return tuple(round(x, 12) + 0.0 for x in line_direction(np.asarray(snap(v))))


def prove_plan(asm: Assembly, analysis: Any, chosen: Plan, *, strategy: str,
               base: int | None, connected: ConnectivityTest,
               others: Sequence[str] = (), budget: int = 1_000_000,
               exact_rounds: int = EXACT_ROUNDS,
               shallow: Callable[[int], Sequence[tuple[int, int, Sequence[float] | None]]
                                 | None] | None = None, workers: int = 1) -> dict:
    """Prove ``chosen`` (a found translation plan) step by step, replacing its steps by
    proven ones (or by a proven tree when a step fails); ``found`` becomes False when no
    proven tree exists along the directions tried. Returns the report's ``verified``,
    ``proofs`` (the proven trees the greedy search finds for the strategies ``others``, when
    ``chosen`` has a proven tree), and, when no proven tree was found, ``blocked``
    (why, :func:`ndbg_cli.planning.proven.why_stuck`) and ``candidate`` (the unproven tree's
    steps, kept for what they are). ``chosen`` may have no tree (``found`` False): the
    search then starts from nothing. ``exact_rounds``: stuck subassemblies whose own infinite
    NDBG may be computed (:data:`EXACT_ROUNDS`). ``shallow``: given the least depth of the proven
    trees found, the steps of a shallower candidate tree of the least candidate depth (or
    ``None``), proven step by step; proven, it joins ``proofs`` (strategy ``shortest``) and
    decides the proven minimum depth. With ``workers`` over 1, a candidate tree and
    ``others``, the rows the greedy searches read (every part along the first natural
    directions) are computed first, half in a second process (:meth:`Rows.fill`)."""
    from ..ndbg.infinite.sweep import SweepChecker

    nd = chosen.ndbg
    sweep = SweepChecker(asm)
    natural = natural_directions(analysis, nd.space_dimension)[:NATURAL_LIMIT]
    order = sorted((r for r, reg in enumerate(nd.regions) if reg.direction is not None),
                   key=lambda r: region_rank(nd, r))
    dirs = directions(nd.space_dimension, natural, [(r, nd.regions[r].direction) for r in order])
    rows = Rows(sweep, nd.n, dirs, nd)
    n_nat = sum(d.source != "region" for d in dirs)  # natural ones first (directions())
    cand = [(s.mask, s.moved, None if s.region is None else nd.regions[s.region].direction)
            for s in chosen.sequence()]
    if workers > 1 and cand and others:
        rows.fill(range(min(n_nat, GREEDY_WIDE)), workers)
    room = _Clearance(analysis, nd.space_dimension)
    used: set[int] = set()  # read by the key (fewest-directions), filled by the search
    key = chooser(strategy, connected, used, dirs, room)
    got = prove(rows, chosen.root, cand, natural=n_nat, key=key, base=base, clearance=room,
                used=used, objective=strategy)
    exact: dict[int, str] = {}
    for _ in range(exact_rounds):
        if got.found or got.stuck in exact:
            break
        # the stuck subassembly's own infinite NDBG over the whole sphere, when small enough:
        # no partitioning is a proof that no plan exists; else its regions' directions join D
        verdict, more = _exact_split(asm, nd, got.stuck, budget)
        exact[got.stuck] = verdict
        if verdict != "some" or not rows.extend(more):
            break
        failed = got.failed_step
        used.clear()
        got = greedy(rows, chosen.root, base=base, key=key, natural=n_nat, used=used)
        got.failed_step = failed
    out: dict = {}
    if got.found:
        steps = {m: _step(nd, sp.mask, sp.moved, sp.vector(dirs), dirs[sp.k].source)
                 for m, sp in got.splits.items()}
        chosen.steps, chosen.found, chosen.stuck = steps, True, None
        if got.searched and cand:
            chosen.exact = False
            chosen.notes.append(
                f"the candidate tree's step {got.failed_step} is blocked further away along "
                f"every direction tried; " + (
                    f"a greedy search from the whole product found a proven tree better for "
                    f"'{strategy}' than the candidate tree repaired" if got.restarted else
                    "the subassemblies whose candidate steps fail are split by a greedy "
                    "search instead") +
                ", which needs no backtracking (any proven tree restricts to every "
                "subassembly)")
        out["verified"] = {"value": True, "steps": len(steps),
                           "directions_tried": len(rows.dirs),
                           "why": "every step is proven: its moved side leaves the rest by one "
                                  "translation to infinity along the stated direction (direct "
                                  "sweep test, exact for that direction): a 1-handed monotone "
                                  "1-prismatic algorithm"}
    else:
        out.update(_no_plan(rows, sweep, nd, chosen, got.stuck, exact.get(got.stuck)))
    out["proofs"] = [] if not got.found else [
        _other(rows, chosen.root, s, n_nat, base, room) for s in others]
    steps = None if not got.found or shallow is None else shallow(min(
        [measures(rows, chosen.root, got.splits)["depth"]]
        + [t["depth"] for t in out["proofs"]]))
    if steps:
        splits, failed = prove_tree(rows, steps, n_nat, room)
        if failed is None:
            out["proofs"].append({"strategy": "shortest",
                                  **measures(rows, chosen.root, splits)})
    return out


def splits_somewhere(asm: Assembly, analysis: Any, nd: NDBG, mask: int
                     ) -> tuple[tuple[float, ...] | None, list[dict]]:
    """A natural direction (the axes, the contacts' normals and cylinder axes, at most
    :data:`NATURAL_LIMIT`) along which the direct sweep test splits subassembly ``mask``, or
    ``None``: a cheap check of a contact-based proof that nothing splits it. With ``None``,
    the report's ``blocked`` entries for it: along those directions, each part of ``mask``
    (the axes first) with a part of ``mask`` that blocks it and where (at most
    :data:`WITNESSES`)."""
    from ..ndbg.infinite.sweep import SweepChecker

    natural = natural_directions(analysis, nd.space_dimension)[:NATURAL_LIMIT]
    dirs = directions(nd.space_dimension, natural, [])
    sweep = SweepChecker(asm)
    rows = Rows(sweep, nd.n, dirs, nd)
    d = next((dirs[k].vector for k in range(len(dirs))
              if len(rows.components(k, mask)) > 1), None)
    if d is not None:
        return d, []
    out: list[dict] = []
    for k, i in ((k, i) for k in range(len(dirs)) for i in bits(mask)):
        j = next(iter(bits(rows.row(k, i, mask) & ~(1 << i))), None)
        if j is None:
            continue
        at = sweep.witness(i, j, np.asarray(dirs[k].vector))
        out.append({"moved": nd.names(1 << i), "region": None,
                    "removal_direction": list(dirs[k].vector),
                    "blocked_by": [nd.ids[i], nd.ids[j]],
                    "at": None if at is None else [float(x) for x in at]})
        if len(out) == WITNESSES:
            break
    return None, out


def cross_check(asm: Assembly, analysis: Any, chosen: Plan, proof: dict, *, strategy: str,
                base: int | None, connected: ConnectivityTest, budget: int,
                workers: int = 1) -> dict:
    """``proof``, the infinitesimal NDBG's proof that no plan exists (``chosen`` has no
    candidate tree; its subassembly ``stuck`` has no candidate split), checked: the plan
    section's fields to use. That proof rests on the contact analysis and its tolerances,
    while the direct sweep test is exact for each direction it tests. So the stuck
    subassembly is tested along the natural directions; where one splits it, ``proof`` does
    not stand, and (up to :data:`CROSS_SEARCH_PARTS` parts) the proven search runs: a proven
    tree it finds is presented, the contradiction noted. When the sweep agrees, the stuck
    subassembly's own infinite-translation NDBG over the whole sphere (which uses no contact),
    within :data:`EXACT_RESTRICTED` times ``budget``, makes the proof independent of the
    contacts, or finds the split they hide. With ``workers`` over 1, that NDBG is built in a
    forked process while the sweep runs here (dropped if the sweep splits), even when the
    interlock job still works (:func:`~ndbg_cli.pipeline.stages.interlock_job`, the tail of
    its grasps): the sweep and that NDBG are both waited for, so sharing two cores three
    ways a moment still ends sooner than the two one after the other (on the engine GLB the
    job had 0.05 s left, and the exact NDBG took 0.3 s after the sweep here)."""
    from ..core.pools import Forked

    stuck, notes = chosen.stuck, list(chosen.notes)
    names = ", ".join(chosen.ndbg.names(stuck))
    with Forked(_exact_split, asm, chosen.ndbg, stuck, EXACT_RESTRICTED * budget, True,
                enabled=workers > 1) as exact:  # dropped when the sweep splits
        d, blocked = splits_somewhere(asm, analysis, chosen.ndbg, stuck)
        exact_found = exact.result() if d is None else None
    by = "the direct sweep test"
    if exact_found is not None:  # the exact test agrees along every natural direction
        verdict, more = exact_found
        if verdict != "some":
            if verdict == "none":
                v = proof["verified"]
                proof = {**proof, "verified": {**v, "why": v["why"] + (
                    f"; confirmed without the contacts: the infinite-translation NDBG of "
                    f"{{{names}}} over the whole sphere has no partitioning")}}
            return {**proof, "blocked": blocked}
        d, by = more[0].vector, f"the infinite-translation NDBG of {{{names}}}"
    doubt = {"verified": {
        "value": False, "steps": 0, "proof_of_none": False,
        "why": f"no candidate tree: the contacts let no direction split {{{names}}} even "
               f"infinitesimally, but {by} splits it along "
               f"({', '.join(f'{x:g}' for x in d)}): the contact analysis reports blocking "
               f"the exact test does not find, so this is not a proof"}}
    if len(asm) > CROSS_SEARCH_PARTS:
        return doubt
    got = prove_plan(asm, analysis, chosen, strategy=strategy, base=base,
                     connected=connected, budget=budget, exact_rounds=0)
    if (got.get("verified") or {}).get("value") is not True:
        chosen.found, chosen.stuck, chosen.steps, chosen.notes = False, stuck, {}, notes
        return doubt
    chosen.notes.append(
        f"the infinitesimal NDBG has no candidate tree ({{{names}}} has no candidate "
        f"partitioning), yet the direct sweep test proves this tree step by "
        f"step: the contact analysis reports blocking that the exact test does not find "
        f"(a contact within the tolerances, e.g. of a coarse or overlapping tessellation)")
    return got


class _Clearance:
    """:class:`ndbg_cli.planning.proven.Clearance` from the contacts: the least ``-n . d``
    over the contact normals ``n`` out of ``moved`` into ``rest`` (1 when they touch
    nowhere). The normals are kept per part, and the smaller side's parts are read: one part
    against the rest costs its own contacts, not the assembly's (the greedy search asks this
    for every split it ranks)."""

    def __init__(self, analysis: Any, dimension: int) -> None:
        pairs: dict[tuple[int, int], list[np.ndarray]] = {}
        for c in getattr(analysis, "contacts", ()):
            n = np.asarray(c.normals, dtype=float).reshape(-1, dimension)
            pairs.setdefault((c.a, c.b), []).append(n)
            pairs.setdefault((c.b, c.a), []).append(-n)
        #: part a -> [(b, normals out of a into b)], in the contacts' order
        self.out: dict[int, list[tuple[int, np.ndarray]]] = {}
        self.touching_of: dict[int, int] = {}  # part a -> bitmask of the parts it touches
        for (a, b), ns in pairs.items():
            self.out.setdefault(a, []).append((b, np.vstack(ns)))
            self.touching_of[a] = self.touching_of.get(a, 0) | 1 << b
        # the answer depends on the smaller side and the parts of the other it touches
        # only: a part leaving one subassembly after another asks the same question again
        self._memo: dict[tuple, float] = {}

    def touching(self, i: int) -> int:
        return self.touching_of.get(i, 0)

    def __call__(self, moved: int, rest: int, d: tuple[float, ...]) -> float:
        # n out of moved into rest along d is -n out of rest into moved: -(n.d) = (-n).(-d)
        side, other, sign = ((moved, rest, 1.0) if moved.bit_count() <= rest.bit_count()
                             else (rest, moved, -1.0))
        near = 0
        for a in bits(side):
            near |= self.touching_of.get(a, 0)
        near &= other
        key = (side, near, sign, d)
        got = self._memo.get(key)
        if got is None:
            v = np.asarray(d)
            got = 1.0
            for a in bits(side):
                for b, n in self.out.get(a, ()):
                    if near >> b & 1:
                        got = min(got, float((-sign * (n @ v)).min()))
            self._memo[key] = got
        return got


def _step(nd: NDBG, mask: int, moved: int, d: tuple[float, ...], source: str) -> Step:
    """A proven step along ``d``, in the region freeing it whose direction is nearest ``d``
    (``None`` when no region of ``nd`` frees it: the tolerances of the two tests differ)."""
    v = np.asarray(d)
    # the regions nearest d first (as the rounded cosine, then the lower index, rank them):
    # the first that frees the step is the one sought, without testing all of them
    near = sorted(((round(float(np.dot(reg.direction, v)), 9), -r) for r, reg
                   in enumerate(nd.regions) if reg.direction is not None), reverse=True)
    region = next((-r for _, r in near if nd.regions[-r].dbg.is_free(moved, mask)), None)
    return Step(mask=mask, moved=moved, rest=mask & ~moved, region=region, stated=d,
                source=source)


def _exact_split(asm: Assembly, nd: NDBG, stuck: int, budget: int, whole_sphere: bool = False
                 ) -> tuple[str, list[Direction]]:
    """Whether any translation splits subassembly ``stuck``, from its own infinite-translation
    NDBG (paper 5.3, the arrangement of :mod:`ndbg_cli.ndbg.infinite.build`, with the whole
    assembly's length tolerance): over the whole sphere within ``budget`` facing triangle
    pairs; up to :data:`EXACT_RESTRICTED` times that, restricted to its free domain (the
    directions where its own infinitesimal NDBG frees something: every partitioning of it
    lies there, :mod:`ndbg_cli.ndbg.infinite.domain`). ``("none", [])`` (a proof),
    ``("some", its partitionings' region directions)`` or ``("over budget", [])``.
    ``whole_sphere``: never restricted (the free domain comes from the contacts)."""
    from ..ndbg.infinite.blocked_sets import triangle_pairs
    from ..ndbg.infinite.build import build_infinite
    from ..ndbg.model import partitionings

    sub = asm.subset(nd.names(stuck)).replace(tolerance=asm.length_tolerance)
    pairs = triangle_pairs(sub)
    if pairs <= budget:
        inf = build_infinite(sub)
    elif sub.dimension == 3 and not whole_sphere and pairs <= EXACT_RESTRICTED * budget:
        domain = _own_domain(sub)
        if domain is None:  # something is free in every direction: no proof to be had here
            return "over budget", []
        inf = build_infinite(sub, domain=domain)
    else:
        return "over budget", []
    parts, _ = partitionings(inf)
    if not parts:
        return "none", []
    regs = sorted({r for p in parts for r in p.regions}, key=lambda r: region_rank(inf, r))
    return "some", [Direction(snap(inf.regions[r].direction), "region") for r in regs
                    if inf.regions[r].direction is not None]


def _own_domain(sub: Assembly):
    """The free domain of ``sub`` from its own contacts (:func:`free_domain`)."""
    from ..contacts.contacts3d import analyze_contacts
    from ..ndbg.infinite.domain import free_domain
    from ..ndbg.infinitesimal.build import contact_pairs

    ca = analyze_contacts(sub)
    return free_domain(len(sub.parts), contact_pairs(sub, ca), float(ca.angle_tolerance))


def _no_plan(rows: Rows, sweep: Any, nd: NDBG, chosen: Plan, stuck: int,
             exact: str | None) -> dict:
    """The report's fields when no proven tree exists along the directions tried (``exact``:
    :func:`_exact_split`'s verdict on ``stuck``, if it ran)."""
    from ..planning.decompose import sink_decompose
    from ..planning.plans import sequence_json

    candidate = {"sequence": sequence_json(chosen),
                 "why": "a candidate tree: each step is free for the family's motions "
                        "(a necessary condition only); some step of it is blocked further "
                        "away along every direction tried"}
    tried = len(rows.dirs)
    names = ", ".join(nd.names(stuck))
    if nd.family == INFINITESIMAL and sink_decompose(nd, stuck)[1] is not None:
        proof, why = True, (f"no plan of single translations exists: no direction moves any "
                            f"part of {{{names}}} even infinitesimally (a proof)")
    elif exact == "none":
        proof, why = True, (f"no plan of single translations exists: the infinite-translation "
                            f"NDBG of {{{names}}}, computed over every direction that moves "
                            f"some part of it even infinitesimally, has no partitioning of it "
                            f"(a proof)")
    else:
        proof, why = False, (
            f"no proven plan along the {tried} directions tried: no direction among them "
            f"splits {{{names}}} (any plan along them would); not a proof over all directions"
            + ("" if exact != "over budget" else
               " (its infinite-translation NDBG is over the --infinite-budget)"))
    blocked = [{"moved": nd.names(w["moved"]), "region": w["region"],
                "removal_direction": list(w["direction"]),
                "blocked_by": [nd.ids[w["pair"][0]], nd.ids[w["pair"][1]]],
                "at": None if w["point"] is None else [float(x) for x in w["point"]]}
               for w in why_stuck(rows, sweep, nd, stuck)]
    chosen.found, chosen.stuck, chosen.steps = False, stuck, {}
    chosen.notes.append(why)
    return {"verified": {"value": False, "steps": 0, "directions_tried": tried,
                         "proof_of_none": proof, "why": why},
            "blocked": blocked, "candidate": candidate}


def _other(rows: Rows, root: int, strategy: str, natural: int, base: int | None,
           room: _Clearance) -> dict:
    """The proven tree the greedy search finds for ``strategy`` (its objective in
    :func:`~ndbg_cli.planning.proven.chooser`'s key): its depth, nonlinear steps and
    directions, each an upper bound on the proven optimum."""
    used: set[int] = set()  # read by the key (fewest-directions), filled by the search
    got = greedy(rows, root, base=base, key=chooser(strategy, None, used, rows.dirs, room),
                 natural=natural, used=used)
    return {"strategy": strategy, **measures(rows, root, got.splits)}


def shallowest(chosen: Plan, depth: dict | None, graph: Any, base: int | None, budget: Any,
               best: int) -> list | None:
    """The steps of a candidate tree of the family's least depth (``depth``, its classes'
    ``min_depth``), when that minimum is exact and the proven trees found so far are deeper
    (``best``; the plan's sides are kept connected, the other proofs follow other
    objectives): proven, it makes the proven minimum depth exact whatever trees the greedy
    proofs happen to find (they depend on the frame and the part order; issue 34's
    invariance). ``graph``: the family's AND/OR graph, reused. ``None`` when there is nothing
    to gain (:func:`prove_plan`'s ``shallow``)."""
    depth = depth or {}
    if not depth.get("exact") or depth.get("value") is None or best <= depth["value"]:
        return None
    from ..planning.plans import plan

    p = plan(chosen.ndbg, "shortest", base=base, connected=None, budget=budget, graph=graph)
    if not p.found or p.depth() != depth["value"]:
        return None
    nd = p.ndbg
    return [(s.mask, s.moved, None if s.region is None else nd.regions[s.region].direction)
            for s in p.sequence()]


def proven_classes(plan: dict, candidates: dict, base: str | None = None) -> dict:
    """The infinite-translation classes a proven plan (or a proof that none exists) decides,
    for a report whose infinite NDBG was not computed over the whole sphere: ``plan`` is the
    report's plan section, ``candidates`` the infinitesimal family's classes (their minima
    are lower bounds: every proven tree is a candidate tree). Labelled as
    :func:`ndbg_cli.planning.classes.label` does; ``{}`` when the plan decides nothing."""
    from ..planning.classes import label

    v = plan.get("verified") or {}
    why_from = "witness: the proven plan" if plan.get("found") else "proof"
    if plan.get("found") and v.get("value") is True:
        tree = _tree_text(plan.get("tree"))
        yes = f"{why_from}, tree {tree}"
        out: dict = {"one_handed_monotone": {"value": True, "why": yes},
                     "prismatic": {"value": True,
                                   "why": "guaranteed 1-handed monotone 1-prismatic: " + yes}}
        # every proven tree is a candidate tree: the candidates' least depth bounds it below
        cand = candidates.get("min_depth") or {}
        # the plan's own lower bound holds for all trees only when its search was not kept
        # to connected sides (as1: 7 for connected trees, while a proven tree has depth 5)
        n = len((plan.get("sequence") or [{}])[-1].get("produces") or ())
        lows = [max(0, n - 1).bit_length() if plan.get("connected")  # ceil(log2 n)
                else plan.get("depth_lower_bound") or 1]
        if cand.get("value") is not None and cand.get("exact", False):
            lows.append(cand["value"])
        elif cand.get("lower_bound") is not None:
            lows.append(cand["lower_bound"])
        depth = min([plan["depth"]] + [t["depth"] for t in plan.get("proofs") or []])
        lower = min(max(lows), depth)
        out["min_depth"] = {"value": depth, "exact": lower == depth, "lower_bound": lower,
                            "upper_bound": depth,
                            "why": f"a proven tree of depth {depth}; no candidate tree is "
                                   f"shallower than {lower}"}
        out.update(_directions_classes(plan, candidates, base))
        linear = plan.get("nonlinear_steps") == 0 or any(
            t.get("nonlinear_steps") == 0 for t in plan.get("proofs") or [])
        cand_lin = (candidates.get("linearizable") or {}).get("value")
        if linear:
            out["linearizable"] = {"value": True, "why": "a proven tree adds one part at a time"}
        elif cand_lin is False:
            out["linearizable"] = {"value": False,
                                   "why": "no candidate tree adds one part at a time"}
    elif v.get("proof_of_none"):
        out = {k: {"value": False, "why": "no 1-prismatic algorithm: " + v["why"]}
               for k in ("one_handed_monotone", "prismatic", "linearizable", "stack_product")}
        for k in ("min_depth", "min_directions"):
            out[k] = {"value": None, "exact": True, "why": v["why"]}
    else:
        return {}
    return {k: label(INFINITE, k, m) for k, m in sorted(out.items())}


def direction_counts(plan: dict, base: str | None) -> list[int]:
    """The distinct removal directions of each proven tree of a plan section: the greedy
    proofs' counts, and the plan's own when its moved sides never hold ``base`` (the
    classes' convention: a direction is the moved side's, the one without the base)."""
    counts = [t["directions"] for t in plan.get("proofs") or [] if "directions" in t]
    steps = plan.get("sequence") or []
    if steps and all(s.get("removal_direction") is not None and base not in s["moved"]
                     for s in steps):
        counts.append(len({tuple(s["removal_direction"]) for s in steps}))
    return counts


def _directions_classes(plan: dict, candidates: dict, base: str | None) -> dict:
    """``min_directions`` and ``stack_product`` from the proven trees of a plan section (the
    greedy proofs' counts of distinct removal directions; their moved sides never hold the
    base, the classes' convention). Every proven tree is a candidate tree whose steps lie in
    at most as many regions as it has directions, so the candidates' exact minimum bounds the
    count below (the plan itself counts when its moved sides never hold ``base``); a proven
    tree along one direction is a stack product (paper 7.1: every
    instruction along that direction); and each infinite-translation DBG holds the
    infinitesimal one of its direction, so no candidate stack product means none at all."""
    counts = direction_counts(plan, base)
    out: dict = {}
    cand = candidates.get("min_directions") or {}
    low = cand.get("value") if cand.get("exact", False) else cand.get("lower_bound")
    if counts:
        best = min(counts)
        lower = best if low is None else min(int(low), best)
        out["min_directions"] = {
            "value": best, "exact": lower == best, "lower_bound": lower, "upper_bound": best,
            "why": f"a proven tree along {best} direction(s); no candidate tree uses fewer "
                   f"than {lower} region(s)"}
        if best == 1:
            out["stack_product"] = {"value": True,
                                    "why": "a proven tree moves every side without the base "
                                           "along one direction"}
    if "stack_product" not in out and (candidates.get("stack_product") or {}).get(
            "value") is False:
        out["stack_product"] = {"value": False,
                                "why": "no single direction's DBG decomposes the product even "
                                       "for infinitesimal translations"}
    return out


def _tree_text(node: dict | None) -> str:
    """``(a | (b | c))`` for a plan section's tree."""
    if not node:
        return "()"
    if "moved" not in node:
        return ", ".join(node["parts"])
    return f"({_tree_text(node['moved'])} | {_tree_text(node['rest'])})"
