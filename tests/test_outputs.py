"""Where ``ndbg analyze`` writes: ``--out`` (a file, or a folder when it ends with a slash or
names one), ``--out-dir``; places that cannot be written and inputs that would be replaced
are input errors (exit code 2, one line naming the path as given), found before analysing."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
FAST = ["--motion", "translation", "--no-cache", "-q"]


@pytest.fixture()
def hover(tmp_path) -> Path:
    """A copy of the hover example (manifest and meshes) in ``tmp_path``."""
    shutil.copytree(EX / "meshes" / "hover", tmp_path / "meshes" / "hover")
    shutil.copy(EX / "hover.yaml", tmp_path / "hover.yaml")
    return tmp_path / "hover.yaml"


def test_jsonl_to_a_file(hover, tmp_path):
    r = run_cli("analyze", hover, "--format", "jsonl", "--out", tmp_path / "o.json", *FAST)
    assert r.returncode == 0, r.stderr
    assert r.stdout == ""
    lines = (tmp_path / "o.json").read_text().splitlines()
    assert len(lines) == 1 and json.loads(lines[0])["assembly"]["name"] == "hover"


@pytest.mark.parametrize("slash", ["/", ""])
def test_out_naming_a_folder_writes_into_it(hover, tmp_path, slash):
    """A trailing slash names a folder (made if missing); so does an existing folder."""
    folder = tmp_path / "new"
    if not slash:
        folder.mkdir()
    r = run_cli("analyze", hover, "--out", f"{folder}{slash}", *FAST)
    assert r.returncode == 0, r.stderr
    assert folder.is_dir()
    assert json.loads((folder / "hover.json").read_text())["assembly"]["name"] == "hover"
    assert (folder / "index.json").is_file()


def _cases(tmp: Path) -> dict[str, tuple[list[str], str, str]]:
    """name: (output options, the path the message names, the reason it gives)."""
    (tmp / "afile").write_text("x")
    cases = {
        "out-dir-under-a-file": (["--out-dir", f"{tmp}/afile/sub"], f"{tmp}/afile/sub",
                                 "Not a directory"),
        "out-under-a-file": (["--out", f"{tmp}/afile/r.json"], f"{tmp}/afile/r.json",
                             "is not a directory"),
        "out-folder-is-a-file": (["--out", f"{tmp}/afile/"], f"{tmp}/afile/",
                                 "is not a directory"),
        "out-over-the-manifest": (["--out", f"{tmp}/hover.yaml"], f"{tmp}/hover.yaml",
                                  "is an input of this run"),
        "out-over-a-mesh": (["--out", f"{tmp}/meshes/hover/base.stl"],
                            f"{tmp}/meshes/hover/base.stl", "is an input of this run"),
    }
    if Path("/proc/self").is_dir():  # nothing can be created in /proc, not even by root
        cases["out-dir-in-proc"] = (["--out-dir", "/proc/ndbg-x"], "/proc/ndbg-x",
                                    "No such file or directory")
        cases["out-in-proc"] = (["--out", "/proc/ndbg-x.json"], "/proc/ndbg-x.json",
                                "No such file or directory")
    return cases


CASE_NAMES = ["out-dir-under-a-file", "out-under-a-file", "out-folder-is-a-file",
              "out-over-the-manifest", "out-over-a-mesh", "out-dir-in-proc", "out-in-proc"]


@pytest.mark.parametrize("name", CASE_NAMES)
def test_unwritable_output_is_an_input_error(hover, tmp_path, name):
    cases = _cases(tmp_path)
    if name not in cases:
        pytest.skip("no /proc")
    args, where, reason = cases[name]
    before = hover.read_bytes()
    r = run_cli("analyze", hover, *args, *FAST)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]  # one line
    assert r.stderr.startswith(f"ndbg: error: cannot write {where}: ")
    assert reason in r.stderr and "internal error" not in r.stderr
    assert ".tmp" not in r.stderr  # names the user's path, not a temporary file
    assert hover.read_bytes() == before


def _mode(path: Path) -> int:
    return path.stat().st_mode & 0o777


def test_reports_get_the_permissions_of_a_plain_open(hover, tmp_path):
    """0o666 less the umask (the temporary file write_atomic renames is 0600), or an existing
    file's own; for --out, --out-dir's reports and index.json, and cache entries."""
    import os

    from ndbg_cli.core.files import write_atomic

    old = os.umask(0o027)
    try:
        write_atomic(tmp_path / "w.json", "{}\n")
        with open(tmp_path / "plain.json", "w") as fh:
            fh.write("{}\n")
        assert _mode(tmp_path / "w.json") == _mode(tmp_path / "plain.json") == 0o640
        os.chmod(tmp_path / "w.json", 0o604)
        write_atomic(tmp_path / "w.json", "{}\n")
        assert _mode(tmp_path / "w.json") == 0o604
        os.umask(0o002)  # inherited by the CLI
        r = run_cli("analyze", hover, "--out", tmp_path / "one.json", "--motion", "translation",
                    "--cache", tmp_path / "cache", "-q")
        assert r.returncode == 0, r.stderr
        r = run_cli("analyze", hover, "--out-dir", tmp_path / "out", *FAST)
        assert r.returncode == 0, r.stderr
    finally:
        os.umask(old)
    written = [tmp_path / "one.json", tmp_path / "out" / "hover.json",
               tmp_path / "out" / "index.json"]
    entries = [p for p in (tmp_path / "cache").rglob("*") if p.is_file()]
    assert entries
    assert {p: _mode(p) for p in written + entries} == {p: 0o664 for p in written + entries}


def test_search_budget_is_counted_work_not_the_clock(tmp_path):
    # sandwich-5's AND/OR graph needs more than 50 work units: the cut is named in the plan's
    # notes, and a counted budget gives the same bytes on every run (a clock would not)
    args = ("analyze", EX / "fig2-sandwich-5.yaml", "--format", "json", "--max-work", "50",
            *FAST)
    first, second = run_cli(*args), run_cli(*args)
    assert first.returncode == 0, first.stderr
    assert first.stdout == second.stdout
    notes = json.loads(first.stdout)["plan"]["notes"]
    assert notes[0].startswith("AND/OR graph cut by the work budget (50 units)")
    # a connected search only cut by the budget does not claim there is no connected tree
    assert all("found within the budget" in n for n in notes
               if n.startswith("no tree with connected"))
    # the same budget from a config file; a wall-clock limit stays available, opt-in
    cfg = tmp_path / "c.yaml"
    cfg.write_text("max_work: 50\ntime_limit: null\n")
    third = run_cli("analyze", EX / "fig2-sandwich-5.yaml", "--format", "json", "--config",
                    cfg, *FAST)
    assert third.returncode == 0, third.stderr
    assert third.stdout == first.stdout
    cfg.write_text("max_work: 0\n")
    bad = run_cli("analyze", EX / "fig2-sandwich-5.yaml", "--config", cfg, *FAST)
    assert bad.returncode == 2 and "max_work" in bad.stderr


def test_a_summary_report_keeps_every_answer_and_cuts_the_long_lists(tmp_path):
    """``--detail summary`` (the default) against ``--detail full`` on the bell: the same plan,
    classes, interferences, warnings and AND/OR counts; contacts without their points but
    with their count; NDBG sections without regions and DBGs but with their counts; at most
    20 partitionings per family; valid against the schema; and much smaller."""
    import json

    from ndbg_cli.report.detail import SUMMARY_ITEMS
    from ndbg_cli.report.document import validate_report

    from helpers import run_cli

    path = ROOT / "assemblies" / "bell.yaml"
    got = {}
    for level in ("summary", "full"):
        out = tmp_path / f"{level}.json"
        r = run_cli("analyze", str(path), "--no-cache", "--detail", level, "--out", str(out))
        assert r.returncode == 0, r.stderr
        got[level] = json.loads(out.read_text())
        validate_report(got[level])
    short, full = got["summary"], got["full"]
    for key in ("plan", "classes", "interferences", "warnings", "andor", "assembly"):
        assert short[key] == full[key], key
    assert [{k: v for k, v in c.items() if k not in ("points", "point_normals")}
            for c in full["contacts"]] == [{k: v for k, v in c.items() if k != "point_count"}
                                           for c in short["contacts"]]
    assert [c["point_count"] for c in short["contacts"]] == [len(c["points"])
                                                             for c in full["contacts"]]
    for fam, sec in full["ndbg"].items():
        kept = short["ndbg"][fam]
        assert "dbgs" not in kept and "region_list" not in kept
        assert {k: v for k, v in sec.items() if k not in ("dbgs", "region_list",
                "suggested_motions", "candidates")} == {
            k: v for k, v in kept.items() if k not in ("suggested_motions", "candidates")}
    fams = {p["family"] for p in full["partitionings"]}
    for fam in fams:
        listed = [p for p in full["partitionings"] if p["family"] == fam]
        assert [p for p in short["partitionings"] if p["family"] == fam] == \
            listed[:SUMMARY_ITEMS]
    assert short["options"]["detail"]["level"] == "summary"
    assert len(json.dumps(short)) < len(json.dumps(full)) / 3


def test_a_report_built_without_contact_points_summarizes_and_renders_the_same():
    """``Options.contact_points`` off (the CLI's ``--detail summary`` without pictures): each
    contact record holds its point count in place of its points, and the summary written
    and the text report are the full report's, to the byte (the dowels' curved contacts
    hold many points)."""
    import ndbg_cli
    from ndbg_cli.core.options import Options
    from ndbg_cli.report.detail import summarize
    from ndbg_cli.report.document import dumps
    from ndbg_cli.report.text import render

    asm = ndbg_cli.load(ROOT / "assemblies" / "dowels.yaml")
    full = ndbg_cli.analyze(asm)
    lean = ndbg_cli.analyze(asm, Options(contact_points=False))
    assert full["contacts"] and all("points" not in c for c in lean["contacts"])
    assert [c["point_count"] for c in lean["contacts"]] == [len(c["points"])
                                                            for c in full["contacts"]]
    assert sum(c["point_count"] for c in lean["contacts"]) > len(lean["contacts"])
    assert dumps(summarize(lean)) == dumps(summarize(full))
    assert render(lean) == render(full)
