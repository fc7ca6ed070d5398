"""The NDBG for infinite translations (paper 5.3): answers worked out by hand, and the region
lookup checked against the independent per-direction sweep test
(:mod:`ndbg_cli.ndbg.infinite.sweep`)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from manifold3d import Manifold

import ndbg_cli
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.dbg import free_subsets
from ndbg_cli.ndbg.infinite import chart_union as cu
from ndbg_cli.ndbg.infinite.build import boundary_distance, build_infinite, free_directions, lookup
from ndbg_cli.ndbg.infinite.cubemap import random_directions
from ndbg_cli.ndbg.infinite.sweep import SweepChecker, dbg_at
from ndbg_cli.ndbg.model import partitionings
from ndbg_cli.report.infinite import infinite_section, infinite_text

from conftest import shared


def box(pid: str, lo, hi, rot: np.ndarray | None = None):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return make_part(pid, m.vertices, m.faces, transform=rot)[0]


def mpart(pid: str, m: Manifold, rot: np.ndarray | None = None):
    mesh = m.to_mesh()
    return make_part(pid, np.asarray(mesh.vert_properties)[:, :3],
                     np.asarray(mesh.tri_verts), transform=rot)[0]


def boxes_part(pid: str, boxes) -> object:
    """A part made of the union of axis-aligned boxes ``(lo, hi)``."""
    m = None
    for lo, hi in boxes:
        c = Manifold.cube(list(np.subtract(hi, lo))).translate(list(lo))
        m = c if m is None else m + c
    return mpart(pid, m)


def arcs(g, asm) -> set[tuple[str, str]]:
    return {(asm.ids[i], asm.ids[j]) for i, j in g.arcs()}


def unit(v) -> np.ndarray:
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


# -- two boxes side by side ------------------------------------------------------------------

@pytest.fixture(scope="module")
def side_by_side():
    asm = Assembly("pair", (box("a", [0, 0, 0], [1, 1, 1]), box("b", [1, 0, 0], [2, 1, 1])))
    return asm, build_infinite(asm)


def test_side_by_side_sliding_is_free(side_by_side):
    asm, nd = side_by_side
    dirs = np.array([[0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1], unit([0, 1, 1])])
    for g in lookup(nd, dirs):
        assert arcs(g, asm) == set()
    # Moving a into b (+x, or any direction with a positive x component) is blocked by b.
    for d, want in [([1, 0, 0], {("a", "b")}), ([-1, 0, 0], {("b", "a")}),
                    (unit([1e-3, 1, 0]), {("a", "b")}), (unit([-0.2, 0.3, 1]), {("b", "a")})]:
        assert arcs(lookup(nd, np.array([d]))[0], asm) == want
        assert arcs(dbg_at(asm, np.array(d, float)), asm) == want


def test_side_by_side_regions(side_by_side):
    asm, nd = side_by_side
    # Three DBGs: a->b (d.x > 0), b->a (d.x < 0), none on the circle d.x = 0 (1-dimensional).
    distinct = {frozenset(arcs(g, asm)) for g, _ in nd.distinct()}
    assert distinct == {frozenset({("a", "b")}), frozenset({("b", "a")}), frozenset()}
    free_both = [r for r in nd.regions if not r.dbg.arcs()]
    assert free_both and all(r.dimension < 2 for r in free_both)
    assert all(abs(r.direction[0]) < 1e-6 for r in free_both)


# -- a box under a hovering box ----------------------------------------------------------------

def hovering(dx: float) -> Assembly:
    base = box("base", [-5, -5, -1], [5, 5, 0])
    a = box("a", [-1, -1, 0], [1, 1, 1])
    pillar = Manifold.cube([1, 2, 2.5]).translate([3, -1, 0])
    arm = Manifold.cube([2.5 + dx, 2, 0.5]).translate([1.5, -1, 2.5])
    bridge = mpart("bridge", pillar + arm)
    c = box("c", [-1 + dx, -1, 3], [2 + dx, 1, 4])
    return Assembly("hover", (base, a, bridge, c))


def test_hovering_box_blocks_infinite_translation():
    asm = hovering(0.0)
    nd = build_infinite(asm)
    up = np.array([[0.0, 0.0, 1.0]])
    g = lookup(nd, up)[0]
    # a rests on the base and touches nothing else, yet c (not touching) blocks it along +z.
    assert ("a", "c") in arcs(g, asm)
    assert ("a", "bridge") not in arcs(g, asm)
    assert ("bridge", "c") in arcs(g, asm)
    assert ("c", "a") not in arcs(g, asm) and not g.succ[asm.index("c")]
    assert arcs(g, asm) == arcs(dbg_at(asm, up[0]), asm)
    assert not g.is_free(nd.mask(["a"]))


def test_hovering_box_moved_aside_frees_a():
    asm = hovering(2.2)  # c spans x in [1.2, 4.2]: no overlap with a (x <= 1) seen from above
    nd = build_infinite(asm)
    g = lookup(nd, np.array([[0.0, 0.0, 1.0]]))[0]
    assert not g.succ[asm.index("a")]
    assert g.is_free(nd.mask(["a"]))
    assert arcs(g, asm) == arcs(dbg_at(asm, np.array([0.0, 0.0, 1.0])), asm)


# -- peg in a hole drilled at 37 degrees -------------------------------------------------------

def peg_in_hole(rot: np.ndarray | None = None) -> tuple[Assembly, np.ndarray]:
    r = trimesh.transformations.rotation_matrix(np.radians(37.0), [1, 0, 0])
    peg = Manifold.cylinder(6.0, 1.0, 1.0, 16, True).transform(r[:3, :])
    hole = Manifold.cylinder(20.0, 1.0, 1.0, 16, True).transform(r[:3, :])
    block = Manifold.cube([8.0, 8.0, 4.0], True) - hole
    asm = Assembly("peg", (mpart("block", block, rot), mpart("peg", peg, rot)))
    axis = r[:3, 2] if rot is None else rot[:3, :3] @ r[:3, 2]
    return asm, axis


def check_peg(asm: Assembly, axis: np.ndarray) -> None:
    nd = build_infinite(asm)
    free = free_directions(nd, nd.mask(["peg"]))
    eta = nd.stats["angular_tolerance"]
    assert free, "the peg must come out along its axis"
    for dim, d in free:
        assert dim in (0, 1)
        assert np.degrees(np.arccos(min(1.0, abs(np.dot(d, axis))))) < np.degrees(eta)
    signs = {int(np.sign(np.dot(d, axis))) for _, d in free}
    assert signs == {1, -1}
    # Both ways along the axis are free; 2 degrees off it the peg is blocked.
    for d in (axis, -axis):
        assert dbg_at(asm, d).arcs() == []
        assert lookup(nd, d[None], exact=True)[0].arcs() == []
    off = unit(axis + 0.035 * np.cross(axis, [1.0, 0, 0]))
    assert (1, 0) in lookup(nd, off[None])[0].arcs()
    assert (1, 0) in dbg_at(asm, off).arcs()


def test_peg_in_tilted_hole_comes_out_along_its_axis_only():
    asm, axis = peg_in_hole()
    check_peg(asm, axis)


def test_rotating_the_assembly_changes_no_answer():
    rot = trimesh.transformations.random_rotation_matrix(np.random.default_rng(7).random(3))
    asm, axis = peg_in_hole(rot)
    check_peg(asm, axis)


# -- a block in a narrow slot at an odd angle ----------------------------------------------------

def test_block_in_slanted_slot_has_one_free_direction():
    r = (trimesh.transformations.rotation_matrix(np.radians(23.0), [0, 0, 1])
         @ trimesh.transformations.rotation_matrix(np.radians(11.0), [1, 0, 0]))
    channel = Manifold.cube([0.6, 20.0, 0.4], True).transform(r[:3, :])
    wall = Manifold.cube([6.0, 1.0, 6.0], True) - channel
    block = Manifold.cube([0.6, 1.2, 0.4], True).transform(r[:3, :])
    asm = Assembly("slot", (mpart("wall", wall), mpart("block", block)))
    s = r[:3, 1]
    nd = build_infinite(asm)
    free = free_directions(nd, nd.mask(["block"]))
    assert free
    eta = nd.stats["angular_tolerance"]
    for dim, d in free:
        assert dim in (0, 1)
        assert np.arccos(min(1.0, abs(np.dot(d, s)))) < eta
    assert {int(np.sign(np.dot(d, s))) for _, d in free} == {1, -1}


# -- the lookup against the direct test ------------------------------------------------------

def small_assembly() -> Assembly:
    """A base, a box on it, a tilted peg block and a bridge: several distant and touching
    pairs."""
    base = box("base", [-4, -4, -1], [4, 4, 0])
    a = box("a", [-3, -3, 0], [-1, -1, 1.5])
    b = box("b", [0.5, -3, 0], [2.5, -2, 1])
    rot = trimesh.transformations.rotation_matrix(0.4, unit([1, 2, 0.5]))
    rot[:3, 3] = [1.5, 2.0, 2.0]
    c = box("c", [-0.7, -0.5, -0.5], [0.7, 0.5, 0.5], rot)
    pillar = Manifold.cube([0.5, 0.5, 3.0]).translate([-3.5, 2.5, 0])
    arm = Manifold.cube([3.0, 0.5, 0.5]).translate([-3.5, 2.5, 3.0])
    return Assembly("small", (base, a, b, c, mpart("bridge", pillar + arm)))


def test_lookup_matches_direct_check_on_random_directions():
    asm = small_assembly()
    nd = build_infinite(asm)
    dirs = random_directions(10_000, seed=3)
    got = lookup(nd, dirs)  # vectorised point location: 10,000 directions in well under 1 s
    assert len(got) == 10_000
    # The direct test costs milliseconds per direction: check the first 300 directions that
    # are not within 1e-3 (chart units) of a B_ij boundary, where the tolerance decides.
    robust = np.nonzero(boundary_distance(nd, dirs[:400]) > 1e-3)[0][:300]
    assert len(robust) > 250
    sc = SweepChecker(asm)
    for k in robust:
        assert got[k].succ == sc.dbg(dirs[k]).succ, dirs[k]


def test_latch_lookup_matches_direct_check_off_the_boundaries():
    """Fig. 10's latch: latch_b does not block latch_a along (0.91, -0.29, -0.29) (the sweep
    test, and manifold3d finds no overlap along it at any distance). With near triangles
    moved along their normals only, two faces meeting at the parts' L-shaped corner crossed
    each other and the NDBG said it does, for 102 of these 199 directions
    (:mod:`ndbg_cli.ndbg.infinite.erosion`)."""
    asm = ndbg_cli.load("assemblies/fig10-latch.yaml")
    nd = build_infinite(asm)
    dirs = random_directions(200, seed=1)
    robust = np.nonzero(boundary_distance(nd, dirs) > 1e-2)[0]
    got = lookup(nd, dirs[robust])
    sc = SweepChecker(asm)
    wrong = sum(g.succ != sc.dbg(dirs[k]).succ for g, k in zip(got, robust))
    assert wrong == 0


def test_region_representatives_match_direct_check():
    asm = small_assembly()
    nd = build_infinite(asm)
    sc = SweepChecker(asm)
    twod = [r for r in nd.regions if r.dimension == 2]
    for r in twod[:: max(1, len(twod) // 40)]:
        assert r.dbg.succ == sc.dbg(np.array(r.direction)).succ, r.direction


def test_two_dimensional_region_directions_lie_off_the_contact_circles():
    """A box in a channel (floor below, walls at x = 0 and x = 1, open along z and +y); hand
    answer: near +y the walls block the box along every direction with d.x != 0, and along
    d.x = 0 (a contact circle) it slides out. The closed sets cover the whole +y cube face:
    one 2-dimensional region, whose chart centre (shapely's point on surface of a square) is
    +y itself, on the seam, where the box is free. Every 2-dimensional region's direction must
    be one where its DBG holds (off the seams), here and on the faces round +-z."""
    u = (Manifold.cube([3.0, 1.0, 1.0]).translate([-1, -1, 0])
         + Manifold.cube([1.0, 1.0, 1.0]).translate([-1, 0, 0])
         + Manifold.cube([1.0, 1.0, 1.0]).translate([1, 0, 0]))
    asm = Assembly("channel", (mpart("u", u), box("b", [0, 0, 0], [1, 1, 1])))
    nd = build_infinite(asm)
    sc = SweepChecker(asm)
    twod = [r for r in nd.regions if r.dimension == 2]
    assert len(twod) >= 6
    for r in twod:
        assert r.dbg.succ == sc.dbg(np.array(r.direction)).succ, r.direction
    # the seam keeps its own (lower-dimensional) regions: b slides out along +y and +-z
    for d in ([0, 1, 0], [0, 0, 1], [0, 0, -1]):
        assert any(r.dimension < 2 and np.allclose(r.direction, d) and r.dbg.is_free(2)
                   for r in nd.regions), d


def test_section_and_text():
    asm = Assembly("pair", (box("a", [0, 0, 0], [1, 1, 1]), box("b", [1, 0, 0], [2, 1, 1])))
    nd = build_infinite(asm)
    parts, truncated = partitionings(nd)
    sec = infinite_section(asm, nd, parts, truncated)
    assert sec["regions"] == len(sec["region_list"]) == sum(sec["regions_by_dimension"].values())
    assert sec["distinct_dbgs"] == len(sec["dbgs"]) == 3
    moved = sorted(tuple(p["moved"]) for p in sec["partitionings"])
    assert moved == [("a",), ("b",)]
    for p in sec["partitionings"]:
        assert p["family"] == "infinite_translation" and p["directions"]
    assert infinite_text(sec)[0].startswith("infinite translations:")
    import json
    from importlib import resources

    import jsonschema

    from ndbg_cli.report.document import clean

    schema = json.loads(resources.files("ndbg_cli").joinpath(
        "schemas/fragments/infinite.json").read_text())
    jsonschema.Draft202012Validator(schema).validate(clean(sec))


# -- 2D --------------------------------------------------------------------------------------

def test_2d_peg_in_slot():
    from ndbg_cli.io.validate import make_polygon_part

    u = make_polygon_part("u", [(0, 0), (3, 0), (3, 2), (2, 2), (2, 1), (1, 1), (1, 2),
                                (0, 2)])[0]
    peg = make_polygon_part("peg", [(1, 1), (2, 1), (2, 3), (1, 3)])[0]
    asm = Assembly("u2d", (u, peg), dimension=2)
    nd = build_infinite(asm)
    free = free_directions(nd, nd.mask(["peg"]))
    # The peg slides out of the slot only straight up (a single direction of S^1).
    assert free and all(dim == 0 and abs(d[0]) < 1e-3 and d[1] > 0 for dim, d in free)
    # Straight up the peg is free and the U is blocked by it (it would push the peg up).
    assert lookup(nd, np.array([[0.0, 1.0]]), exact=True)[0].arcs() == [(0, 1)]
    assert dbg_at(asm, np.array([0.0, 1.0])).arcs() == [(0, 1)]
    assert (1, 0) in lookup(nd, np.array([[0.1, 1.0]]))[0].arcs()
    assert (1, 0) in dbg_at(asm, np.array([0.1, 1.0])).arcs()


def stack_2d(n: int = 4) -> Assembly:
    from ndbg_cli.io.validate import make_polygon_part

    parts = tuple(make_polygon_part(f"b{k}", [(0, 10 * k), (10, 10 * k), (10, 10 * k + 10),
                                              (0, 10 * k + 10)])[0] for k in range(n))
    return Assembly("stack2d", parts, dimension=2)


def test_2d_stack_slides_apart_sideways_exactly():
    """Four unit boxes stacked along y (hand answer): along exactly +-x every box slides on its
    neighbours and nothing blocks; just above +x each box is blocked by the one above, and
    straight up by every box above it. The closed chart polygons of the prisms' cap terms
    (which only touch the plane z = 0) once blocked all of (0, 45 deg]: no +-x region."""
    asm = stack_2d()
    nd = build_infinite(asm)
    flat = [r for r in nd.regions if not r.dbg.arcs()]
    assert sorted(r.direction for r in flat) == [(-1.0, 0.0), (1.0, 0.0)]
    assert all(r.dimension == 0 for r in flat)
    assert lookup(nd, np.array([[1.0, 0.0]]))[0].arcs() == []
    up = lookup(nd, np.array([[1.0, 0.5]]))[0].arcs()  # 27 degrees up: only the box above
    assert up == [(0, 1), (1, 2), (2, 3)]
    assert sorted(lookup(nd, np.array([[0.0, 1.0]]))[0].arcs()) == \
        [(i, j) for i in range(4) for j in range(i + 1, 4)]
    # every region's DBG is the direct sweep test's at its direction
    sc = SweepChecker(asm)
    for r in nd.regions:
        assert sc.dbg(np.array(r.direction)).succ == r.dbg.succ, r


@pytest.mark.parametrize("name", ["stack", "peg-blind", "peg-37", "fig11-nonlinear",
                                  "fig2-sandwich-5", "fig3-2d", "slot-37"])
def test_plan_steps_pass_the_direct_sweep_test(name):
    """Each step of an infinite-translation plan moves its set along a direction where the
    direct sweep test (``ndbg query``, no erosion) finds it free: among the thin regions of a
    bore's or a slot's free band the one on its contacts' circles is chosen, and its
    direction is where those circles meet (the axis), not a cell's centroid mrad off it."""
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.analysis import analyze

    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    rep = analyze(asm, Options(motion="all"))
    plan = rep["plan"]
    assert plan["family"] == "infinite_translation" and plan["sequence"]
    sc = SweepChecker(asm)
    idx = {p: k for k, p in enumerate(asm.ids)}
    for step in plan["sequence"]:
        moved = sum(1 << idx[p] for p in step["moved"])
        mask = sum(1 << idx[p] for p in step["produces"])
        assert sc.dbg(np.array(step["removal_direction"])).is_free(moved, mask), step
    if name == "peg-blind":  # the hole's axis, from the manifest's hand-worked answer
        a = np.radians(37.0)
        d = plan["sequence"][0]["removal_direction"]
        assert np.allclose(d, [np.sin(a), 0.0, np.cos(a)], atol=1e-6)


# -- burrs (external data) ---------------------------------------------------------------------

@pytest.mark.external
@pytest.mark.slow
@pytest.mark.parametrize("name", ["six-piece-000", "six-piece-257"])
def test_burr_has_a_group_removable_by_one_translation(name):
    asm = ndbg_cli.load(shared("burr", name))
    nd = build_infinite(asm)
    parts, _ = partitionings(nd)
    assert parts
    # Every partitioning is confirmed by the direct test along one of its directions (thin
    # free bands of width about eps / L around an axis are free only within the tolerance;
    # the axis itself is among the regions).
    sc = SweepChecker(asm)
    for p in parts:
        dirs = [np.array(nd.regions[k].direction) for k in p.regions]
        assert any(sc.dbg(d).is_free(p.moved) for d in dirs)


@pytest.mark.external
@pytest.mark.slow
def test_pelikan_no_group_comes_out_along_an_axis():
    # README fact: in the Pelikan burr no group can be removed by a single axis translation.
    asm = ndbg_cli.load(shared("burr", "pelikan"))
    nd = build_infinite(asm)
    axes = np.concatenate([np.eye(3), -np.eye(3)])
    sc = SweepChecker(asm)
    for d, g in zip(axes, lookup(nd, axes, exact=True)):
        assert g.succ == sc.dbg(d).succ
        assert len(g.arcs()) and not list(free_subsets(g))


def _open_member(cones: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Directions ``d`` inside some open cone (with the builder's 1e-6 margin)."""
    zero = ~np.any(cones != 0.0, axis=2)
    out = np.zeros(len(d), dtype=bool)
    for s in range(0, len(cones), 2000):
        v = np.einsum("pkx,dx->dpk", cones[s:s + 2000], d)
        out |= np.all((v > 1e-6) | zero[s:s + 2000][None], axis=2).any(axis=1)
    return out


@pytest.mark.parametrize("name", ["peg-37", "hover"])
def test_pruned_terms_give_the_dense_blocked_sets(name):
    """The pruning walk (bounding-box trees, raster cover) against every term of the paper's
    formula: per ordered pair, the same closed chart union, the same open-cone membership on
    random directions and the same contact circles, from fewer terms."""
    import shapely

    from ndbg_cli.ndbg.infinite import blocking_cones as bc

    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    tris = bc.part_triangles(asm)
    trees = [bc.tri_tree(t) for t, _ in tris]
    eps = asm.length_tolerance
    d = random_directions(4000, seed=3)
    fewer = 0
    for i in range(len(tris)):
        for j in range(len(tris)):
            if i == j:
                continue
            dense, dcirc = bc.pair_cones(*tris[i], *tris[j], eps)
            pruned, pcirc = bc.pruned_pair_cones(tris[i][0], tris[i][1], trees[i],
                                                 tris[j][0], tris[j][1], trees[j], eps)
            fewer += len(pruned) < len(dense)
            assert np.array_equal(_open_member(dense, d), _open_member(pruned, d)), (i, j)
            assert np.allclose(np.sort(dcirc, axis=0), np.sort(pcirc, axis=0)), (i, j)
            for gd, gp in zip(cu.cones_to_face_geoms(dense), cu.cones_to_face_geoms(pruned)):
                assert (gd is None) == (gp is None)
                if gd is not None:
                    assert shapely.symmetric_difference(gd[0], gp[0]).area < 1e-12
    # the walk did prune somewhere (hover's few boxes leave nothing to prune once the flat
    # terms, which both lists drop, are gone)
    assert fewer or name == "hover"


@pytest.mark.parametrize("name", ["peg-37", "hover"])
def test_reversed_pair_is_the_antipodal_image(name):
    """``blocked_sets`` computes one orientation of each pair and takes the other as the
    antipodal image (``B_ji = -B_ij``): against the pair computed directly, the same closed
    chart union on every face, the same open-cone membership and the same region lookup on
    random directions."""
    import shapely

    from ndbg_cli.ndbg.infinite import blocking_cones as bc
    from ndbg_cli.ndbg.infinite.blocked_sets import blocked_sets
    from ndbg_cli.ndbg.infinite.chart_union import reverse_entries

    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    tris = bc.part_triangles(asm)
    trees = [bc.tri_tree(t) for t, _ in tris]
    eps = asm.length_tolerance
    d = random_directions(4000, seed=5)
    bs = blocked_sets(asm)
    exact = bs.dbgs(d[:500], exact=True)
    n = len(tris)
    for i in range(n):
        for j in range(n):
            if i == j:
                continue
            direct, _ = bc.pruned_pair_cones(tris[i][0], tris[i][1], trees[i],
                                             tris[j][0], tris[j][1], trees[j], eps)
            other, _ = bc.pruned_pair_cones(tris[j][0], tris[j][1], trees[j],
                                            tris[i][0], tris[i][1], trees[i], eps)
            assert np.array_equal(_open_member(direct, d), _open_member(-other, d)), (i, j)
            mine = cu.cones_to_face_geoms(direct)
            flipped = reverse_entries(cu.cones_to_face_geoms(other))
            for a, b in zip(mine, flipped):
                assert (a is None) == (b is None), (i, j)
                if a is not None:
                    assert shapely.symmetric_difference(a[0], b[0]).area < 1e-12, (i, j)
            got = np.array([bool(g.succ[i] >> j & 1) for g in exact])
            assert np.array_equal(got, _open_member(direct, d[:500])), (i, j)
            # what blocked_sets holds for (i, j), whichever orientation it computed
            for face in range(6):
                got = bs.geoms[face].get((i, j))
                want = mine[face][0] if mine[face] is not None else None
                assert (got is None) == (want is None), (i, j, face)
                if got is not None:
                    assert shapely.symmetric_difference(got, want).area < 1e-12, (i, j, face)


@pytest.mark.parametrize("name", ["slot-37", "peg-37"])
def test_exact_lookup_on_cell_directions_equals_every_cone_tested(name):
    """The exact re-test stops at a direction's first open cone (:meth:`BlockedSets._exact`,
    growing batches): at every region's representative direction (on seams and boundaries,
    where the open-set semantics decides) and at random ones, the same DBG as testing every
    cone of every pair."""
    from ndbg_cli.ndbg.infinite.build import build_infinite

    asm = ndbg_cli.load(f"assemblies/{name}.yaml")
    nd = build_infinite(asm)
    bs = nd.geometry
    d = np.array([r.direction for r in nd.regions] + list(random_directions(500, seed=9)))
    assert (np.array([r.dimension for r in nd.regions]) < 2).any()
    got = bs.dbgs(d, exact=True)
    for (i, j), cones in bs.cones.items():
        want = _open_member(cones, d / np.linalg.norm(d, axis=1, keepdims=True))
        assert np.array_equal(np.array([bool(g.succ[i] >> j & 1) for g in got]), want), \
            (i, j)


def test_dbg_of_the_opposite_direction_is_the_reversed_dbg():
    """``P_j`` blocks ``P_i`` along ``d`` exactly when ``P_i`` blocks ``P_j`` along ``-d``:
    at every region's representative direction (thin 1- and 0-dimensional regions along the
    sliding directions included), the exact lookup at ``-d`` is the reversed DBG."""
    from ndbg_cli.ndbg.infinite.build import build_infinite, lookup

    asm = ndbg_cli.load("assemblies/hover.yaml")
    nd = build_infinite(asm)
    d = np.array([r.direction for r in nd.regions])
    assert (np.array([r.dimension for r in nd.regions]) < 2).sum() > 20
    ahead, behind = lookup(nd, d, exact=True), lookup(nd, -d, exact=True)
    assert [g.succ for g in behind] == [g.reversed().succ for g in ahead]


def test_circle_crossing_inside_a_boundary_chain_is_a_region():
    """A block in a slot of a frame, open at x = 0 and x = 1, under an overhang over its left
    half, with a side part beyond the frame's short wall. By hand, along +x exactly the block
    slides out touching only faces parallel to +x: free (and the side is blocked by the frame
    only); just off +x it rises into the overhang or pushes into a wall. +x is where the
    contact circles of normals y and z cross, and a boundary of B(block, frame) runs along
    the circle d.y = 0 straight through it: the crossing, on the linework but no node of it,
    had no cell, and {block} came out only at a direction 2e-3 rad off +x that the direct
    check blocks."""
    side = boxes_part("side", [([0, 2.5, 0], [0.5, 4.5, 1]), ([0, 2.5, 1], [0.5, 4.5, 2])])
    frame = boxes_part("frame", [([0, 0, 0], [1, 2, 3.5]), ([0, 2, 0], [1, 2.5, 1]),
                                 ([0, 2, 2], [0.5, 2.5, 3.5]), ([0, 2.5, 2], [0.5, 4.5, 3.5]),
                                 ([0.5, 2.5, 0], [1, 4.5, 3.5])])
    block = boxes_part("block", [([0, 2, 1], [1, 2.5, 2])])
    asm = Assembly("slot-x", (side, frame, block))
    nd = build_infinite(asm)
    sc = SweepChecker(asm)
    x = np.array([1.0, 0.0, 0.0])
    assert arcs(sc.dbg(x), asm) == {("side", "frame")}
    at = [r for r in nd.regions if np.allclose(r.direction, x, atol=1e-12)]
    assert at and all(arcs(r.dbg, asm) == {("side", "frame")} for r in at)
    parts, _ = partitionings(nd)
    moved = nd.mask(["block"])
    (p,) = [p for p in parts if p.moved == moved]
    assert any(np.allclose(nd.regions[k].direction, x, atol=1e-12) for k in p.regions)


def test_far_pair_keeps_every_blocked_direction():
    """Two L-shaped slabs 1.5 apart in z (a far pair). By hand: 'top' moving along ``d``
    comes down by 1.5 after t = 4.70, shifted (3.11, 3.19) in x, y: its box x in [0, 3.5], y in [0,
    2] then overlaps bottom's box x in [1.5, 3.5], y in [2.5, 4.5] by 0.39 x 1.31, so bottom blocks
    top along ``d`` (and 0.02 rad round it). GEOS 3.14.1's union_all of the pair's 71 chart pieces
    on the +y face lost 0.03 chart units^2 round ``d``, and the NDBG had no arc there
    (:func:`ndbg_cli.ndbg.infinite.chart_union.robust_union` now checks the union)."""
    top = boxes_part("top", [([0, 0, 2], [1.5, 2, 3.5]), ([1.5, 0, 2], [3.5, 2, 3.5]),
                             ([1.5, 2, 2], [3.5, 2.5, 3.5])])
    bottom = boxes_part("bottom", [([1.5, 0, 0], [3.5, 2, 0.5]),
                                   ([1.5, 2, 0], [3.5, 2.5, 0.5]),
                                   ([1.5, 2.5, 0], [3.5, 4.5, 0.5])])
    asm = Assembly("far-pair", (top, bottom), tolerance=0.0011199314805164838)
    nd = build_infinite(asm)
    sc = SweepChecker(asm)
    d = np.array([0.662288997346108, 0.6779731225920429, -0.31894471156782295])
    near = np.array([unit(d + 0.02 * e) for e in np.eye(3)])
    for x in np.concatenate([d[None], near]):
        assert lookup(nd, x[None])[0].arcs() == [(0, 1)] == sc.dbg(x).arcs(), x


def test_a_union_that_loses_a_piece_is_redone():
    import shapely


    polys = np.array([shapely.box(0, 0, 1, 1), shapely.box(0.5, 0, 2, 1),
                      shapely.box(0.2, 0.2, 0.4, 0.4)])
    assert not cu.loses_area(shapely.union_all(polys), polys)
    assert cu.loses_area(shapely.box(0, 0, 1.9, 1), polys)  # 0.1 of the second piece lost
    assert not cu.loses_area(shapely.box(0, 0, 2 - 1e-16, 1), polys)  # rounding only
    # just above and below LOST_AREA (1e-12): a band 1 high, the pieces' insets (the quick
    # test, cu._inset_covered) must not hide the first
    assert cu.loses_area(shapely.box(0, 0, 2 - 3e-12, 1), polys)
    assert not cu.loses_area(shapely.box(0, 0, 2 - 3e-13, 1), polys)


def test_coplanar_triangles_make_no_term():
    """Two triangles in one plane (faces of two parts flush with each other, far apart): every
    difference lies in that plane, the open cone is empty and no term is kept; lift one of
    them and the term is back."""
    from ndbg_cli.ndbg.infinite import blocking_cones as bc

    ti = np.array([[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])
    ni = np.array([[0.0, 0.0, 1.0]])
    tj = ti + np.array([5.0, 0.0, 0.0])
    nj = np.array([[0.0, 0.0, -1.0]])
    one = np.zeros(1, dtype=np.int64)
    assert len(bc.terms(ti, ni, tj, nj, one, one, 1e-6)[0]) == 0
    assert len(bc.terms(ti, ni, tj + np.array([0.0, 0.0, 1.0]), nj, one, one, 1e-6)[0]) == 1
    cone = bc.terms(ti, ni, tj + np.array([0.0, 0.0, 1.0]), nj, one, one, 1e-6)[0]
    assert not bc.flat(cone).any()


def test_an_arrangement_too_large_to_hold_is_skipped_with_its_size(monkeypatch):
    # a 1000-box grid's 789,702 regions x 1000 parts would need 92 GiB of DBGs (a
    # MemoryError); the limit is lowered here to meet it on hover (3 parts)
    import ndbg_cli.ndbg.infinite.build as inf
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.analysis import analyze

    monkeypatch.setattr(inf, "MAX_DBG_BYTES", 10)
    asm = ndbg_cli.load("assemblies/hover.yaml")
    with pytest.raises(inf.TooLarge, match="regions over 3 parts: their DBGs would take"):
        inf.build_infinite(asm)
    rep = analyze(asm, Options(motion="all", cache=None))
    sec = rep["ndbg"]["infinite_translation"]
    assert sec["skipped"] and "regions over 3 parts" in sec["why"]
    assert rep["plan"]["found"]  # the other families still plan


def pocket_2d(left: float, right: float, clearance: float = 0.0,
              theta: float = 0.0, scale: float = 1.0) -> Assembly:
    """A plate 10 x 1 (mm) with a pocket under a 2 mm block standing in it (to y = 2): the
    pocket's floor is at ``y = 1 - right``, its left wall ``left`` high, its right wall
    ``right`` high and ``clearance`` right of the block (which touches the left wall). The
    whole turned by ``theta`` (radians) about the origin after scaling by ``scale``."""
    from ndbg_cli.io.validate import make_polygon_part

    c, s = np.cos(theta), np.sin(theta)
    t = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    floor, x1 = 1.0 - right, 6.0 + clearance
    base = make_polygon_part("base", [(0, 0), (10, 0), (10, 1), (x1, 1), (x1, floor),
                                      (4, floor), (4, floor + left), (0, floor + left)],
                             transform=t, scale=scale)[0]
    block = make_polygon_part("block", [(4, floor), (6, floor), (6, 2), (4, 2)],
                              transform=t, scale=scale)[0]
    return Assembly("pocket2d", (base, block), dimension=2)


@pytest.mark.parametrize("theta,scale", [(0.0, 1.0), (np.radians(30.0), 1000.0),
                                         (2.0, 0.01)])
def test_2d_short_pocket_is_left_along_its_walls(theta, scale):
    """The block of :func:`pocket_2d` with walls 0.1 and 0.3 high, no clearance (hand answer):
    it comes out only straight up (the walls' sliding direction): turned right of +y its
    right side meets the right wall, left of it its left side the left wall. Eroded by
    ``3 eps`` (``eps`` = 1e-4 x the diagonal, 1.02e-3 mm), the free band runs from
    ``3 eps / 0.3`` rad right of +y to ``3 eps / 0.1`` left of it: 0.041 rad, 8 ``eta``
    (5e-3 rad), a 1-dimensional region whose middle, 0.010 rad left of +y, sinks the block's
    corner ``eps`` into the left wall: the direct test blocks it there. The region is
    represented by +y itself (still 1-dimensional), where the direct test frees the block;
    the same, turned and scaled, for the base coming out along -y."""
    from ndbg_cli.ndbg.infinite.equator import equator_extents, sliding_angles

    asm = pocket_2d(0.1, 0.3, theta=theta, scale=scale)
    nd = build_infinite(asm)
    eps, eta = asm.length_tolerance, nd.stats["angular_tolerance"]
    assert eta == pytest.approx(5e-3)
    sc = SweepChecker(asm)
    for moved, up in (("block", np.pi / 2), ("base", -np.pi / 2)):
        free = [r for r in nd.regions if r.dbg.is_free(nd.mask([moved]))]
        assert len(free) == 1 and free[0].dimension == 1
        want = np.array([np.cos(up + theta), np.sin(up + theta)])
        assert np.allclose(free[0].direction, want, atol=1e-12)
        assert sc.dbg(np.array(free[0].direction)).succ == free[0].dbg.succ
        assert free[0].sliding == 1  # along both walls (one contact circle, normal x)
    # the band's extent, by hand: 3 eps / 0.3 and 3 eps / 0.1 (scaled) either side of +y
    bs = nd.geometry
    ext = equator_extents(bs.arcs, bs.n, bs.eta, sliding_angles(bs.circles))
    (lo, hi, lo_closed, hi_closed), = [e[3] for e in ext
                                       if e[2].is_free(nd.mask(["block"]))]
    rel = eps / scale  # eps in the unscaled mm
    up = np.mod(np.pi / 2 + theta - lo, 2 * np.pi)
    assert up == pytest.approx(np.arctan(3 * rel / 0.3), rel=1e-3)
    assert (hi - lo) - up == pytest.approx(np.arctan(3 * rel / 0.1), rel=1e-3)
    assert lo_closed and hi_closed and hi - lo > 8 * eta
    # every region's representative gets the direct test's DBG
    for r in nd.regions:
        assert sc.dbg(np.array(r.direction)).succ == r.dbg.succ, r


def test_2d_wide_region_keeps_its_middle():
    """The block of :func:`pocket_2d` against the left wall (0.3 high) with 0.5 clearance on
    the right (wall 0.3 high; hand answer): it comes out between straight up (sliding on the
    left wall) and atan(0.5 / 0.3) = 59 deg right of it, its lower right corner passing over
    the right wall's top. That region (widened a little by the erosion) is wide: its direction
    stays its middle, about 60.8 deg, not the sliding direction +y at its end (the rule for
    the thin bands, :data:`ndbg_cli.ndbg.infinite.equator.BAND_ETA`, does not reach it)."""
    asm = pocket_2d(0.3, 0.3, clearance=0.5)
    nd = build_infinite(asm)
    free = [r for r in nd.regions if r.dbg.is_free(nd.mask(["block"]))]
    assert len(free) == 1 and free[0].dimension == 1
    ang = np.degrees(np.arctan2(free[0].direction[1], free[0].direction[0]))
    assert ang == pytest.approx(90.0 - np.degrees(np.arctan(0.5 / 0.3)) / 2, abs=0.5)
    assert SweepChecker(asm).dbg(np.array(free[0].direction)).is_free(nd.mask(["block"]))


def test_2d_pick_prefers_the_sliding_direction_to_tolerance_bands():
    """A plate 10 x 1 (mm) with a pocket 2 wide (floor y = 0.8: left wall 0.1 high, right
    wall 0.2), a block 2 x 1.2 in it with no clearance, and a 1 x 1 side block against the
    plate's right end (hand answer). The block comes out only along +y. Eroded (``eps`` =
    1e-4 x sqrt(125) mm, ``eta`` = 5e-3 rad), it is free from ``atan(3 eps / 0.2)`` right of
    +y (3.35 ``eta``) to ``atan(3 eps / 0.1)`` left of it (6.7 ``eta``); the side block slides
    on the plate's end along +y and, eroded, within ``atan(3 eps / 1)`` (0.67 ``eta``) of it:
    further left it is blocked by the plate, further right the plate by it. So the block is
    free in three 1-dimensional regions: the right band (DBG base -> block, base -> side), the
    middle one (base -> block; represented by +y, sliding on the walls) and the left band
    (base -> block, side -> base). Open regions used to rank first by index: the right band,
    whose middle (2 ``eta`` right of +y) sinks the block's corner 0.2 x 0.01 mm, 1.8 ``eps``,
    into the right wall (the direct sweep test blocks it). All three are thin (at most
    ``BAND_ETA`` ``eta`` wide): the one sliding along the walls, +y, is picked. The same at -y
    for the sets moving the plate away (4 of the 6 partitionings' picks were blocked)."""
    from ndbg_cli.io.validate import make_polygon_part
    from ndbg_cli.ndbg.infinite.equator import BAND_ETA, equator_extents, sliding_angles
    from ndbg_cli.planning.plans import pick_region, plan

    base = make_polygon_part("base", [(0, 0), (10, 0), (10, 1), (6, 1), (6, 0.8), (4, 0.8),
                                      (4, 0.9), (0, 0.9)])[0]
    block = make_polygon_part("block", [(4, 0.8), (6, 0.8), (6, 2), (4, 2)])[0]
    side = make_polygon_part("side", [(10, 0), (11, 0), (11, 1), (10, 1)])[0]
    asm = Assembly("bands2d", (base, block, side), dimension=2)
    nd = build_infinite(asm)
    sc = SweepChecker(asm)
    # every partitioning's pick is free for the direct test, and so is every plan step's
    # first region (no fallback)
    parts, _ = partitionings(nd)
    assert len(parts) == 6
    for p in parts:
        d = np.array(nd.regions[pick_region(nd, p.regions)].direction)
        assert sc.frees(p.moved, p.rest, d), nd.names(p.moved)
    assert all(sc.frees(s.moved, s.rest, np.array(nd.regions[s.region].direction))
               for s in plan(nd).sequence())
    # the block: its three regions, by hand
    eps, eta = asm.length_tolerance, nd.stats["angular_tolerance"]
    # the default tolerance, 1e-4 of the model's size (twice its farthest corner from its
    # hull's centroid: a little under the 11 x 2 bounding box's diagonal, sqrt(125))
    assert eps == pytest.approx(1e-4 * asm.size) and eta == pytest.approx(5e-3)
    assert 0.99 * np.sqrt(125.0) < asm.size < np.sqrt(125.0)
    mask = nd.mask(["block"])
    free = [k for k, r in enumerate(nd.regions) if r.dbg.is_free(mask)]
    assert len(free) == 3
    bs = nd.geometry
    ext = equator_extents(bs.arcs, bs.n, bs.eta, sliding_angles(bs.circles))
    up, b = np.pi / 2, np.arctan(3 * eps / 1.0)
    ends = [up - np.arctan(3 * eps / 0.2), up - b, up + b, up + np.arctan(3 * eps / 0.1)]
    for k, lo, hi in zip(free, ends, ends[1:]):
        assert ext[k][3][:2] == pytest.approx((lo, hi), abs=1e-3 * eta)
    right, middle, left = (nd.regions[k] for k in free)
    named = [sorted((nd.ids[i], nd.ids[j]) for i, j in r.dbg.arcs())
             for r in (right, middle, left)]
    assert named == [[("base", "block"), ("base", "side")], [("base", "block")],
                     [("base", "block"), ("side", "base")]]
    assert all(r.dimension == 1 and r.thin for r in (right, middle, left))
    assert (right.sliding, middle.sliding, left.sliding) == (0, 1, 0)
    assert pick_region(nd, free) == free[1] and middle.direction == (0.0, 1.0)
    assert not sc.frees(mask, nd.mask(["base", "side"]), np.array(right.direction))
    # the wide regions (a real range of directions) are not thin and still rank first
    wide = [k for k, r in enumerate(nd.regions) if r.dimension == 1 and not r.thin]
    assert wide and all(ext[k][3][1] - ext[k][3][0] > BAND_ETA * eta for k in wide)


#: Seeds of ``benchmarks/fuzz_pick2d.py`` whose assemblies (grids, stacks, pegged plates;
#: three turned) had 36 picks the direct sweep test blocked among 104 partitionings.
FUZZ_SEEDS = [1097657232, 161576974, 2040324895, 643626384, 823941273, 846428920, 503606823,
              552547096]


def test_2d_fuzzed_picks_pass_the_direct_sweep_test():
    """The region :func:`~ndbg_cli.planning.plans.pick_region` picks for each partitioning of a few
    fuzzed 2D assemblies with short zero-clearance contacts: its direction frees the moved
    set for the direct sweep test (``benchmarks/fuzz_pick2d.py`` runs thousands)."""
    import importlib.util

    from conftest import ROOT

    spec = importlib.util.spec_from_file_location("fuzz_pick2d",
                                                  ROOT / "benchmarks" / "fuzz_pick2d.py")
    fuzz = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fuzz)
    for seed in FUZZ_SEEDS:
        asm = fuzz.random_assembly(np.random.default_rng(seed))
        recs = fuzz.check(asm)
        assert recs and all(r["free"] for r in recs), (seed, [r for r in recs if not r["free"]])


def test_union_drops_points_along_its_clipping_rectangle():
    """Pieces clipped to a window leave two points each on its sides; without those inside
    straight runs along a side the union is the same point set (corners and the points
    where the boundary leaves a side stay), and the union made with the runs dropped for its
    covers tests is the plain one."""
    import shapely


    rect = (-1.0, -1.0, 1.0, 1.0)
    # four strips across the window (each touching both the left and right sides), then
    # boxes leaving a notch that runs down from the middle of the top side
    strips = [shapely.box(-1, -1, 1, -0.6), shapely.box(-1, -0.7, 1, -0.2),
              shapely.box(-1, -0.3, 1, 0.2), shapely.box(-1, 0.1, 1, 0.6)]
    around = [shapely.box(-1, 0.5, -0.1, 0.9), shapely.box(0.1, 0.5, 1, 0.9),
              shapely.box(-1, 0.9, -0.5, 1), shapely.box(0.5, 0.9, 1, 1),
              shapely.box(-1, 0.55, 1, 0.6)]
    polys = np.array(strips + around, dtype=object)
    plain = shapely.union_all(polys)
    got = cu.off_rect_runs(plain, rect)
    assert got.equals(plain)
    # the left and right sides each keep only the two corners: (-1, -1), (-1, 1)... and the
    # top side its corners and the notch's two ends
    xy = shapely.get_coordinates(got.exterior)[:-1]
    on_left = xy[xy[:, 0] == -1.0]
    assert sorted(map(tuple, on_left)) == [(-1.0, -1.0), (-1.0, 1.0)]
    assert sorted(map(tuple, xy[xy[:, 1] == 1.0])) == [(-1.0, 1.0), (-0.5, 1.0), (0.5, 1.0),
                                                      (1.0, 1.0)]
    assert len(shapely.get_coordinates(plain.exterior)) > len(xy) + 1
    # and the union function gives that same set
    assert cu.union(polys, seed=2, rect=rect).equals(plain)


def test_open_hits_is_the_box_filtered_open_membership():
    """The compiled scan (:func:`ndbg_cli.kernels._cone_kernels.open_hits`) against the same test
    written with an STR-tree query and numpy: a direction is hit when some piece's box holds its
    chart point (ends included) and the piece's open cone holds the direction."""
    import shapely

    from ndbg_cli.kernels import _cone_kernels as kernels
    from ndbg_cli.ndbg.infinite.cubemap import direction_of

    rng = np.random.default_rng(7)
    cones = rng.normal(size=(60, 5, 3))
    cones /= np.linalg.norm(cones, axis=2, keepdims=True)
    cones[::7, 3:] = 0.0  # zero rows: not constraints
    x0, y0 = rng.uniform(-1, 0.8, size=(2, 80))
    boxes = np.column_stack([x0, y0, x0 + rng.uniform(0, 0.6, 80), y0 + rng.uniform(0, 0.6, 80)])
    index = rng.integers(0, len(cones), size=80)
    st = rng.uniform(-1, 1, size=(400, 2))
    st[:40] = boxes[:40, :2]  # on a box's corner: held (ends included)
    d = direction_of(0, st)
    got = kernels.open_hits(cones, d, st[:, 0].copy(), st[:, 1].copy(), boxes, index, 1e-6)
    pt, item = shapely.STRtree(shapely.box(*boxes.T)).query(shapely.points(st))
    inside = np.ones(len(pt), dtype=bool)
    for t in range(cones.shape[1]):
        m = cones[index[item], t]
        inside &= ~np.any(m != 0, axis=1) | ((m * d[pt]).sum(axis=1) > 1e-6)
    want = np.zeros(len(st), dtype=bool)
    want[pt[inside]] = True
    assert np.array_equal(got, want)
    assert 0 < want.sum() < len(st)
