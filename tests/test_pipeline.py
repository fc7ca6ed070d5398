"""End to end: ``ndbg analyze`` on the shipped examples against the answers worked out by hand
in each manifest's ``expect`` block, the report against its JSON Schema, and the CLI commands
built on the pipeline (``contacts``, ``query``, ``remove``)."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path

import jsonschema
import numpy as np
import pytest
import yaml

from ndbg_cli.core.options import Options
from ndbg_cli.pipeline.analysis import analyze_path
from ndbg_cli.report.consistency import CODE, contradictions
from ndbg_cli.report.document import clean, dumps, validate_report

from conftest import shared
from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"


@cache
def report(name: str, motion: str = "all") -> dict:
    return clean(analyze_path(EX / f"{name}.yaml", Options(motion=motion)))


def expect(name: str) -> dict:
    return yaml.safe_load((EX / f"{name}.yaml").read_text())["expect"]


def classes(name: str, family: str) -> dict:
    return {k: v.get("value") for k, v in report(name)["classes"][family].items()}


def parts_of(rep: dict, family: str) -> list[dict]:
    return [p for p in rep["partitionings"] if p["family"] == family]


def moved_sets(rep: dict, family: str) -> set[frozenset[str]]:
    return {frozenset(p["moved"]) for p in parts_of(rep, family)}


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


SMALL = ["hover", "hover-shifted", "fig3-2d", "fig5-rotation", "fig10-latch", "fig11-nonlinear",
         "fig2-sandwich-5", "stack", "peg-37", "peg-blind", "slot-37", "hinge", "bolt-screw",
         "bolt-plain"]


@pytest.mark.parametrize("name", SMALL)
def test_report_validates_and_has_every_section(name):
    rep = report(name)
    validate_report(rep)
    for key in ("schema", "assembly", "contacts", "interferences", "ndbg", "partitionings",
                "plan", "classes", "timings", "warnings"):
        assert key in rep, key
    assert rep["timings"] == {}


#: Every example with hand facts (an ``expect`` block); the heavy ones marked slow.
WITH_EXPECT = sorted(p.stem for p in EX.glob("*.yaml") if "expect" in yaml.safe_load(
    p.read_text()))
HEAVY = {"bell", "gearbox", "press-fit"}


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in HEAVY
                                  else n for n in WITH_EXPECT])
def test_example_reports_do_not_contradict_themselves(name):
    """The consistency rules (ndbg check --self) hold on every example's report, and the
    report carries no contradiction warning."""
    rep = report(name)
    found = contradictions(rep)
    assert found == [], "\n".join(c.line() for c in found)
    assert not [w for w in rep["warnings"] if w["code"] == CODE]
    validate_report(rep)


def test_dowels_interlocked_agrees_with_the_proven_plan():
    """The user's case: dowels in a frame, edge contacts along vertex lines. By hand (the
    manifest): each dowel leaves along the hole axis, so the product is not interlocked and a
    plan of single translations exists. The report once said "interlocked: yes" (the LP,
    reading the edge contacts conservatively) beside that proven plan."""
    rep, e = report("dowels"), expect("dowels")
    plan, lock = rep["plan"], rep["classes"]["infinitesimal_translation"]["interlocked"]
    assert plan["found"] is e["plan_found"] and plan["verified"]["value"] is True
    for step in plan["sequence"]:  # every step along the hole axis, either sense
        assert abs(abs(unit(step["removal_direction"]) @ unit(e["axis"])) - 1) < 1e-9
    assert lock["value"] is e["interlocked"] and lock["evidence"] == "proven"
    w = lock["witness"]  # one side leaves the other along the axis: a dowel, or all but one
    assert abs(abs(unit(w["removal_direction"]) @ unit(e["axis"])) - 1) < 1e-9
    assert sorted(w["moved"] + w["rest"]) == sorted(p["id"] for p in rep["assembly"]["parts"])
    assert (lock["hands"], lock["hands_exact"]) == (1, True)
    assert "edge/point contacts" in lock["why"]  # the LP's reading, said
    for fam in ("infinitesimal_translation", "generalized", "infinite_translation"):
        assert rep["classes"][fam]["one_handed_monotone"]["value"] is True, fam
    assert rep["ndbg"]["infinitesimal_translation"]["conservative_contacts"] > 0


def test_schema_rejects_a_broken_report():
    rep = json.loads(json.dumps(report("hover")))
    rep["classes"]["infinitesimal_translation"]["linearizable"] = "yes"
    with pytest.raises(jsonschema.ValidationError):
        validate_report(rep)
    rep = json.loads(json.dumps(report("hover")))
    del rep["plan"]
    with pytest.raises(jsonschema.ValidationError):
        validate_report(rep)


def test_report_is_byte_identical_across_runs():
    a = dumps(analyze_path(EX / "fig11-nonlinear.yaml", Options()))
    b = dumps(analyze_path(EX / "fig11-nonlinear.yaml", Options()))
    assert a == b


# -- the paper's figures ---------------------------------------------------------------------

def test_hover_infinite_catches_the_hovering_bridge():
    """Locally free along +z (touches only the base below), globally blocked by the bridge."""
    rep = report("hover")
    e = expect("hover")
    assert sorted(sorted(p) for p in rep["contact_stats"]["touching_pairs"]) == \
        sorted(sorted(p) for p in e["contact_pairs"])
    up = np.array([0, 0, 1.0])

    def free_up(family: str) -> bool:
        return any(p["moved"] == ["puck"] and any(np.allclose(unit(d), up, atol=1e-6)
                                                  for d in p["directions"])
                   for p in parts_of(rep, family))
    # infinitesimal: +z lies in a 2D region; check the local cone instead: {puck} is free
    assert frozenset(["puck"]) in moved_sets(rep, "infinitesimal_translation")
    assert not free_up("infinite_translation")
    shifted = report("hover-shifted")
    assert any(p["moved"] == ["puck"] for p in parts_of(shifted, "infinite_translation"))


def test_fig3_local_freedom_facts():
    rep = report("fig3-2d")
    e = expect("fig3-2d")
    sec = rep["ndbg"]["infinitesimal_translation"]
    assert sec["regions"] == e["regions"]["total"]
    assert sec["regions_by_dimension"] == {"0": e["regions"]["points"],
                                           "1": e["regions"]["arcs"]}
    d1, d2 = unit(e["d1"]), unit(e["d2"])

    def free_at(d) -> set[frozenset[str]]:
        out = set()
        for p in parts_of(rep, "infinitesimal_translation"):
            if any(np.allclose(unit(x), d, atol=1e-9) for x in p["directions"]):
                out.add(frozenset(p["moved"]))
        return out
    # d1 = +y is a 0-dimensional region (a cone boundary): exactly the paper's facts
    assert {frozenset(s) for s in e["locally_free_d1"]} <= free_at(d1)
    # d2 lies inside an open arc: look its region up and list what is free there
    from ndbg_cli.io.loaders import load
    from ndbg_cli.ndbg.dbg import free_subsets
    from ndbg_cli.ndbg.infinitesimal.build import infinitesimal_ndbg, locate_region

    asm = load(EX / "fig3-2d.yaml")
    nd = infinitesimal_ndbg(asm)
    for d, want in ((d1, e["locally_free_d1"]), (d2, e["locally_free_d2"])):
        g = nd.regions[locate_region(nd, d)].dbg
        got = {frozenset(nd.names(s)) for s in free_subsets(g)}
        assert got == {frozenset(w) for w in want}


def test_fig5_rotation_frees_the_key_and_no_translation_does():
    rep = report("fig5-rotation")
    e = expect("fig5-rotation")
    for fam in ("infinitesimal_translation", "infinite_translation"):
        assert classes("fig5-rotation", fam)["one_handed_monotone"] is False
        assert not parts_of(rep, fam)
    gen = rep["ndbg"]["generalized"]
    assert [n["parts"] for n in gen["needs_rotation"]] == [[e["rotation"]["moved"]]]
    m = gen["needs_rotation"][0]["motion"]
    assert m["type"] == "rotation"
    assert abs(abs(unit(m["axis"]) @ np.array(e["rotation"]["axis"], float)) - 1) < 1e-6
    assert classes("fig5-rotation", "generalized")["one_handed_monotone"] is True
    assert rep["plan"]["family"] == "generalized" and rep["plan"]["found"]


def test_fig10_latch_needs_two_hands():
    assert classes("fig10-latch", "infinitesimal_translation")["one_handed_monotone"] is False
    lock = report("fig10-latch")["classes"]["infinitesimal_translation"]["interlocked"]
    assert lock["value"] is False and lock["hands"] >= 2


def test_fig11_one_handed_not_linearizable():
    c = classes("fig11-nonlinear", "infinite_translation")
    assert c["one_handed_monotone"] is True and c["linearizable"] is False
    assert c["min_nonlinear"] >= 1


def test_fig2_sandwich_two_top_level_decompositions():
    rep = report("fig2-sandwich-5")
    e = expect("fig2-sandwich-5")
    for fam in ("infinitesimal_translation", "infinite_translation"):
        splits = {frozenset([frozenset(p["moved"]), frozenset(p["rest"])])
                  for p in parts_of(rep, fam)}
        assert len(splits) == e["decomposition_count"], fam
        want = {frozenset(d["moved"]) for d in e["feasible_decompositions"]}
        assert {min(s, key=len) for s in splits} == want


def test_stack_is_a_stack_product_with_the_hand_sequence():
    for fam in ("infinitesimal_translation", "infinite_translation"):
        c = classes("stack", fam)
        assert c["stack_product"] is True and c["linearizable"] is True


@pytest.mark.parametrize("name", ["peg-37", "slot-37"])
def test_odd_angle_peg_and_slot_removal_direction(name):
    rep = report(name)
    want = unit(expect(name)["removal_directions"][0])
    for fam in ("infinitesimal_translation", "infinite_translation"):
        dirs = [unit(d) for p in parts_of(rep, fam) for d in p["directions"]]
        assert dirs, fam
        for d in dirs:  # every free direction is along the axis, either sense
            assert abs(abs(d @ want) - 1) < 2e-3, (fam, d)


def test_bolt_with_screw_joint_is_not_prismatic_unless_threads_are_cylinders():
    rep = report("bolt-screw")
    c = rep["classes"]
    assert c["infinite_translation"]["prismatic"]["value"] is False
    assert c["generalized"]["one_handed_monotone"]["value"] is True
    # by hand (expect: translation_free false): the thread holds the bolt against every
    # translation, which the interlocking LP reads too (it once moved the bolt out alone)
    assert expect("bolt-screw")["translation_free"] is False
    lock = c["infinitesimal_translation"]["interlocked"]
    assert lock["value"] is True and "declared threads hold bolt and block" in lock["why"]
    assert [m["motion"]["type"] for m in rep["ndbg"]["generalized"]["needs_rotation"]] == \
        ["screw"]
    plain = clean(analyze_path(EX / "bolt-screw.yaml", Options(threads_as_cylinders=True)))
    assert plain["classes"]["infinite_translation"]["prismatic"]["value"] is True


def test_bell_translation_section_and_partitionings():
    """Issue 4's must-show through the CLI."""
    r = run_cli("analyze", EX / "bell.yaml", "--motion", "translation", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    sec = doc["ndbg"]["infinitesimal_translation"]
    assert sec["regions"] > 0 and doc["partitionings"]
    first = {p["moved"][0] for p in doc["partitionings"] if len(p["moved"]) == 1}
    for item in expect("bell")["locally_free_first"]:
        assert item["part"] in first
    assert doc["classes"]["infinitesimal_translation"]["linearizable"]["value"] is True
    validate_report(doc)


# -- commands ----------------------------------------------------------------------------------

def test_query_prints_both_dbgs_for_one_direction():
    r = run_cli("query", EX / "hover.yaml", "--direction", "0,0,2", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    inf = doc["dbgs"]["infinitesimal_translation"]["arcs"]
    glob = doc["dbgs"]["infinite_translation"]["arcs"]
    assert ["puck", "bridge"] not in inf and ["puck", "bridge"] in glob
    bad = run_cli("query", EX / "hover.yaml", "--direction", "0,0")
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert "--direction must be 3" in bad.stderr


def test_remove_lists_what_to_withdraw_first():
    r = run_cli("remove", EX / "hover.yaml", "puck", "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["found"] and doc["exact"]
    # the puck comes out sideways without withdrawing anything
    assert doc["count"] == 0
    r = run_cli("remove", EX / "hover.yaml", "nosuchpart")
    assert r.returncode == 2 and "no part 'nosuchpart'" in r.stderr


def test_interference_policy_error_exit_code(tmp_path):
    from helpers import box

    box((0, 0, 0), (10, 10, 10)).export(tmp_path / "a.stl")
    box((5, 5, 5), (15, 15, 15)).export(tmp_path / "b.stl")
    (tmp_path / "m.yaml").write_text("name: clash\nparts:\n  - {id: a, mesh: a.stl}\n"
                                     "  - {id: b, mesh: b.stl}\n")
    r = run_cli("analyze", tmp_path / "m.yaml", "--interference", "error")
    assert r.returncode == 2 and "interpenetrate" in r.stderr
    assert "Traceback" not in r.stderr
    r = run_cli("analyze", tmp_path / "m.yaml", "--format", "json", "--motion", "translation")
    assert r.returncode == 0
    doc = json.loads(r.stdout)
    assert len(doc["interferences"]) == 1 and doc["interferences"][0]["volume"] == \
        pytest.approx(125.0, rel=1e-3)
    assert any(w["code"] == "interference" for w in doc["warnings"])


@pytest.mark.external
def test_contacts_command_on_as1_lists_the_32_pairs():
    r = run_cli("contacts", shared("as1", "as1-oc-214.stp"), "--format", "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    pairs = doc["contact_stats"]["touching_pairs"]
    assert len(pairs) == 32 and not doc["interferences"]
    assert r.stdout == run_cli("contacts", shared("as1", "as1-oc-214.stp"),
                               "--format", "json").stdout


def test_andor_section_counts_the_hover_trees_by_hand():
    # base, puck, bridge (3 parts, no part touches both others' tops): at the root the puck
    # slides out along +y, the bridge lifts off, the base drops away: 3 single-part splits;
    # every pair then has its one split (the puck and the bridge do not touch). Nodes: the
    # root, 3 pairs, 3 parts; hyperarcs 3 + 3; trees 3 (one per root split); linear
    # sequences 3 x 2 (the last part added, times both orders of the first two); depth 2.
    rep = report("hover")
    validate_report(rep)
    for fam in ("infinitesimal_translation", "infinite_translation", "generalized"):
        g = rep["andor"][fam]
        assert (g["nodes"], g["hyperarcs"], g["trees"], g["linear_sequences"],
                g["min_depth"], g["min_nonlinear"], g["truncated"]) == (7, 6, 3, 6, 2, 0, False)
    # a graph cut by the budget gives no counts and says why
    bell = report("bell")
    g = bell["andor"]["infinitesimal_translation"]
    assert g["truncated"] and g["trees"] is None and g["cut_by"] == "splits"
    assert "over 5000 candidate partitionings" in g["why"]
    assert bell["andor"]["generalized"]["cut_by"] == "supergraph"


def test_text_shows_what_the_verified_plan_proves():
    from ndbg_cli.planning.plans import plan_proves
    from ndbg_cli.report.text import render

    rep = report("bell")
    assert rep["plan"]["verified"]["value"] is True
    text = render(rep)
    # the infinitesimal family's verdicts stay candidates; the verified plan proves more
    assert "1-handed monotone: yes (candidate only: a necessary condition)" in text
    assert "proven by the verified plan (sweep test):" in text
    least = min([rep["plan"]["depth"]] + [t["depth"] for t in rep["plan"]["proofs"]])
    assert "1-handed monotone: yes, 1-prismatic: yes, linearizable: yes; minimum depth <= " \
        f"{least}" in text
    failed = dict(rep["plan"], verified={"value": False, "steps": 21, "why": "step 3 blocked"})
    assert plan_proves(failed) is None
    assert "proven by the verified plan" not in render(dict(rep, plan=failed))


def test_one_blas_thread_in_the_cli_unless_the_caller_chose():
    # ndbg's matrices are tiny: BLAS threads only spin on a busy machine. The CLI, which owns
    # its process, sets one thread (cli.main._one_blas_thread); a library import leaves the
    # caller's environment alone.
    import os
    import subprocess
    import sys

    code = ("import atexit, os, sys, ndbg_cli\n"
            "print(os.environ.get('OPENBLAS_NUM_THREADS'))\n"
            "atexit.register(lambda: print(os.environ.get('OPENBLAS_NUM_THREADS')))\n"
            "from ndbg_cli.cli.main import main\n"
            "main(['--version'])\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out[0] == "None" and out[-1] == "1"
    env["OPENBLAS_NUM_THREADS"] = "3"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                         text=True, check=True).stdout.split()
    assert out[0] == "3" and out[-1] == "3"


def test_a_rack_above_the_part_cap_is_proven_without_the_whole_sphere(tmp_path):
    # 9 boards on standoffs: 41 parts, one above INFINITE_MAX_PARTS. By construction the rack
    # comes apart top down along +z; the default run leaves the whole sphere out (its
    # arrangement grows as the fourth power of the parts), says why, and still decides the
    # infinite family's classes from the plan the sweep test proves.
    import sys

    from ndbg_cli.core.constants import INFINITE_MAX_PARTS

    sys.path.insert(0, str(EX))
    import build

    name = build.rack(tmp_path, 9)
    rep = clean(analyze_path(tmp_path / f"{name}.yaml", Options()))
    assert len(rep["assembly"]["parts"]) == 41 > INFINITE_MAX_PARTS
    skipped = [w["message"] for w in rep["warnings"] if w["code"] == "infinite-skipped"]
    assert len(skipped) == 1 and "41 parts" in skipped[0]
    assert rep["ndbg"]["infinite_translation"]["skipped"] is True
    assert rep["plan"]["verified"]["value"] is True
    assert {tuple(s["removal_direction"]) for s in rep["plan"]["sequence"]} <= {
        (0.0, 0.0, 1.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), (-1.0, 0.0, 0.0),
        (0.0, 1.0, 0.0), (0.0, -1.0, 0.0)}
    inf = rep["classes"]["infinite_translation"]
    assert inf["one_handed_monotone"]["value"] is True
    assert inf["prismatic"]["value"] is True
    assert not contradictions(rep)


def test_trees_as_deep_as_2000_parts_stop_no_analysis():
    """Found by the fuzzing campaign (case mesh:20260288: 2,000 cubes): the classes' tree
    height and the report's JSON recurse once per level of the assembly tree, and a tree
    that takes one part at a time is as deep as the assembly has parts: past Python's
    default limit of 1,000 that was a RecursionError (exit 3). ``analyze`` now raises the
    limit to what the assembly's parts need (``core.stack.allow_deep_trees``); here a
    2,000-level tree built by construction goes through the same recursive functions."""
    import sys

    from ndbg_cli.core.stack import allow_deep_trees
    from ndbg_cli.planning.classes import _choice_depth

    n, old = 2000, sys.getrecursionlimit()
    full = (1 << n) - 1
    # part k leaves what is left of parts k..n-1 first: the linear tree, n - 1 levels
    choice = {full >> k << k: (1 << k, 0) for k in range(n - 1)}
    tree: dict = {"part": n - 1}
    for k in range(n - 2, -1, -1):
        tree = {"moved": {"part": k}, "rest": tree}
    try:
        allow_deep_trees(n)
        assert _choice_depth(choice, full) == n - 1
        assert json.loads(dumps(clean(tree)))["rest"]["moved"] == {"part": 1}
    finally:
        sys.setrecursionlimit(old)
