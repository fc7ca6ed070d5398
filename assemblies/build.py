"""Build the shipped example assemblies: meshes (binary STL) and YAML manifests.

Run ``.venv/bin/python assemblies/build.py [OUTDIR]`` (default: this folder). The output is
deterministic: the same bytes on every run. Every solid is made with manifold3d CSG (boxes,
prisms over polygons, facetted cylinders) and written already placed in the assembly frame,
except the bell's screws, which share one mesh placed by ``translation``/``rotation``.

Units are millimetres throughout. Facetted cylinders use :data:`SEGMENTS` facets, phase 0
(a vertex on the +x axis of the cylinder's own frame), and vertex coordinates rounded to
multiples of :data:`GRID` = 2^-16 mm. Rounded coordinates below 256 mm are exact in float32 (the
STL format), so a peg and the hole it fits keep exactly coincident facets even when the peg is
stored in its own frame and moved by an integer translation.

Each manifest's ``expect:`` block holds facts derived by hand; the comment above each block says
how. Tests (``tests/test_examples.py``) check the geometry; analysis tests read ``expect``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import trimesh
import yaml
from manifold3d import CrossSection, Manifold

HERE = Path(__file__).resolve().parent
SEGMENTS = 24  #: facets of every cylinder
GRID = 2.0**-16  #: mm; cylinder vertex coordinates are multiples of this
SIN37 = math.sin(math.radians(37.0))
COS37 = math.cos(math.radians(37.0))


# -- solids -------------------------------------------------------------------------------

def box(x0: float, y0: float, z0: float, x1: float, y1: float, z1: float) -> Manifold:
    """Axis-aligned box with corners ``(x0, y0, z0)`` and ``(x1, y1, z1)`` (mm)."""
    return Manifold.cube([x1 - x0, y1 - y0, z1 - z0]).translate([x0, y0, z0])


def circle(r: float, cx: float = 0.0, cy: float = 0.0, n: int = SEGMENTS) -> np.ndarray:
    """``(n, 2)`` vertices of a regular n-gon of circumradius ``r`` (mm) about ``(cx, cy)``,
    counter-clockwise, first vertex at angle 0, coordinates rounded to :data:`GRID`."""
    k = np.arange(n)
    pts = np.column_stack([cx + r * np.cos(2 * np.pi * k / n), cy + r * np.sin(2 * np.pi * k / n)])
    return np.round(pts / GRID) * GRID


def prism(polygon, z0: float, z1: float) -> Manifold:
    """Extrusion of a counter-clockwise ``(k, 2)`` polygon (x, y in mm) from ``z0`` to ``z1``."""
    section = CrossSection([np.asarray(polygon, dtype=float)])
    return Manifold.extrude(section, z1 - z0).translate([0.0, 0.0, z0])


def cylinder(r: float, z0: float, z1: float, cx: float = 0.0, cy: float = 0.0) -> Manifold:
    """Facetted vertical cylinder of circumradius ``r`` about ``(cx, cy)``, ``z0..z1`` (mm)."""
    return prism(circle(r, cx, cy), z0, z1)


def tube(r_in: float, r_out: float, z0: float, z1: float, cx: float = 0.0,
         cy: float = 0.0) -> Manifold:
    """Facetted vertical tube (mm); its bore has the same facets as ``cylinder(r_in, ...)``."""
    return cylinder(r_out, z0, z1, cx, cy) - cylinder(r_in, z0 - 1.0, z1 + 1.0, cx, cy)


def along_x(m: Manifold) -> Manifold:
    """Map a solid built along +z onto +x by the cyclic permutation (x, y, z) <- (z, x, y)."""
    return m.transform(np.array([[0, 0, 1, 0], [1, 0, 0, 0], [0, 1, 0, 0]], dtype=float))


def xz_prism(polygon, y0: float, y1: float) -> Manifold:
    """Extrusion along y (``y0..y1``, mm) of a polygon given in the (x, z) plane."""
    m = prism(polygon, 0.0, y1 - y0)  # (X, Y, Z) = (x, z, t)
    return m.transform(np.array([[1, 0, 0, 0], [0, 0, -1, y1], [0, 1, 0, 0]], dtype=float))


def screw(head_r: float = 3.5, head_h: float = 3.0, shank_r: float = 1.5,
          shank_len: float = 8.0) -> Manifold:
    """Screw in its own frame: head ``z in [0, head_h]``, shank ``z in [-shank_len, 0]`` (mm)."""
    return cylinder(head_r, 0.0, head_h) + cylinder(shank_r, -shank_len, 0.0)


# -- output -------------------------------------------------------------------------------

def write_stl(m: Manifold, path: Path) -> None:
    """Write a manifold as a binary STL (float32 coordinates, mm)."""
    mesh = m.to_mesh()
    v = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    f = np.asarray(mesh.tri_verts, dtype=np.int64)
    if m.status().name != "NoError" or len(f) == 0:
        raise RuntimeError(f"bad solid for {path}: {m.status()}")
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(trimesh.Trimesh(v, f, process=False).export(file_type="stl"))


class _Dumper(yaml.SafeDumper):
    """Safe YAML dumper writing short lists (vectors, pairs, polygons) on one line."""


def _represent_list(dumper: yaml.SafeDumper, items: list) -> yaml.Node:
    def flat(x: object) -> bool:
        return not isinstance(x, (list, dict)) or (
            isinstance(x, list) and all(not isinstance(y, (list, dict)) for y in x))
    flow = all(flat(x) for x in items) and len(str(items)) <= 90
    return dumper.represent_sequence("tag:yaml.org,2002:seq", items, flow_style=flow)


_Dumper.add_representer(list, _represent_list)


def write_manifest(out: Path, name: str, comment: str, data: dict) -> None:
    """Write ``out/<name>.yaml``: a comment block (the hand derivations) and the data."""
    lines = [f"# {line}".rstrip() for line in comment.strip().splitlines()]
    body = yaml.dump(data, Dumper=_Dumper, sort_keys=False, width=100)
    text = "\n".join(lines) + "\n" + body
    (out / f"{name}.yaml").write_text(text, encoding="utf-8")


def mesh_assembly(out: Path, name: str, description: str, solids: dict[str, Manifold],
                  expect: dict, comment: str, *, base: str | None = None,
                  joints: list | None = None, extra_parts: list | None = None) -> None:
    """Write one STL per solid under ``meshes/<name>/`` and the manifest (identity placement)."""
    parts = []
    for pid, solid in solids.items():
        write_stl(solid, out / "meshes" / name / f"{pid}.stl")
        parts.append({"id": pid, "mesh": f"meshes/{name}/{pid}.stl"})
    parts.extend(extra_parts or [])
    data: dict = {"name": name, "description": description, "units": "mm"}
    if base:
        data["base"] = base
    data["parts"] = parts
    if joints:
        data["joints"] = joints
    data["expect"] = expect
    write_manifest(out, name, comment, data)


def pairs(*names: str) -> list[list[str]]:
    """``"a b"`` strings to ``[a, b]`` pairs."""
    return [n.split() for n in names]


# -- 1. electric bell ---------------------------------------------------------------------

BELL_SCREWS = {  # id: (head-bottom centre, rotation about z in degrees: a multiple of 15)
    "yoke_screw_1": ((74, 54, 10), 90),
    "yoke_screw_2": ((106, 26, 10), 180),
    "gong_screw": ((30, 40, 60), 0),
    "post_screw": ((132, 30, 9), 0),
    "strip_screw": ((124, 40, 43), 0),
    "contact_screw": ((110, 40, 55), 0),
}


def bell(out: Path) -> None:
    """22-part electric bell (paper Fig. 7); every part leaves along +z in some order."""
    holes = {k: cylinder(1.5, c[2] - 8, c[2] + 1, c[0], c[1]) for k, (c, _) in BELL_SCREWS.items()}
    s = {}
    s["base"] = (box(0, 0, 0, 160, 80, 6) - cylinder(4, 2, 7, 30, 40)
                 - cylinder(3, 2, 7, 10, 10) - cylinder(3, 2, 7, 10, 70)
                 - cylinder(3, 2, 7, 110, 66)
                 - holes["yoke_screw_1"] - holes["yoke_screw_2"] - holes["post_screw"])
    s["terminal_1"] = cylinder(3, 2, 16, 10, 10)
    s["terminal_2"] = cylinder(3, 2, 16, 10, 70)
    s["gong_post"] = cylinder(4, 2, 57, 30, 40) - holes["gong_screw"]
    s["gong"] = (cylinder(25, 50, 60, 30, 40) - cylinder(22, 49, 57, 30, 40)
                 - holes["gong_screw"])
    s["yoke"] = (box(70, 22, 6, 110, 58, 10) - cylinder(5, 5, 11, 80, 40)
                 - cylinder(5, 5, 11, 100, 40) - holes["yoke_screw_1"] - holes["yoke_screw_2"])
    s["core_left"] = cylinder(5, 6, 36, 80, 40)
    s["core_right"] = cylinder(5, 6, 36, 100, 40)
    s["coil_left"] = tube(5, 9, 10, 34, 80, 40)
    s["coil_right"] = tube(5, 9, 10, 34, 100, 40)
    s["armature_post"] = (box(116, 26, 6, 136, 54, 9) + box(120, 34, 9, 128, 46, 42)
                          - holes["post_screw"] - holes["strip_screw"])
    s["spring_strip"] = box(112, 35, 42, 132, 45, 43) - holes["strip_screw"]
    s["armature"] = box(76, 35, 43, 118, 45, 47) - cylinder(1.5, 44, 48, 78, 40)
    s["clapper_arm"] = (box(60, 38, 47, 80, 42, 49) + cylinder(1.5, 44, 47, 78, 40)
                        - cylinder(1, 46, 50, 63, 40))
    s["hammer"] = cylinder(3, 49, 56, 63, 40) + cylinder(1, 47, 49, 63, 40)
    s["contact_post"] = (box(106, 62, 6, 114, 70, 55) + box(106, 36, 51, 114, 62, 55)
                         + cylinder(3, 2, 6, 110, 66) - holes["contact_screw"])
    name = "bell"
    parts = []
    for pid, solid in s.items():
        write_stl(solid, out / "meshes" / name / f"{pid}.stl")
        parts.append({"id": pid, "mesh": f"meshes/{name}/{pid}.stl"})
    write_stl(screw(), out / "meshes" / name / "screw.stl")
    for pid, (centre, angle) in BELL_SCREWS.items():
        entry: dict = {"id": pid, "mesh": f"meshes/{name}/screw.stl",
                       "translation": list(centre)}
        if angle == 90:
            entry["rotation"] = {"axis": [0, 0, 1], "angle": 90}
        elif angle:
            entry["rotation"] = {"euler": [0, 0, angle], "order": "xyz"}
        parts.append(entry)
    order = ["terminal_1", "terminal_2", "gong_screw", "gong", "gong_post", "hammer",
             "contact_screw", "contact_post", "clapper_arm", "armature", "strip_screw",
             "spring_strip", "post_screw", "armature_post", "coil_left", "coil_right",
             "core_left", "core_right", "yoke_screw_1", "yoke_screw_2", "yoke"]
    free_first = ["terminal_1", "terminal_2", "gong_screw", "yoke_screw_1", "yoke_screw_2",
                  "post_screw", "strip_screw", "contact_screw", "hammer"]
    expect = {
        "parts": 22,
        "contact_pairs": pairs(
            "base terminal_1", "base terminal_2", "base gong_post", "gong_post gong",
            "gong gong_screw", "gong_post gong_screw", "base yoke", "base core_left",
            "base core_right", "yoke core_left", "yoke core_right", "yoke coil_left",
            "yoke coil_right", "coil_left core_left", "coil_right core_right",
            "yoke_screw_1 yoke", "yoke_screw_1 base", "yoke_screw_2 yoke", "yoke_screw_2 base",
            "base armature_post", "post_screw armature_post", "post_screw base",
            "armature_post spring_strip", "strip_screw spring_strip",
            "strip_screw armature_post", "spring_strip armature", "armature clapper_arm",
            "clapper_arm hammer", "armature contact_screw", "contact_screw contact_post",
            "base contact_post"),
        "linearizable": True,
        "one_handed_monotone": True,
        "stack_product": True,
        "removable_first": [{"part": p, "direction": [0, 0, 1]} for p in free_first],
        "locally_free_first": [{"part": p, "direction": [0, 0, 1]}
                               for p in free_first + ["core_left", "core_right",
                                                      "coil_left", "coil_right"]],
        "base_partition": {"moved": ["base"], "direction": [0, 0, -1],
                           "note": "the rest lifts off the fixed base along +z"},
        "blocked_globally_by": {"core_left": ["armature", "clapper_arm"],
                                "core_right": ["armature"],
                                "coil_left": ["armature", "clapper_arm"],
                                "coil_right": ["armature", "contact_post", "contact_screw"]},
        "sequence": [{"part": p, "direction": [0, 0, 1]} for p in order],
    }
    comment = """\
Electric bell (Wilson & Latombe 1994, Fig. 7), 22 parts, units mm, base fixed.
Built by assemblies/build.py. The six screws share meshes/bell/screw.stl (head r 3.5 x 3, shank
r 1.5 x 8 below the head) placed by translation (+ rotation about z by 90 or 180 deg, which maps
the 24-gon shank onto itself, so it still fits its hole facet for facet).
Layout: base 160x80x6. Gong post (r4, z 2..57) in a blind base hole at (30,40); inverted-cup gong
(r25, z 50..60, hollow r22 below z 57) on the post top, held by gong_screw into the post.
Yoke 40x36x4 on the base, held by two screws into the base; cores (r5, z 6..36) stand on the
base through yoke holes; coils (tubes r5..9, z 10..34) sit on the yoke around the cores.
Armature post (foot + column to z 42) screwed to the base by post_screw through the foot; the
spring strip (1 mm) lies on the column and is clamped by strip_screw; the armature (z 43..47)
lies on the strip and over the cores with a 7 mm gap; the clapper arm lies on the armature with
a peg in an armature hole; the hammer stands on the arm with a peg through it (4 mm clear of
the gong). Contact post (column with a base peg at (110,66), arm over the armature at z 51..55)
carries the contact screw whose tip touches the armature top at (110,40). Terminals: pegs r3.
contact_pairs: every face contact designed above (resting faces, pegs and screws in holes).
removable_first (single infinite translation, whole product assembled): a part is free iff
nothing rests on it and nothing hovers over it: the two terminals, the six screws (every
head is clear above: checked against the contact post arm at x 106..114 y 36..70 and the
armature x 76..118 y 35..45), and the hammer; all only along +z
(pegs and shanks in holes leave only the +z ray).
locally_free_first (infinitesimal): those plus the cores and coils (held only by coincident
cylinder facets and the faces below); parts hover over them, so they are blocked for the
infinite translation: the armature (x 76..118, y 35..45) covers all four, the clapper arm
(x 60..80, y 38..42) also covers core_left (x 75..85) and coil_left (x 71..89), and the
contact post arm (x 106..114, y 36..62) and contact screw head (x >= 106.5) cover coil_right
(x 91..109); core_right (x 95..105) only under the armature (blocked_globally_by).
base_partition: every part touching the base rests on it or is pegged into it from above, so
{base} | rest is also free (base along -z); with the base fixed this is not a removal.
sequence: a linear removal order, every step +z, checked part by part (so linearizable,
one-handed monotone, and a stack product along +z).
"""
    data = {"name": name, "description": "electric bell in the spirit of Fig. 7 of the paper",
            "units": "mm", "base": "base", "parts": parts, "expect": expect}
    write_manifest(out, name, comment, data)


# -- 2. Fig. 3 in 2D ----------------------------------------------------------------------

def fig3_2d(out: Path) -> None:
    """Four polygons with the DBG facts of section 4.1 (tongue-and-groove joints)."""
    def sc(pts):
        return [[10 * x, 10 * y] for x, y in pts]

    polys = {
        "P1": sc([(0, 7), (6, 7), (6, 8), (8, 8), (8, 9), (6, 9), (6, 10), (0, 10)]),
        "P2": sc([(6, 7), (12, 7), (12, 10), (6, 10), (6, 9), (8, 9), (8, 8), (6, 8)]),
        "P3": sc([(0, 4), (5, 4), (5, 2), (7, 2), (7, 4), (12, 4), (12, 7), (0, 7)]),
        "P4": sc([(0, 0), (12, 0), (12, 4), (7, 4), (7, 2), (5, 2), (5, 4), (0, 4)]),
    }
    r = 1 / math.sqrt(2)
    expect = {
        "parts": 4,
        "contact_pairs": pairs("P1 P2", "P1 P3", "P2 P3", "P3 P4"),
        "d1": [0.0, 1.0],
        "d2": [r, -r],
        "dbg_d1": pairs("P1 P2", "P2 P1", "P3 P1", "P3 P2", "P4 P3"),
        "dbg_d2": pairs("P1 P2", "P2 P1", "P1 P3", "P2 P3", "P3 P4", "P4 P3"),
        "locally_free_d1": [["P1", "P2"], ["P1", "P2", "P3"]],
        "locally_free_d2": [["P3", "P4"]],
        "free_cones": {"P1 rel P2": {"ray": [-1, 0]}, "P1 rel P3": {"half_plane": [0, 1]},
                       "P2 rel P3": {"half_plane": [0, 1]}, "P3 rel P4": {"ray": [0, 1]}},
        "regions": {"total": 8, "points": 4, "arcs": 4,
                    "point_directions": [[1, 0], [0, 1], [-1, 0], [0, -1]]},
    }
    comment = """\
Paper Fig. 3 redesigned (units mm, coordinates x10 of the sketch below).
P4: bottom bar 0..12 x 0..4 with a vertical groove 5..7 x 2..4; P3: bar 0..12 x 4..7 with a
tongue down into that groove; P1 (left, 0..6 x 7..10) has a tongue 6..8 x 8..9 pointing +x
into a groove of P2 (right, 6..12 x 7..10). P1 and P2 rest on P3.
Arcs of G(d): Pi -> Pj iff d . n > 0 for an outward normal n of Pi on an edge touching Pj.
P1-P2 contact normals of P1: +x (3 edges), +y, -y; of P2: -x, -y, +y. P1/P2 on P3: -y; P3 to
P1/P2: +y. P3 to P4: -y (shoulders, tip), -x, +x; P4 to P3: +y, +x, -x.
d1 = +y: arcs P1<->P2, P3->P1, P3->P2, P4->P3 (P3 has no +y normal on P4). Closed sets
(no arc leaving): {P1,P2}, {P1,P2,P3} only (any set with P4 needs P3, any with P3 needs
P1, P2). d2 = (1,-1)/sqrt2: P1<->P2 (+x / -y), P1->P3, P2->P3 (-y), P3<->P4 (-y / +x), no
arc from P3 or P4 to P1/P2 (P3's normal there is +y): only {P3,P4} is free.
Regions (refined arrangement): free cones per contacting pair: P1 rel P2 = ray -x (one
diameter, the x axis); P1 rel P3 and P2 rel P3 = half-plane y >= 0 (x axis again); P3 rel P4 =
ray +y (the y axis). Distinct endpoints: +x, +y, -x, -y (4 points) and the 4 open arcs between
them: 8 regions (the paper's own figure has 20). Every contact edge is axis-parallel, so the
unrefined arrangement (a diameter per contact edge) has the same 4 points and 4 arcs.
"""
    data = {"name": "fig3-2d", "description": "paper Fig. 3: four polygons, two DBGs",
            "units": "mm", "dimension": 2,
            "parts": [{"id": k, "polygon": v} for k, v in polys.items()], "expect": expect}
    write_manifest(out, "fig3-2d", comment, data)


# -- 3. Fig. 2 sandwich -------------------------------------------------------------------

def sandwich(out: Path, n: int) -> None:
    """``n`` parts: ``n - 2`` tongue-jointed blocks in a tray (bottom) under a lid (top)."""
    k = n - 2
    length = 20 * k
    solids = {"bottom": box(-5, -15, 0, length + 5, 15, 15) - box(0, -10, 5, length, 10, 16)}
    for i in range(k):
        x0 = 20 * i
        block = box(x0, -10, 5, x0 + 20, 10, 15)
        if i < k - 1:
            block = block + box(x0 + 20, -3, 7, x0 + 25, 3, 13)   # tongue into the next block
        if i > 0:
            block = block - box(x0, -3, 7, x0 + 5, 3, 13)         # socket for the previous one
        solids[f"m{i + 1}"] = block
    solids["top"] = box(-5, -15, 15, length + 5, 15, 20)
    inner = [f"m{i + 1}" for i in range(k)]
    expect = {
        "parts": n,
        "feasible_decompositions": [
            {"moved": ["top"], "direction": [0, 0, 1],
             "free_directions": "closed upper hemisphere d_z >= 0"},
            {"moved": ["bottom"], "direction": [0, 0, -1], "free_directions": "ray -z only"},
        ],
        "decomposition_count": 2,
        "inner_parts": inner,
    }
    comment = f"""\
Paper Fig. 2: {k} interlocking blocks m1..m{k} sandwiched between two plates, {n} parts.
bottom: a tray (floor z 0..5, walls 5 thick, pocket 0..{length} x -10..10 x 5..15); top: a
plate z 15..20 lying on the tray walls and on the blocks. Block m(i) (20 wide) has a 5 mm
rectangular tongue (6x6) pointing +x into a blind socket of m(i+1), so m(i) relative to
m(i+1) is free only along the -x ray.
Hand derivation of the feasible decompositions (infinitesimal translations): top touches only
faces below it, so {{top}} is free for every d with d_z >= 0. The pocket walls and floor leave
every block only +z relative to bottom, and the top leaves them only d_z <= 0, so {{bottom}} is
free along -z (the rest lifts out). Any other split either separates two neighbouring blocks
(possible only along -x for the left group, +x for the right one; non-contiguous groups need
both), and then m1 hits the tray wall x=0 or m{k} the wall x={length}; or moves the blocks
without the top/bottom plate (blocked by the plate in z, by the walls sideways).
Exactly two decompositions: {{top}} | rest and {{bottom}} | rest.
"""
    mesh_assembly(out, f"fig2-sandwich-{n}", f"paper Fig. 2 with {n} parts", solids, expect,
                  comment)


# -- 4. Fig. 5: rotation needed -----------------------------------------------------------

def fig5_rotation(out: Path) -> None:
    """A square key in a pocket with pinwheel contacts and corner lips: freed by turning."""
    h = 10.0
    big_r = h * math.sqrt(2)
    t = h * math.tan(math.radians(22.5))
    m = 4
    delta = 45.0 / m
    quadrant = [(h, t), (h, h)]
    for j in range(m):
        a = math.radians(45 + (j + 0.5) * delta)
        rr = big_r / math.cos(math.radians(delta / 2))
        quadrant.append((rr * math.cos(a), rr * math.sin(a)))
    quadrant.append((0.0, big_r))
    cavity = []
    for q in range(4):  # exact quarter turns: (x, y) -> (-y, x)
        for x, y in quadrant:
            for _ in range(q):
                x, y = -y, x
            cavity.append((x, y))
    diamond = [(big_r, 0.0), (0.0, big_r), (-big_r, 0.0), (0.0, -big_r)]
    housing = box(-25, -25, 0, 25, 25, 20) - prism(cavity, 5, 15) - prism(diamond, 10, 21)
    key = box(-h, -h, 5, h, h, 15)
    p = round(t, 6)
    expect = {
        "parts": 2,
        "translation_free": False,
        "rotation": {"axis": [0, 0, 1], "point": [0, 0, 0], "sense": "counter-clockwise",
                     "moved": "key"},
        "rotation_free_clockwise": False,
        "pad_contacts": {"x=+10": [[10, p], [10, 10]], "y=+10": [[-p, 10], [-10, 10]],
                         "x=-10": [[-10, -p], [-10, -10]], "y=-10": [[p, -10], [10, -10]]},
        "after_rotation": {"angle_deg": 45, "then_translate": [0, 0, 1]},
    }
    comment = """\
Paper Fig. 5 in 3D: a key that must turn. housing (fixed) = box 50x50x20 with a pocket
(z 5..15) and an opening above (z 15..20) shaped as the square rotated 45 deg (|x|+|y| <= 10
sqrt2); key = box -10..10 x -10..10 x 5..15. The pocket is the region the key sweeps turning
0..45 deg counter-clockwise about z (sides of the start and end squares, corner arcs of radius
10 sqrt2 replaced by circumscribed polygons), so the housing touches the key's sides only on
four pinwheel pads: x=10 for y in [10 tan22.5, 10] (= [4.142, 10]) and its quarter-turn images.
Contacts and normals m (housing -> key): floor m=+z, lips over the 4 corner triangles outside
the opening m=-z, pads m=-x, -y, +x, +y: all six axis directions, so no translation is free.
Rotation w = +z about the z axis, velocity v = w x p: floor and lips: v . m = 0 (sliding).
Pad x=10: m=(-1,0,0), v . m = y >= 4.142 > 0 at both ends; pad y=10 (x in [-10,-4.142]):
m=(0,-1,0), v . m = -x >= 4.142; the others by symmetry. So the turn is free and breaks
every side contact; clockwise gives v . m < 0 (blocked). After 45 deg the key fits the opening
and leaves along +z.
"""
    mesh_assembly(out, "fig5-rotation", "paper Fig. 5: a part freed only by rotation",
                  {"housing": housing, "key": key}, expect, comment, base="housing")


# -- 5. Fig. 10: latch, 2-handed ----------------------------------------------------------

def fig10_latch(out: Path) -> None:
    """Two tilted pegs in blind slots of a base, hooked together by a wedge nose."""
    alpha = math.radians(30.0)

    def peg(px: float, sign: float, u1: float) -> list[tuple[float, float]]:
        a = (sign * math.sin(alpha), math.cos(alpha))
        e = (math.cos(alpha), -sign * math.sin(alpha))
        pts = [(-12, -3), (-12, 3), (u1, 3), (u1, -3)]
        poly = [(px + u * a[0] + w * e[0], u * a[1] + w * e[1]) for u, w in pts]
        return _ccw(poly)

    a_peg, b_peg = peg(10, 1, 20), peg(-10, -1, 20)
    base = box(-40, -15, -20, 40, 15, 0) - xz_prism(peg(10, 1, 40), -5, 5) \
        - xz_prism(peg(-10, -1, 40), -5, 5)
    part_a = xz_prism(a_peg, -5, 5) + xz_prism(
        [(2, 6), (22, 6), (22, 14), (2, 14), (6, 10)], -5, 5)
    part_b = xz_prism(b_peg, -5, 5) + xz_prism(
        [(-20, 6), (2, 6), (6, 10), (2, 14), (-20, 14)], -5, 5)
    sa, ca = math.sin(alpha), math.cos(alpha)
    expect = {
        "parts": 3,
        "one_handed_monotone": False,
        "interlocked": False,
        "two_handed_monotone": True,
        "fixed": "base",
        "two_handed_separation": [{"part": "latch_a", "direction": [sa, 0.0, ca]},
                                  {"part": "latch_b", "direction": [-sa, 0.0, ca]}],
        "free_cones": {"latch_a rel base": {"ray": [sa, 0.0, ca]},
                       "latch_b rel base": {"ray": [-sa, 0.0, ca]},
                       "latch_a rel latch_b": "d_x cos45 >= |d_z| sin45 (y free)"},
    }
    comment = """\
Paper Fig. 10: three-part latch. base: block 80x30x20 (top at z=0) with two blind slots
6x10 tilted 30 deg from vertical in the xz plane. latch_a: a 6x10 bar in the right slot
(axis a = (sin30, 0, cos30), through (10,0,0), bottom 12 mm down the axis) with a head at
z 6..14 holding a V notch; latch_b: the mirror bar (axis b = (-sin30, 0, cos30) through
(-10,0,0)) with an arm whose wedge nose (faces at +-45 deg) sits in that notch.
Free cones: latch_a rel base = ray a; latch_b rel base = ray b; latch_a rel latch_b =
{d : d . (cos45,0,-sin45) >= 0 and d . (cos45,0,sin45) >= 0} = d_x >= |d_z| (any d_y).
1-handed: a is not in the A-B cone (0.5 < 0.866), so latch_a alone is blocked; -b is not in it
either (latch_b alone blocked); rays a != b, so {latch_a, latch_b} cannot leave the base
together. Every partition is blocked for every d: not 1-handed monotone (every DBG strongly
connected). 2-handed: move latch_a along a and latch_b along b at the same speed: relative
motion a - b = (2 sin30, 0, 0) = +x, inside the A-B cone, and nothing else is in the way:
the latch is not interlocked.
"""
    mesh_assembly(out, "fig10-latch", "paper Fig. 10: three-part latch, 2-handed",
                  {"base": base, "latch_a": part_a, "latch_b": part_b}, expect, comment,
                  base="base")


def _ccw(poly: list[tuple[float, float]]) -> list[tuple[float, float]]:
    area = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(poly, poly[1:] + poly[:1]))
    return poly if area > 0 else poly[::-1]


# -- 6. Fig. 11: 1-handed but not linearizable --------------------------------------------

def fig11_nonlinear(out: Path) -> None:
    """Channel + lid (pegged) and slider + hook (keyed): only pairs come off first."""
    channel = (box(0, -15, 0, 40, 15, 20) - box(-1, -12, 5, 41, 12, 8)
               - box(-1, -10, 7, 41, 10, 21))
    pegs = [box(x, y, 15, x + 4, y + 3, 20) for x in (8, 28) for y in (11, -14)]
    holes = [box(x, y, 15, x + 4, y + 3, 21) for x in (8, 28) for y in (11, -14)]
    for hole in holes:
        channel = channel - hole
    lid = box(0, -15, 20, 40, 15, 25)
    for p in pegs:
        lid = lid + p
    bump = box(15, -4, 12, 25, 4, 14)
    slider = box(0, -12, 5, 40, 12, 8) + box(0, -10, 8, 40, 10, 12) + bump
    hook = (box(0, -10, 12, 40, 10, 20) - bump + box(40, -8, 12, 46, 8, 30)
            + box(30, -8, 25, 46, 8, 30))
    expect = {
        "parts": 4,
        "one_handed_monotone": True,
        "linearizable": False,
        "first_subassemblies": [{"moved": ["slider", "hook"], "direction": [1, 0, 0]},
                                {"moved": ["hook", "lid"], "direction": [0, 0, 1]}],
        "free_cones": {"slider rel channel": {"line": [1, 0, 0]},
                       "slider rel hook": {"ray": [0, 0, -1]},
                       "lid rel channel": {"ray": [0, 0, 1]},
                       "hook rel channel": "d_y = 0",
                       "hook rel lid": "d_z = 0 and d_x >= 0"},
    }
    comment = """\
Paper Fig. 11: a 1-handed product that is not linearizable (4 parts, x 0..40).
channel: U section (floor z 0..5, walls |y| 10..15 up to z 20) with side grooves |y| < 12 at
z 5..8; slider: T bar filling the grooves (z 5..12) with a bump (x 15..25, |y|<4, z 12..14);
hook: fills the channel above the slider (z 12..20) with a recess for the bump, and at x 40..46
rises to z 30 and turns back over the lid (flange x 30..46, z 25..30); lid: plate z 20..25 on
the walls with four square pegs in blind holes of the walls.
Free cones (hand): slider rel channel = line +-x (grooves); slider rel hook = ray -z (bump);
lid rel channel = ray +z (pegs); hook rel channel = plane d_y = 0; hook rel lid = d_z = 0
(under and over the lid) and d_x >= 0 (hook face against the lid end).
Single parts: slider: line x ^ ray -z = 0; hook: (d_y=0) ^ (d_z=0, d_x>=0) ^ ray +z = 0; lid:
ray +z ^ (d_z <= 0 under the flange) = 0; channel (the other three together): slider's line
x ^ lid's ray +z = 0. No part comes off alone: not linearizable.
Pairs: {slider, hook} vs {channel, lid} along +x (slider line x, hook d_y=0 and d_x>=0);
{hook, lid} vs {channel, slider} along +z (hook rel slider +z, hook rel channel d_y=0, lid +z);
{slider, lid} is blocked (slider alone already is). Then each pair separates (slider -z from
the hook; lid +z from the channel): 1-handed monotone.
"""
    mesh_assembly(out, "fig11-nonlinear", "paper Fig. 11: 1-handed, not linearizable",
                  {"channel": channel, "slider": slider, "hook": hook, "lid": lid}, expect,
                  comment, base="channel")


# -- 7. stack -----------------------------------------------------------------------------

def stack(out: Path) -> None:
    """Base, pin, two plates and a cap stacked along z."""
    solids = {
        "base": box(-20, -20, 0, 20, 20, 10) - cylinder(4, 5, 11),
        "pin": cylinder(4, 5, 30),
        "plate_a": box(-20, -20, 10, 20, 20, 20) - cylinder(4, 9, 21),
        "plate_b": box(-20, -20, 20, 20, 20, 30) - cylinder(4, 19, 31),
        "cap": box(-20, -20, 30, 20, 20, 35),
    }
    expect = {
        "parts": 5,
        "stack_product": True,
        "direction": [0, 0, 1],
        "linearizable": True,
        "sequence": ["cap", "plate_b", "plate_a", "pin"],
    }
    comment = """\
Stack product: base (40x40x10, blind hole r4 z 5..10), pin (r4, z 5..30), plates a and b
(z 10..20, 20..30, holes r4), cap (z 30..35) on plate b and the pin top.
Each part only rests on the one below (or sits in its hole); removing the top one each time
along +z: cap, plate_b, plate_a, pin (base last): one direction for every step.
"""
    mesh_assembly(out, "stack", "stack product along z", solids, expect, comment, base="base")


# -- 8. pegs at 37 degrees ----------------------------------------------------------------

def _tilted_peg(length: float, centre: tuple[float, float, float], start: float) -> Manifold:
    """Facetted r4 cylinder along (sin37, 0, cos37) from ``start`` to ``start + length`` along
    the axis, measured from ``centre`` (mm)."""
    return cylinder(4, start, start + length).rotate([0, 37, 0]).translate(list(centre))


def pegs37(out: Path) -> None:
    """Peg in a through hole and in a blind hole, axis 37 deg from vertical."""
    axis = [SIN37, 0.0, COS37]
    block = box(-20, -20, 0, 20, 20, 30)
    through = _tilted_peg(80, (0, 0, 15), -40)
    expect = {"parts": 2, "removal_directions": [axis, [-a for a in axis]],
              "axis": axis, "angle_from_vertical_deg": 37}
    comment = """\
Peg (r4, 24 facets) in a through hole drilled at 37 deg from vertical (in the xz plane) through
the centre of a 40x40x30 block; the peg is the hole's volume, flush with both faces.
The facetted peg in the coincident facetted hole can only slide along the axis; both ends are
open: removal along +axis and -axis, axis = (sin37, 0, cos37).
"""
    mesh_assembly(out, "peg-37", "peg in a 37 deg through hole",
                  {"block": block - through, "peg": through ^ block}, expect, comment,
                  base="block")
    blind = _tilted_peg(40, (-10, 0, 10), 0)
    expect = {"parts": 2, "removal_directions": [axis], "axis": axis,
              "angle_from_vertical_deg": 37}
    comment = """\
Peg in a blind hole at 37 deg from vertical: the hole's flat bottom (perpendicular to the axis,
centre (-10,0,10)) is inside the block; the peg fills the hole up to the top face.
The bottom face blocks -axis; the walls block every other direction: removal only along
+axis = (sin37, 0, cos37).
"""
    mesh_assembly(out, "peg-blind", "peg in a 37 deg blind hole",
                  {"block": block - blind, "peg": blind ^ block}, expect, comment,
                  base="block")


# -- 9. hover -----------------------------------------------------------------------------

def hover(out: Path) -> None:
    """A puck under a bridge (blocked only for infinite +z) and with the bridge moved aside."""
    for name, dy in (("hover", 0), ("hover-shifted", 25)):
        bridge = (box(-30, -10 + dy, 5, -20, 10 + dy, 30) + box(20, -10 + dy, 5, 30, 10 + dy, 30)
                  + box(-30, -10 + dy, 25, 30, 10 + dy, 30))
        solids = {"base": box(-40, -20, 0, 40, 40, 5), "puck": box(-10, -10, 5, 10, 10, 15),
                  "bridge": bridge}
        shifted = dy != 0
        expect = {
            "parts": 3,
            "contact_pairs": pairs("base puck", "base bridge"),
            "infinitesimal": {"puck_free_plus_z": True, "puck_free_cone": "d_z >= 0"},
            "infinite": {"puck_free_plus_z": shifted,
                         "puck_plus_z_blocked_by": [] if shifted else ["bridge"],
                         "puck_free_plus_y": True},
        }
        comment = f"""\
{"Shifted variant: the bridge moved 25 mm along +y, no longer above the puck." if shifted
 else "A puck resting on the base under a bridge (legs on the base, deck z 25..30)."}
puck 20x20x10 on the base; the bridge never touches it (legs at |x| >= 20, deck 10 mm above).
Infinitesimal: the puck touches only the base top, free for every d with d_z >= 0.
Infinite translation along +z: the puck's sweep {"misses" if shifted else "hits"} the deck
({"deck at y 15..35, puck at y -10..10" if shifted else "deck over x -30..30, y -10..10"}).
Along +y the puck slides on the base under/past the deck and between the legs: free.
"""
        mesh_assembly(out, name, "a part hovering over another" if not shifted
                      else "hover with the bridge moved aside", solids, expect, comment,
                      base="base")


# -- 10. slot at 37 degrees ---------------------------------------------------------------

def slot37(out: Path) -> None:
    """A block in a closed rectangular slot through a wall at 37 deg in the horizontal plane."""
    wall = box(-30, -10, 0, 30, 10, 40)
    tunnel = Manifold.cube([80, 6, 8], center=True).rotate([0, 0, 37]).translate([0, 0, 20])
    d = [COS37, SIN37, 0.0]
    expect = {"parts": 2, "slot_direction": d, "removal_directions": [d, [-d[0], -d[1], 0.0]]}
    comment = """\
A wall (60x20x40, faces at y = +-10) pierced by a closed rectangular slot 6 wide x 8 high
(z 16..24) whose axis runs at 37 deg from +x in the horizontal plane; the block fills the slot
and is flush with both wall faces. Slot walls block the block in every direction
perpendicular to the axis; both ends are open: removal only along +-(cos37, sin37, 0).
"""
    mesh_assembly(out, "slot-37", "block in a slot at 37 deg", {"wall": wall - tunnel,
                  "block": tunnel ^ wall}, expect, comment, base="wall")


# -- 11. hinge ----------------------------------------------------------------------------

def hinge(out: Path) -> None:
    """Leaf A (one knuckle) and leaf B (two knuckles) on a pin along x."""
    def knuckle(x0: float, x1: float) -> Manifold:
        return along_x(tube(3, 6, x0, x1))

    pin = along_x(cylinder(3, 0, 30))
    leaf_b = (knuckle(0, 10) + knuckle(20, 30) + box(0, -40, -1, 30, -7, 1)
              + box(0, -7, -1, 10, -4, 1) + box(20, -7, -1, 30, -4, 1))
    leaf_a = knuckle(10, 20) + box(0, 7, -1, 30, 40, 1) + box(10, 4, -1, 20, 7, 1)
    expect = {
        "parts": 3,
        "axis": [1, 0, 0],
        "point": [0, 0, 0],
        "pin_removal_directions": [[1, 0, 0], [-1, 0, 0]],
        "leaf_a_translation_free": False,
        "leaf_a_rotation_with_joint": {"axis": [1, 0, 0], "point": [0, 0, 0]},
        "leaf_a_rotation_polyhedral": False,
    }
    comment = """\
Hinge along the x axis: pin r3 (24 facets) x 0..30; leaf_b has knuckles x 0..10 and 20..30,
leaf_a the knuckle x 10..20 (tubes r3..6 with the pin's facets); flat leaves at z -1..1.
Pin: coincident facets leave only the axis; both ends flush and open: removal along +-x.
leaf_a: the pin blocks y and z, leaf_b's knuckle faces at x=10 and x=20 block +-x: no
translation. A revolute joint (leaf_a about the pin axis) is declared: the hinge turns about
axis (1,0,0) through (0,0,0). Without it, the identical 24-gon facets of pin and bore block
even an infinitesimal turn in a strict polyhedral check: at a facet end p, w x (p - c) has
a component sin(7.5 deg)|p - c| into the other part (leaf_a_rotation_polyhedral: false).
"""
    mesh_assembly(out, "hinge", "hinge: pin through three knuckles",
                  {"leaf_b": leaf_b, "leaf_a": leaf_a, "pin": pin}, expect, comment,
                  base="leaf_b",
                  joints=[{"type": "revolute", "parts": ["leaf_a", "pin"], "axis": [1, 0, 0],
                           "point": [0, 0, 0]}])


# -- 12. bolts ----------------------------------------------------------------------------

def bolts(out: Path) -> None:
    """A bolt in a threaded (modelled plain) blind hole, with and without a screw joint."""
    block = box(-15, -15, 0, 15, 15, 20) - cylinder(4, 5, 21)
    bolt = cylinder(7, 20, 26) + cylinder(4, 5, 20)
    joint = {"type": "screw", "parts": ["bolt", "block"], "axis": [0, 0, 1],
             "point": [0, 0, 0], "pitch": 1.25}
    pitch_rate = round(1.25 / (2 * math.pi), 9)
    common = ("Bolt (head r7 z 20..26, shank r4 z 5..20) in a blind hole r4 (24 facets) of a\n"
              "30x30x20 block; the thread is not modelled (the hole fits the shank).\n")
    expect = {"parts": 2, "translation_free": False, "screw_motion_frees": True,
              "unscrew": {"omega": [0, 0, 1], "velocity_per_radian": [0, 0, pitch_rate],
                          "point": [0, 0, 0]}}
    mesh_assembly(out, "bolt-screw", "bolt in a threaded block with a screw joint",
                  {"block": block, "bolt": bolt}, expect,
                  common + """\
With the declared screw joint (right-hand, pitch 1.25) the bolt may only move helically:
pure translation out (+z) is blocked by the thread; unscrewing (turn +z, i.e. counter-
clockwise seen from above, advancing 1.25/(2 pi) mm per radian along +z) frees it.
""", base="block", joints=[joint])
    expect = {"parts": 2, "translation_free": True, "removal_directions": [[0, 0, 1]]}
    mesh_assembly(out, "bolt-plain", "the same bolt without a joint",
                  {"block": block, "bolt": bolt}, expect, common + """\
No joint: the shank's facets coincide with the hole's, the hole is blind and the head rests
on the top face: the bolt leaves only along +z.
""", base="block")


# -- 13. interferences of real CAD: a press fit, an overlap, a clash -----------------------

#: Facets of the press-fit example's cylinders: fine enough that a 0.03 mm radial interference
#: is thicker than the chord sag (r (1 - cos(pi / 96)) = 0.0054 mm at r 10).
PRESS_SEGMENTS = 96


def _fine_cylinder(r: float, z0: float, z1: float) -> Manifold:
    return prism(circle(r, n=PRESS_SEGMENTS), z0, z1)


def press_fit(out: Path) -> None:
    """A bearing pressed into a housing bore and a shaft pressed into the bearing."""
    solids = {
        "housing": (box(-30, -30, 0, 30, 30, 20) - _fine_cylinder(10, 5, 21)
                    - _fine_cylinder(6, -1, 6)),
        "bearing": _fine_cylinder(10.05, 5, 20) - _fine_cylinder(5, 4, 21),
        "shaft": _fine_cylinder(5.03, 0, 40),
    }
    expect = {
        "parts": 3,
        "interferences": [
            {"pair": ["housing", "bearing"], "kind": "press_fit", "axis": [0, 0, 1],
             "depth": 0.05, "radius": 10},
            {"pair": ["bearing", "shaft"], "kind": "press_fit", "axis": [0, 0, 1],
             "depth": 0.03, "radius": 5},
        ],
        "bearing_removal": [0, 0, 1],
        "shaft_removal": [[0, 0, 1], [0, 0, -1]],
        "press_steps": 2,
    }
    comment = """\
Housing 60x60x20 with a bore r 10 from z 5 up (a shoulder at z 5) and a clearance hole r 6
below it; a bearing (r 5 .. 10.05, z 5..20) pressed into the bore: radial interference
0.05 mm; a shaft r 5.03 (z 0..40) pressed into the bearing's bore r 5: 0.03 mm, passing the
clearance hole with 1 mm to spare. All cylinders have 96 facets (chord sag 0.0054 mm at r 10,
below both interferences). Both fits are coaxial about z: each pair slides along z only.
The shoulder stops the bearing going down: it leaves the housing along +z only; the shaft
leaves the bearing along +z or -z (the hole below is wider). Both separations are presses.
"""
    mesh_assembly(out, "press-fit", "press-fitted bearing and shaft", solids, expect, comment,
                  base="housing")


def overlap(out: Path) -> None:
    """A sheet-metal tray whose front and left walls overlap by 0.2 mm at their corner."""
    solids = {
        "floor": box(0, 0, 0, 100, 60, 3),
        "front": box(0, 0, 3, 100, 3, 40),
        "left": box(0, 2.8, 3, 3, 60, 40),
        "right": box(97, 3, 3, 100, 60, 40),
    }
    expect = {
        "parts": 4,
        "interferences": [
            {"pair": ["front", "left"], "kind": "overlap", "direction": [0, -1, 0],
             "depth": 0.2},
        ],
        "free_up": ["front", "left", "right"],
    }
    comment = """\
Floor 100x60x3; walls 3 thick and 37 high standing on it: front (y 0..3), left (x 0..3,
y 2.8..60) and right (x 97..100, y 3..60). The left wall was modelled 0.2 mm too long: it
overlaps the front wall in the slab x 0..3, y 2.8..3, z 3..40 (0.2 thick along y).
Moving front by 0.2 along -y (or left along +y) ends the overlap: a shallow overlap whose
separating direction for (front, left) is -y. Each wall alone lifts off the rest along +z
(nothing above; the overlap slides along z).
"""
    mesh_assembly(out, "overlap", "sheet-metal walls overlapping at a corner", solids, expect,
                  comment, base="floor")


def clash(out: Path) -> None:
    """A bracket modelled 3 mm into its plate (a clash), and a cover on the bracket."""
    solids = {
        "plate": box(-30, -20, 0, 30, 20, 5),
        "bracket": box(-10, -10, 2, 10, 10, 20),
        "cover": box(-10, -10, 20, 10, 10, 22),
    }
    expect = {
        "parts": 3,
        "interferences": [{"pair": ["plate", "bracket"], "kind": "clash"}],
        "unit": ["bracket", "plate"],
        "sequence": [["cover"]],
        "cover_removal": [0, 0, 1],
    }
    comment = """\
Plate 60x40x5; a bracket 20x20 from z 2 to 20, sunk 3 mm into the plate (a 20x20x3 block of
overlap: neither a press fit nor shallow); a cover 20x20x2 on the bracket's top.
The clash keeps plate and bracket together as one unit bracket+plate (ids in natural
order); the cover then lifts off along +z: a one-step plan.
"""
    mesh_assembly(out, "clash", "a bracket modelled into its plate", solids, expect, comment,
                  base="plate")


# -- 14. a gearbox, at any tessellation ----------------------------------------------------

def _ring(r: float, n: int, cx: float = 0.0, cy: float = 0.0) -> np.ndarray:
    """:func:`circle` with ``n`` facets (a hole is cut with more facets than the peg in it, as
    two CAD faces are tessellated independently)."""
    return circle(r, cx, cy, n=n)


def _gear_profile(r_root: float, r_tip: float, teeth: int, n: int) -> np.ndarray:
    """Counter-clockwise outline of a spur gear: ``teeth`` trapezoidal teeth between the root
    and tip circles, each arc cut into ``max(2, n // (4 teeth))`` pieces."""
    k = max(2, n // (4 * teeth))
    pts = []
    pitch = 2 * np.pi / teeth
    for t in range(teeth):
        a0 = t * pitch
        for a, r in ((np.linspace(a0, a0 + 0.4 * pitch, k, endpoint=False), r_root),
                     (np.linspace(a0 + 0.5 * pitch, a0 + 0.8 * pitch, k, endpoint=False), r_tip)):
            pts.extend(zip(r * np.cos(a), r * np.sin(a)))
    return np.round(np.asarray(pts) / GRID) * GRID


GEARBOX_BOLTS = ((30, 30), (-30, 30), (-30, -30), (30, -30))


def gearbox_solids(n: int) -> dict[str, Manifold]:
    """The 11 solids of :func:`gearbox` with ``n`` facets on the pegs (``n + n // 4`` on
    the holes)."""
    h = n + n // 4

    def cyl(r, z0, z1, cx=0.0, cy=0.0, m=n):
        # a hole's polygon circumscribes its circle: the peg's vertices (on the circle) touch
        # its facets at most, never cut into them
        return prism(_ring(r if m == n else r / math.cos(math.pi / m), m, cx, cy), z0, z1)

    housing = (box(-40, -40, 0, 40, 40, 40) - cyl(20, 10, 41, m=h) - cyl(9, -1, 11, m=h))
    cover = box(-40, -40, 40, 40, 40, 45) - cyl(10, 39, 46, m=h)
    for x, y in GEARBOX_BOLTS:
        housing = housing - cyl(3, 25, 41, x, y, m=h)
        cover = cover - cyl(3, 39, 46, x, y, m=h)
    solids = {
        "housing": housing,
        "bearing_low": cyl(20, 10, 20) - cyl(8, 9, 21, m=h),
        "bearing_up": cyl(20, 30, 38) - cyl(8, 29, 39, m=h),
        "spacer": cyl(20, 38, 40) - cyl(12, 37, 41, m=h),
        "cover": cover,
        "shaft": cyl(8, 0, 50) + cyl(12, 20, 30) + cyl(6, 50, 70),
        "gear": prism(_gear_profile(26, 30, 40, 4 * n), 50, 60) - cyl(6, 49, 61, m=h),
    }
    for k, (x, y) in enumerate(GEARBOX_BOLTS):
        solids[f"bolt_{k + 1}"] = cyl(5, 45, 49, x, y) + cyl(3, 25, 45, x, y)
    return solids


def gearbox(out: Path, n: int = 48, name: str = "gearbox") -> None:
    """An 11-part gearbox along z; ``n`` facets per cylinder (the shipped example: 48; the
    benchmark's heavy product: thousands)."""
    expect = {
        "parts": 11,
        "removal_directions": [[0, 0, 1]],
        "sequence": ["bolt_1", "bolt_2", "bolt_3", "bolt_4", "gear", "cover", "spacer",
                     "bearing_up", "shaft", "bearing_low"],
        "plan_directions": [[0, 0, 1]],
    }
    comment = f"""\
Housing 80x80x40 (the base) with a bore r 20 from z 10 up (a shoulder at z 10), a hole r 9
below it and four blind bolt holes r 3 (z 25..40) at (+-30, +-30). In the bore, from the
shoulder up: bearing_low (r 8 .. 20, z 10..20), the shaft's collar (r 12, z 20..30),
bearing_up (z 30..38) and a spacer (r 12 .. 20, z 38..40). A cover (z 40..45, a hole r 10
for the shaft) is held by four bolts (head r 5 z 45..49, shank r 3 z 25..45). The shaft (r 8,
z 0..50; r 6, z 50..70) carries a 40-tooth gear (r 26 .. 30, z 50..60) on its shoulder.
Pegs have {n} facets and the holes {n + n // 4} (their polygons circumscribe the circles): the
pegs' vertices touch the holes' facets, with gaps below the chord sag elsewhere.
By construction everything comes apart along +z only, top down: each bolt, the gear, the
cover, the spacer, bearing_up, then the shaft (its collar stops it going down and is held
by bearing_up going up), bearing_low; the housing stays. One direction suffices.
"""
    mesh_assembly(out, name, f"an 11-part gearbox, {n} facets per cylinder",
                  gearbox_solids(n), expect, comment, base="housing")


# -- 15. dowels in a frame, tessellated independently --------------------------------------

DOWEL_CENTRES = ((-30, -15), (0, -15), (30, -15), (-30, 15), (0, 15), (30, 15))
#: Facets of the dowels and of their holes: both polygons have their vertices on the one
#: nominal circle (r 4), as a tessellator puts them, and every dowel vertex is a hole vertex.
DOWEL_FACETS, DOWEL_HOLE_FACETS = 8, 24


def dowels(out: Path) -> None:
    """Six dowels through a frame plate, flush with both faces; the dowels have 8 facets and
    the holes 24, so the dowels touch the holes only along vertex lines (edge contacts)."""
    frame = box(-45, -30, 0, 45, 30, 10)
    solids = {}
    for k, (x, y) in enumerate(DOWEL_CENTRES):
        frame = frame - prism(circle(4, x, y, n=DOWEL_HOLE_FACETS), -1, 11)
        solids[f"dowel_{k + 1}"] = prism(circle(4, x, y, n=DOWEL_FACETS), 0, 10)
    solids["frame"] = frame  # last: the dowels come first, as in the model a user reported
    ids = [f"dowel_{k + 1}" for k in range(len(DOWEL_CENTRES))]
    expect = {
        "parts": 7,
        "contact_pairs": [[d, "frame"] for d in ids],
        "axis": [0, 0, 1],
        "removal_directions": [[0, 0, 1], [0, 0, -1]],
        "blocked_directions": [[1, 0, 0], [0, -1, 0], [-1, 1, 0], [0.1, 0, 1], [0, 0.1, -1]],
        "interlocked": False,
        "plan_found": True,
        "one_direction": True,
    }
    n, h = DOWEL_FACETS, DOWEL_HOLE_FACETS
    comment = f"""\
Frame plate 90x60x10 (z 0..10) with six through holes r 4 at (+-30, +-15) and (0, +-15); a
dowel in each (r 4, z 0..10, flush with both faces). The dowels have {n} facets and the holes {h},
both polygons with their vertices on the nominal circle r 4 (phase 0): every dowel vertex
(every 45 deg) is a hole vertex (every 15 deg), and the dowel's chords lie inside the hole's,
so each dowel touches its hole only along 8 vertical vertex lines: edge contacts.
A dowel's vertex line sits in the hole's corner, whose free directions are within 82.5 deg of
the inward radial; with vertices every 45 deg any motion with a horizontal component pushes
some vertex outward (within 22.5 deg of it): blocked. Along the axis nothing is in the way
(through holes, ends flush): each dowel leaves along +z or -z, alone, in any order (no two
dowels touch). So the product is not interlocked (a dowel slides along its axis), a plan of
single translations exists (take the dowels out one at a time, all along +z: one direction).
"""
    mesh_assembly(out, "dowels", "six dowels in a frame, 8-facet dowels in 24-facet holes",
                  solids, expect, comment)


# -- 16. a rack of boards on standoffs, at any size ------------------------------------------

#: Board size (x, y), thickness, standoff radius and height, and the standoffs' corners.
RACK_BOARD, RACK_T, RACK_R, RACK_GAP = (100.0, 60.0), 2.0, 3.0, 10.0
RACK_CORNERS = ((8.0, 8.0), (92.0, 8.0), (8.0, 52.0), (92.0, 52.0))


def rack_solids(levels: int) -> dict[str, Manifold]:
    """``levels`` boards stacked on four standoffs per gap: ``5 levels - 4`` parts, board_0
    (the base) at the bottom. Standoffs are 16-sided prisms between the boards' faces."""
    pitch = RACK_T + RACK_GAP
    solids: dict[str, Manifold] = {}
    for k in range(levels):
        z = k * pitch
        solids[f"board_{k}"] = box(0, 0, z, RACK_BOARD[0], RACK_BOARD[1], z + RACK_T)
        if k + 1 < levels:
            for c, (x, y) in enumerate(RACK_CORNERS):
                solids[f"standoff_{k}_{c}"] = prism(circle(RACK_R, x, y, n=16), z + RACK_T,
                                                    z + pitch)
    return solids


def rack(out: Path, levels: int, name: str | None = None) -> str:
    """A rack of ``levels`` boards on standoffs (``5 levels - 4`` parts: 96 at 20 levels, 296
    at 60, 996 at 200), written as ``NAME.yaml``; returns the name. By construction each part
    touches only the parts above and below it, on faces normal to z: the rack comes apart
    along +z, top down, so one direction suffices; a board cannot leave downwards or, while
    a standoff stands on it, upwards; a standoff pinched between two boards may also slide out
    sideways (away from the board's middle, where no other standoff stands in its way)."""
    name = name or f"rack-{5 * levels - 4}"
    solids = rack_solids(levels)
    expect = {
        "parts": len(solids),
        "top_down": [[0, 0, 1]],
        "min_directions": 1,
        "top": f"board_{levels - 1}",
    }
    size = f"{RACK_BOARD[0]:g} x {RACK_BOARD[1]:g} x {RACK_T:g}"
    comment = f"""{levels} boards {size} stacked {RACK_T + RACK_GAP:g} apart on
four standoffs (r {RACK_R:g}, 16 sides) per gap at the boards' corners; board_0 is the base.
Each part touches only the parts above and below it, on faces normal to z: by construction
the rack comes apart along +z, top down (a board once the standoffs on it are gone, a standoff
once the board on it is gone), and one direction suffices. A standoff may also slide out
sideways, away from the board's middle.
"""
    mesh_assembly(out, name, f"a rack of {levels} boards on standoffs ({len(solids)} parts)",
                  solids, expect, comment, base="board_0")
    return name


def build(out: Path = HERE) -> None:
    """Build every example into ``out`` (manifests) and ``out/meshes`` (STL files)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    bell(out)
    fig3_2d(out)
    for n in (5, 8):
        sandwich(out, n)
    fig5_rotation(out)
    fig10_latch(out)
    fig11_nonlinear(out)
    stack(out)
    pegs37(out)
    hover(out)
    slot37(out)
    hinge(out)
    bolts(out)
    press_fit(out)
    overlap(out)
    clash(out)
    gearbox(out)
    dowels(out)


if __name__ == "__main__":
    build(Path(sys.argv[1]) if len(sys.argv) > 1 else HERE)
