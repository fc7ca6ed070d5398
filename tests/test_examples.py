"""The shipped example assemblies (``assemblies/``): loading, geometry, determinism.

Geometry is checked with manifold3d booleans on the loaded meshes, against facts derived by
hand and recorded in each manifest's ``expect`` block (not against ndbg's own analysis):

* every manifest loads, part counts match, 3D parts are closed with positive volume, no
  error diagnostics;
* no two parts overlap (intersection volume <= 1e-6 of the smaller part's volume);
* every hand-listed contact pair touches (manifold ``min_gap`` below 1e-6 mm) and, where a
  manifest lists its contact pairs, no other pair touches;
* stated removal motions are collision-free when carried out as finite motions, and a few
  stated blockages really collide;
* ``assemblies/build.py`` reproduces the committed files byte for byte.
"""

from __future__ import annotations

import importlib.util
import itertools
import math
from functools import cache
from pathlib import Path

import numpy as np
import pytest
import shapely
from manifold3d import Manifold, Mesh

import ndbg_cli

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLIES = ROOT / "assemblies"
MANIFESTS = sorted(ASSEMBLIES.glob("*.yaml"))
OVERLAP_REL = 1e-6  #: allowed intersection volume, relative to the smaller part
TOUCH_MM = 1e-6  #: contact: minimum distance below this (mm)
COLLIDE_MM3 = 1e-3  #: a blocked motion must sweep at least this much volume into a part (mm^3)

EXPECTED_NAMES = {
    "bell", "fig3-2d", "fig2-sandwich-5", "fig2-sandwich-8", "fig5-rotation", "fig10-latch",
    "fig11-nonlinear", "stack", "peg-37", "peg-blind", "hover", "hover-shifted", "slot-37",
    "hinge", "bolt-screw", "bolt-plain", "press-fit", "overlap", "clash", "gearbox", "dowels",
}


@cache
def load(name: str):
    return ndbg_cli.load(ASSEMBLIES / f"{name}.yaml")


@cache
def solids(name: str) -> dict[str, Manifold]:
    """Each part of a 3D example as a manifold3d solid (placed, mm)."""
    out = {}
    for part in load(name).parts:
        mesh = Mesh(vert_properties=np.asarray(part.mesh.vertices, dtype=np.float32),
                    tri_verts=np.asarray(part.mesh.faces, dtype=np.uint32))
        m = Manifold(mesh)
        assert m.status().name == "NoError", (name, part.id, m.status())
        out[part.id] = m
    return out


def overlap(a: Manifold, b: Manifold) -> float:
    """Intersection volume (mm^3)."""
    return (a ^ b).volume()


def collides(moving: Manifold, others: list[Manifold]) -> bool:
    return any(overlap(moving, o) > COLLIDE_MM3 for o in others)


def three_d() -> list[str]:
    return sorted(p.stem for p in MANIFESTS if load(p.stem).dimension == 3)


def test_every_example_is_present():
    assert {p.stem for p in MANIFESTS} == EXPECTED_NAMES


@pytest.mark.parametrize("path", MANIFESTS, ids=lambda p: p.stem)
def test_manifest_loads_cleanly(path):
    asm = ndbg_cli.load(path)
    assert not [d for d in asm.diagnostics if d.level == "error"]
    assert not asm.diagnostics  # the examples are clean: not even warnings
    if "parts" in asm.expect:
        assert len(asm.parts) == asm.expect["parts"]
    for part in asm.parts:
        if asm.dimension == 3:
            assert part.check.watertight and part.check.winding_consistent, part.id
        assert part.check.volume > 0 if asm.dimension == 3 else part.check.area > 0


@pytest.mark.parametrize("name", sorted(EXPECTED_NAMES - {"fig3-2d"}))
def test_parts_do_not_overlap(name):
    """No two parts overlap, except the pairs an example interferes by design (its
    ``expect.interferences``), which do."""
    s = solids(name)
    meant = {frozenset(e["pair"]) for e in load(name).expect.get("interferences", [])}
    for a, b in itertools.combinations(s, 2):
        limit = OVERLAP_REL * min(s[a].volume(), s[b].volume())
        if frozenset((a, b)) in meant:
            assert overlap(s[a], s[b]) > limit, (a, b)
        else:
            assert overlap(s[a], s[b]) <= limit, (a, b)


@pytest.mark.parametrize("name", ["bell", "hover", "hover-shifted", "dowels"])
def test_contact_pairs_are_exactly_the_touching_pairs(name):
    s = solids(name)
    listed = {frozenset(p) for p in load(name).expect["contact_pairs"]}
    assert all(len(p) == 2 and p <= set(s) for p in listed)
    touching = {frozenset((a, b)) for a, b in itertools.combinations(s, 2)
                if s[a].min_gap(s[b], 1.0) < TOUCH_MM}
    assert listed == touching


def test_fig3_polygons_touch_along_edges():
    asm = load("fig3-2d")
    polys = {p.id: p.polygon for p in asm.parts}
    listed = {frozenset(p) for p in asm.expect["contact_pairs"]}
    for a, b in itertools.combinations(polys, 2):
        assert polys[a].intersection(polys[b]).area == pytest.approx(0.0, abs=1e-9)
        shared = polys[a].boundary.intersection(polys[b].boundary).length
        assert (shared > 0) == (frozenset((a, b)) in listed), (a, b)


def fig3_contact_normals() -> dict[tuple[str, str], list[np.ndarray]]:
    """Outward unit normals of part a on its exterior edges that share a segment with b."""
    polys = {p.id: p.polygon for p in load("fig3-2d").parts}  # counter-clockwise exteriors
    out: dict[tuple[str, str], list[np.ndarray]] = {}
    for a, b in itertools.permutations(polys, 2):
        xy = np.asarray(polys[a].exterior.coords)
        for p, q in zip(xy[:-1], xy[1:]):
            edge = shapely.LineString([p, q])
            if edge.intersection(polys[b].boundary).length > 1e-9:
                t = (q - p) / np.linalg.norm(q - p)
                out.setdefault((a, b), []).append(np.array([t[1], -t[0]]))
    return out


def test_fig3_dbgs_and_regions_match_the_hand_derivation():
    """The paper's rule (Pi -> Pj iff d . n > 0 on a shared edge) on the shipped polygons."""
    exp = load("fig3-2d").expect
    normals = fig3_contact_normals()
    ids = ["P1", "P2", "P3", "P4"]
    for key in ("d1", "d2"):
        d = np.asarray(exp[key])
        assert np.linalg.norm(d) == pytest.approx(1.0, abs=1e-12)
        arcs = {(a, b) for (a, b), ns in normals.items() if any(d @ n > 1e-9 for n in ns)}
        assert arcs == {tuple(x) for x in exp[f"dbg_{key}"]}
        closed = [set(s) for k in range(1, 4) for s in itertools.combinations(ids, k)
                  if not any(a in s and b not in s for a, b in arcs)]
        assert closed == [set(s) for s in exp[f"locally_free_{key}"]]
    # regions: every contact normal's perpendicular gives a diameter (both endpoints)
    points = set()
    for ns in normals.values():
        for n in ns:
            for p in ([-n[1], n[0]], [n[1], -n[0]]):
                points.add(tuple(np.round(p, 9) + 0.0))
    regions = exp["regions"]
    assert points == {tuple(float(c) for c in p) for p in regions["point_directions"]}
    assert regions["points"] == len(points) == regions["arcs"]
    assert regions["total"] == 2 * len(points)


# -- removal motions carried out as finite motions ----------------------------------------

def sweep_free(name: str, moved: list[str], direction, distance: float, step: float = 0.5,
               removed: tuple[str, ...] = ()) -> bool:
    """Translate ``moved`` along ``direction`` in steps up to ``distance`` (mm); True when it
    never collides with the parts not moved and not ``removed``."""
    s = solids(name)
    d = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    group = Manifold.batch_boolean([s[p] for p in moved], _union())
    rest = [s[p] for p in s if p not in moved and p not in removed]
    for k in range(1, int(round(distance / step)) + 1):
        if collides(group.translate(list(d * k * step)), rest):
            return False
    return True


def _union():
    from manifold3d import OpType

    return OpType.Add


def test_bell_sequence_is_collision_free_and_first_moves_are_right():
    exp = load("bell").expect
    removed: list[str] = []
    for step in exp["sequence"]:
        assert sweep_free("bell", [step["part"]], step["direction"], 80.0,
                          removed=tuple(removed)), step["part"]
        removed.append(step["part"])
    assert len(removed) == 21  # all but the base
    first = {e["part"] for e in exp["removable_first"]}
    for e in exp["removable_first"]:
        assert sweep_free("bell", [e["part"]], e["direction"], 80.0), e["part"]
    for pid, blockers in exp["blocked_globally_by"].items():
        assert pid not in first
        assert not sweep_free("bell", [pid], [0, 0, 1], 80.0)
        assert sweep_free("bell", [pid], [0, 0, 1], 80.0, removed=tuple(blockers))
        for blocker in blockers:  # each listed blocker is really in the way
            others = tuple(p for p in solids("bell") if p not in (pid, blocker))
            assert not sweep_free("bell", [pid], [0, 0, 1], 80.0, removed=others), blocker
    for pid in set(solids("bell")) - first - {"base"}:  # nothing else leaves first along +z
        assert not sweep_free("bell", [pid], [0, 0, 1], 80.0), pid


@pytest.mark.parametrize("name", ["fig2-sandwich-5", "fig2-sandwich-8"])
def test_sandwich_plates_leave_and_inner_blocks_are_locked(name):
    exp = load(name).expect
    for dec in exp["feasible_decompositions"]:
        assert sweep_free(name, dec["moved"], dec["direction"], 30.0)
    for pid in exp["inner_parts"]:
        for d in ([1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]):
            assert not sweep_free(name, [pid], d, 1.0), (pid, d)


def test_fig5_key_turns_out_but_cannot_translate():
    s = solids("fig5-rotation")
    key, housing = s["key"], s["housing"]
    for d in ([1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
              [1, 1, 0], [-1, 1, 0], [1, 1, 1]):
        moved = key.translate(list(0.1 * np.asarray(d, dtype=float)))
        assert overlap(moved, housing) > COLLIDE_MM3, d
    assert overlap(key.rotate([0, 0, -1.0]), housing) > COLLIDE_MM3  # clockwise: blocked
    for angle in np.arange(0.5, 45.01, 0.5):  # counter-clockwise about (0,0,z): free
        assert overlap(key.rotate([0, 0, float(angle)]), housing) < COLLIDE_MM3, angle
    turned = key.rotate([0, 0, 45.0])
    for k in range(1, 31):
        assert overlap(turned.translate([0, 0, k * 0.5]), housing) < COLLIDE_MM3


def test_fig10_needs_two_hands():
    exp = load("fig10-latch").expect
    s = solids("fig10-latch")
    moves = {m["part"]: np.asarray(m["direction"]) for m in exp["two_handed_separation"]}
    for k in range(1, 61):  # both latches together, 0.5 mm steps, 30 mm
        a = s["latch_a"].translate(list(moves["latch_a"] * 0.5 * k))
        b = s["latch_b"].translate(list(moves["latch_b"] * 0.5 * k))
        assert overlap(a, s["base"]) < COLLIDE_MM3
        assert overlap(b, s["base"]) < COLLIDE_MM3
        assert overlap(a, b) < COLLIDE_MM3
    # one hand: each latch alone, the pair together, along its only free ray: blocked
    assert not sweep_free("fig10-latch", ["latch_a"], moves["latch_a"], 2.0)
    assert not sweep_free("fig10-latch", ["latch_b"], moves["latch_b"], 2.0)
    for d in (moves["latch_a"], moves["latch_b"], [0, 0, 1]):
        assert not sweep_free("fig10-latch", ["latch_a", "latch_b"], d, 2.0)


def test_fig11_pairs_come_off_but_no_single_part():
    exp = load("fig11-nonlinear").expect
    for sub in exp["first_subassemblies"]:
        assert sweep_free("fig11-nonlinear", sub["moved"], sub["direction"], 60.0)
    axes = [v for i in range(3) for v in (np.eye(3)[i], -np.eye(3)[i])]
    for pid in solids("fig11-nonlinear"):
        others = [p for p in solids("fig11-nonlinear") if p != pid]
        for d in axes:  # the candidate directions of the hand derivation (the cones' edges)
            assert not sweep_free("fig11-nonlinear", [pid], d, 1.0), (pid, d)
            assert not sweep_free("fig11-nonlinear", others, d, 1.0), (pid, d)


@pytest.mark.parametrize("name", ["peg-37", "peg-blind", "slot-37", "bolt-plain"])
def test_single_removal_axis(name):
    exp = load(name).expect
    moving = "bolt" if name.startswith("bolt") else ("block" if name == "slot-37" else "peg")
    allowed = [np.asarray(d, dtype=float) for d in exp["removal_directions"]]
    for d in allowed:
        assert sweep_free(name, [moving], d, 60.0)
    axis = allowed[0]
    perp = np.cross(axis, [0.0, 0.0, 1.0] if abs(axis[2]) < 0.9 else [1.0, 0.0, 0.0])
    perp /= np.linalg.norm(perp)
    other = np.cross(axis, perp)
    probes = [perp, -perp, other, -other, axis + perp, axis - other]
    if len(allowed) == 1:
        probes.append(-axis)
    for d in probes:
        assert not sweep_free(name, [moving], d, 0.5), d


def test_peg_axes_are_37_degrees():
    for name in ("peg-37", "peg-blind", "slot-37"):
        axis = np.asarray(load(name).expect["removal_directions"][0])
        assert np.linalg.norm(axis) == pytest.approx(1.0, abs=1e-12)
        ref = [0, 0, 1] if name.startswith("peg") else [1, 0, 0]
        assert math.degrees(math.acos(axis @ ref)) == pytest.approx(37.0, abs=1e-9)


@pytest.mark.parametrize("name", ["hover", "hover-shifted"])
def test_hover_infinite_translation(name):
    exp = load(name).expect
    assert sweep_free(name, ["puck"], [0, 0, 1], 40.0) == exp["infinite"]["puck_free_plus_z"]
    assert sweep_free(name, ["puck"], [0, 1, 0], 60.0) == exp["infinite"]["puck_free_plus_y"]
    assert solids(name)["puck"].min_gap(solids(name)["bridge"], 2.0) > 1.0  # hovering


def test_hinge_pin_leaves_along_axis_and_leaf_is_held():
    exp = load("hinge").expect
    for d in exp["pin_removal_directions"]:
        assert sweep_free("hinge", ["pin"], d, 40.0)
    for d in ([1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]):
        assert not sweep_free("hinge", ["leaf_a"], d, 0.5), d
    asm = load("hinge")
    assert asm.joints[0].type == "revolute"
    assert asm.joints[0].axis == pytest.approx(tuple(exp["axis"]))


def test_bolt_screw_declares_the_joint():
    asm = load("bolt-screw")
    assert [j.type for j in asm.joints] == ["screw"]
    assert asm.joints[0].pitch == pytest.approx(1.25)
    assert not load("bolt-plain").joints


def test_stack_sequence():
    exp = load("stack").expect
    removed: list[str] = []
    for pid in exp["sequence"]:
        assert sweep_free("stack", [pid], exp["direction"], 40.0, removed=tuple(removed)), pid
        removed.append(pid)


def test_dowels_leave_along_their_axis_only():
    """Each dowel alone slides out of the frame along +z and -z, and any motion with a
    horizontal component (the listed probes) pushes it into the frame at once; all of them
    leave along +z one after the other."""
    exp = load("dowels").expect
    dowels = [p for p in solids("dowels") if p != "frame"]
    for pid in dowels:
        for d in exp["removal_directions"]:
            assert sweep_free("dowels", [pid], d, 20.0), (pid, d)
        for d in exp["blocked_directions"]:
            assert not sweep_free("dowels", [pid], d, 0.5), (pid, d)
    removed: list[str] = []
    for pid in dowels:
        assert sweep_free("dowels", [pid], exp["axis"], 20.0, removed=tuple(removed)), pid
        removed.append(pid)
    assert exp["interlocked"] is False and exp["plan_found"] and exp["one_direction"]


def test_bell_reuses_one_screw_mesh_with_placements():
    asm = load("bell")
    screws = [p for p in asm.parts if p.source.endswith("screw.stl")]
    assert len(screws) == 6
    assert any(not np.allclose(p.transform[:3, :3], np.eye(3)) for p in screws)


def test_build_is_deterministic(tmp_path):
    spec = importlib.util.spec_from_file_location("assemblies_build", ASSEMBLIES / "build.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.build(tmp_path)
    built = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    shipped = sorted(p.relative_to(ASSEMBLIES) for p in ASSEMBLIES.rglob("*")
                     if p.is_file() and p.suffix in {".yaml", ".stl"})
    assert built == shipped
    for rel in built:
        assert (tmp_path / rel).read_bytes() == (ASSEMBLIES / rel).read_bytes(), rel
