"""Bad input gets one clear line on stderr, exit code 2, and never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from helpers import box, run_cli

CUBE = "meshes/cube.stl"


def _folder(tmp: Path) -> Path:
    (tmp / "meshes").mkdir(exist_ok=True)
    box((0, 0, 0), (1, 1, 1)).export(tmp / CUBE)
    return tmp


def manifest(text: str):
    def make(tmp: Path) -> Path:
        _folder(tmp)
        p = tmp / "bad.yaml"
        p.write_text(text)
        return p
    return make


def part(extra: str = "", pid: str = "a", mesh: str = CUBE) -> str:
    return f"  - id: {pid}\n    mesh: {mesh}\n{extra}"


def stl_text(tmp: Path, name: str, body: str) -> Path:
    p = tmp / name
    p.write_text(f"solid x\n{body}endsolid x\n")
    return p


def facet(*pts) -> str:
    return ("facet normal 0 0 1\n outer loop\n" + "".join(f"  vertex {x} {y} {z}\n"
            for x, y, z in pts) + " endloop\nendfacet\n")


def nan_stl(tmp: Path) -> Path:
    return stl_text(tmp, "nan.stl", facet((0, 0, 0), (1, 0, 0), ("nan", 1, 0))
                    + facet((0, 0, 0), (1, 0, 0), (0, 0, 1)))


def flat_stl(tmp: Path) -> Path:
    return stl_text(tmp, "flat.stl", facet((0, 0, 0), (1, 0, 0), (2, 0, 0))
                    + facet((0, 0, 0), (2, 0, 0), (3, 0, 0)))


def empty_stl(tmp: Path) -> Path:
    return stl_text(tmp, "empty.stl", "")


def garbage_step(tmp: Path) -> Path:
    p = tmp / "junk.step"
    p.write_text("ISO-10303-21;\nthis is not a STEP file\nEND-ISO-10303-21;\n")
    return p


def garbage_stl(tmp: Path) -> Path:
    p = tmp / "junk.stl"
    p.write_bytes(b"\x00\x01garbage" * 7)
    return p


def not_there(tmp: Path) -> Path:
    return tmp / "missing.yaml"


def text_file(tmp: Path) -> Path:
    p = tmp / "notes.txt"
    p.write_text("hello")
    return p


def outside_mesh(tmp: Path) -> Path:
    inner = tmp / "inner"
    _folder(tmp)
    inner.mkdir()
    p = inner / "bad.yaml"
    p.write_text("parts:\n" + part(mesh="../meshes/cube.stl"))
    return p


CASES = {
    # name: (input builder, extra CLI args, expected fragment of the message)
    "malformed-yaml": (manifest("parts: [\n  - id: a\n"), [], "malformed YAML"),
    "not-a-mapping": (manifest("- a\n- b\n"), [], "must be a YAML mapping"),
    "missing-parts": (manifest("name: x\n"), [], "'parts' is a required property"),
    "unknown-key": (manifest("parts:\n" + part("    colour: red\n")), [], "unknown key"),
    "duplicate-yaml-key": (manifest("name: a\nname: b\nparts:\n" + part()), [],
                           "duplicate key 'name'"),
    "missing-mesh": (manifest("parts:\n" + part(mesh="meshes/nope.stl")), [],
                     "mesh file 'meshes/nope.stl' not found"),
    "unknown-unit": (manifest("units: furlong\nparts:\n" + part()), [], "unknown unit 'furlong'"),
    "unknown-part-unit": (manifest("parts:\n" + part("    units: cubit\n")), [],
                          "unknown unit 'cubit'"),
    "duplicate-part-id": (manifest("parts:\n" + part() + part()), [], "duplicate part id 'a'"),
    "path-traversal": (outside_mesh, [], "leaves the manifest's folder"),
    "matrix-shape": (manifest("parts:\n" + part("    matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0]]\n")),
                     [], "matrix must be 4x4"),
    "matrix-not-rigid": (manifest("parts:\n" + part(
        "    matrix: [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n")), [], "not a rigid motion"),
    "matrix-and-translation": (manifest("parts:\n" + part(
        "    translation: [0,0,0]\n    matrix: [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]\n")),
        [], "either matrix or translation"),
    "translation-not-numbers": (manifest("parts:\n" + part("    translation: [a, b, c]\n")), [],
                                "is not of type 'number'"),
    "zero-quaternion": (manifest("parts:\n" + part("    rotation: {quaternion: [0,0,0,0]}\n")),
                        [], "quaternion has zero length"),
    # found by the fuzzing campaign (manifest:20260149): scipy's ValueError was exit 3
    "euler-repeated-axis": (manifest("parts:\n" + part("    rotation: {euler: [0, 0, 0], "
                                                       "order: zxx}\n")), [],
                            "bad.yaml:4: parts[0].rotation.order: Euler order 'zxx' repeats"),
    # found by the fuzzing campaign: a NUL in a mesh path was os.stat's ValueError (exit 3)
    "nul-in-mesh-path": (manifest('parts:\n  - id: a\n    mesh: "meshes/cube.stl\\0x"\n'), [],
                         "contains a NUL character"),
    "bad-rotation": (manifest("parts:\n" + part("    rotation: {spin: 3}\n")), [],
                     "rotation must be"),
    "unknown-base": (manifest("base: ghost\nparts:\n" + part()), [], "base part 'ghost'"),
    "joint-unknown-part": (manifest("parts:\n" + part() + "joints:\n  - {type: screw, parts: "
                                    "[a, b], axis: [0,0,1], pitch: 1}\n"), [],
                           "joint names unknown part 'b'"),
    "nan-vertex": (nan_stl, [], "NaN or infinite"),
    "empty-mesh": (empty_stl, [], "no triangle mesh"),
    "degenerate-mesh": (flat_stl, [], "degenerate mesh"),
    "unreadable-step": (garbage_step, [], "cannot read STEP file"),
    "unreadable-stl": (garbage_stl, [], "no triangle mesh"),
    "no-such-file": (not_there, [], "no such file or directory"),
    "unknown-file-type": (text_file, [], "unknown file type '.txt'"),
    "bad-polygon": (manifest("dimension: 2\nparts:\n  - id: bowtie\n    polygon: "
                             "[[0,0],[1,1],[1,0],[0,1]]\n"), [], "invalid polygon"),
    "mesh-in-2d": (manifest("dimension: 2\nparts:\n" + part()), [], "a 2D part needs 'polygon'"),
    "negative-tolerance": (manifest("parts:\n" + part()), ["--tolerance", "-1"],
                           "tolerance must be positive"),
    "infinite-tolerance": (manifest("parts:\n" + part()), ["--tolerance", "inf"],
                           "tolerance must be positive and finite, got inf"),
    "nan-tolerance": (manifest("parts:\n" + part()), ["--tolerance", "nan"],
                      "tolerance must be positive and finite, got nan"),
    "huge-tolerance": (manifest("parts:\n" + part()), ["--tolerance", "1e300"],
                       "tolerance 1e+300 mm is not smaller than the assembly's size "
                       "(1.73205 mm)"),
    "manifest-huge-tolerance": (manifest("tolerance: 2.0\nparts:\n" + part()), [],
                                "tolerance 2 mm is not smaller than the assembly's size"),
    # found by the fuzz campaign: 5e-324 passed the schema (> 0) and the report wrote 0.0
    "manifest-tiny-tolerance": (manifest("tolerance: 5.0e-324\nparts:\n" + part()), [],
                                "tolerance 4.94066e-324 mm is below the smallest one ndbg can "
                                "honour here, 1.73e-12 mm"),
    "tiny-tolerance": (manifest("parts:\n" + part()), ["--tolerance", "1e-13"],
                       "tolerance 1e-13 mm is below the smallest one"),
    "manifest-infinite-tolerance": (manifest("tolerance: .inf\nparts:\n" + part()), [],
                                    "bad.yaml:1: tolerance: not a finite number"),
    "cli-unknown-unit": (manifest("parts:\n" + part()), ["--units", "parsec"],
                         "unknown unit 'parsec'"),
    # NaN and infinity: named where they are, not as a singular matrix or a degenerate mesh
    "nan-translation": (manifest("parts:\n" + part() + part("    translation: [0, .nan, 0]\n",
                                                           pid="b")),
                        [], "bad.yaml:6: parts[1].translation: not a finite number"),
    "inf-euler": (manifest("parts:\n" + part("    rotation: {euler: [0, -.inf, 0], order: xyz}"
                                            "\n")), [], "parts[0].rotation.euler: not a finite"),
    "nan-quaternion": (manifest("parts:\n" + part("    rotation: {quaternion: [1, .NaN, 0, 0]}"
                                                 "\n")),
                       [], "bad.yaml:4: parts[0].rotation.quaternion: not a finite number"),
    "inf-angle": (manifest("parts:\n" + part("    rotation: {axis: [0, 0, 1], angle: .inf}\n")),
                  [], "parts[0].rotation.angle: not a finite number"),
    "nan-joint-axis": (manifest("parts:\n" + part() + part(pid="b") + "joints:\n  - {type: "
                                "screw, parts: [a, b], axis: [.nan, 0, 1], pitch: 1}\n"), [],
                       "bad.yaml:7: joints[0].axis: not a finite number"),
    "inf-joint-point": (manifest("parts:\n" + part() + part(pid="b") + "joints:\n  - type: "
                                 "screw\n    parts: [a, b]\n    axis: [0, 0, 1]\n    point: "
                                 "[0, .inf, 0]\n    pitch: 1\n"), [],
                        "bad.yaml:10: joints[0].point: not a finite number"),
    "nan-joint-pitch": (manifest("parts:\n" + part() + part(pid="b") + "joints:\n  - {type: "
                                 "screw, parts: [a, b], axis: [0, 0, 1], pitch: .nan}\n"), [],
                        "joints[0].pitch: not a finite number"),
    "nan-2d-rotation": (manifest("dimension: 2\nparts:\n  - id: sq\n    polygon: "
                                 "[[0,0],[1,0],[1,1],[0,1]]\n    rotation: .nan\n"), [],
                        "bad.yaml:5: parts[0].rotation: not a finite number"),
    "inf-2d-translation": (manifest("dimension: 2\nparts:\n  - id: sq\n    polygon: "
                                    "[[0,0],[1,0],[1,1],[0,1]]\n    translation: [.inf, 0]\n"),
                           [], "parts[0].translation: not a finite number"),
    "nan-polygon": (manifest("dimension: 2\nparts:\n  - id: sq\n    polygon: "
                             "[[0,0],[1,.nan],[1,1],[0,1]]\n"), [],
                    "parts[0].polygon: not a finite number"),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_one_line_exit_2(tmp_path, name):
    build, args, fragment = CASES[name]
    path = build(tmp_path)
    r = run_cli("analyze", path, *args)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("ndbg: error: ")
    assert fragment in lines[0]
    assert path.name in lines[0]


def test_manifest_errors_name_the_line(tmp_path):
    p = manifest("name: x\nparts:\n  - id: a\n    mesh: meshes/cube.stl\n"
                 "  - id: b\n    mesh: meshes/cube.stl\n    matrix: [[1, 0]]\n")(tmp_path)
    r = run_cli("analyze", p)
    assert f"{p}:7: parts[1].matrix: matrix must be 4x4" in r.stderr


def test_usage_error_is_exit_2():
    r = run_cli("analyze", "--motion", "teleport", "x.yaml")
    assert r.returncode == 2 and "Traceback" not in r.stderr


def test_json_mode_still_prints_a_record_on_stdout(tmp_path):
    import json

    p = manifest("units: furlong\nparts:\n" + part())(tmp_path)
    r = run_cli("analyze", p, "--format", "json")
    assert r.returncode == 2
    doc = json.loads(r.stdout)
    assert doc["error"]["code"] == 2 and "furlong" in doc["error"]["message"]


def test_huge_quaternion_is_a_rotation(tmp_path):
    """Found by the fuzzing campaign: the norm of [1e308, 1e308, 0, 0] overflows to inf,
    q / inf is the zero quaternion and scipy's ValueError was an internal error (exit 3);
    it is the rotation of [1, 1, 0, 0]."""
    p = manifest("parts:\n" + part("    rotation: {quaternion: [1e308, 1e308, 0, 0]}\n"))(
        tmp_path)
    r = run_cli("analyze", p, "--motion", "translation", "--format", "json", "--no-cache")
    assert r.returncode == 0, r.stderr
