"""CI gates: `ndbg check` with rules files and JUnit output, `ndbg diff` between analyses."""

from __future__ import annotations

import json
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import trimesh

from ndbg_cli.report.rules import RuleSet, evaluate, load_rules

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
CONFIGS = ROOT / "configs"


@pytest.fixture(scope="module")
def bell_report(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("bell") / "bell.json"
    r = run_cli("analyze", EX / "bell.yaml", "--format", "json", "--out", out)
    assert r.returncode == 0, r.stderr
    return out


def _lenient_bell_rules(tmp_path: Path) -> Path:
    """configs/rules-bell.yaml with ``undecided: pass``."""
    text = (CONFIGS / "rules-bell.yaml").read_text()
    assert "undecided: fail" in text
    out = tmp_path / "rules-bell-lenient.yaml"
    out.write_text(text.replace("undecided: fail", "undecided: pass"))
    return out


def test_bell_rules_are_proven_by_its_verified_plans(bell_report, tmp_path):
    # The bell's infinite-translation NDBG is over --infinite-budget and skipped: its classes
    # are candidates (necessary conditions), which prove nothing. Its reported plan and a
    # linear tree pass the direct sweep test at every step: real 1-handed monotone
    # 1-prismatic algorithms, which prove the rules (at most 4 directions, depth 6, linear).
    r = run_cli("check", bell_report, "--rules", CONFIGS / "rules-bell.yaml", "--format",
                "json")
    assert r.returncode == 0, r.stdout + r.stderr
    outcomes = json.loads(r.stdout)["outcomes"][0]
    assert all(o["ok"] is True for o in outcomes), outcomes
    notes = {o["rule"]: o["reason"] for o in outcomes}
    assert notes["one_handed_monotone"].startswith("verified plan")
    assert notes["linearizable"].startswith("verified plan")
    # one direction: by construction every bell part leaves along +z in some order
    # (assemblies/build.py), and the fewest-directions proven tree finds such an order
    tight = tmp_path / "rules-bell-1dir.yaml"
    tight.write_text((CONFIGS / "rules-bell.yaml").read_text()
                     .replace("max_directions: 4", "max_directions: 1"))
    r = run_cli("check", bell_report, "--rules", tight, "--format", "json")
    assert r.returncode == 0, r.stdout + r.stderr
    ok = {o["rule"]: o["ok"] for o in json.loads(r.stdout)["outcomes"][0]}
    assert ok["max_directions"] is True
    r = run_cli("check", EX / "bell.yaml", "--rules", _lenient_bell_rules(tmp_path))
    assert r.returncode == 0, r.stdout + r.stderr
    assert "1 of 1 assemblies pass" in r.stdout + r.stderr


def test_check_fails_a_tightened_rule_with_one_line_each(bell_report, tmp_path):
    junit = tmp_path / "ndbg.xml"
    r = run_cli("check", bell_report, "--rules", CONFIGS / "rules-strict.yaml", "--junit", junit)
    assert r.returncode == 1
    lines = r.stdout.strip().splitlines()
    # ceil(log2 22) = 5 (any binary tree; the candidates' minimum is 5 too), so <= 4 fails;
    # the reported plan (contact-connected subassemblies) has depth 6, and a proven tree of
    # depth 5 (another strategy's, any subassemblies) meets the bound: exactly 5
    assert any(line.startswith("bell: max_depth: measured 5, expected <= 4")
               for line in lines)
    assert any(line.startswith("bell: max_fingers:") for line in lines)
    # the depth is proven too deep, the grasp only undecided: told apart in the summary
    assert "1 violation(s), 1 undecided (undecided: fail)" in r.stderr
    # the bell's linear tree passes the sweep test: linearizable is proven (no line)
    assert not [line for line in lines if "linearizable" in line]
    root = ET.parse(junit).getroot()
    cases = root.findall(".//testcase")
    assert [c.get("name") for c in cases] == ["bell"]
    failure = cases[0].find("failure")
    assert failure is not None and "max_depth" in failure.get("message")


def test_check_json_and_saved_reports(bell_report, tmp_path):
    r = run_cli("check", bell_report, "--rules", _lenient_bell_rules(tmp_path), "--format",
                "json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["summary"] == {"assemblies": 1, "rules_checked": 9, "violations": 0,
                              "undecided_failed": 0, "failed_assemblies": 0}


def test_check_reads_a_folder_of_reports_without_an_index(bell_report, tmp_path):
    """A folder of saved reports (written by --out, no --out-dir index) is read as reports,
    not analysed as a folder of meshes; a folder that also holds a manifest is a batch of
    assemblies, as before."""
    saved = tmp_path / "saved"
    saved.mkdir()
    shutil.copy(bell_report, saved / "bell.json")
    r = run_cli("check", saved, "--rules", _lenient_bell_rules(tmp_path), "--format", "json")
    assert r.returncode == 0, r.stdout + r.stderr
    assert json.loads(r.stdout)["summary"]["assemblies"] == 1
    shutil.copytree(EX / "meshes", saved / "meshes")
    shutil.copy(EX / "hover.yaml", saved / "hover.yaml")
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules:\n  no_interference: true\n")
    r = run_cli("check", saved, "--rules", rules, "--motion", "translation", "--format", "json")
    assert r.returncode == 0, r.stdout + r.stderr
    assert [o[0]["assembly"] for o in json.loads(r.stdout)["outcomes"]] == ["hover"]


def test_check_reports_a_broken_assembly_and_goes_on(tmp_path):
    batch = tmp_path / "batch"
    shutil.copytree(EX / "meshes", batch / "meshes")
    shutil.copy(EX / "hover.yaml", batch / "hover.yaml")
    (batch / "zz-broken.yaml").write_text("name: x\nparts: [\n")
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules:\n  no_interference: true\n")
    r = run_cli("check", batch, "--rules", rules, "--motion", "translation")
    assert r.returncode == 2
    assert "zz-broken: analysis:" in r.stdout
    assert "1 of 2 assemblies pass" in r.stderr


@pytest.mark.parametrize("text, message", [
    ("rules:\n  max_depht: 3\n", ":2: rules: unknown rule 'max_depht'"),
    ("rules:\n  max_depth: yes\n", ":2: rules: rule 'max_depth' needs a non-negative integer"),
    ("rules:\n  linearizable: 1\n", ":2: rules: rule 'linearizable' needs true or false"),
    ("family: sideways\nrules:\n  linearizable: true\n", ":1: family must be one of"),
    ("rules:\n  linearizable: true\nassemblies:\n  bell:\n    max_depth: -1\n",
     ":5: assemblies.bell: rule 'max_depth' needs a non-negative integer"),
    ("rules:\n  linearizable: true\nrules:\n  prismatic: true\n", ":3: duplicate key 'rules'"),
    ("rules: [\n", "malformed YAML"),
    ("rules: {}\n", "states no rule"),
])
def test_bad_rules_files_are_input_errors(tmp_path, text, message):
    """Each problem is one line naming the file and, where it has one, the line."""
    rules = tmp_path / "rules.yaml"
    rules.write_text(text)
    r = run_cli("check", EX / "hover.yaml", "--rules", rules)
    assert r.returncode == 2
    assert f"{rules}{message}" in r.stderr or (message[0] != ":" and message in r.stderr)
    assert "Traceback" not in r.stderr


def _report(**classes) -> dict:
    return {"schema": "ndbg.report/1", "assembly": {"name": "x", "source": "a/x.yaml"},
            "interferences": [], "warnings": [], "plan": {"found": True},
            "ndbg": {"infinite_translation": {"skipped": True}},
            "classes": {"infinitesimal_translation": classes}}


def test_bounds_decide_max_rules_and_undecided_follows_the_policy():
    rep = _report(min_depth={"value": 4, "exact": True, "lower_bound": 4, "upper_bound": 4})
    # a real tree of depth 6 (infinite translations, search cut); candidates need depth 4
    rep["ndbg"] = {}
    rep["classes"]["infinite_translation"] = {
        "min_depth": {"value": 6, "exact": False, "lower_bound": 4, "upper_bound": 6}}
    strict = RuleSet(rules=(("max_depth", 6), ("max_depth", 5)))
    # a tree of depth 6 exists: <= 6 holds; <= 5 is neither proven nor refuted; <= 3 is
    # refuted by the candidates (every translation algorithm is one)
    got = [evaluate(rep, RuleSet(rules=(("max_depth", k),)))[0] for k in (6, 5, 3)]
    assert [g.ok for g in got] == [True, None, False]
    assert [g.passed for g in got] == [True, False, False]
    assert evaluate(rep, RuleSet(rules=(("max_depth", 5),), undecided="pass"))[0].passed
    assert got[1].measured == "between 4 and 6"
    assert strict.rules_for("x", "a/x.yaml") == {"max_depth": 5}


def test_per_assembly_rules_match_name_or_path_glob(tmp_path):
    rules = tmp_path / "r.yaml"
    rules.write_text("rules:\n  linearizable: true\nassemblies:\n  'fig11-*':\n"
                     "    linearizable: false\n  '*/sub/*.yaml':\n    max_depth: 2\n")
    rs = load_rules(rules)
    assert rs.rules_for("fig11-nonlinear", "x.yaml") == {"linearizable": False}
    assert rs.rules_for("bell", "a/sub/bell.yaml") == {"linearizable": True, "max_depth": 2}
    rep = _report(linearizable={"value": False}, one_handed_monotone={"value": True})
    (o,) = evaluate(rep, RuleSet(rules=(("linearizable", True),)))
    assert o.ok is False and o.line().startswith("x: linearizable: measured false, expected "
                                                 "true")
    (h,) = evaluate(rep, RuleSet(rules=(("max_hands", 1),)))
    assert h.ok is None  # a candidate (infinitesimal) 1-handed monotone proves no hand count


def _fig11_without_flange(folder: Path) -> Path:
    """Fig. 11 with the hook's flange over the lid cut off: the lid then lifts off first, the
    hook next, the slider last, so the product becomes linearizable."""
    sys.path.insert(0, str(EX))
    try:
        from build import box
    finally:
        sys.path.pop(0)
    shutil.copytree(EX / "meshes" / "fig11-nonlinear", folder / "meshes" / "fig11-nonlinear")
    shutil.copy(EX / "fig11-nonlinear.yaml", folder / "fig11-nonlinear.yaml")
    bump = box(15, -4, 12, 25, 4, 14)
    hook = (box(0, -10, 12, 40, 10, 20) - bump + box(40, -8, 12, 46, 8, 30)).to_mesh()
    trimesh.Trimesh(hook.vert_properties[:, :3], hook.tri_verts).export(
        folder / "meshes" / "fig11-nonlinear" / "hook.stl")
    return folder / "fig11-nonlinear.yaml"


def test_diff_flags_a_lost_class_when_a_part_changes(tmp_path):
    old_manifest = _fig11_without_flange(tmp_path / "old")
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    for src, dst in ((old_manifest, old), (EX / "fig11-nonlinear.yaml", new)):
        r = run_cli("analyze", src, "--motion", "translation", "--format", "json", "--out", dst)
        assert r.returncode == 0, r.stderr
    assert json.loads(old.read_text())["classes"]["infinitesimal_translation"][
        "linearizable"]["value"] is True
    r = run_cli("diff", old, new)
    assert r.returncode == 1
    lines = r.stdout.splitlines()
    assert ("fig11-nonlinear: worse: classes.infinitesimal_translation.linearizable: "
            "true -> false (class lost: linearizable)") in lines
    assert any(line.startswith("fig11-nonlinear: changed: parts.modified: none -> [hook]")
               for line in lines)
    back = run_cli("diff", new, old, "--format", "json")
    assert back.returncode == 0  # the reverse change only made things better
    grades = {c["what"]: c["grade"] for c in json.loads(back.stdout)["changes"]}
    assert grades["classes.infinitesimal_translation.linearizable"] == "better"
    assert run_cli("diff", new, old, "--fail-on", "any").returncode == 1
    assert run_cli("diff", old, new, "--fail-on", "never").returncode == 0
    same = run_cli("diff", new, new)
    assert same.returncode == 0 and "no change" in same.stdout


def test_diff_of_batches_matches_by_name_and_rejects_non_reports(tmp_path):
    a = tmp_path / "a.jsonl"
    r = run_cli("analyze", EX / "hover.yaml", EX / "stack.yaml", "--format", "jsonl",
                "--motion", "translation", "--jobs", "1")
    a.write_text(r.stdout)
    b = tmp_path / "b.jsonl"
    b.write_text(r.stdout.splitlines()[1] + "\n")
    got = run_cli("diff", a, b)
    assert got.returncode == 0 and "hover: changed: assembly: present -> none (removed)" \
        in got.stdout
    junk = tmp_path / "junk.json"
    junk.write_text('{"hello": 1}')
    bad = run_cli("diff", junk, b)
    assert bad.returncode == 2 and "not an ndbg report" in bad.stderr


def test_an_assembly_that_stops_analysing_is_worse_even_when_renamed(tmp_path):
    proj = tmp_path / "proj"
    shutil.copytree(EX / "meshes" / "hover", proj / "meshes" / "hover")
    design = proj / "design.yaml"
    design.write_text((EX / "hover.yaml").read_text().replace("name: hover", "name: hover-mk2"))
    old, new = tmp_path / "old.json", tmp_path / "new.json"
    assert run_cli("analyze", design, "--motion", "translation", "--format", "json",
                   "--out", old).returncode == 0
    design.write_text("name: hover-mk2\nparts: [\n")
    run_cli("analyze", design, "--format", "json", "--out", new)
    r = run_cli("diff", old, new)
    assert r.returncode == 1 and "hover-mk2: worse: analysis: ok -> error" in r.stdout
    empty = tmp_path / "empty.jsonl"
    empty.write_text("")
    assert run_cli("diff", old, empty).returncode == 2
    c = run_cli("check", empty, "--rules", CONFIGS / "rules-bell.yaml")
    assert c.returncode == 2 and "no reports" in c.stderr


def test_bounds_are_not_graded_and_greedy_fingers_are_only_upper_bounds(bell_report, tmp_path):
    doc = json.loads(bell_report.read_text())
    fam = doc["classes"]["infinitesimal_translation"]
    worse = json.loads(json.dumps(doc))
    worse["classes"]["infinitesimal_translation"]["min_depth"] = {
        "value": fam["min_depth"]["value"] + 1, "exact": False, "lower_bound": 5}
    changed = tmp_path / "changed.json"
    changed.write_text(json.dumps(worse))
    r = run_cli("diff", bell_report, changed, "--format", "json")
    assert r.returncode == 0  # an unproven bound moving is "changed", not "worse"
    grades = {c["what"]: c["grade"] for c in json.loads(r.stdout)["changes"]}
    assert grades["classes.infinitesimal_translation.min_depth"] == "changed"
    rules = tmp_path / "r.yaml"
    fingers = fam["grasp"]["value"]
    rules.write_text(f"undecided: pass\nrules:\n  max_fingers: {fingers - 1}\n")
    assert run_cli("check", bell_report, "--rules", rules).returncode == 0
    rules.write_text(f"rules:\n  max_fingers: {fingers}\n")
    assert run_cli("check", bell_report, "--rules", rules).returncode == 0


def test_check_reads_an_out_dir_of_saved_reports(tmp_path):
    out = tmp_path / "reports"
    r = run_cli("analyze", EX / "hover.yaml", EX / "stack.yaml", "--motion", "translation",
                "--out-dir", out, "--jobs", "1")
    assert r.returncode == 0, r.stderr
    rules = tmp_path / "r.yaml"
    rules.write_text("undecided: pass\nrules:\n  linearizable: true\n  max_depth: 1\n")
    c = run_cli("check", out, "--rules", rules)
    # hover (3 parts) and stack (5 parts) need depth >= 2 and >= 3: both fail max_depth only
    # (linearizable is only a candidate with infinitesimal translations: undecided, passed)
    assert c.returncode == 1
    assert sorted(line.split(":")[0] for line in c.stdout.splitlines()) == ["hover", "stack"]
    assert all(": max_depth: measured" in line for line in c.stdout.splitlines())
    # a report an earlier run left in the folder is not read: only those index.json names
    (out / "old.json").write_text((out / "hover.json").read_text().replace(
        '"name": "hover"', '"name": "old"'))
    c = run_cli("check", out, "--rules", rules)
    assert sorted(line.split(":")[0] for line in c.stdout.splitlines()) == ["hover", "stack"]


def test_read_reports_of_a_folder_follows_its_index(tmp_path):
    from ndbg_cli.core.errors import InputError
    from ndbg_cli.report.diff import read_reports

    rep = {"schema": "ndbg.report/1", "assembly": {"name": "a"}, "classes": {}}
    (tmp_path / "a.json").write_text(json.dumps(rep))
    (tmp_path / "b.json").write_text(json.dumps({**rep, "assembly": {"name": "b"}}))
    assert sorted(read_reports(tmp_path)) == ["a", "b"]  # no index: every *.json
    (tmp_path / "index.json").write_text(json.dumps({"reports": [{"report": "a.json"}]}))
    assert sorted(read_reports(tmp_path)) == ["a"]  # b.json is an earlier run's
    (tmp_path / "index.json").write_text(json.dumps({"reports": [{"report": "c.json"}]}))
    with pytest.raises(InputError, match="names c.json, which is missing"):
        read_reports(tmp_path)
    (tmp_path / "index.json").write_text(json.dumps({"reports": [{"name": "a"}]}))
    assert sorted(read_reports(tmp_path)) == ["a", "b"]  # an index without file names
