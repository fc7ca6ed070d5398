"""Assembly planning, AND/OR graph, complexity classes, interlocking LP and grasps, checked
against hand-built NDBGs whose answers are worked out by hand, and against brute force."""

from __future__ import annotations

import itertools
import json
import math
import random
from pathlib import Path

import numpy as np
import pytest

from ndbg_cli.ndbg.dbg import DBG, bits, mask_of
from ndbg_cli.ndbg.model import NDBG, ConnectivityTest, Region
from ndbg_cli.planning.andor import AndOrGraph, Budget, node_splits
from ndbg_cli.planning.classes import classes_section, classify
from ndbg_cli.planning.decompose import min_depth_search, min_directions, sink_decompose
from ndbg_cli.planning.grasp import grasp
from ndbg_cli.planning.interlock import interlock
from ndbg_cli.planning.plans import STRATEGIES, plan
from ndbg_cli.planning.removal import remove
from ndbg_cli.report.classes import andor_section, classes_text
from ndbg_cli.report.plans import plan_section
from ndbg_cli.report.text import plan_lines

UP, DOWN = (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)
PX, NX, PY, NY = (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)


def mk(ids, regions, family="infinitesimal_translation") -> NDBG:
    n = len(ids)
    return NDBG(family, tuple(ids),
                tuple(Region(2, d, DBG.from_arcs(n, arcs)) for d, arcs in regions))


def both(*pairs):
    return [a for i, j in pairs for a in ((i, j), (j, i))]


def complete(n):
    return [(i, j) for i in range(n) for j in range(n) if i != j]


# ------------------------------------------------------------------------- hand examples
def stack3():
    """A (0) under B (1) under C (2); pinned laterally, so only +-z separate anything."""
    lateral = both((0, 1), (1, 2))
    return mk("ABC", [(UP, [(0, 1), (1, 2)]), (DOWN, [(1, 0), (2, 1)]),
                      (PX, lateral), (NX, lateral), (PY, lateral), (NY, lateral)])


def test_stack3_by_hand():
    nd = stack3()
    g = AndOrGraph(nd).build()
    # root splits {C | AB} (+z) and {A | BC} (-z); nodes ABC, AB, BC, A, B, C
    assert g.complete and g.node_count == 6 and g.hyperarc_count == 4
    assert g.min_depth() == 2
    assert g.tree_count() == 2          # (C | (A | B)) and (A | (B | C))
    assert g.linear_count() == 4        # ABC, BAC, CBA, BCA
    assert g.min_nonlinear() == 0
    c = classify(nd)
    assert c["one_handed_monotone"]["value"] is True
    assert c["linearizable"]["value"] is True
    assert c["stack_product"]["value"] is True and c["stack_product"]["region"] == 0
    assert c["min_directions"]["value"] == 1 and c["min_directions"]["exact"]


def test_free_parts_counts_are_the_textbook_formulas():
    # n parts, no arcs: every split is free. Trees = (2n-3)!!, linear = n!, depth ceil(log2 n)
    for n in range(1, 7):
        nd = mk([f"P{i}" for i in range(n)], [(UP, [])])
        g = AndOrGraph(nd).build()
        assert g.tree_count() == math.prod(range(1, 2 * n - 2, 2))
        assert g.linear_count() == math.factorial(n)
        assert g.min_depth() == (n - 1).bit_length()
        assert g.node_count == 2 ** n - 1


def latch():
    """Fig. 10: three parts, every DBG strongly connected."""
    cyc = [(0, 1), (1, 2), (2, 0)]
    rev = [(j, i) for i, j in cyc]
    return mk("ABC", [(PX, cyc), (NX, rev), (PY, both((0, 1), (1, 2))),
                      (NY, both((0, 1), (1, 2))), (UP, complete(3)), (DOWN, complete(3))])


def test_latch_not_one_handed_monotone():
    nd = latch()
    c = classify(nd)
    assert c["one_handed_monotone"]["value"] is False
    assert "{A, B, C}" in c["one_handed_monotone"]["why"]
    assert c["linearizable"]["value"] is False
    assert c["min_depth"]["value"] is None
    assert c["prismatic"]["value"] is False
    g = AndOrGraph(nd).build()
    assert g.min_depth() is None and g.tree_count() == 0 and g.linear_count() == 0
    p = plan(nd, "shortest")
    assert not p.found and p.stuck == 0b111
    assert plan_section(p)["sequence"] == []


def latch_normals():
    """Normals (out of a into b) realising the latch: A-B allows v_B - v_A = (t,0,0), t >= 0;
    A-C allows v_C - v_A = (0,t,0); B-C allows v_C - v_B along (-1,1,0) only; z is blocked."""
    s = 1 / math.sqrt(2)
    z = [(0, 0, 1), (0, 0, -1)]
    return {(0, 1): np.array([(1, 0, 0), (0, 1, 0), (0, -1, 0)] + z, float),
            (0, 2): np.array([(0, 1, 0), (1, 0, 0), (-1, 0, 0)] + z, float),
            (1, 2): np.array([(s, s, 0), (-s, -s, 0)] + z, float)}


def test_latch_not_interlocked_but_needs_two_hands():
    normals = latch_normals()
    # no single part (or pair: the complement) translates alone: check the one-part motions
    for moving in range(3):
        for d in itertools.product((-1, 0, 1), repeat=3):
            if d == (0, 0, 0):
                continue
            v = np.zeros((3, 3))
            v[moving] = d
            ok = all(float(n @ (v[b] - v[a])) >= -1e-12
                     for (a, b), ns in normals.items() for n in ns)
            assert not ok
    # exactly: merging the other two parts into one fixed body leaves a boxed-in part
    for moving in range(3):
        merged = {}
        for (a, b), ns in normals.items():
            if moving in (a, b):
                sign = 1.0 if b == moving else -1.0   # normals out of the fixed body
                merged.setdefault((0, 1), []).extend(sign * ns)
        assert interlock(2, {k: np.array(v) for k, v in merged.items()})["value"] is True
    r = interlock(3, normals, fixed=0)
    assert r["value"] is False and r["kind"] == "separating"
    assert r["moved_set_count"] == 2 and r["fixed_set"] == [0] and r["moved_sets"] == [[1], [2]]
    v = np.array(r["velocities"])
    for (a, b), ns in normals.items():
        assert np.all(ns @ (v[b] - v[a]) >= -1e-9)


def test_interlock_two_boxes_and_boxed_part_and_peg():
    r = interlock(2, {(0, 1): np.array([[0, 0, 1.0]])})
    assert r["value"] is False and r["moved_sets"] == [[1]] and r["velocities"][1][2] == 1.0
    box = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], float)
    r = interlock(2, {(0, 1): box})
    assert r["value"] is True and r["kind"] is None
    # fixing the inner part instead changes nothing
    assert interlock(2, {(0, 1): box}, fixed=1)["value"] is True
    # peg in a through-hole: radial normals only; it slides along z without separating
    ang = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    radial = np.stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)], axis=1)
    r = interlock(2, {(0, 1): radial})
    assert r["value"] is False and r["kind"] == "sliding"
    assert abs(r["velocities"][1][2]) == 1.0 and r["velocities"][1][:2] == [0.0, 0.0]


def fig11():
    """Fig. 11: {A,B} comes off {C,D} (+z) and each pair splits (+-x), no single part can
    leave the whole product."""
    cyc4 = [(0, 1), (1, 2), (2, 3), (3, 0)]
    up = both((0, 1), (2, 3)) + [(2, 0), (3, 1)]
    return mk("ABCD", [(UP, up), (DOWN, [(j, i) for i, j in up]), (PX, cyc4),
                       (NX, [(j, i) for i, j in cyc4])])


def test_fig11_one_handed_not_linearizable():
    nd = fig11()
    c = classify(nd)
    assert c["one_handed_monotone"]["value"] is True
    assert c["linearizable"]["value"] is False
    assert c["min_nonlinear"]["value"] == 1 and c["min_nonlinear"]["assembly_lines"] == 2
    g = AndOrGraph(nd).build()
    assert [(h.left, h.right) for h in g.arcs[0b1111]] == [(0b0011, 0b1100)]
    assert g.tree_count() == 1 and g.linear_count() == 0 and g.min_depth() == 2
    p = plan(nd, "linear")
    assert p.found and p.nonlinear() == 1


def sandwich(k):
    """Fig. 2: plates P (0) and Q (1) around k >= 2 interlocked middles M1..Mk (2..k+1).

    +z: P blocked by every middle, every middle by Q, middles in a cycle; -z reversed. +-x:
    everything blocks everything. +y: plates and middles block each other both ways, middles
    form a chain M1 -> M2 -> ... (so alone they come apart along y); -y reversed chain."""
    n = k + 2
    mids = list(range(2, n))
    cyc = [(mids[i], mids[(i + 1) % k]) for i in range(k)]
    up = [(0, m) for m in mids] + [(m, 1) for m in mids] + cyc
    chain = [(mids[i], mids[i + 1]) for i in range(k - 1)]
    pm = both(*[(p, m) for p in (0, 1) for m in mids])
    return mk(["P", "Q"] + [f"M{i}" for i in range(1, k + 1)],
              [(UP, up), (DOWN, [(j, i) for i, j in up]), (PX, complete(n)),
               (NX, complete(n)), (PY, pm + chain), (NY, pm + [(j, i) for i, j in chain])])


def catalan(m):
    return math.comb(2 * m, m) // (m + 1)


@pytest.mark.parametrize("k", [2, 3, 4, 5, 6])
def test_sandwich_two_decompositions(k):
    nd = sandwich(k)
    full = (1 << (k + 2)) - 1
    arcs, _ = node_splits(nd, full)
    assert sorted((h.left, h.right) for h in arcs) == sorted(
        [(0b1, full & ~0b1), (full & ~0b10, 0b10)])   # {P | rest} and {Q | rest}
    g = AndOrGraph(nd).build()
    # nodes: the k(k+1)/2 intervals of middles, the product, P+middles, Q+middles, P, Q
    assert g.node_count == k * (k + 1) // 2 + 5
    # T = 2 * Catalan(k-1) (the middles split as an ordered chain), L = 2 * 2^(k-1)
    assert g.tree_count() == 2 * catalan(k - 1)
    assert g.linear_count() == 2 ** k
    assert g.min_depth() == 2 + (k - 1).bit_length()


def test_min_directions_two():
    # +z: only C leaves; +x (on A, B): B leaves; -z: A,B leave together (cycle), -x: cycle
    nd = mk("ABC", [(UP, both((0, 1)) + [(0, 2), (1, 2)]),
                    (DOWN, both((0, 1)) + [(2, 0), (2, 1)]),
                    (PX, [(0, 1)] + both((2, 0), (2, 1))),
                    (NX, [(1, 0)] + both((2, 0), (2, 1)))])
    md = min_directions(nd)
    assert md["value"] == 2 and md["exact"] and md["lower_bound"] == 2
    assert classify(nd)["stack_product"]["value"] is False
    p = plan(nd, "fewest-directions")
    assert p.found and len(p.regions_used()) == 2


def test_stack_product_four_parts():
    up = [(0, 1), (1, 2), (2, 3)]
    nd = mk("ABCD", [(UP, up), (DOWN, [(j, i) for i, j in up]),
                     (PX, complete(4)), (NX, complete(4))], family="infinite_translation")
    c = classify(nd)
    assert c["stack_product"]["value"] is True
    assert c["min_directions"]["value"] == 1
    assert c["prismatic"]["value"] is True
    p = plan(nd, "fewest-directions")
    assert len(p.regions_used()) == 1


# ----------------------------------------------------------------------------- brute force
def random_ndbg(rng: random.Random, n: int, regions: int, prob: float) -> NDBG:
    regs = []
    for _ in range(regions):
        arcs = [(i, j) for i in range(n) for j in range(n) if i != j and rng.random() < prob]
        regs.append(((1.0, 0.0, 0.0), arcs))
    return mk([f"p{i}" for i in range(n)], regs)


def random_neighbours(rng: random.Random, n: int) -> list[int]:
    """A random undirected graph over ``n`` parts as neighbour bitmasks (symmetric)."""
    neigh = [rng.randrange(1 << n) & ~(1 << i) for i in range(n)]
    for i in range(n):
        for j in bits(neigh[i]):
            neigh[j] |= 1 << i
    return neigh


def hier_ndbg(rng: random.Random, n: int, regions: int, noise: float) -> NDBG:
    """A random hierarchical product: a random binary tree over the parts; at every internal
    node ``X | Y`` one random region lets ``X`` leave (arcs ``Y -> X`` only), every other region
    locks ``X`` and ``Y`` both ways; then a fraction ``noise`` of the arcs is dropped. Gives
    nonlinear and non-linearizable cases that uniform random DBGs rarely produce."""
    arcs: list[set] = [set() for _ in range(regions)]

    def build(parts: list[int]) -> None:
        if len(parts) == 1:
            return
        k = rng.randint(1, len(parts) - 1)
        xs, ys = parts[:k], parts[k:]
        rv = rng.randrange(regions)
        for i in xs:
            for j in ys:
                for r in range(regions):
                    arcs[r].update({(j, i)} if r == rv else {(i, j), (j, i)})
        build(xs)
        build(ys)

    parts = list(range(n))
    rng.shuffle(parts)
    build(parts)
    for r in range(regions):
        for a in sorted(arcs[r]):
            if rng.random() < noise:
                arcs[r].discard(a)
    return mk([f"p{i}" for i in range(n)], [((1.0, 0.0, 0.0), sorted(a)) for a in arcs])


def split_ok(nd: NDBG, mask: int, s: int, base: int | None) -> bool:
    """Generate-and-test: is {s, mask - s} a candidate partitioning (direct DBG test)?"""
    r = mask & ~s
    for moved in (s, r):
        if base is not None and (mask >> base) & 1 and (moved >> base) & 1:
            continue
        if any(reg.dbg.is_free(moved, mask) for reg in nd.regions):
            return True
    return False


def all_trees(mask: int, memo: dict) -> list:
    """Every binary tree over the parts of ``mask`` (unordered children), as nested tuples."""
    if mask in memo:
        return memo[mask]
    if mask.bit_count() == 1:
        memo[mask] = [mask]
        return memo[mask]
    low = mask & -mask
    rest = mask & ~low
    out = []
    sub = rest
    while True:
        s = low | sub
        if s != mask:
            for a in all_trees(s, memo):
                for b in all_trees(mask & ~s, memo):
                    out.append((mask, s, a, b))
        if sub == 0:
            break
        sub = (sub - 1) & rest
    memo[mask] = out
    return out


def tree_valid(nd, t, base) -> bool:
    if isinstance(t, int):
        return True
    mask, s, a, b = t
    return split_ok(nd, mask, s, base) and tree_valid(nd, a, base) and tree_valid(nd, b, base)


def tree_depth(t) -> int:
    return 0 if isinstance(t, int) else 1 + max(tree_depth(t[2]), tree_depth(t[3]))


def tree_nonlinear(t) -> int:
    if isinstance(t, int):
        return 0
    mask, s, a, b = t
    nl = 0 if min(s.bit_count(), (mask & ~s).bit_count()) == 1 else 1
    return nl + tree_nonlinear(a) + tree_nonlinear(b)


def brute_linear(nd, n, base) -> int:
    count = 0
    for perm in itertools.permutations(range(n)):
        ok = True
        for k in range(1, n):
            m = mask_of(perm[:k + 1])
            if not split_ok(nd, m, 1 << perm[k], base):
                ok = False
                break
        count += ok
    return count


@pytest.mark.parametrize("kind", ["uniform", "hierarchical"])
@pytest.mark.parametrize("seed", range(40))
def test_bruteforce_against_andor(seed, kind):
    rng = random.Random(seed)
    n = rng.randint(2, 7)
    if kind == "uniform":
        nd = random_ndbg(rng, n, rng.randint(1, 4), rng.choice([0.15, 0.3, 0.45]))
    else:
        nd = hier_ndbg(rng, n, rng.randint(1, 3), rng.choice([0.0, 0.05, 0.15]))
    base = rng.choice([None, rng.randrange(n)])
    full = (1 << n) - 1
    valid = [t for t in all_trees(full, {}) if tree_valid(nd, t, base)]
    g = AndOrGraph(nd, base=base).build()
    assert g.tree_count() == len(valid)
    assert g.min_depth() == (min(map(tree_depth, valid)) if valid else None)
    assert g.min_nonlinear() == (min(map(tree_nonlinear, valid)) if valid else None)
    assert g.linear_count() == brute_linear(nd, n, base)
    assert min_depth_search(nd, base=base).depth == g.min_depth()
    c = classify(nd, base=base)
    assert c["one_handed_monotone"]["value"] == bool(valid)
    assert c["linearizable"]["value"] == any(tree_nonlinear(t) == 0 for t in valid)
    # min_directions against brute force over region subsets
    if valid:
        best = None
        for k in range(1, len(nd.regions) + 1):
            for combo in itertools.combinations(range(len(nd.regions)), k):
                sub = NDBG(nd.family, nd.ids, tuple(nd.regions[i] for i in combo))
                if any(tree_valid(sub, t, base) for t in valid):
                    best = k
                    break
            if best:
                break
        assert c["min_directions"]["value"] == best


@pytest.mark.parametrize("cut", [None, "work", "nodes"])
def test_a_build_with_a_helper_process_is_the_build_in_one(cut):
    """``Budget.workers`` 2: the nodes are expanded in batches, half of each in a forked
    :class:`~ndbg_cli.core.pools.Helper`, and replayed in order, so the graph (its nodes in
    the same order, their hyperarcs), the work spent and where a budget cuts it are those
    of one process, whether the budget cuts it or not."""
    rng = random.Random(7)
    nd = random_ndbg(rng, 12, 3, 0.15)  # 352 subassemblies, 8,303 work units
    limits = {None: {}, "work": {"max_work": 4_000}, "nodes": {"max_nodes": 250}}[cut]
    one, two = (AndOrGraph(nd, base=0, budget=Budget(workers=w, **limits)).build()
                for w in (1, 2))
    assert list(two.arcs.items()) == list(one.arcs.items())
    assert (two.truncated, two.cut_by, two.work, two.built_size) == \
        (one.truncated, one.cut_by, one.work, one.built_size)
    assert one.cut_by == cut and len(one.arcs) > 3 * 32  # several batches


@pytest.mark.parametrize("seed", range(3))
def test_bruteforce_eight_parts(seed):
    rng = random.Random(1000 + seed)
    nd = random_ndbg(rng, 8, 3, 0.12)
    full = 255
    valid = [t for t in all_trees(full, {}) if tree_valid(nd, t, None)]
    g = AndOrGraph(nd).build()
    assert g.tree_count() == len(valid)
    assert g.min_depth() == (min(map(tree_depth, valid)) if valid else None)


@pytest.mark.parametrize("seed", range(25))
def test_base_part_never_moved(seed):
    rng = random.Random(500 + seed)
    n = rng.randint(3, 7)
    nd = random_ndbg(rng, n, 3, 0.2)
    base = rng.randrange(n)
    feasible = AndOrGraph(nd, base=base).build().min_depth() is not None
    for strategy in STRATEGIES:
        p = plan(nd, strategy, base=base)
        assert p.found == feasible
        for s in p.steps.values():
            assert not (s.moved >> base) & 1
            assert nd.regions[s.region].dbg.is_free(s.moved, s.mask)
            assert s.moved | s.rest == s.mask and not s.moved & s.rest
        if p.found:
            assert len(p.steps) == n - 1
            covered = set()
            for st in p.sequence():
                covered.add(st.mask)
            assert (1 << n) - 1 in covered


def plan_header(p) -> str:
    """The text report's first line of the plan ``p`` (as the pipeline builds its section)."""
    return plan_lines({"plan": {"family": p.ndbg.family, **plan_section(p)}})[1]


def test_plan_shortest_is_optimal_and_sequence_order():
    nd = sandwich(4)
    p = plan(nd, "shortest")
    assert p.depth() == 4 and p.exact
    sec = plan_section(p)
    seq = sec["sequence"]
    assert [s["step"] for s in seq] == list(range(1, 6))
    assert sorted(seq[-1]["produces"]) == sorted(nd.ids)
    # every step's inputs exist before it: leaves or the output of an earlier step
    made = {frozenset([i]) for i in nd.ids}
    for s in seq:
        assert frozenset(s["moved"]) in made and frozenset(s["onto"]) in made
        made.add(frozenset(s["produces"]))
    assert sec["tree"]["depth"] == 4
    assert plan_header(p).startswith("assembly sequence (shortest")


# ------------------------------------------------------------------------------- remove
def test_remove_buried_part():
    """B (0, base with an overhang), X (1) under Y (2) under Z (3); Z is under the overhang, so
    it must slide out along +x first, then Y lifts (+z), then X is free (+z)."""
    up = [(1, 2), (2, 3), (3, 0)]
    nd = mk("BXYZ", [(UP, up), (DOWN, [(1, 0), (2, 1), (3, 2)]),
                     (PX, [(1, 0), (2, 0)]), (NX, [(1, 0), (2, 0), (3, 0)]),
                     (PY, both((0, 1), (0, 2), (0, 3))), (NY, both((0, 1), (0, 2), (0, 3)))])
    r = remove(nd, 0b0010, base=0)
    assert r.found and r.exact
    assert r.withdrawn == 0b1100
    assert r.steps == [(0b1000, 2), (0b0100, 0)]
    assert r.final_region == 0
    sec = r.section(nd)
    assert sec["withdrawn"] == ["Y", "Z"] and sec["steps"][0]["withdraw"] == ["Z"]
    # the subassembly {X, Y} only needs Z out of the way (sideways), then lifts along +z
    r2 = remove(nd, 0b0110, base=0)
    assert r2.exact and r2.withdrawn == 0b1000 and r2.steps == [(0b1000, 2)]
    assert r2.final_region == 0
    # a part that is free from the start needs nothing
    assert remove(nd, 0b1000, base=0).withdrawn == 0
    # the heuristic (tiny budget) returns a valid plan with the stated lower bound
    h = remove(nd, 0b0010, base=0, budget=Budget(max_nodes=1))
    assert h.found and not h.exact and h.lower_bound == 1
    assert h.withdrawn.bit_count() >= 2


# -------------------------------------------------------------------------------- grasp
def test_grasp_two_stacked_boxes_needs_ten_fingers():
    # bottom box 0 under top box 1; regions: the six axis directions
    nd = mk("LT", [(UP, [(0, 1)]), (DOWN, [(1, 0)]), (PX, []), (NX, []), (PY, []), (NY, [])])
    faces = []
    for part, z in ((0, 0.5), (1, 1.5)):
        for nrm in (PX, NX, PY, NY):
            faces.append((part, nrm, (nrm[0] * 0.5, nrm[1] * 0.5, z)))
    faces.append((0, DOWN, (0, 0, 0)))
    faces.append((1, UP, (0, 0, 2)))
    r = grasp(nd, faces)
    # requirements: up {T}, down {L}, and both parts separately for +-x, +-y: 10, one each
    assert r["complete"] and r["value"] == 10
    parts = sorted((f["part"], tuple(f["normal"])) for f in r["fingers"])
    assert ("T", UP) in parts and ("L", DOWN) in parts
    # without the top face the up-requirement cannot be covered
    r2 = grasp(nd, faces[:-1])
    # (hand-built regions carry no extent: only their representatives are required, and
    # each uncovered requirement names a direction no finger blocks, here the region's own)
    assert r["coverage"] == "representatives"
    assert not r2["complete"] and r2["uncovered"] == [{"region": 0, "parts": ["T"],
                                                        "direction": [0.0, 0.0, 1.0]}]


def _greedy_grasp_reference(nd, faces, tol=1e-9):
    """The plain greedy scan over the dense requirements x faces matrix (the definition)."""
    from ndbg_cli.ndbg.dbg import bit_rows
    from ndbg_cli.planning.grasp import requirements

    reqs = requirements(nd)
    part_of = np.array([p for p, _, _ in faces], dtype=np.intp)
    dirs = np.array([nd.regions[k].direction for k, _ in reqs], dtype=float)
    normals = np.array([nv for _, nv, _ in faces], dtype=float)
    cover = bit_rows([c for _, c in reqs], nd.n)[:, part_of] & (dirs @ normals.T > tol)
    left = np.ones(len(reqs), dtype=bool)
    chosen = []
    tie = np.lexsort((np.arange(len(faces)), part_of))
    while left.any():
        gain = cover[left].sum(axis=0)
        best = int(tie[np.argmax(gain[tie])])
        if gain[best] == 0:
            break
        chosen.append(best)
        left &= ~cover[:, best]
    return chosen, [int(cover[:, f].sum()) for f in chosen], int(left.sum())


def test_grasp_lazy_greedy_equals_the_plain_scan():
    rng = random.Random(7)
    axes = [UP, DOWN, PX, NX, PY, NY, (1, 1, 0), (0, -1, 1), (1, 0, -1)]
    for _ in range(40):
        n = rng.randint(2, 6)
        regions = []
        for _ in range(rng.randint(1, 12)):
            d = np.array([rng.gauss(0, 1) for _ in range(3)])
            arcs = [(i, j) for i in range(n) for j in range(n)
                    if i != j and rng.random() < 0.3]
            regions.append((tuple(d / np.linalg.norm(d)), arcs))
        nd = mk([f"P{i}" for i in range(n)], regions)
        # few distinct normals, so that gains tie often
        faces = [(rng.randrange(n), rng.choice(axes), None) for _ in range(rng.randint(1, 25))]
        chosen, covers, uncovered = _greedy_grasp_reference(nd, faces)
        r = grasp(nd, faces, exact=False)  # the greedy placement itself
        assert [(f["part"], tuple(f["normal"])) for f in r["fingers"]] == [
            (nd.ids[faces[f][0]], tuple(float(x) for x in faces[f][1])) for f in chosen]
        assert [f["covers"] for f in r["fingers"]] == covers
        assert len(r["uncovered"]) == uncovered and r["complete"] == (uncovered == 0)
    # no candidate face: nothing placed, every requirement left
    r = grasp(nd, [])
    assert r["value"] == 0 and not r["complete"] and r["uncovered"]
    # over the budget: skipped with the reason, not computed
    r = grasp(nd, faces, budget=0)
    assert r["value"] is None and r["skipped"] and "budget" in r["why"]


# ------------------------------------------------------------------------------- sections
def test_sections_json_and_schema():
    import jsonschema

    nd = sandwich(3)
    g = AndOrGraph(nd).build()
    sec = andor_section(g)
    assert sec["trees"] == 4 and sec["linear_sequences"] == 8 and not sec["truncated"]
    cs = classes_section([nd, stack3()], interlock=interlock(2, {(0, 1): np.eye(3)}))
    ps = plan_section(plan(nd))
    schema = json.loads((Path(__file__).parents[1] / "ndbg_cli/schemas/fragments/planning.json")
                        .read_text())
    defs = schema["$defs"]
    for name, doc in (("andor", sec), ("classes", cs), ("plan", ps)):
        jsonschema.validate(json.loads(json.dumps(doc)),
                            {"$defs": defs, "$ref": f"#/$defs/{name}"})
    assert any("1-handed monotone" in line for line in classes_text(cs))


def test_truncated_graph_reports_bounds():
    nd = mk([f"P{i}" for i in range(12)], [(UP, [])])
    g = AndOrGraph(nd, budget=Budget(max_nodes=50)).build()
    assert g.truncated
    sec = andor_section(g)
    # counts need the whole graph; the depth comes from iterative deepening (greedy = log2 12)
    assert sec["trees"] is None and sec["linear_sequences"] is None
    assert sec["min_depth"] == 4 and sec["min_depth_exact"]
    assert sec["min_depth_lower_bound"] == sec["min_depth_upper_bound"] == 4
    p = plan(nd, "shortest", budget=Budget(max_nodes=50))
    assert p.found and p.exact and p.depth() == 4
    # a budget too small for the search keeps bounds only
    r = min_depth_search(sandwich(6), budget=Budget(max_nodes=3))
    assert not r.exact and r.depth is None and r.lower == 3 and r.upper is None


@pytest.mark.parametrize("k", [2, 3, 5, 9, 12])
def test_min_depth_search_on_sandwich(k):
    # optimum 2 + ceil(log2 k) (hand), above ceil(log2(k + 2)): the search must refute depths
    r = min_depth_search(sandwich(k))
    assert r.exact and r.depth == 2 + (k - 1).bit_length()
    g = AndOrGraph(sandwich(k), budget=Budget(max_nodes=2)).build()
    assert g.truncated
    p = plan(sandwich(k), "shortest", graph=g)
    assert p.exact and p.depth() == r.depth


def test_big_counts_are_exact_ints():
    # a 41-part stack (+z chain, -z reversed): nodes are the 41*42/2 intervals, every split of
    # an interval is a cut point, so trees = Catalan(40) (> 2^53), linear = 2^40
    n = 41
    up = [(i, i + 1) for i in range(n - 1)]
    nd = mk([f"P{i:02d}" for i in range(n)], [(UP, up), (DOWN, [(j, i) for i, j in up])])
    g = AndOrGraph(nd).build()
    assert g.node_count == n * (n + 1) // 2
    sec = andor_section(g)
    assert sec["trees"] == catalan(40) and sec["trees_str"] == str(catalan(40))
    assert sec["linear_sequences"] == 2 ** 40 and "linear_sequences_str" not in sec
    assert sec["min_depth"] == 6


def test_sink_decompose_matches_graph():
    for seed in range(30):
        rng = random.Random(seed)
        nd = random_ndbg(rng, rng.randint(2, 7), 2, 0.3)
        _, stuck = sink_decompose(nd)
        assert (stuck is None) == (AndOrGraph(nd).build().min_depth() is not None)
        if stuck is not None:
            assert not node_splits(nd, stuck)[0]
            assert all(b in bits((1 << nd.n) - 1) for b in bits(stuck))


def test_node_splits_agree_with_shared_partitionings():
    from ndbg_cli.ndbg.model import ConnectivityTest, partitionings

    for seed in range(40):
        rng = random.Random(seed)
        n = rng.randint(2, 8)
        nd = random_ndbg(rng, n, rng.randint(1, 4), rng.choice([0.1, 0.25, 0.4]))
        mask = rng.randrange(1, 1 << n) | 1
        neigh = random_neighbours(rng, n)
        for conn in (None, ConnectivityTest(neigh)):
            parts, _ = partitionings(nd, mask, connected=conn)
            want = {(p.moved, p.regions) for p in parts}
            arcs, trunc = node_splits(nd, mask, connected=conn)
            got = {(m, regs) for h in arcs for m, regs in h.moves}
            assert not trunc and got == want


def test_connected_node_splits_with_base_and_limit_against_brute_force():
    # every proper S of the mask free in some region, both sides connected, S missing the
    # base and the avoided parts: the search for connected sets must list exactly these,
    # and a limited list must be a true part of them, cut only when they do not fit
    from ndbg_cli.ndbg.model import ConnectivityTest

    for seed in range(60):
        rng = random.Random(1000 + seed)
        n = rng.randint(3, 9)
        nd = random_ndbg(rng, n, rng.randint(1, 4), rng.choice([0.1, 0.25, 0.4]))
        mask = rng.randrange(1, 1 << n) | 0b11
        neigh = random_neighbours(rng, n)
        conn = ConnectivityTest(neigh)
        base = rng.choice([None] + list(bits(mask)))
        avoid = rng.choice([0, 1 << rng.randrange(n)])
        fixed = ((0 if base is None else 1 << base) | avoid) & mask
        want: dict[int, set[int]] = {}
        for s in range(1, mask):
            if s & ~mask or s & fixed or not (conn(s) and conn(mask & ~s)):
                continue
            regs = {k for k, r in enumerate(nd.regions) if r.dbg.is_free(s, mask)}
            if regs:
                want[s] = regs
        arcs, cut = node_splits(nd, mask, base=base, avoid=avoid, connected=conn)
        got = {m: set(regs) for h in arcs for m, regs in h.moves}
        assert not cut and got == want
        for limit in (1, 3, 10):
            arcs, cut = node_splits(nd, mask, base=base, avoid=avoid, connected=conn,
                                    limit=limit)
            some = {m: set(regs) for h in arcs for m, regs in h.moves}
            assert len(some) <= limit and set(some) <= set(want)
            assert cut == (len(want) > limit)
            if not cut:
                assert some == want


def test_connected_splits_of_a_disconnected_subassembly():
    # contact graph 0-1, 2-3, 4 alone; every part free (no arcs): {0,1,2,3} splits only into
    # its two components, {0,1,2,3,4} (three components) not at all, and a DBG in which 0
    # needs 2 to move along leaves only {2,3} movable
    from ndbg_cli.ndbg.model import ConnectivityTest

    conn = ConnectivityTest([0b00010, 0b00001, 0b01000, 0b00100, 0])
    free = mk("ABCDE", [(UP, [])])
    arcs, cut = node_splits(free, 0b01111, connected=conn)
    assert not cut and [(h.left, h.right) for h in arcs] == [(0b00011, 0b01100)]
    assert node_splits(free, 0b11111, connected=conn) == ([], False)
    dragging = mk("ABCDE", [(UP, [(0, 2)])])
    arcs, _ = node_splits(dragging, 0b01111, connected=conn)
    assert [dict(h.moves) for h in arcs] == [{0b01100: (0,)}]


def test_a_search_that_ends_on_its_last_budgeted_node_is_not_called_cut(monkeypatch):
    # a contact path 0-1-2-3, nothing blocks: 3 splits. With exactly the search nodes it
    # needs, the list is complete; one node fewer and it is cut.
    import ndbg_cli.planning.andor as andor
    from ndbg_cli.ndbg.candidates import connected_free_sets
    from ndbg_cli.ndbg.model import ConnectivityTest

    nb = [0b0010, 0b0101, 0b1010, 0b0100]
    nd = mk("ABCD", [(UP, [])])
    left = [10_000]
    assert len(list(connected_free_sets(nd.regions[0].dbg.succ, nb, 0b1111, left))) == 6
    need = 10_000 - left[0]
    full, _ = node_splits(nd, 0b1111, connected=ConnectivityTest(nb), limit=100)
    assert len(full) == 3
    for budget, cut in ((need, False), (need - 1, True)):
        monkeypatch.setattr(andor, "CONNECTED_SEARCH", budget)
        arcs, truncated = node_splits(nd, 0b1111, connected=ConnectivityTest(nb), limit=100)
        assert truncated is cut and (cut or arcs == full)


def test_plan_says_when_its_depth_is_the_minimum_for_connected_subassemblies():
    from ndbg_cli.ndbg.model import ConnectivityTest

    # 4 free parts in a contact path: halving gives depth 2 either way
    nd = mk("ABCD", [(UP, [])])
    conn = ConnectivityTest([0b0010, 0b0101, 0b1010, 0b0100])
    p = plan(nd, "shortest", connected=conn)
    sec = plan_section(p)
    assert sec["connected"] is True and sec["exact"] and sec["depth"] == 2
    assert "minimum for contact-connected subassemblies" in plan_header(p)
    free = plan(nd, "shortest")
    assert plan_section(free)["connected"] is False
    assert plan_header(free).endswith("tree depth 2")


def test_insertion_direction_is_opposite_of_removal():
    p = plan(stack3(), "shortest")
    for s in plan_section(p)["sequence"]:
        assert s["direction"] == [-x if x else 0.0 for x in s["removal_direction"]]
        moved_mask = p.ndbg.mask(s["moved"])
        produced = p.ndbg.mask(s["produces"])
        assert p.ndbg.regions[s["region"]].dbg.is_free(moved_mask, produced)


def test_generalized_motions_are_reported():
    screw = {"type": "screw", "axis": [0.0, 0.0, 1.0], "point": [0.0, 0.0, 0.0], "pitch": 1.5}
    nd = NDBG("generalized", ("nut", "bolt"),
              (Region(-1, None, DBG.from_arcs(2, [(1, 0)]), motion=screw),))
    p = plan(nd, "shortest")
    (step,) = plan_section(p)["sequence"]
    assert step["moved"] == ["nut"] and step["direction"] is None and step["motion"] == screw
    c = classes_section({"generalized": nd})
    assert c["generalized"]["one_handed_monotone"]["value"] is True
    assert c["generalized"]["stack_product"]["value"] is None
    assert grasp(nd, [(0, UP, None)])["value"] == 0


def test_connected_filter_in_plans():
    from ndbg_cli.ndbg.model import ConnectivityTest

    # 4 free parts in a path contact graph 0-1-2-3: only splits into two sub-paths are allowed,
    # i.e. the trees of an ordered chain: Catalan(3) = 5 trees, linear orders 2^3 = 8
    nd = mk("ABCD", [(UP, [])])
    conn = ConnectivityTest([0b0010, 0b0101, 0b1010, 0b0100])
    g = AndOrGraph(nd, connected=conn).build()
    assert g.tree_count() == 5 and g.linear_count() == 8 and g.min_depth() == 2
    for strategy in STRATEGIES:
        p = plan(nd, strategy, connected=conn)
        for s in p.steps.values():
            assert conn(s.moved) and conn(s.rest)


def cycles(*groups):
    """Arcs making each group of parts one directed cycle (one strong component)."""
    return [(g[k], g[(k + 1) % len(g)]) for g in groups if len(g) > 1 for k in range(len(g))]


def test_cut_partitioning_lists_never_claim_an_exact_depth():
    """At most 3 partitionings listed per subassembly: the optimum may be missed, so nothing
    may be called exact above ceil(log2 n). Two regions over 8 parts whose strong components
    (3, 3, 2 parts each) leave no free set of 4 at the root; every smaller subassembly breaks
    a cycle. Worked by hand: the root splits 5 | 3 at best, so the optimum is 4 (8 -> {0, 1,
    2, 6, 7} -> {0, 1, 2} -> {1, 2} in R1 then R2), above ceil(log2 8) = 3."""
    from ndbg_cli.planning.andor import AndOrGraph, Budget
    from ndbg_cli.planning.classes import classify
    from ndbg_cli.report.classes import andor_section

    nd = mk("ABCDEFGH", [(UP, cycles((0, 1, 2), (3, 4, 5), (6, 7))),
                         (DOWN, cycles((0, 3, 6), (1, 4, 7), (2, 5)))])
    b = Budget(split_limit=3, time_limit=None)
    sec = andor_section(AndOrGraph(nd, budget=b).build())
    assert sec["min_depth_exact"] is False and sec["min_depth_lower_bound"] == 3
    got = classify(nd, budget=b)["min_depth"]
    assert got["exact"] is False and got["lower_bound"] == 3 and got["upper_bound"] >= 4
    full = AndOrGraph(nd, budget=Budget(split_limit=None)).build()
    assert full.complete and full.min_depth() == 4


def test_a_tree_as_shallow_as_ceil_log2_n_is_exact_even_over_cut_lists():
    """8 mutually free parts, at most 3 partitionings listed per subassembly (of the 254):
    the balanced tree, found without the lists, has depth 3 = ceil(log2 8), which no binary
    tree over 8 leaves beats, so the cut lists need no search."""
    from ndbg_cli.ndbg.dbg import DBG
    from ndbg_cli.ndbg.model import NDBG, Region
    from ndbg_cli.planning.andor import AndOrGraph, Budget, node_splits
    from ndbg_cli.planning.classes import classify
    from ndbg_cli.report.classes import andor_section

    n = 8
    nd = NDBG("infinitesimal_translation", tuple(f"p{i}" for i in range(n)),
              (Region(2, (0.0, 0.0, 1.0), DBG.empty(n)),))
    b = Budget(split_limit=3, time_limit=None)
    arcs, cut = node_splits(nd, (1 << n) - 1, limit=3)
    assert cut and len(arcs) <= 3 and min(h.balance for h in arcs) == 4  # balanced set first
    sec = andor_section(AndOrGraph(nd, budget=b).build())
    assert sec["min_depth"] == 3 and sec["min_depth_exact"] is True
    got = classify(nd, budget=b)["min_depth"]
    assert got["value"] == 3 and got["exact"] is True and "ceil(log2 n)" in got["why"]


# --------------------------------------------------- grouping, truncation reasons, supergraphs
def test_grouping_by_induced_dbg_merges_regions_on_a_subassembly():
    # Two regions differ only in an arc into part 2: on the whole product they are two
    # DBGs, on {0, 1} one, so the hyperarc there lists both regions for the same moved set.
    nd = mk("ABC", [(UP, [(0, 1), (0, 2)]), (DOWN, [(0, 1)]), (PX, [(1, 0)])])
    from ndbg_cli.planning.andor import _groups_of

    groups = _groups_of(nd)
    assert [regs for _, regs in groups.of(0b111)] == [[0], [1], [2]]
    assert [regs for _, regs in groups.of(0b011)] == [[0, 1], [2]]
    assert groups.of(0b011) == groups._exact(0b011)
    arcs, cut = node_splits(nd, 0b011)
    assert not cut and len(arcs) == 1
    # B (1) moves free of A in regions 0 and 1; A (0) moves free of B in region 2
    assert dict(arcs[0].moves) == {0b010: (0, 1), 0b001: (2,)}


@pytest.mark.parametrize("seed", range(6))
def test_hashed_grouping_equals_exact_grouping(seed):
    rng = random.Random(seed)
    n = rng.choice([5, 9, 40, 64])
    base = [[(i, j) for i in range(n) for j in range(n) if i != j and rng.random() < 0.2]
            for _ in range(6)]
    # regions repeat a few DBGs (with extra arcs outside small masks) so groups merge
    regions = []
    for k in range(40):
        arcs = list(base[k % 6])
        if k % 4 == 0:
            arcs.append((rng.randrange(n), n - 1))
        regions.append((UP, arcs))
    nd = mk([f"P{i}" for i in range(n)], regions)
    from ndbg_cli.planning.andor import _groups_of

    groups = _groups_of(nd)
    for _ in range(30):
        mask = rng.getrandbits(n) | 1
        assert groups.of(mask) == groups._exact(mask)


def test_plan_note_says_why_the_graph_was_cut_not_how_far_it_got():
    nd = mk([f"P{i}" for i in range(6)], [(UP, [])])  # 6 free parts: 203 subassemblies
    p = plan(nd, "shortest", budget=Budget(max_nodes=10, time_limit=None))
    assert p.found and p.notes
    assert p.notes[0].startswith("AND/OR graph has over 10 subassemblies (--max-nodes)")
    g = AndOrGraph(nd, budget=Budget(max_nodes=10, time_limit=None)).build()
    assert g.truncated and g.cut_by == "nodes" and g.node_count <= 10


def test_plan_reports_the_proven_depth_lower_bound():
    # 5 parts of which only one at a time comes off (region k frees part k alone): every tree
    # is linear, depth 4, above ceil(log2 5) = 3; proven from the complete graph, and by the
    # deepening when the graph (31 subassemblies) is cut at 16 (the deepening may expand
    # DEEPENING_SHARE of them: 8 suffice)
    n = 5
    nd = mk([f"P{i}" for i in range(n)],
            [(UP, [(i, j) for i in range(n) for j in range(n) if i != j and i != k])
             for k in range(n)])
    for budget in (Budget(), Budget(max_nodes=16, time_limit=None)):
        sec = plan_section(plan(nd, "shortest", budget=budget))
        assert (sec["depth"], sec["exact"], sec["depth_lower_bound"]) == (4, True, 4)
    # a greedy answer proves nothing beyond ceil(log2 n)
    sec = plan_section(plan(nd, "balanced"))
    assert (sec["depth"], sec["depth_lower_bound"]) == (4, 3)


def test_supergraph_of_a_cut_graph_is_not_built_and_gives_the_same_measures():
    # The hybrid holds the translational regions plus one more: its graph contains the
    # translational one, so a budget that cuts the latter cuts it too.
    n = 7
    trans = mk([f"P{i}" for i in range(n)], [(UP, [(i, i + 1) for i in range(n - 1)]),
                                              (DOWN, [(i + 1, i) for i in range(n - 1)])])
    extra = Region(-1, None, DBG.from_arcs(n, [(i, 0) for i in range(1, n)]),
                   motion={"type": "rotation"})
    hyb = NDBG("generalized", trans.ids, trans.regions + (extra,))
    budget = Budget(max_nodes=5, time_limit=None)
    graphs: dict = {}
    sec = classes_section({"generalized": hyb, "infinitesimal_translation": trans},
                          budget=budget, graphs=graphs)
    g = graphs["generalized"]
    assert graphs["infinitesimal_translation"].cut_by == "nodes"
    assert g.cut_by == "supergraph" and g.truncated
    assert "contains the infinitesimal_translation one" in g.cut_reason()
    built = AndOrGraph(hyb, budget=budget).build()
    assert built.truncated  # what building would have said
    alone = classes_section({"generalized": hyb}, budget=budget)
    # the same measures; the depth's reason names the contained family when it is there
    got, ref = dict(sec["generalized"]), dict(alone["generalized"])
    for d in (got, ref):
        d["min_depth"] = {k: v for k, v in d["min_depth"].items() if k != "why"}
    assert got == ref and got["min_depth"]["exact"]
    # an NDBG that does not hold the other's DBGs is built as usual
    other = mk(trans.ids, [(PX, [])], family="generalized")
    graphs = {}
    classes_section({"generalized": other, "infinitesimal_translation": trans},
                    budget=budget, graphs=graphs)
    assert graphs["generalized"].cut_by != "supergraph"


def test_hybrid_min_depth_follows_from_a_contained_family_at_the_lower_bound():
    # An 8-part stack: up, part i is blocked by every part above it (down, by every part
    # below). Halving it gives depth 3 = ceil(log2 8), the lower bound for any tree, so the
    # hybrid (the same regions plus a rotation freeing part 0) has depth 3 too.
    from ndbg_cli.planning.decompose import min_depth_search

    n = 8
    trans = mk([f"P{i}" for i in range(n)],
               [(UP, [(i, j) for i in range(n) for j in range(i + 1, n)]),
                (DOWN, [(j, i) for i in range(n) for j in range(i + 1, n)])])
    extra = Region(-1, None, DBG.from_arcs(n, [(i, 0) for i in range(1, n)]),
                   motion={"type": "rotation"})
    hyb = NDBG("generalized", trans.ids, trans.regions + (extra,))
    budget = Budget(max_nodes=20, time_limit=None)  # 36 subassemblies (the intervals)
    graphs: dict = {}
    sec = classes_section({"generalized": hyb, "infinitesimal_translation": trans},
                          budget=budget, graphs=graphs)
    assert graphs["infinitesimal_translation"].cut_by == "nodes"
    assert graphs["generalized"].cut_by == "supergraph"
    t, g = sec["infinitesimal_translation"]["min_depth"], sec["generalized"]["min_depth"]
    assert (t["value"], t["exact"]) == (3, True)
    assert (g["value"], g["exact"], g["lower_bound"], g["upper_bound"]) == (3, True, 3, 3)
    assert "infinitesimal_translation family" in g["why"]
    r = min_depth_search(hyb, budget=Budget(split_limit=None, time_limit=None))
    assert (r.depth, r.exact) == (3, True)
    # above the lower bound nothing follows: 5 parts of which only one at a time comes off
    # (region k frees part k alone) need depth 4 > 3; the hybrid, whose extra motion frees
    # everything, has depth 3 and is searched
    n = 5
    single = mk([f"P{i}" for i in range(n)],
                [(UP, [(i, j) for i in range(n) for j in range(n) if i != j and i != k])
                 for k in range(n)])
    hyb = NDBG("generalized", single.ids, single.regions + (
        Region(-1, None, DBG.empty(n), motion={"type": "rotation"}),))
    sec = classes_section({"generalized": hyb, "infinitesimal_translation": single},
                          budget=Budget(max_nodes=8, time_limit=None))
    assert sec["infinitesimal_translation"]["min_depth"]["value"] == 4
    assert sec["generalized"]["min_depth"]["value"] == 3
    assert "ceil(log2 n)" in sec["generalized"]["min_depth"]["why"]  # its balanced tree


@pytest.mark.parametrize("seed", range(4))
def test_connectivity_test_against_networkx(seed):
    import networkx as nx

    from ndbg_cli.ndbg.model import ConnectivityTest

    rng = random.Random(seed)
    n = rng.choice([6, 12, 70])
    g = nx.gnp_random_graph(n, 2.5 / n, seed=seed)
    nb = [0] * n
    for a, b in g.edges:
        nb[a] |= 1 << b
        nb[b] |= 1 << a
    test = ConnectivityTest(nb)
    for _ in range(300):
        mask = rng.getrandbits(n)
        want = mask != 0 and nx.is_connected(g.subgraph(list(bits(mask))))
        assert test(mask) == want and test(mask) == want  # the memoised answer too


def test_a_list_that_fits_its_limit_is_not_called_cut():
    # A chain 1 -> 2 -> 3 with part 0 the base: exactly 3 moved sets ({3}, {2,3}, {1,2,3}).
    # The closures are found first and used to be counted again against the limit.
    nd = NDBG("infinitesimal_translation", tuple("abcd"),
              (Region(2, UP, DBG((0, 0b100, 0b1000, 0))),))
    for limit, cut in ((2, True), (3, False), (4, False), (None, False)):
        arcs, truncated = node_splits(nd, 0b1111, base=0, limit=limit)
        assert truncated is cut and len(arcs) == (2 if cut else 3)


def test_finger_probes_are_covered_exactly_when_another_part_is_within_reach():
    """:func:`~ndbg_cli.planning.fingers.covered` against the distance to every triangle of
    every other part: points just outside each face of the stack (its parts rest on each
    other, so many faces are covered), half of them pushed farther out, some to just inside
    the reach of 1.5 gaps and some just beyond it."""
    import ndbg_cli
    from ndbg_cli.contacts.facets import point_triangle_distance
    from ndbg_cli.planning.fingers import covered

    asm = ndbg_cli.load("assemblies/stack.yaml")
    gap = 2.0 * asm.length_tolerance
    rng = np.random.default_rng(7)
    owner = np.concatenate([np.full(len(p.mesh.faces), k) for k, p in enumerate(asm.parts)])
    centre = np.concatenate([p.mesh.triangles_center for p in asm.parts])
    normal = np.concatenate([p.mesh.face_normals for p in asm.parts])
    out = rng.choice([1.0, 1.4, 1.6, 3.0], size=len(owner)) * gap
    q = centre + out[:, None] * normal
    want = np.zeros(len(q), dtype=bool)
    for j, other in enumerate(asm.parts):
        tri = np.asarray(other.mesh.triangles)
        for i in np.flatnonzero(owner != j):
            d = point_triangle_distance(np.repeat(q[i:i + 1], len(tri), axis=0), tri)
            want[i] |= d.min() <= 1.5 * gap
    assert 0 < want.sum() < len(want)
    assert np.array_equal(covered(asm, owner, q, gap), want)


def test_grasp_fingers_only_touch_exposed_faces():
    """Fingers go on faces no other part covers (review finding: fig3-2d had fingers on P3's
    tongue sides inside P4's groove and on P1's tongue top inside P2's groove; stack.yaml one
    on the wall of the base's blind hole). 2D, checked independently: every finger point lies
    on the boundary of the union of all parts (the assembly's outside). 3D: every finger point
    is farther than the tolerance from every other part."""
    import shapely
    import trimesh

    import ndbg_cli
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.analysis import analyze

    asm = ndbg_cli.load("assemblies/fig3-2d.yaml")
    outside = shapely.union_all([p.polygon for p in asm.parts]).boundary
    rep = analyze(asm, Options(motion="all"))
    fingers = [f for fam in rep["classes"].values() if "grasp" in fam
               for f in fam["grasp"]["fingers"]]
    assert fingers
    for f in fingers:
        assert outside.distance(shapely.Point(f["point"])) < 1e-9, f
    assert not any(f["point"] in ([50, 30], [70, 30], [70, 90]) for f in fingers)

    asm = ndbg_cli.load("assemblies/stack.yaml")
    rep = analyze(asm, Options(motion="all"))
    ids = asm.ids
    for fam in rep["classes"].values():
        for f in (fam.get("grasp") or {}).get("fingers", []):
            p = np.array([f["point"]])
            for j, other in enumerate(asm.parts):
                if ids[j] == f["part"]:
                    continue
                _, dist, _ = trimesh.proximity.closest_point(other.mesh, p)
                assert dist[0] > asm.length_tolerance, (f, ids[j])


# ------------------------------------------------------------------- deterministic budgets
def test_budget_has_no_clock_by_default_and_cuts_by_counted_work():
    # the default budget is counts only, so a report does not depend on the machine's speed
    assert Budget().time_limit is None and Budget().max_work is not None
    # 6 free parts: 203 subassemblies; each expansion charges its induced DBG (1) and the
    # regions of its moved sets (one per set), so a small work budget cuts the build, always
    # after the same nodes
    nd = mk([f"P{i}" for i in range(6)], [(UP, [])])
    cuts = []
    for _ in range(3):
        g = AndOrGraph(nd, budget=Budget(max_work=100)).build()
        assert g.truncated and g.cut_by == "work"
        assert "work budget (100 units)" in g.cut_reason()
        cuts.append((g.node_count, g.work, sorted(g.arcs)))
    assert cuts[0] == cuts[1] == cuts[2]
    # the root alone has 2^6 - 2 = 62 moved sets (31 hyperarcs), each free in region 0:
    # 1 induced DBG + 62 region entries + 6 for the single parts and 1 for the balanced
    # set, listed first (their closures and the DBG's balanced set, kept under a split
    # limit) and again by the enumeration
    g = AndOrGraph(nd, budget=Budget(max_work=1)).build()
    assert list(g.arcs) == [0b111111] and g.work == 1 + 62 + 6 + 1
    # a budget large enough leaves the graph complete, with the same answers as no budget
    full = AndOrGraph(nd, budget=Budget(max_work=None)).build()
    assert full.complete and AndOrGraph(nd).build().tree_count() == full.tree_count()


def one_at_a_time(n):
    """``n`` parts, region ``k`` freeing part ``k`` alone (every other part runs into all the
    rest): every tree is linear, of height ``n - 1``, above ceil(log2 n) from 4 parts."""
    return mk([f"P{i}" for i in range(n)],
              [(UP, [(i, j) for i in range(n) for j in range(n) if i != j and i != k])
               for k in range(n)])


def test_anytime_searches_stop_on_the_work_budget():
    nd = one_at_a_time(6)
    r = min_depth_search(nd, budget=Budget(max_work=1))
    assert not r.exact and (r.lower, r.upper) == (3, 5) or r.upper is None
    p = plan(nd, "shortest", budget=Budget(max_work=1))
    assert p.found and not p.exact and "work budget (1 units)" in p.notes[0]
    # a cut that found no tree still bounds the depth: the polynomial sink decomposition's
    # tree (here it peels one part at a time: height 5) is a candidate tree; ceil(log2 6) = 3
    md = classify(nd, budget=Budget(max_nodes=1, max_work=1))["min_depth"]
    assert (md["value"], md["exact"], md["lower_bound"], md["upper_bound"]) == (5, False, 3, 5)
    assert md["why"].startswith("upper bound from the sink decomposition's tree, lower bound 3")
    # 3 mutually free parts: a balanced tree of height 2 = ceil(log2 3), exact without a
    # search; 6 of them: the same at 3, although the budget lists not one partitioning
    for n, depth in ((3, 2), (6, 3)):
        md = classify(mk([f"P{i}" for i in range(n)], [(UP, [])]),
                      budget=Budget(max_nodes=1, max_work=1))["min_depth"]
        assert (md["value"], md["exact"]) == (depth, True) and "ceil(log2 n)" in md["why"]
    nd = mk([f"P{i}" for i in range(6)], [(UP, [])])
    # the greedy search cut before any tree: the polynomial sink decomposition's tree is a
    # candidate tree all the same (every step's moved set free in its region)
    for strategy in ("balanced", "linear"):
        p = plan(nd, strategy, budget=Budget(max_nodes=1, max_work=1))
        assert p.found and not p.exact and "sink decomposition" in p.notes[-1]
        assert len(p.steps) == 5 and p.depth() >= 3
        for s in p.steps.values():
            assert s.moved and s.rest and s.moved | s.rest == s.mask
            assert nd.regions[s.region].dbg.is_free(s.moved, s.mask)


def test_no_candidate_tree_is_proven_without_a_search():
    # A and B interlock in every region (a 2-cycle), C is free: {A, B} has no partitioning,
    # whatever the budget: the plan is an exact failure naming the smallest stuck set, even
    # with a budget too small to expand a single subassembly
    nd = mk("ABC", [(d, both((0, 1))) for d in (UP, DOWN, PX)])
    for budget in (Budget(max_nodes=1, max_work=1), Budget()):
        for strategy in STRATEGIES:
            p = plan(nd, strategy, budget=budget)
            assert not p.found and p.exact and p.stuck == 0b011, strategy
            assert "['A', 'B'] has no candidate partitioning" in p.notes[0]


def test_removal_states_the_nearest_axis_the_sweep_test_frees():
    # a tilted region frees A (on B on C) and then B; the stand-in sweep test frees only
    # well-upward translations: the removal states +z for both; without the test, or for a
    # step the test does not free along +z, the region's direction stays
    tilt = tuple(np.array([0.3, 0.1, 0.95]) / np.linalg.norm([0.3, 0.1, 0.95]))
    nd = NDBG("infinite_translation", ("A", "B", "C"),
              (Region(2, tilt, DBG.from_arcs(3, [(1, 0), (2, 1), (2, 0)])),))
    r = remove(nd, 0b010)
    assert r.found and r.steps == [(0b001, 0)] and r.final_region == 0
    assert [s.rest for s in r.instructions(nd)] == [0b110, 0b100]

    def up(m, rest, d):
        return d[2] > 0.5

    sec = r.section(nd, up)
    assert sec["steps"][0]["removal_direction"] == [0.0, 0.0, 1.0]
    assert sec["final"]["removal_direction"] == [0.0, 0.0, 1.0]
    plain = r.section(nd)
    assert plain["final"]["removal_direction"][2] == pytest.approx(0.9487, 1e-3)
    only_a = r.section(nd, lambda m, rest, d: m == 0b001 and d[2] > 0.5)
    assert only_a["steps"][0]["removal_direction"] == [0.0, 0.0, 1.0]
    assert only_a["final"] == plain["final"]


def test_fewest_directions_cut_by_the_budget_still_gives_its_tree():
    # review finding: the sink-decomposition fallback was not given to this strategy, so a
    # work cut left no plan although min_directions had just found a tree
    nd = mk("ABC", [(UP, [(0, 1), (1, 2)]), (DOWN, [(1, 0), (2, 1)]), (PX, complete(3))])
    for connected in (None, ConnectivityTest([0b110, 0b101, 0b011])):
        p = plan(nd, "fewest-directions", connected=connected,
                 budget=Budget(max_nodes=1, max_work=1))
        if connected is None:
            assert p.found and not p.exact and p.directions() == 1
            assert {s.region for s in p.steps.values()} <= {0, 1}
        else:  # the connected search is cut: said so, not "no connected tree"
            assert not p.found or not p.exact
            assert all("found within the budget" in n for n in p.notes
                       if n.startswith("no connected tree"))


def test_andor_section_reports_the_size_the_build_reached():
    # review finding: anytime searches expanding the same memo after the build made the
    # section's size depend on which searches ran first
    nd = one_at_a_time(6)
    g = AndOrGraph(nd, budget=Budget(max_nodes=10)).build()
    size = (g.node_count, g.hyperarc_count)
    min_depth_search(nd, budget=Budget(max_nodes=10_000), graph=g)
    assert g.node_count > size[0]  # the search expanded more nodes into the graph
    sec = andor_section(g)
    assert (sec["nodes"], sec["hyperarcs"]) == size and sec["cut_by"] == "nodes"


def test_min_directions_cut_by_the_budget_is_exact_when_its_bounds_meet():
    nd = mk("ABC", [(UP, [(0, 1), (1, 2)]), (DOWN, [(1, 0), (2, 1)]), (PX, complete(3))])
    md = min_directions(nd, budget=Budget(max_nodes=0))  # cut before the first test
    assert (md["value"], md["lower_bound"], md["exact"]) == (1, 1, True)
    assert md["why"].startswith("exact: the bounds meet")


def test_cut_partitioning_lists_prove_no_failure():
    # differential fuzzing finding: a failure over a partitioning list cut by split_limit was
    # reported as a proof (found False, exact True, "no candidate algorithm").
    # (1) fewest-directions: region 0 frees only {P0}, region 1 (a chain) alone decomposes;
    # split_limit=1 keeps {P0} (region 0 only), which the minimum region set [1] drops
    nd = mk("ABC", [(UP, both((1, 2))), (PX, [(0, 1), (1, 2)])])
    p = plan(nd, "fewest-directions", budget=Budget(split_limit=1))
    assert p.found or not p.exact
    assert p.found and p.regions_used() == [1]
    # (2) contact-connected plans (no heredity): the pentagon contact graph, one DBG
    # 0 -> 2 -> 4 -> 1; the kept split {0,1,2,4} | {3} dead-ends, {1} | {0,2,3,4} does not
    from ndbg_cli.planning.andor import greedy_tree

    nd = mk([f"P{i}" for i in range(5)], [(UP, [(0, 2), (2, 4), (4, 1)])])
    conn = ConnectivityTest([0b10010, 0b00101, 0b01010, 0b10100, 0b01001])
    assert plan(nd, "balanced", connected=conn).found
    cut = Budget(split_limit=1)
    g = greedy_tree(nd, connected=conn, budget=cut)
    assert not g.found and g.truncated
    for strategy in STRATEGIES:
        p = plan(nd, strategy, connected=conn, budget=cut)
        assert p.found or not p.exact, strategy
        assert not any("no candidate algorithm" in n for n in p.notes), strategy


def test_no_connected_tree_is_not_called_no_candidate_algorithm():
    # A, B, C with contacts A-B and B-C only; +z (A and C blocked by B and by each other)
    # frees {B} alone, +x splits {A, C} only: the candidate tree (B | (A | C)) leaves {A, C}
    # apart, no connected tree exists; the note must not say there is no candidate algorithm
    nd = mk("ABC", [(UP, [(0, 1), (2, 1), (0, 2), (2, 0)]), (PX, both((0, 1), (1, 2)))])
    assert plan(nd, "shortest").found
    conn = ConnectivityTest([0b010, 0b101, 0b010])
    for strategy in STRATEGIES:
        p = plan(nd, strategy, connected=conn)
        assert not p.found and p.exact, strategy
        assert "no tree with connected subassemblies" in p.notes[-1], (strategy, p.notes)


def test_fewest_directions_of_a_subassembly_counts_its_own_directions():
    # plan(mask=) took the whole product's minimum direction set: with C interlocked with B
    # in every region the whole has no tree and {A, B} was refused ("no candidate algorithm")
    nd = mk("ABC", [(UP, both((1, 2))), (PX, both((1, 2)) + [(0, 1)])])
    p = plan(nd, "fewest-directions", mask=0b011)
    assert p.found and p.exact and p.regions_used() == [0]
    assert min_directions(nd, mask=0b011)["value"] == 1


def test_stack_regions_by_hand_an_arc_into_the_base_spoils_a_direction():
    """Three parts, base 0. Region 0's DBG: 2 -> 1 -> 0 (1 rests on the base, 2 on 1 along
    -d: 2 is blocked by 1, 1 by the base): {0, 1} has only the base as sink, so no stack
    product with base 0 (without a base, any acyclic DBG is one). Region 1's DBG: 0 -> 1,
    1 -> 2 (the base blocked by 1, 1 by 2: moving the others away from the base frees 2
    first, then 1): a stack product. Region 2: a cycle 1 <-> 2, never."""
    from ndbg_cli.core.constants import INFINITE
    from ndbg_cli.ndbg.dbg import DBG
    from ndbg_cli.ndbg.model import NDBG, Region
    from ndbg_cli.planning.classes import stack_regions
    from ndbg_cli.planning.decompose import sink_decompose

    dbgs = (DBG.from_arcs(3, [(2, 1), (1, 0)]), DBG.from_arcs(3, [(0, 1), (1, 2)]),
            DBG.from_arcs(3, [(1, 2), (2, 1)]))
    nd = NDBG(INFINITE, ["a", "b", "c"],
              tuple(Region(2, d, g) for d, g in zip(((0, 0, 1.0), (0, 1.0, 0), (1.0, 0, 0)),
                                                   dbgs)), 3)
    assert stack_regions(nd, base=0) == [1]
    assert stack_regions(nd) == [0, 1]
    # the same as the sink decomposition on each region alone (its definition)
    for base in (None, 0, 1, 2):
        assert stack_regions(nd, base=base) == [
            r for r in range(3) if sink_decompose(nd, 7, [r], base=base)[1] is None]


_DEEP = """
import json, sys
import ndbg_cli
from ndbg_cli.ndbg.dbg import DBG
from ndbg_cli.ndbg.model import NDBG, Region
from ndbg_cli.planning.decompose import tree_string
from ndbg_cli.planning.plans import Plan, Step, sequence_json, tree_json
from ndbg_cli.pipeline.analysis import analyze

n = 1500
analyze(ndbg_cli.load(sys.argv[1]))  # the library's entry raises the limit for such trees
nd = NDBG("infinitesimal_translation", tuple(f"p{i}" for i in range(n)),
          (Region(2, (0.0, 0.0, 1.0), DBG.empty(n)),))
root = (1 << n) - 1
steps, m = {}, root
while m.bit_count() > 1:  # one part at a time: the highest leaves first
    top = 1 << (m.bit_length() - 1)
    steps[m] = Step(m, top, m & ~top, 0)
    m &= ~top
p = Plan(nd, root, "linear", steps)
tree = json.loads(json.dumps(tree_json(p)))
text = tree_string(nd, {k: (s.moved, 0) for k, s in steps.items()}, root)
print(p.depth(), tree["depth"], len(sequence_json(p)), text.count("|"))
"""


def test_a_tree_as_deep_as_a_large_product_is_rendered(tmp_path):
    # A product that comes apart one part at a time has trees as deep as it has parts: the
    # 996-part rack ended in a RecursionError (Python's default limit is 1,000 frames). A fresh
    # interpreter (default limit) renders a linear tree of 1,500 parts once analyze() ran.
    import subprocess
    import sys

    script = tmp_path / "deep.py"
    script.write_text(_DEEP)
    ex = Path(__file__).resolve().parents[1] / "assemblies" / "hover.yaml"
    got = subprocess.run([sys.executable, str(script), str(ex)], capture_output=True,
                         text=True, timeout=300)
    assert got.returncode == 0, got.stderr[-2000:]
    assert got.stdout.split() == ["1499", "1499", "1499", "1499"]


# ------------------------------------------------------------------- balanced free sets
@pytest.mark.parametrize("seed", range(40))
def test_balanced_free_set_is_a_free_set_of_at_most_the_target(seed):
    """Against brute force over every subset: the set is free (closed under the DBG's arcs),
    within the target, clear of ``avoid``; on an acyclic DBG (every component one part)
    first fit reaches the target whenever a free set that large avoids ``avoid``."""
    from ndbg_cli.ndbg.components import balanced_free_set, condense

    rng = random.Random(seed)
    n = rng.randint(2, 9)
    acyclic = seed % 2 == 0
    arcs = [(i, j) for i in range(n) for j in range(n)
            if i != j and (not acyclic or i < j) and rng.random() < 0.3]
    succ = DBG.from_arcs(n, arcs).succ
    full = (1 << n) - 1
    avoid = 0 if seed % 3 else 1 << rng.randrange(n)
    target = rng.randint(1, n - 1)
    got = balanced_free_set(*condense(succ, full), target, avoid=avoid)
    free = [s for s in range(1, full) if all(succ[i] & full & ~s == 0 for i in bits(s))
            and not s & avoid]
    assert got == 0 or (got in free and got.bit_count() <= target)
    best = max((s.bit_count() for s in free if s.bit_count() <= target), default=0)
    if acyclic:
        assert got.bit_count() == best


@pytest.mark.parametrize("seed", range(30))
def test_the_balanced_tree_is_a_candidate_tree_exactly_when_one_exists(seed):
    """Random NDBGs: every node of the balanced tree is split by a moved set free in each
    region it names, the tree covers the product, and it is missing exactly when the sink
    decomposition (exact by heredity) finds a stuck subassembly."""
    from ndbg_cli.planning.andor import tree_depth
    from ndbg_cli.planning.decompose import balanced_tree

    rng = random.Random(seed)
    n = rng.randint(2, 9)
    regions = [(d, [(i, j) for i in range(n) for j in range(n) if i != j
                    and rng.random() < 0.35]) for d in (UP, DOWN, PX)]
    nd = mk([f"P{i}" for i in range(n)], regions)
    base = None if seed % 2 else rng.randrange(n)
    full = (1 << n) - 1
    tree = balanced_tree(nd, base=base)
    _, stuck = sink_decompose(nd, full, base=base)
    assert (tree is None) == (stuck is not None)
    if tree is None:
        return
    leaves, stack = 0, [full]
    while stack:
        m = stack.pop()
        if m.bit_count() == 1:
            leaves += 1
            continue
        h = tree[m]
        assert h.left | h.right == m and not h.left & h.right and h.left & m & -m
        for moved, regs in h.moves:
            assert regs and all(nd.regions[r].dbg.is_free(moved, m) for r in regs)
            assert base is None or not moved >> base & 1
        stack += [h.left, h.right]
    assert leaves == n and tree_depth(tree, full) >= max(0, n - 1).bit_length()


@pytest.mark.parametrize("width", [1, 7, 8, 9, 64, 131])
def test_unique_rows_equals_numpys_unique_rows(width):
    """The packed-bytes ``unique_rows`` against ``np.unique(axis=0)``: the same rows in the
    same order (the cover program reads them in that order), widths off the byte."""
    from ndbg_cli.planning.grasp_exact import unique_rows

    rng = np.random.default_rng(width)
    a = rng.random((300, width)) < 0.3
    a = np.concatenate([a, a[::3]])  # duplicates
    assert np.array_equal(unique_rows(a), np.unique(a, axis=0))
    assert unique_rows(a[:0]).shape == (0, width)


def test_sink_split_takes_the_same_split_as_visiting_every_region():
    """``sink_split`` visits one region per distinct DBG (``NDBG.dbg_group``): on NDBGs whose
    regions repeat DBGs, in any region order, it returns what visiting every region in that
    order returns (the reference below is the straightforward scan: the first region, in
    order, whose induced DBG offers the split)."""
    from ndbg_cli.ndbg.components import balanced_free_set, condense
    from ndbg_cli.planning.decompose import sink_split

    def reference(nd, mask, order, base):
        base_bit = 0 if base is None else (1 << base) & mask
        for r in order:
            comps, succ = condense(nd.regions[r].dbg.succ, mask)
            if len(comps) < 2:
                continue
            half = balanced_free_set(comps, succ, mask.bit_count() // 2, avoid=base_bit)
            if half:
                return half, r
            for c, s in zip(comps, succ):
                if s == 0 and not c & base_bit:
                    return c, r
        return None

    rng = random.Random(46)
    checked = 0
    for _ in range(40):
        n = rng.randint(3, 8)
        few = random_ndbg(rng, n, rng.randint(1, 4), rng.choice([0.2, 0.5, 0.8]))
        regions = [few.regions[rng.randrange(len(few.regions))] for _ in range(12)]
        nd = NDBG(few.family, few.ids, tuple(regions))
        assert len(set(nd.dbg_group())) <= len(few.regions)
        base = rng.choice([None, 0])
        for _ in range(5):
            mask = rng.randrange(1, 1 << n)
            order = rng.sample(range(len(regions)), rng.randint(1, len(regions)))
            want = reference(nd, mask, order, base) if mask.bit_count() > 1 else None
            assert sink_split(nd, mask, order, base=base) == want
            checked += want is not None
    assert checked > 20  # most cases have a split to agree on, not only None
