"""Portable reports (issue 34): the paths a report writes (the assembly's ``source``, each
part's, the ``file`` of warnings and errors, the batch index, the text output) are relative
to the current folder, or to ``--root DIR``, with ``/`` separators; so the same checkout
copied to two folders and analysed from each root gives byte-identical reports. A path
outside the root stays absolute."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

import ndbg_cli
from ndbg_cli.core.options import Options
from ndbg_cli.core.paths import portable, portable_source
from ndbg_cli.report.document import validate_report

from helpers import box, run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
FAST = ["--motion", "translation", "--no-cache", "-q"]


def _obj(path: Path) -> None:
    """A model file of two bodies (``o lower``, ``o upper``), the upper one open (a face
    missing): its not-watertight warning names the file and the body."""
    lines, base = [], 0
    for name, lo, open_ in (("lower", 0.0, False), ("upper", 10.0, True)):
        m = box((0, 0, lo), (10, 10, lo + 10))
        faces = m.faces[:-2] if open_ else m.faces
        lines.append(f"o {name}")
        lines += [f"v {x:g} {y:g} {z:g}" for x, y, z in m.vertices]
        lines += [f"f {a + base + 1} {b + base + 1} {c + base + 1}" for a, b, c in faces]
        base += len(m.vertices)
    path.write_text("\n".join(lines) + "\n")


def checkout(folder: Path) -> Path:
    """A small checkout in ``folder``: ``assemblies/`` with two examples (a manifest of STL
    meshes, a 2D one), a broken manifest, and a multi-body OBJ model file."""
    a = folder / "assemblies"
    shutil.copytree(EX / "meshes" / "hover", a / "meshes" / "hover")
    for name in ("hover.yaml", "fig3-2d.yaml"):
        shutil.copy(EX / name, a / name)
    (a / "broken.yaml").write_text("name: broken\nparts: 5\n")
    (a / "models").mkdir()
    _obj(a / "models" / "two.obj")
    return folder


@pytest.fixture()
def copies(tmp_path) -> tuple[Path, Path]:
    """The same checkout in two folders (at different depths)."""
    return checkout(tmp_path / "one"), checkout(tmp_path / "deeper" / "two")


def _same(copies, *args: str, code: int = 0, root: bool = False) -> str:
    """Run ``ndbg ARGS`` from each copy's root (or, with ``root``, from the folder above
    with ``--root COPY`` and the inputs' absolute paths); assert the two outputs are the
    same, and return it."""
    outs = []
    for c in copies:
        if root:
            argv = [str(c / a) if a.startswith("assemblies") else a for a in args]
            r = run_cli(*argv, "--root", c, cwd=c.parent)
        else:
            r = run_cli(*args, cwd=c)
        assert r.returncode == code, r.stderr[-2000:]
        assert str(c) not in r.stdout
        outs.append(r.stdout)
    assert outs[0] == outs[1]
    return outs[0]


def test_batch_json_is_byte_identical_from_two_folders(copies):
    """The batch (reports and the broken manifest's error record) names its files
    relative to the root; same bytes from both copies."""
    out = _same(copies, "analyze", "assemblies/", "--format", "json", *FAST, code=2)
    doc = json.loads(out)
    validate_report(doc)
    by = {r.get("source") or r["assembly"]["source"]: r for r in doc["reports"]}
    assert sorted(by) == ["assemblies/broken.yaml", "assemblies/fig3-2d.yaml",
                          "assemblies/hover.yaml"]
    hover = by["assemblies/hover.yaml"]["assembly"]
    assert [p["source"] for p in hover["parts"]] == [
        f"assemblies/meshes/hover/{p}.stl" for p in ("base", "puck", "bridge")]
    err = by["assemblies/broken.yaml"]["error"]
    assert err["file"] == "assemblies/broken.yaml"
    assert err["message"] == "assemblies/broken.yaml:2: parts: 5 is not of type 'array'"


def test_model_file_parts_and_warnings(copies):
    """A model file's parts are ``FILE#NODE``, its warnings name that file: relative."""
    out = _same(copies, "analyze", "assemblies/models/two.obj", "--format", "json", *FAST)
    rep = json.loads(out)
    validate_report(rep)
    assert rep["assembly"]["source"] == "assemblies/models/two.obj"
    assert [p["source"] for p in rep["assembly"]["parts"]] == [
        "assemblies/models/two.obj#lower", "assemblies/models/two.obj#upper"]
    files = {w["file"] for w in rep["warnings"] if w["code"] == "not-watertight"}
    assert files == {"assemblies/models/two.obj#upper"}


def test_out_dir_text_and_check_are_identical(copies):
    """--out-dir (each report and index.json), the text output and ``check --self``."""
    for c in copies:
        r = run_cli("analyze", "assemblies/", "--out-dir", "reports", *FAST, cwd=c)
        assert r.returncode == 2, r.stderr[-2000:]
    one, two = (sorted((c / "reports").iterdir()) for c in copies)
    assert [p.name for p in one] == ["broken.json", "fig3-2d.json", "hover.json", "index.json"]
    for a, b in zip(one, two):
        assert a.read_bytes() == b.read_bytes(), a.name
    index = json.loads((copies[0] / "reports" / "index.json").read_text())
    assert [e["source"] for e in index["reports"]] == [
        "assemblies/broken.yaml", "assemblies/fig3-2d.yaml", "assemblies/hover.yaml"]
    text = _same(copies, "analyze", "assemblies/hover.yaml", *FAST)
    assert text.splitlines()[0] == "assembly hover  (assemblies/hover.yaml)"
    for c in copies:
        (c / "rules.yaml").write_text("rules:\n  max_warnings: 100\n")
    checked = json.loads(_same(copies, "check", "--self", "assemblies/hover.yaml", "--rules",
                               "rules.yaml", "--format", "json", *FAST))
    assert checked["outcomes"][0][0]["source"] == "assemblies/hover.yaml"


def test_root_option(copies):
    """``--root COPY`` from elsewhere, inputs named by absolute paths: the same bytes as
    from the copy's root."""
    here = _same(copies, "analyze", "assemblies/", "--format", "json", *FAST, code=2)
    there = _same(copies, "analyze", "assemblies/", "--format", "json", *FAST, code=2,
                  root=True)
    assert here == there
    r = run_cli("analyze", "assemblies/hover.yaml", "--root", "nowhere", *FAST,
                cwd=copies[0])
    assert r.returncode == 2 and r.stderr == "ndbg: error: --root nowhere: no such directory\n"


def test_a_path_outside_the_root_stays_absolute(copies):
    """An input outside the root keeps its absolute path (with ``/``)."""
    one, two = copies
    r = run_cli("analyze", one / "assemblies" / "hover.yaml", "--format", "json", *FAST,
                cwd=two)
    assert r.returncode == 0, r.stderr[-2000:]
    a = json.loads(r.stdout)["assembly"]
    assert a["source"] == (one / "assemblies" / "hover.yaml").as_posix()
    assert a["parts"][0]["source"] == (one / "assemblies/meshes/hover/base.stl").as_posix()


def test_library_writes_sources_relative_to_the_working_folder(copies, monkeypatch):
    """``ndbg_cli.analyze`` too (relative to the working folder, or to ``Options.root``);
    the assembly keeps the paths it was loaded from."""
    one = copies[0]
    asm = ndbg_cli.load(one / "assemblies" / "hover.yaml")
    assert asm.source == str(one / "assemblies" / "hover.yaml")
    fast = Options(motion="translation", cache=None)
    monkeypatch.chdir(one)
    rep = ndbg_cli.analyze(asm, fast)
    assert rep["assembly"]["source"] == "assemblies/hover.yaml"
    assert rep["assembly"]["parts"][0]["source"] == "assemblies/meshes/hover/base.stl"
    monkeypatch.chdir(one.parent)
    rep = ndbg_cli.analyze(asm, Options(motion="translation", cache=None,
                                        root=str(one / "assemblies")))
    assert rep["assembly"]["source"] == "hover.yaml"


def test_portable_paths(tmp_path, monkeypatch):
    """Relative inside the root (as given or through a symbolic link), absolute outside,
    ``/`` separators; a ``FILE#NODE`` keeps its node name as it is."""
    (tmp_path / "real" / "sub").mkdir(parents=True)
    (tmp_path / "real" / "sub" / "a.stl").write_text("")
    os.symlink(tmp_path / "real", tmp_path / "link")
    monkeypatch.chdir(tmp_path / "real")
    assert portable("sub/a.stl") == "sub/a.stl"
    assert portable(tmp_path / "real" / "sub" / "a.stl") == "sub/a.stl"
    assert portable(tmp_path / "link" / "sub" / "a.stl") == "sub/a.stl"
    assert portable("sub/a.stl", tmp_path / "link") == "sub/a.stl"
    assert portable(tmp_path / "real" / "sub" / "a.stl", tmp_path / "link") == "sub/a.stl"
    assert portable("../other/b.yaml") == (tmp_path / "other" / "b.yaml").as_posix()
    assert portable(".") == "."
    assert portable(None) is None and portable("") == ""
    model = str(tmp_path / "real" / "m.glb")
    assert portable_source(model + "#arm/../x", model) == "m.glb#arm/../x"
    assert portable_source(None, model) is None
    assert portable("sub/a.stl", tmp_path) == "real/sub/a.stl"
