"""What a person running ndbg sees on stderr, and where ``ndbg convert`` writes: warnings
summarised one line each when the report does not go to stdout as text; an unwritable
``convert --out`` is the one-line input error ``analyze --out`` gives."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from helpers import run_cli, write_two_boxes

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"


@pytest.fixture()
def hover(tmp_path) -> Path:
    """A copy of the hover example (manifest and meshes) in ``tmp_path``."""
    shutil.copytree(EX / "meshes" / "hover", tmp_path / "meshes" / "hover")
    shutil.copy(EX / "hover.yaml", tmp_path / "hover.yaml")
    return tmp_path / "hover.yaml"


CONVERT_CASES = {  # name: (--out relative to tmp, or absolute; the reason the message gives)
    "folder-under-a-file": ("afile/proj", "Not a directory"),
    "folder-is-a-file": ("afile", "afile is not a directory"),
    "meshes-is-a-file": ("proj", "proj/meshes is not a directory"),
    "in-proc": ("/proc/ndbg-x", "No such file or directory"),
}


@pytest.mark.parametrize("name", sorted(CONVERT_CASES))
def test_convert_to_an_unwritable_folder_is_an_input_error(hover, tmp_path, name):
    """Was: exit 3 ('internal error: NotADirectoryError' or 'FileNotFoundError'); now the
    one-line 'cannot write OUT: REASON' (exit 2) that analyze --out gives."""
    rel, reason = CONVERT_CASES[name]
    if rel.startswith("/proc") and not Path("/proc/self").is_dir():
        pytest.skip("no /proc")
    (tmp_path / "afile").write_text("x")
    (tmp_path / "proj").mkdir()
    (tmp_path / "proj" / "meshes").write_text("x")
    out = rel if rel.startswith("/") else str(tmp_path / rel)
    r = run_cli("convert", hover.parent / "meshes" / "hover" / "base.stl", "--out", out)
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]  # one line
    assert r.stderr.startswith(f"ndbg: error: cannot write {out}: ")
    assert reason in r.stderr and "internal error" not in r.stderr
    assert not list(tmp_path.rglob("*.tmp"))


@pytest.fixture()
def overlapping(tmp_path) -> Path:
    """Two 10 mm cubes, the second sunk 5 mm into the first: one interference warning."""
    path = write_two_boxes(tmp_path / "src")
    path.write_text(path.read_text().replace("[0, 0, 10]", "[0, 0, 5]"))
    return path


@pytest.mark.parametrize("where", ["out", "out-dir", "json", "jsonl", "text-out"])
def test_warnings_are_summarised_on_stderr(overlapping, tmp_path, where):
    """Was: a report written to a file, a folder or as JSON kept its warnings to itself;
    stderr was empty. Now one line each on stderr (never stdout)."""
    args = {"out": ["--out", tmp_path / "r.json"], "out-dir": ["--out-dir", tmp_path / "o"],
            "json": ["--format", "json"], "jsonl": ["--format", "jsonl"],
            "text-out": ["--out", tmp_path / "r.txt"]}[where]
    r = run_cli("analyze", overlapping, *args, "--motion", "translation", "--no-cache")
    assert r.returncode == 0, r.stderr
    lines = r.stderr.splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("ndbg: warning: two: parts 'a' and 'b' interpenetrate")
    if where in ("json", "jsonl"):
        assert json.loads(r.stdout)["warnings"][0]["code"] == "interference"
    else:
        assert r.stdout == ""


def test_no_warning_summary_when_quiet_or_in_the_text_on_stdout(overlapping, tmp_path):
    quiet = run_cli("analyze", overlapping, "--out", tmp_path / "r.json", "--motion",
                    "translation", "--no-cache", "-q")
    assert quiet.returncode == 0 and quiet.stderr == ""
    text = run_cli("analyze", overlapping, "--motion", "translation", "--no-cache")
    assert text.returncode == 0 and text.stderr == ""
    assert "interpenetrate" in text.stdout


def test_warning_summary_is_capped_per_assembly():
    from ndbg_cli.cli.analyze import MAX_WARNING_LINES, _warning_lines

    report = {"assembly": {"name": "x", "source": "x.yaml"},
              "warnings": [{"message": f"w{k}", "part": None} for k in range(25)]}
    lines = _warning_lines(report)
    assert len(lines) == MAX_WARNING_LINES + 1
    assert lines[-1] == "ndbg: warning: x: ... and 5 more (see the report)"


def test_contacts_json_warns_on_stderr_too(overlapping):
    """Was: 'ndbg contacts' printed its interference warnings on stderr for text only."""
    r = run_cli("contacts", overlapping, "--format", "json")
    assert r.returncode == 0, r.stderr
    assert r.stderr.startswith("ndbg: warning: parts 'a' and 'b' interpenetrate")
    assert json.loads(r.stdout)["warnings"][0]["code"] == "interference"
    assert run_cli("contacts", overlapping, "--format", "json", "-q").stderr == ""


def test_out_file_format_follows_its_suffix_unless_given(hover, tmp_path):
    base = ("analyze", hover, "--motion", "translation", "--no-cache", "-q")
    assert run_cli(*base, "--out", tmp_path / "r.json").returncode == 0
    assert json.loads((tmp_path / "r.json").read_text())["assembly"]["name"] == "hover"
    assert run_cli(*base, "--out", tmp_path / "r.jsonl").returncode == 0
    (line,) = (tmp_path / "r.jsonl").read_text().splitlines()
    assert json.loads(line)["assembly"]["name"] == "hover"
    # an explicit --format wins; other suffixes keep the default text
    assert run_cli(*base, "--out", tmp_path / "t.json", "--format", "text").returncode == 0
    assert (tmp_path / "t.json").read_text().startswith("assembly hover")
    assert run_cli(*base, "--out", tmp_path / "r.txt").returncode == 0
    assert (tmp_path / "r.txt").read_text().startswith("assembly hover")


def test_convert_a_single_mesh_file_names_its_mesh_once(tmp_path):
    shutil.copy(EX / "meshes" / "hover" / "puck.stl", tmp_path / "b.stl")
    r = run_cli("convert", tmp_path / "b.stl", "--out", tmp_path / "out")
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in (tmp_path / "out" / "meshes").iterdir()) == ["b.stl"]
    r = run_cli("analyze", tmp_path / "out" / "b.yaml", "--format", "json", "--motion",
                "translation", "--no-cache", "-q")
    assert r.returncode == 0 and json.loads(r.stdout)["assembly"]["parts"][0]["id"] == "b.stl"



def test_the_program_ends_cleanly_on_a_closed_pipe_and_on_ctrl_c(tmp_path):
    """``python -m ndbg_cli`` ends through ``cli.main.run`` (exit functions, flush, then
    ``os._exit``): a reader that stops after the first bytes gets exit 0 and no traceback;
    SIGINT in the middle of an analysis (after the warning its NDBG stage prints, a 96-part
    rack of ``assemblies/build.py``) gives 130, "ndbg: aborted" and no report."""
    import importlib.util
    import os
    import signal
    import subprocess
    import sys

    cmd = [sys.executable, "-m", "ndbg_cli", "analyze"]
    proc = subprocess.Popen([*cmd, str(EX / "bell.yaml")], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    proc.stdout.read(16)
    proc.stdout.close()
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 0 and "Traceback" not in err
    spec = importlib.util.spec_from_file_location("assemblies_build", EX / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    rack = tmp_path / f"{build.rack(tmp_path, 20)}.yaml"
    out = tmp_path / "report.json"
    proc = subprocess.Popen([*cmd, str(rack), "--no-cache", "--format", "json", "--out",
                             str(out)], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True)
    first = proc.stderr.readline().decode()  # the infinite NDBG skipped: the plan is next
    assert "skipped" in first, first
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and "ndbg: aborted" in err.decode(), err.decode()
    assert not out.exists()
