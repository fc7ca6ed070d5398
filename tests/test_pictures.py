"""The pictures of a report (``ndbg analyze --html/--glb/--png/--svg``): the GLB reloads with
trimesh with one node per part and the plan as animations, the images exist, have their size
and are not blank, everything is byte-identical from run to run, the sphere maps colour as
many DBGs as the report has, and the CLI writes them (one assembly, a batch with its
index.html). The browser's checks of the HTML report are in test_pictures_browser.py."""

from __future__ import annotations

import json
import shutil
import struct
import time
from pathlib import Path

import numpy as np
import pytest

import ndbg_cli
from ndbg_cli.core.options import Options
from ndbg_cli.report.document import dumps

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"


def analysed(path: Path, motion: str = "translation") -> tuple[dict, object]:
    """``(report as JSON reads it back, assembly)`` of one example."""
    asm = ndbg_cli.load(path)
    report = json.loads(dumps(ndbg_cli.analyze(asm, Options(motion=motion, cache=None))))
    return report, asm


@pytest.fixture(scope="module")
def bell():
    return analysed(EX / "bell.yaml")


@pytest.fixture(scope="module")
def hover():
    return analysed(EX / "hover.yaml", motion="all")


def glb_json(data: bytes) -> dict:
    """The JSON chunk of a GLB."""
    magic, version, total = struct.unpack("<4sII", data[:12])
    assert (magic, version, total) == (b"glTF", 2, len(data))
    length, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20:20 + length])


def test_glb_reloads_with_a_node_per_part_and_a_channel_group_per_step(bell, tmp_path):
    import trimesh

    from ndbg_cli.pictures.glb import glb_bytes

    report, asm = bell
    data = glb_bytes(report, asm)
    assert data == glb_bytes(report, asm)  # deterministic
    (tmp_path / "bell.glb").write_bytes(data)
    scene = trimesh.load(tmp_path / "bell.glb")
    assert sorted(scene.graph.nodes_geometry) == sorted(asm.ids)
    doc = glb_json(data)
    steps = report["plan"]["sequence"]
    names = [a["name"] for a in doc["animations"]]
    assert names == ["disassembly"] + [f"step {j}" for j in range(1, len(steps) + 1)]
    whole = doc["animations"][0]
    times = doc["accessors"][whole["samplers"][0]["input"]]
    assert times["count"] == len(steps) + 1 and times["max"] == [float(len(steps))]
    moved = {p for s in steps for p in s["moved"]}
    nodes = [doc["nodes"][c["target"]["node"]]["name"] for c in whole["channels"]]
    assert set(nodes) == moved and all(c["target"]["path"] == "translation"
                                       for a in doc["animations"] for c in a["channels"])
    for a in doc["animations"][1:]:
        assert len(a["channels"]) == len(moved)


def test_glb_pose_moves_each_step_s_parts_along_its_removal_direction(hover):
    from ndbg_cli.pictures._scene import disassembly, display_meshes, poses

    report, asm = hover
    meshes = display_meshes(asm)
    moves = disassembly(report, meshes)
    offsets = poses(meshes, moves)
    seq = report["plan"]["sequence"]
    assert [mv.step for mv in moves] == [s["step"] for s in reversed(seq)]
    for j, (mv, s) in enumerate(zip(moves, reversed(seq)), start=1):
        delta = offsets[j] - offsets[j - 1]
        for k, m in enumerate(meshes):
            if m.id in s["moved"]:
                assert np.allclose(delta[k], np.asarray(s["removal_direction"]) * mv.distance)
                assert mv.distance > 0
            else:
                assert np.allclose(delta[k], 0)


@pytest.mark.parametrize("fixture", ["bell", "hover"])
def test_sphere_maps_colour_every_distinct_dbg(fixture, request):
    from ndbg_cli.pictures.sphere import sphere_maps

    report, _ = request.getfixturevalue(fixture)
    maps = sphere_maps(report)
    assert {m.family for m in maps} == {f for f, s in report["ndbg"].items()
                                        if s.get("region_list")}
    for m in maps:
        assert len(m.distinct_drawn) == report["ndbg"][m.family]["distinct_dbgs"]
        assert (m.sample_dbg >= 0).all()  # every sampled direction has a listed DBG
        if m.family == "infinitesimal_translation":
            assert m.mode == "regions" and len(m.face_dbg) == len(m.faces)
            # a face region's DBG is the colour of the samples around its representative
            for d, k, dim in m.representatives:
                if dim == 2:
                    near = np.argmax(m.samples @ np.asarray(d))
                    assert m.sample_dbg[near] == k
        else:
            assert m.mode == "representatives" and "representative" in m.note


def test_html_is_deterministic_small_and_offline(bell):
    from ndbg_cli.pictures.html import render_html

    report, asm = bell
    page = render_html(report, asm)
    t = time.perf_counter()
    again = render_html(report, asm)  # timed once the lazy imports are done
    elapsed = time.perf_counter() - t
    assert page == again
    assert len(page.encode()) < 10 * 2**20
    assert elapsed < 2.0
    assert "<script src" not in page and "<link" not in page  # nothing fetched
    data = page.split('<script id="ndbg-data" type="application/json">')[1].split("</script>")[0]
    doc = json.loads(data)
    assert len(doc["view"]["parts"]) == len(asm.parts)
    assert len(doc["moves"]) == len(report["plan"]["sequence"])
    assert len(doc["offsets"]) == len(doc["moves"]) + 1


def png_pixels(path: Path) -> np.ndarray:
    from PIL import Image

    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"))


def test_png_and_svg_images_exist_have_their_size_are_not_blank_and_repeat(hover, tmp_path):
    from ndbg_cli.pictures.static import DPI, write_images

    report, asm = hover
    first = write_images(report, asm, tmp_path / "a", "png")
    again = write_images(report, asm, tmp_path / "b", "png")
    names = sorted(p.name for p in first)
    assert names == ["plan.png", "sphere-infinite_translation.png",
                     "sphere-infinitesimal_translation.png", "tree.png"]
    for p, q in zip(first, again):
        assert p.read_bytes() == q.read_bytes(), p.name
        pixels = png_pixels(p)
        assert pixels.shape[0] >= 2 * DPI and pixels.shape[1] >= 4 * DPI
        # not blank: many pixels differ from the background (white)
        assert (np.abs(pixels.astype(int) - 255).sum(axis=2) > 30).mean() > 0.01, p.name
    strip = png_pixels(tmp_path / "a" / "plan.png")
    assert strip.shape[:2] == (4 * DPI, 4 * DPI * 3)  # 3 poses: assembled, 2 steps
    svg = write_images(report, asm, tmp_path / "c", "svg")
    svg2 = write_images(report, asm, tmp_path / "d", "svg")
    assert [p.read_bytes() for p in svg] == [p.read_bytes() for p in svg2]
    assert all(p.read_text().lstrip().startswith("<?xml") for p in svg)


def test_cli_writes_the_pictures_of_one_assembly(tmp_path):
    shutil.copytree(EX / "meshes" / "hover", tmp_path / "meshes" / "hover")
    shutil.copy(EX / "hover.yaml", tmp_path / "hover.yaml")
    r = run_cli("analyze", tmp_path / "hover.yaml", "--motion", "translation", "-q",
                "--html", tmp_path / "out" / "hover.html", "--glb", tmp_path / "hover.glb",
                "--png", tmp_path / "png", "--svg", tmp_path / "svg")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out" / "hover.html").read_text().startswith("<!DOCTYPE html>")
    assert glb_json((tmp_path / "hover.glb").read_bytes())["scenes"][0]["name"] == "hover"
    assert sorted(p.name for p in (tmp_path / "png").iterdir()) == [
        "plan.png", "sphere-infinitesimal_translation.png", "tree.png"]
    assert len(list((tmp_path / "svg").iterdir())) == 3


def test_cli_batch_writes_a_page_each_and_an_index(tmp_path):
    for name in ("hover", "peg-blind"):
        shutil.copy(EX / f"{name}.yaml", tmp_path / f"{name}.yaml")
    shutil.copytree(EX / "meshes", tmp_path / "meshes")
    bad = tmp_path / "broken.yaml"
    bad.write_text("name: broken\nparts: [\n")
    r = run_cli("analyze", tmp_path / "hover.yaml", tmp_path / "peg-blind.yaml", bad,
                "--motion", "translation", "-q", "--out-dir", tmp_path / "out",
                "--html", tmp_path / "out", "--glb", tmp_path / "glb")
    assert r.returncode == 2, r.stderr  # the broken manifest: an input error
    out = tmp_path / "out"
    assert (out / "hover.html").exists() and (out / "peg-blind.html").exists()
    assert (tmp_path / "glb" / "hover.glb").exists()
    index = (out / "index.html").read_text()
    assert 'href="hover.html"' in index and 'href="peg-blind.html"' in index
    assert "error:" in index and "broken" in index


def test_cli_refuses_an_unwritable_picture_place_before_analysing(tmp_path):
    (tmp_path / "file").write_text("x")
    r = run_cli("analyze", EX / "hover.yaml", "--png", tmp_path / "file" / "png", "-q")
    assert r.returncode == 2
    assert "cannot write" in r.stderr and "png" in r.stderr


def test_plain_runs_do_not_import_the_picture_libraries():
    """plotly and matplotlib are imported only when a picture is asked for (and the HTML
    report reads plotly.js from the package without importing plotly's Python side)."""
    import subprocess
    import sys

    code = ("import sys, ndbg_cli.cli.main, ndbg_cli.cli.analyze, ndbg_cli.pipeline.analysis\n"
            "import ndbg_cli.pictures.html, ndbg_cli.pictures.glb\n"
            "print(','.join(m for m in ('plotly', 'matplotlib') if m in sys.modules))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == ""


def test_the_andor_graph_is_drawn_when_small_with_the_report_s_counts(hover, bell):
    from ndbg_cli.pictures.andor import andor_svg

    report, _ = hover
    for family in ("infinitesimal_translation", "infinite_translation"):
        svg, caption = andor_svg(report, family)
        g = report["andor"][family]
        assert svg is not None, caption
        assert svg.count("<rect") == g["nodes"] and svg.count("<circle") == g["hyperarcs"]
    # the plan's steps are red in its own family's graph
    assert 'stroke="#d62728"' in andor_svg(report, report["plan"]["family"])[0]
    svg, caption = andor_svg(bell[0], "infinitesimal_translation")
    assert svg is None and "cut" in caption


def test_display_meshes_are_coarsened_to_the_budget_the_same_way_each_time(bell):
    from ndbg_cli.pictures._scene import display_meshes

    _, asm = bell
    full = display_meshes(asm)
    assert sum(len(m.faces) for m in full) == sum(p.check.triangles for p in asm.parts)
    coarse = display_meshes(asm, max_triangles=2000)
    assert sum(len(m.faces) for m in coarse) <= 2000
    again = display_meshes(asm, max_triangles=2000)
    assert all(np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
               for a, b in zip(coarse, again))
    assert [m.id for m in coarse] == asm.ids and all(len(m.faces) for m in coarse)
