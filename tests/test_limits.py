"""Bounded resources (issue 34): an assembly with more triangles than ``--max-triangles``
(default ``MAX_TRIANGLES``, 5 million) fails as its files are read, before any analysis,
with one line naming the limit and the flag (exit 2); in a batch it is an error record and
the others complete."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import trimesh

import ndbg_cli
from ndbg_cli.core.constants import MAX_TRIANGLES
from ndbg_cli.core.errors import InputError
from ndbg_cli.core.options import Options
from ndbg_cli.report.document import validate_report

from helpers import box, run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
FAST = ["--motion", "translation", "--no-cache", "-q"]
HOVER = 64  # triangles of the hover example (12 + 12 + 40)


@pytest.fixture()
def folder(tmp_path) -> Path:
    """``assemblies/`` in ``tmp_path``: hover (64 triangles), the 2D example (none), and
    ``ball.yaml``, a generated sphere on a block (1,280 + 12 triangles)."""
    a = tmp_path / "assemblies"
    shutil.copytree(EX / "meshes" / "hover", a / "meshes" / "hover")
    for name in ("hover.yaml", "fig3-2d.yaml"):
        shutil.copy(EX / name, a / name)
    ball = trimesh.creation.icosphere(subdivisions=3, radius=5.0)
    ball.apply_translation((5, 5, 15))
    ball.export(a / "meshes" / "ball.stl")
    box((0, 0, 0), (10, 10, 10)).export(a / "meshes" / "block.stl")
    (a / "ball.yaml").write_text("name: ball\nparts:\n  - id: block\n    mesh: meshes/block.stl\n"
                                 "  - id: ball\n    mesh: meshes/ball.stl\n")
    return tmp_path


def _one_line(r, message: str) -> None:
    assert r.returncode == 2, r.stderr[-2000:]
    assert r.stderr == f"ndbg: error: {message}\n"


def test_above_the_limit_fails_at_the_limit_passes(folder):
    """One triangle over: exit 2, one line naming the count, the limit and the flag; at
    the limit: analysed."""
    r = run_cli("analyze", "assemblies/hover.yaml", "--max-triangles", HOVER - 1, *FAST,
                cwd=folder)
    _one_line(r, f"assemblies/hover.yaml: {HOVER} triangles exceed the limit of {HOVER - 1} "
                 "(raise it with --max-triangles)")
    r = run_cli("analyze", "assemblies/hover.yaml", "--max-triangles", HOVER, "--format",
                "json", *FAST, cwd=folder)
    assert r.returncode == 0, r.stderr[-2000:]
    assert json.loads(r.stdout)["assembly"]["triangles"] == HOVER


def test_reading_stops_at_the_part_that_passes_the_limit(folder):
    """A manifest stops being read at the part that passes the limit (and says so); a
    large generated assembly gives thousands separators."""
    r = run_cli("analyze", "assemblies/hover.yaml", "--max-triangles", 20, *FAST, cwd=folder)
    _one_line(r, "assemblies/hover.yaml: 24 triangles in its first 2 of 3 parts exceed the "
                 "limit of 20 (raise it with --max-triangles)")
    r = run_cli("analyze", "assemblies/ball.yaml", "--max-triangles", 1000, *FAST, cwd=folder)
    _one_line(r, "assemblies/ball.yaml: 1,292 triangles exceed the limit of 1,000 (raise it "
                 "with --max-triangles)")


def test_model_files_folders_and_the_other_commands(folder):
    """A model file and a folder of meshes count their bodies and files; ``check`` and the
    commands that load take the flag too."""
    a = folder / "assemblies"
    scene = trimesh.Scene()
    scene.add_geometry(box((0, 0, 0), (1, 1, 1)), node_name="one")
    scene.add_geometry(box((0, 0, 1), (1, 1, 2)), node_name="two")
    scene.export(a / "two.obj")
    r = run_cli("analyze", "assemblies/two.obj", "--max-triangles", 23, *FAST, cwd=folder)
    _one_line(r, "assemblies/two.obj: 24 triangles exceed the limit of 23 (raise it with "
                 "--max-triangles)")
    r = run_cli("analyze", "assemblies/meshes/hover", "--max-triangles", 63, *FAST, cwd=folder)
    assert r.returncode == 2 and "exceed the limit of 63" in r.stderr
    r = run_cli("check", "--self", "assemblies/hover.yaml", "--max-triangles", 63, *FAST,
                cwd=folder)
    assert r.returncode == 2 and "exceed the limit of 63 (raise it with --max-triangles)" \
        in r.stdout  # check's line for an assembly it could not analyse
    for cmd in (["contacts"], ["query", "--direction", "0,0,1"], ["remove"]):
        args = [*cmd, "assemblies/hover.yaml", *(["puck"] if cmd == ["remove"] else [])]
        r = run_cli(*args, "--max-triangles", 63, "-q", cwd=folder)
        _one_line(r, "assemblies/hover.yaml: 64 triangles exceed the limit of 63 (raise it "
                     "with --max-triangles)")


def test_a_batch_records_the_oversized_one_and_reports_the_others(folder):
    r = run_cli("analyze", "assemblies/", "--max-triangles", 100, "--format", "json", *FAST,
                cwd=folder)
    assert r.returncode == 2, r.stderr[-2000:]
    assert "Traceback" not in r.stderr
    doc = json.loads(r.stdout)
    validate_report(doc)
    assert doc["summary"] == {"assemblies": 3, "ok": 2, "errors": 1}
    bad = [x for x in doc["reports"] if "error" in x]
    assert bad == [{
        "schema": "ndbg.report/1", "tool": doc["tool"], "source": "assemblies/ball.yaml",
        "error": {"code": 2, "kind": "InputError", "file": "assemblies/ball.yaml",
                  "part": None, "line": None,
                  "message": "assemblies/ball.yaml: 1,292 triangles exceed the limit of 100 "
                             "(raise it with --max-triangles)"}}]
    assert sorted(x["assembly"]["name"] for x in doc["reports"] if "assembly" in x) == \
        ["fig3-2d", "hover"]


def test_config_file_and_flag(folder):
    """``max_triangles`` in a config file; the flag wins; ``null`` is no limit."""
    (folder / "low.yaml").write_text("max_triangles: 63\n")
    r = run_cli("analyze", "assemblies/hover.yaml", "--config", "low.yaml", *FAST, cwd=folder)
    assert r.returncode == 2 and "limit of 63" in r.stderr
    r = run_cli("analyze", "assemblies/hover.yaml", "--config", "low.yaml", "--max-triangles",
                64, *FAST, cwd=folder)
    assert r.returncode == 0, r.stderr[-2000:]
    (folder / "bad.yaml").write_text("max_triangles: 0\n")
    r = run_cli("analyze", "assemblies/hover.yaml", "--config", "bad.yaml", *FAST, cwd=folder)
    assert r.returncode == 2 and "max_triangles" in r.stderr and "Traceback" not in r.stderr


def test_library(folder):
    """``load(max_triangles=)``, with the default from ``MAX_TRIANGLES``; ``None``: none."""
    assert MAX_TRIANGLES == 5_000_000 == Options().max_triangles
    path = folder / "assemblies" / "hover.yaml"
    with pytest.raises(InputError, match=r"64 triangles exceed the limit of 63 \(raise"):
        ndbg_cli.load(path, max_triangles=63)
    assert len(ndbg_cli.load(path, max_triangles=None).parts) == 3
    for bad in (0, 2.5, True):
        with pytest.raises(InputError, match="max triangles must be an integer >= 1"):
            ndbg_cli.load(path, max_triangles=bad)
