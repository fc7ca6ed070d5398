"""Every input format loads from a real file, with the right parts, placements and units."""

from __future__ import annotations

import json

import numpy as np
import pytest
import trimesh

import ndbg_cli

from formats import box_patches, write_3dxml, write_iges_patches
from helpers import box, run_cli, write_two_boxes


def test_manifest_places_parts_and_keeps_units(tmp_path):
    asm = ndbg_cli.load(write_two_boxes(tmp_path))
    assert asm.ids == ["a", "b"]
    assert asm.units == "mm"
    np.testing.assert_allclose(asm.part("b").bounds, [[0, 0, 10], [10, 10, 20]])
    assert asm.part("a").check.volume == pytest.approx(1000.0)
    assert asm.part("a").check.watertight


def test_rotation_forms_agree(tmp_path):
    # 90 degrees about z, three ways: a 10x20x30 box's x extent becomes 20
    (tmp_path / "m").mkdir()
    box((0, 0, 0), (10, 20, 30)).export(tmp_path / "m" / "b.stl")
    forms = ["{euler: [0, 0, 90], order: xyz}", "{quaternion: [0.70710678, 0, 0, 0.70710678]}",
             "{axis: [0, 0, 1], angle: 90}"]
    for k, rot in enumerate(forms):
        p = tmp_path / f"r{k}.yaml"
        p.write_text(f"parts:\n  - id: b\n    mesh: m/b.stl\n    rotation: {rot}\n")
        b = ndbg_cli.load(p).part("b").bounds
        np.testing.assert_allclose(b, [[-20, 0, 0], [0, 10, 30]], atol=1e-6)
    p = tmp_path / "mat.yaml"
    p.write_text("parts:\n  - id: b\n    mesh: m/b.stl\n    matrix: [[0,-1,0,5],[1,0,0,0],"
                 "[0,0,1,0],[0,0,0,1]]\n")
    np.testing.assert_allclose(ndbg_cli.load(p).part("b").bounds, [[-15, 0, 0], [5, 10, 30]],
                               atol=1e-6)


def test_mixed_units_convert_to_the_assembly_unit(tmp_path):
    # the assembly is in cm; part b's file and translation are in mm
    (tmp_path / "m").mkdir()
    box((0, 0, 0), (10, 10, 10)).export(tmp_path / "m" / "a.stl")   # 10 cm cube
    box((0, 0, 0), (100, 100, 100)).export(tmp_path / "m" / "b.stl")  # 100 mm = 10 cm cube
    p = tmp_path / "mix.yaml"
    p.write_text("units: cm\ntolerance: 0.001\nparts:\n  - id: a\n    mesh: m/a.stl\n"
                 "  - id: b\n    mesh: m/b.stl\n    units: mm\n    translation: [0, 0, 100]\n"
                 "joints:\n  - {type: screw, parts: [a, b], axis: [0, 0, 2], point: [1, 2, 3],"
                 " pitch: 0.125}\n")
    asm = ndbg_cli.load(p)
    assert asm.units == "cm"
    np.testing.assert_allclose(asm.part("b").bounds, [[0, 0, 10], [10, 10, 20]], atol=1e-9)
    j = asm.joints[0]
    assert j.axis == (0.0, 0.0, 1.0) and j.pitch == 0.125
    # converting the whole manifest to mm scales everything, the tolerance included
    mm = ndbg_cli.load(p, units="mm")
    np.testing.assert_allclose(mm.part("b").bounds, [[0, 0, 100], [100, 100, 200]], atol=1e-6)
    assert mm.length_tolerance == pytest.approx(0.01)
    assert mm.joints[0].pitch == pytest.approx(1.25)
    assert mm.joints[0].point == pytest.approx((10.0, 20.0, 30.0))


def test_inch_unit(tmp_path):
    (tmp_path / "m").mkdir()
    box((0, 0, 0), (1, 1, 1)).export(tmp_path / "m" / "a.stl")
    p = tmp_path / "in.yaml"
    p.write_text("units: mm\nparts:\n  - id: a\n    mesh: m/a.stl\n    units: in\n")
    assert ndbg_cli.load(p).part("a").check.volume == pytest.approx(25.4**3)


def test_2d_polygons_with_holes(tmp_path):
    p = tmp_path / "flat.yaml"
    p.write_text("dimension: 2\nunits: mm\nparts:\n"
                 "  - id: frame\n    polygon: [[0,0],[10,0],[10,10],[0,10]]\n"
                 "    holes: [[[2,2],[2,8],[8,8],[8,2]]]\n"
                 "  - id: key\n    polygon: [[2,2],[8,2],[8,8],[2,8]]\n"
                 "  - id: cw\n    polygon: [[10,0],[10,10],[20,10],[20,0]]\n"
                 "    rotation: 0\n    translation: [0, 0]\n")
    asm = ndbg_cli.load(p)
    assert asm.dimension == 2
    assert asm.part("frame").check.area == pytest.approx(100 - 36)
    assert asm.part("key").check.area == pytest.approx(36)
    assert asm.part("cw").polygon.exterior.is_ccw  # stored counter-clockwise whatever given
    assert asm.part("frame").mesh is None


def test_glb_scene_instances_become_parts(tmp_path):
    # one geometry instanced twice: two parts with their own transforms, unique ids
    scene = trimesh.Scene()
    cube = box((0, 0, 0), (1, 1, 1))
    scene.add_geometry(cube, node_name="bolt", geom_name="g")
    scene.add_geometry(cube, node_name="bolt_b", geom_name="g",
                       transform=trimesh.transformations.translation_matrix([0, 0, 1]))
    path = tmp_path / "s.glb"
    scene.export(path)
    asm = ndbg_cli.load(path)
    assert len(asm) == 2 and asm.units == "m"
    assert sorted(asm.ids) == ["bolt", "bolt_b"]
    zs = sorted(p.bounds[0][2] for p in asm.parts)
    assert zs == pytest.approx([0.0, 1.0])
    assert ndbg_cli.load(path, units="mm").units == "mm"


def test_gltf_3mf_obj_ply_off_stl(tmp_path):
    scene = trimesh.Scene()
    scene.add_geometry(box((0, 0, 0), (1, 1, 1)), node_name="a", geom_name="a")
    scene.add_geometry(box((0, 0, 1), (1, 1, 2)), node_name="b", geom_name="b")
    for ext in ("gltf", "3mf", "obj"):
        path = tmp_path / f"s.{ext}"
        scene.export(path)
        asm = ndbg_cli.load(path)
        assert len(asm) == 2, ext
        assert all(p.check.watertight for p in asm.parts), ext
        assert sum(p.check.volume for p in asm.parts) == pytest.approx(2.0), ext
    for ext in ("ply", "off", "stl"):
        path = tmp_path / f"one.{ext}"
        box((0, 0, 0), (2, 2, 2)).export(path)
        asm = ndbg_cli.load(path)
        assert len(asm) == 1 and asm.ids == ["one"] or len(asm) == 1, ext
        assert asm.parts[0].check.volume == pytest.approx(8.0), ext


def test_obj_groups_are_parts(tmp_path):
    v = box((0, 0, 0), (1, 1, 1))
    lines = []
    for k, (name, dz) in enumerate([("left", 0), ("right", 1)]):
        lines.append(f"o {name}")
        lines += [f"v {x} {y} {z + dz}" for x, y, z in v.vertices]
        lines += [f"f {a + 1 + 8 * k} {b + 1 + 8 * k} {c + 1 + 8 * k}" for a, b, c in v.faces]
    path = tmp_path / "groups.obj"
    path.write_text("\n".join(lines) + "\n")
    asm = ndbg_cli.load(path)
    assert sorted(asm.ids) == ["left", "right"]


def test_iges_file(tmp_path):
    path = tmp_path / "box.igs"
    write_iges_patches(path, box_patches((0, 0, 0), (10, 20, 30)))
    asm = ndbg_cli.load(path)
    assert len(asm) == 1 and asm.units == "mm"
    assert asm.parts[0].check.volume == pytest.approx(6000.0, rel=1e-6)


def test_3dxml_instances(tmp_path):
    cube = box((-5, -5, -5), (5, 5, 5))
    T = np.eye(4)
    T[:3, 3] = [0, 0, 10]
    path = tmp_path / "a.3dxml"
    write_3dxml(path, [("lower", cube, np.eye(4)), ("upper", cube, T)])
    asm = ndbg_cli.load(path)
    assert len(asm) == 2 and asm.units == "mm"
    assert sorted(p.bounds[0][2] for p in asm.parts) == pytest.approx([-5.0, 5.0])


def test_mesh_directory_one_part_per_file(tmp_path):
    box((0, 0, 0), (1, 1, 1)).export(tmp_path / "base.stl")
    box((0, 0, 1), (1, 1, 2)).export(tmp_path / "lid.ply")
    asm = ndbg_cli.load(tmp_path)
    assert asm.ids == ["base", "lid"]
    assert ndbg_cli.discover(tmp_path) == [tmp_path]


def test_split_vertices_are_merged_before_judging_watertightness(tmp_path):
    # a cube with every face's vertices duplicated (as STEP exports do along sharp edges)
    cube = box((0, 0, 0), (1, 1, 1))
    tri = cube.triangles.reshape(-1, 3)
    split = trimesh.Trimesh(vertices=tri, faces=np.arange(len(tri)).reshape(-1, 3), process=False)
    assert not split.is_watertight
    split.export(tmp_path / "split.stl")
    part = ndbg_cli.load(tmp_path / "split.stl").parts[0]
    assert part.check.watertight and part.check.volume == pytest.approx(1.0)


def test_open_mesh_is_a_warning_not_an_error(tmp_path):
    cube = box((0, 0, 0), (1, 1, 1))
    cube.update_faces(np.arange(len(cube.faces)) > 1)  # drop two triangles: a hole
    cube.export(tmp_path / "open.stl")
    asm = ndbg_cli.load(tmp_path / "open.stl")
    assert not asm.parts[0].check.watertight
    assert [d.code for d in asm.diagnostics] == ["not-watertight"]


def test_edge_stats_count_open_and_nonmanifold_edges_and_tell_closed_surfaces():
    """``edge_stats``' counts by construction on a tetrahedron (4 faces, 6 edges, each on two
    faces in opposite directions)."""
    from ndbg_cli.io.validate import edge_stats

    v = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]]
    tetra = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]

    def stats(faces):
        return edge_stats(trimesh.Trimesh(v, faces, process=False, validate=False))
    assert stats(tetra) == (0, 0, True)
    assert stats(tetra[:3]) == (3, 0, False)  # face 1-2-3 gone: its three edges are open
    # one face wound the other way: no open edge, but each of its edges twice one way
    assert stats(tetra[:3] + [[1, 3, 2]]) == (0, 0, False)
    # a second tetrahedron 0-1-2-4 on face 0-1-2 (wound the other way): its three edges
    # have four faces each, and both surfaces are closed
    twin = [[1, 4, 2], [1, 2, 0], [4, 0, 2], [1, 0, 4]]
    assert stats(twin) == (0, 0, True)
    assert stats(tetra + twin) == (0, 3, True)
    # a face repeating vertex 0: its edge from 0 to itself has one face but is its own
    # reverse; edge 0-1 then has four faces
    assert stats(tetra + [[0, 0, 1]]) == (1, 1, True)


def test_inside_out_mesh_is_inverted_with_a_warning(tmp_path):
    cube = box((0, 0, 0), (1, 1, 1))
    cube.invert()
    cube.export(tmp_path / "inv.stl")
    asm = ndbg_cli.load(tmp_path / "inv.stl")
    assert asm.parts[0].check.volume == pytest.approx(1.0)
    assert "inverted-normals" in [d.code for d in asm.diagnostics]


def test_subset_shares_parts_and_part_hash_is_content_based(tmp_path):
    asm = ndbg_cli.load(write_two_boxes(tmp_path))
    sub = asm.subset(["b"])
    assert sub.ids == ["b"] and sub.part("b") is asm.part("b")
    # same mesh file, different placement: different hashes; reloading gives equal hashes
    assert asm.part("a").hash != asm.part("b").hash
    assert ndbg_cli.load(write_two_boxes(tmp_path)).part("b").hash == asm.part("b").hash


def test_convert_writes_an_equivalent_manifest(tmp_path):
    scene = trimesh.Scene()
    scene.add_geometry(box((0, 0, 0), (1, 1, 1)), node_name="a/b c", geom_name="a")
    scene.add_geometry(box((0, 0, 1), (1, 1, 2)), node_name="d", geom_name="d")
    src = tmp_path / "s.glb"
    scene.export(src)
    r = run_cli("convert", src, "--out", tmp_path / "proj", "-q")
    assert r.returncode == 0, r.stderr
    manifest = tmp_path / "proj" / "s.yaml"
    assert r.stdout.strip() == str(manifest)
    back = ndbg_cli.load(manifest)
    assert back.ids == ["a/b c", "d"] and back.units == "m"
    np.testing.assert_allclose(back.part("d").bounds, [[0, 0, 1], [1, 1, 2]], atol=1e-6)
    again = run_cli("convert", src, "--out", tmp_path / "proj")
    assert again.returncode == 2 and "manifest exists" in again.stderr


def test_json_report_is_deterministic_and_valid(tmp_path):
    path = write_two_boxes(tmp_path)
    first = run_cli("analyze", path, "--format", "json")
    second = run_cli("analyze", path, "--format", "json")
    assert first.returncode == 0, first.stderr
    assert first.stdout == second.stdout
    doc = json.loads(first.stdout)
    from ndbg_cli.report.document import validate_report

    validate_report(doc)
    assert doc["schema"] == "ndbg.report/1"
    assert [p["id"] for p in doc["assembly"]["parts"]] == ["a", "b"]


def test_batch_continues_past_a_bad_assembly(tmp_path):
    write_two_boxes(tmp_path / "good")
    (tmp_path / "good" / "broken.yaml").write_text("parts: [\n")
    r = run_cli("analyze", tmp_path / "good", "--format", "json")
    assert r.returncode == 2
    doc = json.loads(r.stdout)
    assert doc["schema"] == "ndbg.batch/1"
    assert doc["summary"] == {"assemblies": 2, "ok": 1, "errors": 1}
    from ndbg_cli.report.document import validate_report

    validate_report(doc)
    out = tmp_path / "reports"
    r = run_cli("analyze", tmp_path / "good", "--out", out)
    assert sorted(p.name for p in out.iterdir()) == ["broken.json", "index.json", "two.json"]
    assert not list(out.glob("*.tmp"))


def test_cli_help_version_and_module_entry():
    r = run_cli("--version")
    assert r.returncode == 0 and r.stdout.startswith("ndbg, version ")
    for cmd in ([], ["analyze"], ["convert"], ["schema"]):
        h = run_cli(*cmd, "--help")
        assert h.returncode == 0 and "Example" in h.stdout, cmd
    s = run_cli("schema")
    assert json.loads(s.stdout)["title"] == "ndbg report"


def test_config_file_sets_defaults_and_flags_win(tmp_path):
    path = write_two_boxes(tmp_path)
    cfg = tmp_path / "ci.yaml"
    cfg.write_text("tolerance: 0.5\nmotion: translation\n")
    doc = json.loads(run_cli("analyze", path, "--format", "json", "--config", cfg).stdout)
    assert doc["assembly"]["tolerance"] == 0.5
    assert doc["options"]["motion"] == "translation"
    doc = json.loads(run_cli("analyze", path, "--format", "json", "--config", cfg,
                             "--tolerance", "0.25").stdout)
    assert doc["assembly"]["tolerance"] == 0.25
    cfg.write_text("tolerence: 1\n")
    r = run_cli("analyze", path, "--config", cfg)
    assert r.returncode == 2 and "unknown setting 'tolerence'" in r.stderr


def test_text_meshes_in_latin_1(tmp_path):
    """An OBJ comment and an ASCII STL solid name in Latin-1 (not UTF-8): trimesh decodes
    them with charset_normalizer, a dependency since it failed with ModuleNotFoundError."""
    cube = box((0, 0, 0), (1, 1, 1))
    obj = trimesh.exchange.obj.export_obj(cube, include_normals=False)
    (tmp_path / "cube.obj").write_bytes("# pièce usinée\n".encode("latin-1") + obj.encode())
    stl = trimesh.exchange.stl.export_stl_ascii(cube).replace("solid ", "solid pièce ", 1)
    (tmp_path / "cube.stl").write_bytes(stl.encode("latin-1"))
    for name in ("cube.obj", "cube.stl"):
        with pytest.raises(UnicodeDecodeError):
            (tmp_path / name).read_bytes().decode("utf-8")
        asm = ndbg_cli.load(tmp_path / name)
        assert len(asm.parts) == 1 and asm.parts[0].check.triangles == 12, name
        assert asm.parts[0].check.volume == pytest.approx(1.0), name


def test_scientific_notation_is_a_number(tmp_path):
    """YAML 1.2 floats (``1e-3``, ``1.0e1``: no dot or no exponent sign) in manifests and
    config files; PyYAML's YAML 1.1 rules read them as strings. Other scalars are as before."""
    from ndbg_cli.io.config import read_config
    from ndbg_cli.io.manifest import read_manifest

    path = write_two_boxes(tmp_path).parent / "sci.yaml"
    path.write_text(write_two_boxes(tmp_path).read_text()
                    .replace("units: mm\n", "units: mm\ntolerance: 1e-3\n")
                    .replace("[0, 0, 10]", "[0, 0, 1.0e1]"))
    asm = ndbg_cli.load(path)
    assert asm.tolerance == 0.001
    np.testing.assert_allclose(asm.part("b").bounds, [[0, 0, 10], [10, 10, 20]])
    cfg = tmp_path / "c.yaml"
    cfg.write_text("time_limit: 5E-1\ntolerance: 2.5e+0\n")
    assert read_config(cfg) == {"time_limit": 0.5, "tolerance": 2.5}
    path.write_text("name: 1e5x\nexpect: {a: 12, b: 0x1f, c: yes, d: 1_000, e: '1e3'}\nparts:\n"
                    "  - id: a\n    mesh: meshes/a.stl\n")
    assert read_manifest(path).data["expect"] == {"a": 12, "b": 31, "c": True, "d": 1000,
                                                  "e": "1e3"}


@pytest.mark.parametrize("text, problem", [
    ("max_partitions: abc", "max_partitions: expected an integer >= 1, got 'abc'"),
    ("cache: 5", "cache: expected a non-empty string or null, got 5"),
    ("max_nodes: -5", "max_nodes: expected an integer >= 1, got -5"),
    ("max_nodes: 2.5", "max_nodes: expected an integer >= 1, got 2.5"),
    ("time_limit: .nan", "time_limit: expected a finite number > 0 or null, got nan"),
    ("time_limit: 0", "time_limit: expected a finite number > 0 or null, got 0"),
    ("infinite_budget: -1", "infinite_budget: expected an integer >= 0, got -1"),
    ("timings: maybe", "timings: expected true or false, got 'maybe'"),
    ("motion: teleport", "motion: expected one of all, translation, infinite, generalized"),
    ("units: parsec", "unknown unit 'parsec'"),
])
def test_config_values_have_the_options_types_and_ranges(tmp_path, text, problem):
    from ndbg_cli.core.errors import InputError
    from ndbg_cli.io.config import read_config

    cfg = tmp_path / "c.yaml"
    cfg.write_text(text + "\n")
    with pytest.raises(InputError) as info:
        read_config(cfg)
    # the value's line: one-line files here, line 2 below a comment
    assert info.value.message.startswith(f"{cfg}:1: ") and problem in info.value.message
    cfg.write_text("# settings\n" + text + "\n")
    with pytest.raises(InputError) as info:
        read_config(cfg)
    assert info.value.message.startswith(f"{cfg}:2: ") and problem in info.value.message


def test_config_nulls_and_bad_values_on_the_command_line(tmp_path):
    from ndbg_cli.io.config import read_config

    cfg = tmp_path / "c.yaml"
    cfg.write_text("# every setting left at its default\n")  # an empty config sets nothing
    assert read_config(cfg) == {}
    cfg.write_text("region_limit: null\ntolerance: null\ntimings: true\nunits: inch\n")
    assert read_config(cfg) == {"region_limit": None, "tolerance": None, "timings": True,
                                "units": "in"}
    path = write_two_boxes(tmp_path)
    cfg.write_text("cache: 5\n")  # was an internal error, printed twice
    r = run_cli("analyze", path, "--config", cfg)
    assert r.returncode == 2
    assert r.stderr == f"ndbg: error: {cfg}:1: cache: expected a non-empty string or null, got 5\n"
    r = run_cli("analyze", path, "--time-limit", "nan")  # click's FloatRange lets NaN in
    assert r.returncode == 2
    assert r.stderr == "ndbg: error: --time-limit: expected a finite number > 0, got nan\n"


def _gltf_two_primitive_mesh(path):
    """A glTF whose node "17" holds one mesh of two primitives (unit cubes at x = 0 and x =
    2): trimesh makes each primitive a child node named "17_<random hex>"."""
    import base64

    blob, views, accessors, prims = b"", [], [], []
    for dx in (0.0, 2.0):
        cube = box((dx, 0, 0), (dx + 1, 1, 1))
        v = np.asarray(cube.vertices, dtype="<f4")
        f = np.asarray(cube.faces, dtype="<u4")
        for arr in (v, f):
            views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": arr.nbytes})
            blob += arr.tobytes()
        accessors.append({"bufferView": len(views) - 2, "componentType": 5126,
                          "count": len(v), "type": "VEC3",
                          "min": v.min(axis=0).tolist(), "max": v.max(axis=0).tolist()})
        accessors.append({"bufferView": len(views) - 1, "componentType": 5125,
                          "count": f.size, "type": "SCALAR"})
        prims.append({"attributes": {"POSITION": len(accessors) - 2},
                      "indices": len(accessors) - 1})
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "17", "mesh": 0}],
        "meshes": [{"name": "link", "primitives": prims}],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64,"
                     + base64.b64encode(blob).decode()}],
        "bufferViews": views,
        "accessors": accessors,
    }
    path.write_text(json.dumps(doc))


def test_multi_primitive_node_gets_the_same_ids_at_every_load(tmp_path):
    path = tmp_path / "link.gltf"
    _gltf_two_primitive_mesh(path)
    loads = [ndbg_cli.load(path) for _ in range(3)]
    # the node name, the primitives numbered in geometry order, whatever trimesh's suffixes
    assert [tuple(a.ids) for a in loads] == [("17", "17-2")] * 3
    xs = [p.bounds[0][0] for p in loads[0].parts]
    assert xs == pytest.approx([0.0, 2.0])


def test_cli_options_share_the_config_ranges_and_defaults():
    """Every numeric setting a config file may give has the same range as its command-line
    option (one table, analysis.SETTINGS) and the same default (analysis.Options)."""
    import dataclasses

    import click

    import ndbg_cli.cli.main  # noqa: F401  (registers the commands on the group)
    from ndbg_cli.cli._app import cli
    from ndbg_cli.core.options import SETTINGS, Options

    params = {p.name: p for p in cli.commands["analyze"].params}
    defaults = {f.name: f.default for f in dataclasses.fields(Options)}
    checked = 0
    for name, spec in SETTINGS.items():
        if spec[0] not in (int, float) or name not in params or name == "tolerance":
            continue  # the tolerance is checked by the loader, against the assembly's size
        p = params[name]
        assert isinstance(p.type, (click.IntRange, click.FloatRange)), name
        assert p.type.min == spec[1] and p.type.min_open == (spec[2] if len(spec) > 2
                                                            else False), name
        assert p.default == defaults[name], name
        checked += 1
    assert checked >= 5  # max_partitions, max_nodes, max_work, time_limit, infinite_budget
