"""What a proven plan refutes (:func:`ndbg_cli.pipeline.interlocking.apply_witnesses`), on
report sections written by hand, and the interlocking LP's yes as a necessary condition.

The hand sections: parts a (bottom), b, c (top) stacked along z, the LP fixing a; the proven
plan takes c off along +z, then b. The contact analysis has two edge contacts read pair by pair
("blocking on any"), so the LP and the infinitesimal NDBG read them as more than they block:
here the LP found no motion and the NDBG no candidate tree, as on the dowels example.
"""

from __future__ import annotations

import copy

import numpy as np

from ndbg_cli.contacts.contacts3d import Contact, ContactAnalysis
from ndbg_cli.pipeline.interlocking import apply_witnesses, conservative_contacts
from ndbg_cli.planning.classes import label, verdict
from ndbg_cli.report.consistency import contradictions

INF, INFT, GEN = "infinitesimal_translation", "infinite_translation", "generalized"
IDS = ["a", "b", "c"]
UP = [0.0, 0.0, 1.0]


def edge(a: int, b: int, blocking: str = "any") -> Contact:
    return Contact(a=a, b=b, kind="edge", normals=np.array([[1.0, 0.0, 0.0]]),
                   points=np.zeros((2, 3)), point_normals=np.array([[1.0, 0, 0]] * 2),
                   area=0.0, blocking=blocking)


def contacts(*found: Contact) -> ContactAnalysis:
    return ContactAnalysis(contacts=tuple(found), interferences=(), tolerance=0.01,
                           angle_tolerance=0.0175)


def no_tree(fam: str) -> dict:
    """What a candidate family's classes say when its NDBG has no candidate tree."""
    none = {"value": None, "exact": True, "why": "no candidate algorithm"}
    out = {"one_handed_monotone": {"value": False, "why": "stuck"},
           "linearizable": {"value": False, "why": "stuck"},
           "min_depth": dict(none), "min_nonlinear": dict(none), "min_directions": dict(none)}
    if fam == INF:
        out.update(prismatic={"value": False, "why": "stuck"},
                   stack_product={"value": False, "why": "none"},
                   interlocked={"value": True, "exact": False, "fixed": 0, "kind": None,
                                "moved_set_count": 0, "hands": None, "hands_exact": False,
                                "hands_lower_bound": None, "why": "no motion (2 edge/point)"})
    return {k: label(fam, k, v) for k, v in out.items()}


def sections() -> dict:
    tree = {"parts": IDS, "depth": 2, "removal_direction": UP, "moved": {"parts": ["c"]},
            "rest": {"parts": ["a", "b"], "depth": 1, "removal_direction": UP,
                     "moved": {"parts": ["b"]}, "rest": {"parts": ["a"]}}}
    seq = [{"step": 1, "moved": ["b"], "onto": ["a"], "removal_direction": UP},
           {"step": 2, "moved": ["c"], "onto": ["a", "b"], "removal_direction": UP}]
    return {
        "plan": {"found": True, "family": INFT, "depth": 2, "depth_lower_bound": 2,
                 "nonlinear_steps": 0, "tree": tree, "sequence": seq,
                 "verified": {"value": True, "steps": 2, "why": "swept"}},
        "classes": {INF: no_tree(INF), GEN: no_tree(GEN)},
        "ndbg": {INF: {"dbgs": [{"arcs": [[i, j] for i in IDS for j in IDS if i != j]}]}},
        "partitionings": [],
    }


def test_conservative_contacts_counts_edge_and_point_contacts():
    assert conservative_contacts(contacts(edge(0, 1), edge(1, 2, "all"))) == (2, 1)
    assert conservative_contacts(contacts()) == (0, 0)


def test_a_conservative_lp_yes_is_a_candidate_its_no_a_proof():
    yes = label(INF, "interlocked", {"value": True, "exact": False, "why": "LP"})
    assert yes["evidence"] == "candidate"
    assert verdict("interlocked", yes) == "yes (candidate only: a necessary condition)"
    assert label(INF, "interlocked", {"value": False, "exact": False})["evidence"] == "proven"
    assert label(INF, "interlocked", {"value": True})["evidence"] == "proven"  # exact LP


def test_a_proven_plan_refutes_interlocked_and_no_candidate_tree():
    out = sections()
    assert {c.rule for c in contradictions(out)} >= {"plan-vs-interlocked", "plan-vs-monotone",
                                                     "linear-plan"}
    apply_witnesses(out, IDS, contacts(edge(0, 1), edge(1, 2)))
    lock = out["classes"][INF]["interlocked"]
    # the plan's first removal step: c leaves {a, b} along +z (a, the fixed part, stays)
    assert lock["value"] is False and lock["evidence"] == "proven"
    assert lock["witness"] == {"moved": ["c"], "rest": ["a", "b"], "removal_direction": UP,
                               "source": "the proven plan's first removal step, by the "
                                         "direct sweep test"}
    assert (lock["moved_sets"], lock["fixed_set"], lock["hands"]) == ([[2]], [0, 1], 1)
    assert "2 edge/point contacts" in lock["why"]
    inf, gen = out["classes"][INF], out["classes"][GEN]
    for fam in (inf, gen):
        assert fam["one_handed_monotone"]["value"] is True
        assert fam["one_handed_monotone"]["evidence"] == "candidate"
        assert fam["linearizable"]["value"] is True  # the plan takes one part off at a time
        # depth 2 = ceil(log2 3): exact; 0 nonlinear steps; one direction (+z)
        assert (fam["min_depth"]["value"], fam["min_depth"]["exact"]) == (2, True)
        assert (fam["min_nonlinear"]["value"], fam["min_directions"]["value"]) == (0, 1)
    assert inf["prismatic"]["value"] is None and inf["stack_product"]["value"] is True
    assert out["ndbg"][INF]["conservative_contacts"] == 2
    assert contradictions(out) == []


def test_the_witness_moves_the_side_without_the_fixed_part():
    out = sections()
    out["classes"][INF]["interlocked"]["fixed"] = 2  # c fixed: {a, b} leaves c along -z
    apply_witnesses(out, IDS, contacts(edge(0, 1)))
    w = out["classes"][INF]["interlocked"]["witness"]
    assert (w["moved"], w["rest"], w["removal_direction"]) == (["a", "b"], ["c"],
                                                                [0.0, 0.0, -1.0])


def test_without_a_proven_plan_a_split_removable_by_one_translation_is_the_witness():
    out = sections()
    out["plan"]["verified"]["value"] = False
    out["partitionings"] = [{"family": INFT, "moved": ["c"], "rest": ["a", "b"],
                             "directions": [UP]}]
    apply_witnesses(out, IDS, contacts(edge(0, 1)))
    lock = out["classes"][INF]["interlocked"]
    assert lock["value"] is False and lock["witness"]["source"].startswith("a partitioning")
    # the NDBG's "no candidate tree" stands: no proven tree refutes it
    assert out["classes"][INF]["one_handed_monotone"]["value"] is False


def test_without_a_witness_the_conservative_yes_stays_a_candidate():
    out = sections()
    out["plan"]["verified"]["value"] = False
    before = copy.deepcopy(out["classes"])
    apply_witnesses(out, IDS, contacts(edge(0, 1, "all")))
    assert out["classes"] == before
    assert out["classes"][INF]["interlocked"]["evidence"] == "candidate"
    assert "conservative_contacts" not in out["ndbg"][INF]  # "all": read as they block
