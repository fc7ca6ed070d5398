"""The consistency rules of a report's answers (:mod:`ndbg_cli.report.consistency`), one by
one on small reports written by hand: a consistent one, and each rule's contradiction built by
changing what that rule ties (a rule that cannot fail would check nothing).

The hand report: parts a (bottom), b, c (top) stacked along z; a proven linear plan takes c off
along +z, then b (depth 2 = ceil(log2 3)); along +z the infinitesimal DBG has the contact arcs
a -> b, b -> c (a moving up hits b, b hits c), so {c} and {b, c} are free there, as they are
for the infinite translations; one direction suffices (a stack product).
"""

from __future__ import annotations

import copy
import json

import pytest

from ndbg_cli.report.consistency import CODE, RULES, contradictions, warnings

from helpers import run_cli

INF, INFT, GEN = "infinitesimal_translation", "infinite_translation", "generalized"
UP = [0.0, 0.0, 1.0]


def _step(n: int, moved: list[str], onto: list[str]) -> dict:
    return {"step": n, "moved": moved, "onto": onto, "produces": onto + moved,
            "family": INFT, "region": 0, "direction": [0.0, 0.0, -1.0],
            "removal_direction": UP}


def _classes(evidence: str) -> dict:
    return {
        "one_handed_monotone": {"value": True, "evidence": evidence},
        "linearizable": {"value": True, "evidence": evidence},
        "stack_product": {"value": True, "evidence": evidence},
        "min_depth": {"value": 2, "exact": True, "lower_bound": 2, "upper_bound": 2,
                      "evidence": evidence},
        "min_nonlinear": {"value": 0, "exact": True, "lower_bound": 0, "assembly_lines": 1,
                          "evidence": evidence},
        "min_directions": {"value": 1, "exact": True, "lower_bound": 1, "evidence": evidence},
    }


def good() -> dict:
    """The consistent hand report (see the module docstring)."""
    tree = {"parts": ["a", "b", "c"], "depth": 2, "removal_direction": UP,
            "moved": {"parts": ["c"]},
            "rest": {"parts": ["a", "b"], "depth": 1, "removal_direction": UP,
                     "moved": {"parts": ["b"]}, "rest": {"parts": ["a"]}}}
    inf = _classes("candidate")
    inf["prismatic"] = {"value": None, "evidence": "undecided"}
    inf["interlocked"] = {"value": False, "evidence": "proven", "moved_set_count": 1,
                          "hands": 1, "hands_lower_bound": 1, "hands_exact": True}
    infinite = _classes("proven")
    infinite["prismatic"] = {"value": True, "evidence": "proven"}
    split = {"moved": ["c"], "rest": ["a", "b"], "directions": [UP]}
    return {
        "schema": "ndbg.report/1",
        "plan": {"found": True, "family": INFT, "depth": 2, "depth_lower_bound": 2,
                 "nonlinear_steps": 0, "tree": tree,
                 "sequence": [_step(1, ["b"], ["a"]), _step(2, ["c"], ["a", "b"])],
                 "verified": {"value": True, "steps": 2, "why": "swept"}},
        "classes": {INF: inf, INFT: infinite, GEN: _classes("candidate")},
        "ndbg": {INF: {"dbgs": [{"arcs": [["a", "b"], ["b", "c"]]},
                                {"arcs": [["b", "a"], ["c", "b"]]}]}},
        "partitionings": [{**split, "family": INF}, {**split, "family": INFT}],
    }


def rules_of(report: dict) -> set[str]:
    return {c.rule for c in contradictions(report)}


def test_the_hand_report_is_consistent():
    assert contradictions(good()) == []


def test_every_rule_is_tested_here():
    tested = {name[len("test_rule_"):].replace("_", "-") for name in globals()
              if name.startswith("test_rule_")}
    assert tested == set(RULES)


def test_rule_plan_vs_interlocked():
    rep = good()
    rep["classes"][INF]["interlocked"] = {"value": True, "evidence": "candidate"}
    assert "plan-vs-interlocked" in rules_of(rep)
    # without a proven plan a candidate yes contradicts nothing of the plan's
    rep["plan"]["verified"]["value"] = False
    assert "plan-vs-interlocked" not in rules_of(rep)


@pytest.mark.parametrize("family,key,entry", [
    (INF, "one_handed_monotone", {"value": False}),
    (GEN, "one_handed_monotone", {"value": False}),
    (INF, "prismatic", {"value": False}),
    (GEN, "min_depth", {"value": None, "exact": True}),
])
def test_rule_plan_vs_monotone(family, key, entry):
    rep = good()
    rep["classes"][family][key] = entry
    assert "plan-vs-monotone" in rules_of(rep)
    rep["classes"][family][key] = {**entry, "evidence": "undecided"}  # claims nothing
    assert "plan-vs-monotone" not in rules_of(rep)


def test_rule_infinite_split_is_infinitesimal():
    rep = good()
    # every pair blocks both ways in every infinitesimal DBG: {c} is free in none
    both = [[i, j] for i in "abc" for j in "abc" if i != j]
    rep["ndbg"][INF]["dbgs"] = [{"arcs": both}]
    assert "infinite-split-is-infinitesimal" in rules_of(rep)
    rep["ndbg"][INF]["conservative_contacts"] = 2  # the NDBG says it may block what is free
    assert "infinite-split-is-infinitesimal" not in rules_of(rep)


def test_rule_prismatic_tree():
    rep = good()
    rep["plan"]["tree"]["rest"]["motion"] = {"twist": [0, 0, 1, 0, 0, 0]}  # a turn, not a
    assert "prismatic-tree" in rules_of(rep)                                 # translation
    rep = good()
    rep["plan"]["verified"]["value"] = False
    assert "prismatic-tree" in rules_of(rep)


def test_rule_depth_vs_plan():
    rep = good()
    rep["classes"][GEN]["min_depth"].update(value=3, lower_bound=3, upper_bound=3)
    assert "depth-vs-plan" in rules_of(rep)


def test_rule_linear_plan():
    rep = good()
    rep["classes"][GEN]["linearizable"] = {"value": False, "evidence": "proven"}
    assert "linear-plan" in rules_of(rep)
    # a nonlinear plan ((a | b) | (c | d)) says nothing of linearizable
    rep = good()
    leaf = [{"parts": [p]} for p in "abcd"]
    rep["plan"]["tree"] = {"parts": list("abcd"),
                           "moved": {"parts": ["c", "d"], "moved": leaf[2], "rest": leaf[3]},
                           "rest": {"parts": ["a", "b"], "moved": leaf[1], "rest": leaf[0]}}
    rep["classes"][GEN]["linearizable"] = {"value": False, "evidence": "proven"}
    assert "linear-plan" not in rules_of(rep)


@pytest.mark.parametrize("change", [
    {"depth": 3}, {"depth_lower_bound": 3}, {"nonlinear_steps": 1},
    {"sequence": [_step(1, ["c"], ["a", "b"])]},
])
def test_rule_plan_shape(change):
    rep = good()
    rep["plan"].update(change)
    assert "plan-shape" in rules_of(rep)


def test_plan_shape_bounds_the_height_by_the_parts():
    rep = good()
    rep["plan"]["tree"] = {"parts": ["a", "b", "c"], "moved": {"parts": ["a"]},
                           "rest": {"parts": ["b"]}}  # a split losing a part: height 1 < 2
    rep["plan"]["sequence"], rep["plan"]["depth"] = rep["plan"]["sequence"][:1], 1
    assert "plan-shape" in rules_of(rep)


def test_rule_proof_of_none():
    rep = good()
    rep["plan"]["verified"] = {"value": False, "proof_of_none": True, "why": "stuck"}
    assert "proof-of-none" in rules_of(rep)   # found, and infinite says 1-handed monotone
    rep["plan"]["verified"] = {"value": True, "proof_of_none": True, "why": "both"}
    assert "proof-of-none" in rules_of(rep)


def test_rule_infinite_monotone_has_plan():
    rep = good()
    rep["plan"] = {"found": False, "family": INFT, "depth": None, "tree": None,
                   "sequence": [], "verified": {"value": False, "why": "blocked"}}
    assert "infinite-monotone-has-plan" in rules_of(rep)


def test_rule_class_implications():
    rep = good()
    rep["classes"][GEN]["one_handed_monotone"] = {"value": False}
    assert "class-implications" in rules_of(rep)  # yet linearizable, a depth, ...
    rep = good()
    rep["classes"][GEN]["min_depth"] = {"value": None, "exact": True}
    assert "class-implications" in rules_of(rep)  # 1-handed monotone without a depth


@pytest.mark.parametrize("key,entry", [
    ("min_nonlinear", {"value": 1, "exact": True, "lower_bound": 1, "assembly_lines": 2}),
    ("linearizable", {"value": False}),
    ("min_nonlinear", {"value": 0, "exact": True, "lower_bound": 0, "assembly_lines": 2}),
])
def test_rule_linear_vs_nonlinear(key, entry):
    rep = good()
    rep["classes"][GEN][key] = entry
    assert "linear-vs-nonlinear" in rules_of(rep)


@pytest.mark.parametrize("entry", [
    {"value": 2, "exact": False, "lower_bound": 3, "upper_bound": 4},
    {"value": 2, "exact": True, "lower_bound": 1, "upper_bound": 2},
    {"value": 5, "exact": False, "lower_bound": 2, "upper_bound": 4},
])
def test_rule_minimum_bounds(entry):
    rep = good()
    rep["classes"][GEN]["min_depth"] = entry
    assert "minimum-bounds" in rules_of(rep)


@pytest.mark.parametrize("key,entry", [
    ("min_directions", {"value": 2, "exact": True, "lower_bound": 2}),
    ("stack_product", {"value": False}),
])
def test_rule_stack_vs_directions(key, entry):
    rep = good()
    rep["classes"][INF][key] = entry
    assert "stack-vs-directions" in rules_of(rep)


@pytest.mark.parametrize("narrow,wide,key,entry", [
    (INFT, INF, "one_handed_monotone", {"value": False}),
    (INF, GEN, "linearizable", {"value": False}),
    (INFT, INF, "min_directions", {"value": 2, "exact": False, "lower_bound": 2}),
    (INFT, INF, "prismatic", {"value": False}),
])
def test_rule_containment(narrow, wide, key, entry):
    rep = good()
    rep["classes"][wide][key] = entry
    assert "containment" in rules_of(rep)


def test_rule_interlocked_vs_splits():
    rep = good()
    rep["plan"]["verified"]["value"] = False  # no proven plan: the splits alone
    rep["classes"][INF]["interlocked"] = {"value": True, "evidence": "proven"}
    assert "interlocked-vs-splits" in rules_of(rep)
    # an LP yes that is a necessary condition only: an infinitesimal candidate split does
    # not refute it, a split removable by one translation does
    rep["classes"][INF]["interlocked"]["evidence"] = "candidate"
    assert "interlocked-vs-splits" in rules_of(rep)
    rep["partitionings"] = [p for p in rep["partitionings"] if p["family"] == INF]
    rep["classes"][INF]["one_handed_monotone"]["value"] = True
    assert "interlocked-vs-splits" not in rules_of(rep)


@pytest.mark.parametrize("change", [
    {"hands_lower_bound": 2, "hands": None, "hands_exact": False},  # bolt-screw, before
    {"hands": 2},
    {"hands": None},
])
def test_rule_interlock_hands(change):
    rep = good()
    rep["classes"][INF]["interlocked"].update(change)
    assert "interlock-hands" in rules_of(rep)


def test_error_records_and_undecided_values_claim_nothing():
    assert contradictions({"schema": "ndbg.report/1", "error": {"code": 2}}) == []
    rep = good()
    for fam in rep["classes"].values():
        for entry in fam.values():
            entry["evidence"] = "undecided"
    rep["plan"]["verified"]["value"] = False
    rep["partitionings"] = []
    assert contradictions(rep) == []


def test_warnings_are_diagnostics_naming_rule_and_fields():
    rep = good()
    rep["classes"][INF]["interlocked"] = {"value": True, "evidence": "candidate"}
    got = warnings(contradictions(rep), "x.yaml")
    assert got and all(w["code"] == CODE and w["level"] == "warning" and w["file"] == "x.yaml"
                       for w in got)
    assert got[0]["rule"] == "plan-vs-interlocked"
    assert "plan.verified.value" in got[0]["fields"]


def test_check_self_exits_1_on_a_contradiction_and_0_without(tmp_path):
    rep = good()
    rep["classes"][INF]["interlocked"] = {"value": True, "evidence": "candidate"}
    bad, ok = tmp_path / "bad.json", tmp_path / "ok.json"
    bad.write_text(json.dumps({**rep, "assembly": {"name": "bad", "source": "bad.yaml"}}))
    ok.write_text(json.dumps({**copy.deepcopy(good()),
                              "assembly": {"name": "ok", "source": "ok.yaml"}}))
    r = run_cli("check", "--self", str(ok))
    assert r.returncode == 0, r.stderr
    r = run_cli("check", "--self", str(bad), str(ok))
    assert r.returncode == 1
    assert "plan-vs-interlocked" in r.stdout and "1 of 2 reports consistent" in r.stderr
    r = run_cli("check", str(ok))
    assert r.returncode == 2 and "--self" in r.stderr
