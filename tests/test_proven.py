"""Proven plans (:mod:`ndbg_cli.planning.proven`, :mod:`ndbg_cli.pipeline.proofs`): every step
of the presented plan leaves by one translation to infinity, checked on geometry built so that
the answer is known by hand, and checked again by moving the parts (manifold3d booleans along
the stated direction); or the stuck subassembly with a proof."""

import time

import numpy as np
import pytest
import trimesh

import ndbg_cli
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.dbg import DBG
from ndbg_cli.ndbg.infinite.sweep import SweepChecker
from ndbg_cli.ndbg.model import NDBG, Region
from ndbg_cli.planning.proven import Rows, chooser, directions, greedy, prove, snap

from conftest import ROOT

EX = ROOT / "assemblies"


def _solid(pid, *boxes):
    """A part made of the union of axis-aligned ``boxes`` ``((lo), (hi))``."""
    meshes = [trimesh.creation.box(bounds=np.array(b, float)) for b in boxes]
    m = meshes[0] if len(meshes) == 1 else trimesh.boolean.union(meshes, engine="manifold")
    return make_part(pid, m.vertices, m.faces)[0]


def _pocket_under_bridge():
    """A block in a closed pocket of the base (walls on all four sides: only +z frees it
    locally) under a bridge resting on two posts of the base, 1 above the block. By hand: the
    block is free infinitesimally (+z) but blocked by the bridge further up; the bridge lifts
    off (+z) or slides along +-y; the block comes out after the bridge, never before."""
    base = _solid("base", ((-5, -2, -1), (5, 2, 0)),  # slab
                  ((-2, -2, 0), (-1, 2, 1)), ((1, -2, 0), (2, 2, 1)),  # pocket walls in x
                  ((-1, -2, 0), (1, -1, 1)), ((-1, 1, 0), (1, 2, 1)),  # and in y
                  ((-5, -1, 0), (-4, 1, 2)), ((4, -1, 0), (5, 1, 2)))  # posts
    block = _solid("block", ((-1, -1, 0), (1, 1, 1)))
    bridge = _solid("bridge", ((-5, -1, 2), (5, 1, 3)))
    return Assembly("pocket", (base, block, bridge), base="base")


def _moves_apart(asm, moved, rest, d, steps=60):
    """Independent check: the overlap volume of ``moved`` and ``rest`` (manifold3d) never
    grows beyond the tolerance's cube while ``moved`` travels along ``d`` past the product."""
    import manifold3d

    def solid(ids):
        out = None
        for pid in ids:
            m = asm.part(pid).mesh
            s = manifold3d.Manifold(manifold3d.Mesh(
                vert_properties=np.asarray(m.vertices, np.float32),
                tri_verts=np.asarray(m.faces, np.uint32)))
            out = s if out is None else out + s
        return out

    a, b = solid(moved), solid(rest)
    start = (a ^ b).volume()
    for t in np.linspace(0.0, 1.5 * asm.diagonal, steps)[1:]:
        if (a.translate(tuple(t * np.asarray(d))) ^ b).volume() > start + asm.length_tolerance ** 3:
            return False
    return True


def test_pocket_under_bridge_is_taken_apart_bridge_first_along_exact_axes():
    asm = _pocket_under_bridge()
    report = ndbg_cli.analyze(asm)
    plan = report["plan"]
    assert plan["found"] and plan["verified"]["value"] is True
    seq = plan["sequence"]  # assembly order: the block goes in before the bridge
    order = [s["moved"] for s in seq]
    assert order.index(["block"]) < order.index(["bridge"])
    for s in seq:
        d = s["removal_direction"]
        assert s["proof"]["test"] == "sweep" and s["proof"]["source"] == "axis"
        assert d in ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0])
        assert _moves_apart(asm, s["moved"], s["onto"], d)
    # and the block, moved first along +z, does hit the bridge (the check can fail)
    assert not _moves_apart(asm, ["block"], ["base", "bridge"], (0, 0, 1))


@pytest.mark.parametrize("workers", [1, 2])
def test_rows_filled_at_once_are_the_rows_asked_one_by_one(workers):
    """``Rows.fill``: every part's row along the first directions, every other direction in
    a forked Helper with two workers, equal to the rows the sweep test gives one by one (the
    bell's 22 parts along the six axes: parts that block and parts that do not)."""
    asm = ndbg_cli.load(EX / "bell.yaml")
    dirs = directions(3, [], [])
    filled, one = Rows(SweepChecker(asm), len(asm), dirs), Rows(SweepChecker(asm), len(asm), dirs)
    filled.fill(range(len(dirs)), workers)
    want = {(k, i): one.row(k, i) for k in range(len(dirs)) for i in range(len(asm))}
    assert {(k, i): filled.row(k, i) for k in range(len(dirs)) for i in range(len(asm))} == want
    assert any(want.values()) and not all(want.values())


def test_a_failing_candidate_step_is_replaced_by_a_searched_proven_tree():
    asm = _pocket_under_bridge()
    sweep = SweepChecker(asm)
    dirs = directions(3, [], [])
    rows = Rows(sweep, 3, dirs)
    # the candidate tree: block out first along +z (free infinitesimally), then the bridge
    cand = [(0b011 | 0b100, 0b100, None), (0b111, 0b010, (0.0, 0.0, 1.0))]
    key = chooser("shortest", None, set(), dirs)
    got = prove(rows, 0b111, cand, natural=len(dirs), key=key, base=0)
    assert got.found and got.searched and got.failed_step == 2
    root = got.splits[0b111]
    assert root.moved & 0b100 and not root.moved & 0b001  # the bridge (maybe with the block)
    # every split really frees its moved side, pair by pair
    for sp in got.splits.values():
        d = np.asarray(sp.vector(dirs))
        assert sweep.frees(sp.moved, sp.rest, d)


class _Pairs:
    """A blocking relation given by hand: ``table[d]`` lists the arcs ``(i, j)`` (j blocks i)
    along direction ``d``; every other direction is blocked by every part (a stand-in for a
    geometric test, to check the search's logic on its own)."""

    def __init__(self, n, table):
        self.n, self.table = n, {tuple(float(x) for x in k): v for k, v in table.items()}

    def blocked(self, i, j, d):
        arcs = self.table.get(snap(d))
        return True if arcs is None else (i, j) in arcs

    def blockers(self, i, d, among=None):
        among = (1 << self.n) - 1 if among is None else among
        return sum(1 << j for j in range(self.n)
                   if j != i and among >> j & 1 and self.blocked(i, j, d))

    def witness(self, i, j, d):
        return (0.0, 0.0, 0.0) if self.blocked(i, j, d) else None


def test_rows_within_a_subassembly_test_its_pairs_once():
    """``Rows.row(k, i, within)`` is the whole row restricted to ``within``, and each pair is
    tested once whatever the order of the questions (a subassembly's rows, then the whole
    product's)."""
    rng = np.random.default_rng(46)
    n = 9
    arcs = {(i, j) for i in range(n) for j in range(n) if i != j and rng.random() < 0.4}
    calls = []

    class Counted(_Pairs):
        def blocked(self, i, j, d):
            calls.append((i, j))
            return super().blocked(i, j, d)

    dirs = directions(3, [], [])
    k = next(k for k, d in enumerate(dirs) if snap(d.vector) == (0.0, 0.0, 1.0))
    rows = Rows(Counted(n, {(0, 0, 1): arcs}), n, dirs)
    full = {i: sum(1 << j for j in range(n) if (i, j) in arcs) for i in range(n)}
    for _ in range(30):
        within = int(rng.integers(0, 1 << n))
        i = int(rng.integers(n))
        assert rows.row(k, i, within) == full[i] & within
    for i in range(n):
        assert rows.row(k, i) == full[i]
    assert len(calls) == len(set(calls)) == n * (n - 1)


def test_greedy_needs_no_backtracking_and_stops_where_no_direction_splits():
    # A on B on C: +z frees A from {B, C} and B from C; nothing else is free anywhere
    up = {(0, 0, 1): {(1, 0), (2, 1), (2, 0)}}
    dirs = directions(3, [], [])
    key = chooser("linear", None, set(), dirs)
    got = greedy(Rows(_Pairs(3, up), 3, dirs), 0b111, key=key, natural=len(dirs))
    assert got.found and got.splits[0b111].moved == 0b001 and got.splits[0b110].moved == 0b010
    # A and B locked together both ways along +z and -z: {A, B} cannot be split
    locked = {(0, 0, 1): {(0, 1), (1, 0), (2, 0), (2, 1)},
              (0, 0, -1): {(0, 1), (1, 0), (0, 2), (1, 2)}}
    got = greedy(Rows(_Pairs(3, locked), 3, dirs), 0b111, key=key, natural=len(dirs))
    assert not got.found and got.stuck == 0b011


def test_linear_greedy_offers_every_part_that_leaves_alone():
    # Along +z: A and B block each other; C and D are blocked by A and block nobody, so each
    # of them may leave along -z (the rest along +z). Along -z, C and D are blocked by every
    # part and B by A. Every other direction is blocked. The strong components along +z are
    # {A, B}, {C}, {D}: their prefixes offered D alone and never C; the linear search reads
    # the one-part splits from the rows and takes C (the lower part at the same direction).
    table = {(0, 0, 1): {(0, 1), (1, 0), (2, 0), (3, 0)},
             (0, 0, -1): {(1, 0), (2, 0), (2, 1), (2, 3), (3, 0), (3, 1), (3, 2)}}
    dirs = directions(3, [], [])
    got = greedy(Rows(_Pairs(4, table), 4, dirs), 0b1111,
                 key=chooser("linear", None, set(), dirs), natural=len(dirs))
    assert got.found
    root = got.splits[0b1111]
    assert (root.moved, root.vector(dirs)) == (0b0100, (0.0, 0.0, -1.0))
    assert all(sp.moved.bit_count() == 1 or sp.rest.bit_count() == 1
               for sp in got.splits.values())


@pytest.mark.parametrize("seed", range(8))
def test_the_linear_peel_takes_the_same_splits_as_ranking_every_part(seed, monkeypatch):
    """``proven._peel`` keeps blocking counts and a heap instead of ranking every one-part
    split of every subassembly afresh: on random blocking relations (with cycles, so the
    chain stops and the plain search goes on) and random contacts, with and without a base,
    it takes the same splits in the same order as the plain ranking, which the tests above
    check by hand."""
    from types import SimpleNamespace

    from ndbg_cli.pipeline.proofs import _Clearance
    from ndbg_cli.planning import proven

    rng = np.random.default_rng(seed)
    n = 40
    axes = [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    # sparse arcs, dense ones within a cluster of 8 parts along x and y, and its pairs (0, 1),
    # (2, 3), ... locked together along z: there one-part splits run out, and the plain
    # search moves pairs or is stuck
    table = {d: {(i, j) for i in range(n) for j in range(n) if i != j and (
        rng.random() < 0.04 if max(i, j) >= 8 else i // 2 == j // 2 if d[2] else
        rng.random() < 0.5)} for d in axes}
    normals = [np.array(d) * s for d in axes for s in (1, -1)]
    contacts = []
    for _ in range(3 * n):
        a, b = (int(x) for x in rng.choice(n, 2, replace=False))
        ns = [normals[rng.integers(6)] if rng.random() < 0.5 else rng.normal(size=3)
              for _ in range(rng.integers(1, 4))]
        contacts.append(SimpleNamespace(a=a, b=b, normals=[v / np.linalg.norm(v) for v in ns]))
    room = _Clearance(SimpleNamespace(contacts=contacts), 3)
    dirs = directions(3, [], [])
    base = None if seed % 2 else int(rng.integers(n))
    calls = []
    peel = proven._peel

    def counted(*a):
        calls.append(a[1])
        return peel(*a)

    def run():
        return greedy(Rows(_Pairs(n, table), n, dirs), (1 << n) - 1, base=base,
                      key=chooser("linear", None, set(), dirs, room), natural=len(dirs))

    monkeypatch.setattr(proven, "_peel", counted)
    fast = run()
    monkeypatch.setattr(proven, "_peel", lambda rows, m, *a: m)
    plain = run()
    assert calls and fast.found == plain.found and fast.stuck == plain.stuck
    assert list(fast.splits.items()) == list(plain.splits.items())
    assert fast.found or not fast.splits


def test_region_directions_are_tried_only_where_their_region_frees_something():
    # the proposer: region 0 frees nothing in {A, B}; the test says its direction would
    nd = NDBG("infinitesimal_translation", ("A", "B"),
              (Region(2, (0.6, 0.0, 0.8), DBG.from_arcs(2, [(0, 1), (1, 0)])),))
    free = {(0.6, 0.0, 0.8): set()}
    dirs = directions(3, [], [(0, (0.6, 0.0, 0.8))])
    rows = Rows(_Pairs(2, free), 2, dirs, nd)
    assert dirs[-1].region == 0 and not rows.may_split(len(dirs) - 1, 0b11)
    got = greedy(rows, 0b11, key=chooser("shortest", None, set(), dirs), natural=6)
    assert not got.found  # the necessary condition fails, so the direction is not tried
    rows = Rows(_Pairs(2, free), 2, dirs)  # without a proposer it is tried, and frees A
    assert greedy(rows, 0b11, key=chooser("shortest", None, set(), dirs), natural=6).found


def _linked_rings():
    """Two rings linked like chain links, not touching (hand answer: no translation separates
    them, and none moves either part into the other infinitesimally: no contact at all)."""
    a = trimesh.creation.torus(major_radius=3, minor_radius=0.5, major_sections=24,
                               minor_sections=8)
    b = a.copy()
    b.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, (1, 0, 0)))
    b.apply_translation((3, 0, 0))
    return Assembly("links", (make_part("ring_a", a.vertices, a.faces)[0],
                              make_part("ring_b", b.vertices, b.faces)[0]))


def test_linked_rings_have_no_plan_and_the_report_proves_it():
    report = ndbg_cli.analyze(_linked_rings())
    plan = report["plan"]
    assert not plan["found"] and plan["tree"] is None and plan["sequence"] == []
    v = plan["verified"]
    assert v["value"] is False and v["proof_of_none"] is True
    assert "computed over every direction that moves some part of it" in v["why"]
    assert plan["stuck"] == ["ring_a", "ring_b"]
    # each candidate side is named with its blocker and a point on the blocker near the other
    assert plan["blocked"]
    for b in plan["blocked"]:
        assert sorted(b["blocked_by"]) == ["ring_a", "ring_b"]
        assert len(b["at"]) == 3
    # the candidate tree stays available, labelled as a necessary condition
    assert "necessary condition" in plan["candidate"]["why"]


@pytest.mark.parametrize("name", ["bell", "stack", "hover", "fig2-sandwich-8", "hinge",
                                  "fig3-2d", "peg-blind"])
def test_every_example_plan_is_proven_with_exact_directions(name):
    report = ndbg_cli.analyze(ndbg_cli.load(f"assemblies/{name}.yaml"))
    plan = report["plan"]
    assert plan["found"] and plan["verified"]["value"] is True
    for s in plan["sequence"]:
        assert s["proof"]["test"] == "sweep"
        d = s["removal_direction"]
        # no near-zero noise: a component is either 0 exactly or clearly not
        assert all(x == 0.0 or abs(x) > 1e-6 for x in d), d


def test_a_restricted_infinite_family_still_gives_a_proven_plan_and_decided_classes():
    from ndbg_cli.core.options import Options

    # --motion infinite with the exact family restricted to its free domain (budget 0)
    report = ndbg_cli.analyze(ndbg_cli.load("assemblies/fig11-nonlinear.yaml"),
                              Options(motion="infinite", infinite_budget=0))
    assert report["ndbg"]["infinite_translation"]["domain"]["restricted"]
    plan = report["plan"]
    assert plan["family"] == "infinite_translation" and plan["verified"]["value"] is True
    assert all(s["region"] is None and s["family"] == "infinite_translation"
               for s in plan["sequence"])
    inf = report["classes"]["infinite_translation"]
    for key in ("one_handed_monotone", "prismatic"):
        assert inf[key]["value"] is True and inf[key]["evidence"] == "proven"
    d = inf["min_depth"]
    # fig. 11 (by hand, its expect block): no linear plan, a tree of depth 2
    assert load_expect("fig11-nonlinear")["linearizable"] is False
    assert d["value"] == 2 and d["lower_bound"] == 2 and d["evidence"] == "proven"
    assert inf["linearizable"]["value"] is False


def load_expect(name):
    return ndbg_cli.load(f"assemblies/{name}.yaml").expect


def test_no_plan_is_a_proof_that_decides_the_classes_no():
    report = ndbg_cli.analyze(ndbg_cli.load("assemblies/fig10-latch.yaml"))
    plan = report["plan"]
    assert not plan["found"] and plan["verified"]["proof_of_none"] is True
    inf = report["classes"]["infinite_translation"]
    assert inf["prismatic"]["value"] is False and inf["prismatic"]["evidence"] == "proven"


@pytest.mark.external
def test_the_pelikan_burr_has_a_proof_that_no_plan_of_translations_exists():
    """Pelikan (shared data): no group of pieces comes out by one translation along an axis,
    and the puzzle needs 98 moves. Its own infinite NDBG, restricted to the directions where
    some piece is infinitesimally free (3 million facing triangle pairs: over the default
    budget, within the restricted one), has no partitioning: a proof over every direction."""
    from conftest import shared

    path = shared("burr", "pelikan")
    plan = ndbg_cli.analyze(ndbg_cli.load(path))["plan"]
    assert not plan["found"] and plan["verified"]["proof_of_none"] is True
    assert len(plan["stuck"]) == 7


def _gearbox(tmp_path, segments):
    import importlib.util

    spec = importlib.util.spec_from_file_location("assemblies_build", "assemblies/build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    build.gearbox(tmp_path, segments, f"gearbox-{segments}")
    return ndbg_cli.load(tmp_path / f"gearbox-{segments}.yaml")


@pytest.mark.parametrize("segments", [48, 480])
def test_the_gearbox_comes_apart_along_z_at_any_tessellation(tmp_path, segments):
    """The gearbox (assemblies/build.py, by construction): everything leaves along +z, top
    down, one direction suffices. At 480 facets per turn a facet angle (0.75 degrees) is below
    the contact angle tolerance, as in a fine STEP export: the answer must not change."""
    asm = _gearbox(tmp_path, segments)
    exp = asm.expect
    report = ndbg_cli.analyze(asm)
    plan = report["plan"]
    assert plan["found"] and plan["verified"]["value"] is True
    for s in plan["sequence"]:
        assert s["removal_direction"] in ([0.0, 0.0, 1.0], [0.0, 0.0, -1.0])
    inf = report["classes"]["infinite_translation"]
    assert inf["min_directions"]["value"] == 1 and inf["min_directions"]["exact"]
    assert inf["stack_product"]["value"] is True
    assert inf["prismatic"]["value"] is True
    # by hand: the top-down order is a sequence of proven single-part removals along +z
    s = SweepChecker(asm)
    left = (1 << len(asm)) - 1
    for pid in exp["sequence"]:
        m = 1 << asm.index(pid)
        assert s.frees(m, left & ~m, np.array(exp["removal_directions"][0], float)), pid
        left &= ~m
    # and not out of order: the shaft is held while bearing_up is in, the cover by the gear
    for pid, d in (("shaft", (0, 0, 1)), ("shaft", (0, 0, -1)), ("cover", (0, 0, 1))):
        m = 1 << asm.index(pid)
        assert not s.frees(m, ((1 << len(asm)) - 1) & ~m, np.array(d, float)), pid


def test_a_contact_proof_of_none_is_cross_checked_by_the_exact_test():
    """The infinitesimal NDBG's "no plan" rests on the contacts; the sweep test is exact. Given
    an NDBG that (wrongly) blocks every part in every direction, the pocket's real geometry
    still comes apart (by hand: the bridge first, then the block, both along +z), so the
    plan is the proven tree and the contradiction is noted, not a false proof of none."""
    from ndbg_cli.core.constants import INFINITESIMAL
    from ndbg_cli.pipeline.stages import find_contacts, measure, plan_assembly

    asm = _pocket_under_bridge()
    contacts = find_contacts(asm)
    n = len(asm)
    locked = DBG.from_arcs(n, [(i, j) for i in range(n) for j in range(n) if i != j])
    wrong = NDBG(INFINITESIMAL, asm.ids, (Region(2, (0.0, 0.0, 1.0), locked),), 3)
    ndbgs = {INFINITESIMAL: wrong}
    plan = plan_assembly(asm, contacts, ndbgs, measure(asm, contacts, ndbgs))
    assert plan["found"] and plan["verified"]["value"] is True
    assert any("yet the direct sweep test proves this tree" in x for x in plan["notes"])
    order = [s["moved"] for s in plan["sequence"]]
    assert order.index(["block"]) < order.index(["bridge"])  # assembly order: block first
    for s in plan["sequence"]:
        assert _moves_apart(asm, s["moved"], s["onto"], s["removal_direction"])


def test_the_exact_check_of_a_proof_of_none_runs_beside_the_sweep(monkeypatch):
    """The latch (paper Fig. 10) with infinitesimal translations only: no direction splits
    it, and its own infinite-translation NDBG confirms that without the contacts. With two
    workers that NDBG is built in a forked process while the sweep runs here, even while
    another forked job (the interlock job's grasps) still works: the same proof."""
    from ndbg_cli.core import pools
    from ndbg_cli.core.constants import INFINITESIMAL
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.stages import build_ndbg, find_contacts, measure, plan_assembly

    asm = ndbg_cli.load(ROOT / "assemblies" / "fig10-latch.yaml")
    contacts = find_contacts(asm)
    ndbgs = {INFINITESIMAL: build_ndbg(asm, INFINITESIMAL, contacts).ndbg}
    forked = []

    class Spy(pools.Forked):
        def __init__(self, fn, *args, **kwargs):
            super().__init__(fn, *args, **kwargs)
            forked.append((fn.__name__, self._proc is not None))

    monkeypatch.setattr(pools, "Forked", Spy)
    got = {w: plan_assembly(asm, contacts, ndbgs, measure(asm, contacts, ndbgs),
                            Options(workers=w))["verified"] for w in (1, 2)}
    assert got[1] == got[2]
    assert got[1]["proof_of_none"] and "confirmed without the contacts" in got[1]["why"]
    exact = [f for f in forked if f[0] == "_exact_split"]
    assert exact == [("_exact_split", False), ("_exact_split", True)]
    with pools.Forked(time.sleep, 30) as busy:  # the side job, still working
        assert pools.spare_workers(2) == 0
        again = plan_assembly(asm, contacts, ndbgs, measure(asm, contacts, ndbgs),
                              Options(workers=2))["verified"]
        busy.cancel()
    assert again == got[1]
    assert [f for f in forked if f[0] == "_exact_split"][-1] == ("_exact_split", True)


def test_directions_within_the_angle_tolerance_are_one():
    # two cylinder axes fitted 3e-9 rad apart (two press fits on one shaft): one direction of
    # D, whatever the frame; kept apart, a plan along "both" counted two directions after a
    # turn (the press-fit example's min_directions 1 -> 2 under a rotation)
    a = np.array([0.6, 0.8, 0.0])
    t = 3e-9
    b = np.array([0.6 * np.cos(t) - 0.8 * np.sin(t), 0.6 * np.sin(t) + 0.8 * np.cos(t), 0.0])
    dirs = directions(3, [(a, "cylinder axis"), (b, "cylinder axis")], [])
    assert [d.source for d in dirs].count("cylinder axis") == 2  # a and -a
    far = np.array([np.cos(1e-5) * 0.6 - np.sin(1e-5) * 0.8,
                    np.sin(1e-5) * 0.6 + np.cos(1e-5) * 0.8, 0.0])
    dirs = directions(3, [(a, "cylinder axis"), (far, "cylinder axis")], [])
    assert [d.source for d in dirs].count("cylinder axis") == 4  # 1e-5 rad: two axes


def test_a_connected_plans_own_depth_bound_does_not_bound_every_proven_tree():
    # AS1's case: the plan keeps both sides of each step connected, and no connected tree is
    # shallower than 7 (its depth_lower_bound), while a proven tree of depth 6 exists and
    # the candidates' exact least depth is 5. The proven minimum depth is then between 5 and
    # 6, not "exactly 6" (the connected plan's bound is no bound on other trees).
    from ndbg_cli.pipeline.proofs import proven_classes

    names = [f"p{k}" for k in range(18)]
    plan = {"found": True, "verified": {"value": True}, "connected": True, "depth": 7,
            "depth_lower_bound": 7, "nonlinear_steps": 2,
            "sequence": [{"moved": names[:1], "onto": names[1:], "produces": names,
                          "removal_direction": [0.0, 0.0, 1.0]}],
            "proofs": [{"strategy": "fewest-directions", "depth": 6, "nonlinear_steps": 6,
                        "directions": 2}]}
    cands = {"min_depth": {"value": 5, "exact": True, "lower_bound": 5, "upper_bound": 5}}
    d = proven_classes(plan, cands)["min_depth"]
    assert (d["value"], d["exact"], d["lower_bound"], d["upper_bound"]) == (6, False, 5, 6)
    # without the candidates, ceil(log2 18) = 5 still bounds every tree
    d = proven_classes(plan, {})["min_depth"]
    assert (d["lower_bound"], d["upper_bound"]) == (5, 6)
    # a plan searched over all trees bounds them all: its 7 against a proven 6 is capped
    d = proven_classes({**plan, "connected": False, "depth_lower_bound": 6}, cands)["min_depth"]
    assert (d["value"], d["exact"]) == (6, True)
