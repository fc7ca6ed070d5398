"""Fast paths of the infinite-translation NDBG, each against the general route and against
answers worked out by hand: one cone for convex parts far apart
(:func:`ndbg_cli.ndbg.infinite.convex_cones.convex_pair_cone`), the merging of collinear boundary
segments before the arrangement is noded
(:func:`ndbg_cli.ndbg.infinite.arrangement.merged_segments`), the
candidate facets of difference and box cones, and the near-first walk inside a domain."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
import trimesh

import ndbg_cli
from ndbg_cli.contacts.contacts3d import analyze_contacts
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.kernels._cone_kernels import FACES
from ndbg_cli.ndbg.infinite import arrangement, blocked_sets
from ndbg_cli.ndbg.infinite import blocking_cones as bc
from ndbg_cli.ndbg.infinite import build as infinite
from ndbg_cli.ndbg.infinite import chart_union as cu
from ndbg_cli.ndbg.infinite import convex_cones as cc
from ndbg_cli.ndbg.infinite.cover import RASTER
from ndbg_cli.ndbg.infinite.cubemap import (
    BOX_EDGE_PAIRS,
    DIFFERENCE_PAIRS,
    compact,
    cone_normals,
    face_of,
    random_directions,
)
from ndbg_cli.ndbg.infinite.domain import free_domain
from ndbg_cli.ndbg.infinite.sweep import SweepChecker
from ndbg_cli.ndbg.infinitesimal.build import contact_pairs


def _tris(m: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    return np.asarray(m.triangles, dtype=float), np.asarray(m.face_normals, dtype=float)


def _inside(cones: np.ndarray, d: np.ndarray, tol: float = 1e-9,
            chunk: int = 2048) -> np.ndarray:
    """``(m,)`` whether each direction of ``d`` lies in some open cone (zero rows ignored);
    a chunk of cones at a time, as one matrix product (a dense pair's 10,000 cones against
    4,000 directions would otherwise make one 10^9-element array)."""
    zero = ~np.any(cones != 0.0, axis=2)
    p, k, _ = cones.shape
    flat = cones.reshape(-1, 3)
    out = np.zeros(len(d), dtype=bool)
    for s in range(0, p, chunk):
        todo = np.flatnonzero(~out)  # a direction inside one cone needs no other
        if not len(todo):
            break
        v = (d[todo] @ flat[s * k:(s + chunk) * k].T).reshape(len(todo), -1, k)
        v[:, zero[s:s + chunk]] = np.inf  # padding rows constrain nothing
        out[todo] = (v.min(axis=2) > tol).any(axis=1)
    return out


def test_two_cubes_block_exactly_the_directions_of_one_cube_face():
    # P_i = [0,1]^3, P_j = [2,3]x[0,1]x[0,1]: P_j - P_i = [1,3]x[-1,1]x[-1,1], whose cone is
    # {d_x > 0, |d_y| < d_x, |d_z| < d_x}: the +x face of the cube map, nothing else.
    a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    b = trimesh.creation.box(bounds=[[2, 0, 0], [3, 1, 1]])
    cone = cc.convex_pair_cone(a.vertices, b.vertices, 1e-6)
    assert cone is not None and cone.shape == (1, 4, 3)
    d = np.array([[1, 0, 0], [1, 0.9, 0.9], [1, -0.9, 0.5], [1, 1.1, 0], [1, 0, -1.1],
                  [-1, 0, 0], [0, 1, 0]], dtype=float)
    assert _inside(cone, d).tolist() == [True, True, True, False, False, False, False]
    entries = cc.convex_entries([cone])[0]
    # face 0 is +x: its whole chart square; the others only reach past their border by
    # the chart margin (SQUARE_MARGIN), on the cube edges
    assert entries[0][0].area == pytest.approx(4.0, rel=1e-9)
    others = [e[0].area for e in entries[1:] if e is not None]
    assert max(others, default=0.0) < 1e-6
    assert entries[1] is None  # -x


def test_touching_or_overlapping_boxes_take_the_terms():
    a = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    b = trimesh.creation.box(bounds=[[1, 0, 0], [2, 1, 1]])  # face contact: erosion applies
    assert cc.convex_pair_cone(a.vertices, b.vertices, 1e-3) is None
    c = trimesh.creation.box(bounds=[[1.003, 0, 0], [2, 1, 1]])  # gap 3 eps < 4 eps: near
    assert cc.convex_pair_cone(a.vertices, c.vertices, 1e-3) is None


def test_convexity_test():
    box = trimesh.creation.box(extents=[1, 2, 3])
    assert cc.is_convex(*_tris(box))
    assert cc.is_convex(*_tris(trimesh.creation.cylinder(radius=1, height=2, sections=16)))
    ell = trimesh.boolean.union([trimesh.creation.box(bounds=[[0, 0, 0], [2, 1, 1]]),
                                 trimesh.creation.box(bounds=[[0, 0, 0], [1, 2, 1]])],
                                engine="manifold")
    assert not cc.is_convex(*_tris(ell))
    # a dent of 1e-6 of the size is a dent: push the middle vertex of a face inward
    fine = box.subdivide().subdivide()
    v = fine.vertices.copy()
    mid = np.flatnonzero(np.all(np.isclose(v, [0, 0, 1.5]), axis=1))
    assert len(mid) == 1
    v[mid[0], 2] -= 1e-6
    dented = trimesh.Trimesh(v, fine.faces, process=False)
    assert not cc.is_convex(*_tris(dented))
    assert cc.is_convex(*_tris(fine))  # subdivided but flat: convex


def _random_convex(rng: np.random.Generator) -> trimesh.Trimesh:
    kind = rng.integers(3)
    if kind == 0:
        m = trimesh.creation.box(extents=rng.uniform(0.3, 2.0, 3))
    elif kind == 1:
        m = trimesh.creation.cylinder(radius=rng.uniform(0.2, 1.0), height=rng.uniform(0.3, 2),
                                      sections=int(rng.integers(5, 12)))
    else:
        m = trimesh.convex.convex_hull(rng.normal(size=(12, 3)))
    m.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    return m


def test_convex_cone_is_the_union_of_the_terms_on_random_pairs():
    rng = np.random.default_rng(7)
    d = random_directions(3000, seed=3)
    checked = 0
    while checked < 40:
        a, b = _random_convex(rng), _random_convex(rng)
        b.apply_translation(rng.normal(size=3) * 2 + np.sign(rng.normal(size=3)) * 2.5)
        cone = cc.convex_pair_cone(a.vertices, b.vertices, 1e-3)
        if cone is None:
            continue
        ta, na = _tris(a)
        tb, nb = _tris(b)
        terms, circles = bc.pair_cones(ta, na, tb, nb, 1e-3)
        assert not len(circles)
        np.testing.assert_array_equal(_inside(cone, d, 1e-6), _inside(terms, d, 1e-6))
        fast, slow = cc.convex_entries([cone])[0], cu.cones_to_face_geoms(terms)
        for f in range(6):
            assert (fast[f] is None) == (slow[f] is None)
            if fast[f] is not None:
                diff = shapely.symmetric_difference(fast[f][0], slow[f][0]).area
                assert diff <= 1e-9 * fast[f][0].area
        checked += 1


def grid(k: int, pitch: float = 1.5) -> Assembly:
    parts = []
    for n in range(k ** 3):
        x, y, z = n % k, (n // k) % k, n // (k * k)
        m = trimesh.creation.box(extents=[1, 1, 1])
        m.apply_translation([pitch * x, pitch * y, pitch * z])
        parts.append(make_part(f"b{n}", m.vertices, m.faces)[0])
    return Assembly("grid", tuple(parts))


def test_grid_of_boxes_fast_paths_agree_with_the_general_route(monkeypatch):
    asm = grid(2)
    fast = infinite.build_infinite(asm)
    assert fast.stats["regions"] > 0
    bs = fast.geometry
    assert bs.stats["convex_pairs"] == 28  # every pair of the 8 boxes
    d = random_directions(2000, seed=5)
    got = bs.dbgs(d, exact=True)
    # the direct per-direction test, independent of both routes
    sweep = SweepChecker(asm)
    for k in range(0, len(d), 50):
        assert got[k].succ == sweep.dbg(d[k]).succ
    # the general route: every pair through its terms, the linework noded unmerged
    monkeypatch.setattr(blocked_sets, "convex_pairs", lambda *a, **k: {})
    monkeypatch.setattr(arrangement, "merged_segments", lambda lines: lines)
    slow = infinite.build_infinite(asm)
    assert slow.geometry.stats["convex_pairs"] == 0
    assert [g.succ for g in slow.geometry.dbgs(d, exact=True)] == [g.succ for g in got]

    def two_d(nd):
        return sorted((r.direction, r.dbg.succ) for r in nd.regions if r.dimension == 2)

    assert {s for _, s in two_d(fast)} == {s for _, s in two_d(slow)}
    assert fast.region_counts()["2"] == slow.region_counts()["2"]


def test_merged_segments_by_hand():
    lines = [shapely.LineString([(0, 0), (1, 0)]), shapely.LineString([(2, 0), (0.5, 0)]),
             shapely.LineString([(3, 0), (4, 0)]), shapely.LineString([(4, 0), (5, 0)]),
             shapely.LineString([(1, 1), (0, 1)]), shapely.LineString([(0, -1), (0, 2)]),
             shapely.box(10, 10, 11, 11).boundary]
    got = arrangement.merged_segments(lines)
    segs = sorted(tuple(sorted(map(tuple, shapely.get_coordinates(g).tolist()))) for g in got)
    assert segs == sorted([((0.0, 0.0), (2.0, 0.0)),   # overlapping, one reversed
                           ((3.0, 0.0), (5.0, 0.0)),   # touching end to end
                           ((0.0, 1.0), (1.0, 1.0)),
                           ((0.0, -1.0), (0.0, 2.0)),
                           ((10.0, 10.0), (11.0, 10.0)), ((11.0, 10.0), (11.0, 11.0)),
                           ((10.0, 11.0), (11.0, 11.0)), ((10.0, 10.0), (10.0, 11.0))])
    # the same point set: merging changes no coordinate
    assert shapely.equals(shapely.union_all(got), shapely.union_all(lines))


def test_arrangement_cells_are_chains_between_true_nodes():
    # two squares crossing: each square's boundary is cut by the other at 2 points, so 4
    # chains (1-dimensional cells, through the squares' corners) and 2 nodes
    a, b = shapely.box(0, 0, 2, 2), shapely.box(1, 1, 3, 3)
    noded = shapely.line_merge(shapely.union_all(
        arrangement.merged_segments([a.boundary, b.boundary]), grid_size=cu.GRID))
    parts = shapely.get_parts(noded)
    assert len(parts) == 4
    ends = {tuple(p) for g in parts for p in shapely.get_coordinates(g)[[0, -1]].tolist()}
    assert ends == {(1.0, 2.0), (2.0, 1.0)}


def test_merged_segments_keep_exact_input_coordinates():
    # many lines, random float end points: every output end point is an input vertex, bit for
    # bit (noding snaps to GRID; a rounded end would move a node), and the length is that of
    # the union of the intervals, line by line
    rng = np.random.default_rng(11)
    lines, pts, expected = [], set(), 0.0
    for _ in range(200):
        o, u = rng.uniform(-1, 1, 2), rng.normal(size=2)
        u /= np.linalg.norm(u)
        spans = np.sort(rng.uniform(-0.7, 0.7, (4, 2)), axis=1)
        for a, b in spans:
            p, q = o + a * u, o + b * u
            lines.append(shapely.LineString([p, q]))
            pts |= {tuple(p), tuple(q)}
        hi = -np.inf
        for a, b in spans[np.argsort(spans[:, 0])]:
            expected += max(b, hi) - max(a, hi) if b > hi else 0.0
            hi = max(hi, b)
    got = arrangement.merged_segments(lines)
    ends = shapely.get_coordinates(got)
    assert all(tuple(e) in pts for e in ends.tolist())
    assert len(got) < len(lines)  # overlapping pieces on one line were merged
    assert shapely.length(got).sum() == pytest.approx(expected, rel=1e-9)


def test_budget_counts_a_far_convex_pair_as_one_cone():
    # 8 boxes of 12 triangles: 96^2 - 8 * 12^2 = 8,064 ordered triangle pairs; apart, each of
    # the 56 ordered pairs of parts is one cone, counted as CONVEX_PAIR_COST
    # plus 8 x 8 difference vectors per pair, one triangle pair per 128 of them
    assert blocked_sets.triangle_pairs(grid(2)) == 56 * (blocked_sets.CONVEX_PAIR_COST + 64 / 128)
    assert blocked_sets.triangle_pairs(grid(2, pitch=1.0)) == 8064  # touching: the terms


def test_open_mesh_is_not_taken_for_convex():
    # a box without its top face: closed-surface reasoning does not apply, the terms decide
    box = trimesh.creation.box(bounds=[[0, 0, 0], [1, 1, 1]])
    top = box.triangles_center[:, 2] > 1 - 1e-9
    cup = trimesh.Trimesh(box.vertices, box.faces[~top], process=False)
    peg = trimesh.creation.box(bounds=[[0.3, 0.3, 2], [0.7, 0.7, 3]])
    tris = [_tris(cup), _tris(peg)]
    assert cc.is_convex(*tris[0])  # the test itself cannot tell: the mesh must be closed
    assert cc.convex_pairs(tris, [10, 12], 1e-4, [False, True]) == {}
    assert list(cc.convex_pairs(tris, [10, 12], 1e-4, [True, True])) == [(0, 1)]


def test_many_facet_cone_is_clipped_whole():
    # two 64-sided cylinders: a cone of more facets than the clipper's default 48 vertices
    a = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=64)
    b = a.copy()
    b.apply_transform(trimesh.transformations.rotation_matrix(0.7, [1, 1, 0]))
    b.apply_translation([4.0, 1.0, 0.5])
    cone = cc.convex_pair_cone(a.vertices, b.vertices, 1e-4)
    assert cone is not None and cone.shape[1] > 44
    terms, _ = bc.pair_cones(*_tris(a), *_tris(b), 1e-4)
    d = random_directions(4000, seed=9)
    np.testing.assert_array_equal(_inside(cone, d, 1e-6), _inside(terms, d, 1e-6))
    fast, slow = cc.convex_entries([cone])[0], cu.cones_to_face_geoms(terms)
    for f in range(6):
        assert (fast[f] is None) == (slow[f] is None)
        if fast[f] is not None:
            assert shapely.symmetric_difference(fast[f][0], slow[f][0]).area \
                <= 1e-9 * fast[f][0].area


def test_hull_rounding_falls_back_to_the_terms():
    # a gap of 4.1e-9 against parts of size 5 (eps 1e-9): the projected coordinates reach
    # 4e8 and qhull drops an extreme point by 1e-6 rad; the cone must not be used then
    va = np.array([[-1.2533289028463013, -0.7109335598437617, 0.47375283050154054],
                   [-1.2533176046954821, -0.7109040329234958, 0.4738270226187472],
                   [-0.5416118636266756, 1.3427892701893194, -0.4519681124521201],
                   [-0.5416005654758563, 1.3428187971095853, -0.45189392033491343],
                   [0.5416005654758563, -1.3428187971095853, 0.45189392033491343],
                   [0.5416118636266756, -1.3427892701893194, 0.4519681124521201],
                   [1.2533176046954821, 0.7109040329234958, -0.4738270226187472],
                   [1.2533289028463013, 0.7109335598437617, -0.47375283050154054]])
    vb = np.array([[-3.6005989986737577, -1.3266078710927647, -1.6178215707847876],
                   [-3.329354670998983, 1.0369505996508321, -0.8642522715247065],
                   [-2.142750756705746, 1.8478441838621131, -2.438545925361339],
                   [-1.7856534119013436, -0.48893399877227783, -4.09389215121083],
                   [-1.4311771478047428, 0.25187860032758314, -1.1113484829013403],
                   [-1.4299155878739271, -0.029303005565346374, -3.208231269595987],
                   [-1.3288767713206862, 2.7073806143623673, -1.491951846140464],
                   [-0.8816138092549795, 0.8750972933859902, -1.032859185623773],
                   [-0.2457680652709897, 2.1051599226652824, -0.4738270267187472],
                   [0.08632293737661545, 1.5408701709090404, -3.375527671415915]])
    cone = cc.convex_pair_cone(va, vb, 1e-9)
    if cone is not None:  # then it must hold every generator
        diff = (vb[:, None] - va[None]).reshape(-1, 3)
        diff /= np.linalg.norm(diff, axis=1, keepdims=True)
        assert (diff @ cone[0].T).min() >= -1e-9


def test_union_is_never_smaller_than_a_piece():
    # two chart polygons one ulp apart at a vertex, the first covering the second: GEOS 3.14's
    # plain union returns the smaller one; the union must be the larger
    a = shapely.Polygon([[1.000000001, 0.7016129004864957],
                         [0.2366823741967847, 0.7265055648644683],
                         [0.23668237419678473, 1.000000001], [1.000000001, 1.000000001]])
    b = shapely.Polygon([[1.000000001, 0.7016129004864957],
                         [0.23668237419678473, 0.7265055648644683],
                         [0.32604473088553954, 1.000000001], [1.000000001, 1.000000001]])
    assert a.covers(b)
    for pieces in ([b, a], [a, b]):
        got = cu.union(np.array(pieces, dtype=object))
        assert got.area == pytest.approx(a.area, rel=1e-9)
        assert got.buffer(1e-9).covers(a)  # snapped to GRID: within 1e-10


# --------------------------------------------------------------------------------------------
# Candidate facets: the generator pairs that can span a facet
# --------------------------------------------------------------------------------------------

def _same_open_set(m_all: np.ndarray, m_few: np.ndarray, d: np.ndarray) -> bool:
    """Whether two H-representations give the same open cone on ``d``, up to 1e-9 (each
    strict membership implies the other's lenient one)."""
    a, b = _inside(m_all, d, 1e-9), _inside(m_few, d, 1e-9)
    a2, b2 = _inside(m_all, d, -1e-9), _inside(m_few, d, -1e-9)
    return not (np.any(a & ~b2) or np.any(b & ~a2))


def test_triangle_difference_facets_come_from_edge_vertex_pairs():
    # cone(t_j - t_i) over the 18 generator pairs sharing a vertex of one triangle equals the
    # cone over all 36 pairs: generic, coplanar, parallel-edged, touching and integer pairs
    rng = np.random.default_rng(7)
    d = random_directions(3000, seed=11)
    only_v = (DIFFERENCE_PAIRS[0][DIFFERENCE_PAIRS[0] // 3 == DIFFERENCE_PAIRS[1] // 3],
              DIFFERENCE_PAIRS[1][DIFFERENCE_PAIRS[0] // 3 == DIFFERENCE_PAIRS[1] // 3])
    missed = 0
    for trial in range(600):
        ti = rng.normal(size=(3, 3))
        tj = rng.normal(size=(3, 3)) + rng.normal(size=3) * rng.uniform(0, 3)
        kind = trial % 5
        if kind == 1:
            ti[:, 2] = tj[:, 2] = 0.0
        elif kind == 2:
            tj = -ti + rng.normal(size=3)  # every edge of t_j parallel to one of t_i
        elif kind == 3:
            tj[0] = ti[1]  # a shared vertex: the origin is on the difference's boundary
        elif kind == 4:
            ti, tj = np.round(ti), np.round(tj)
        gens = (tj[None, :, None, :] - ti[None, None, :, :]).reshape(1, 9, 3)
        full = compact(cone_normals(gens))
        assert _same_open_set(full, compact(cone_normals(gens, pairs=DIFFERENCE_PAIRS)), d)
        missed += not _same_open_set(full, compact(cone_normals(gens, pairs=only_v)), d)
    assert missed > 100  # the edges of t_i are needed too: the check has teeth


def test_box_cone_facets_come_from_box_edges():
    rng = np.random.default_rng(8)
    d = random_directions(3000, seed=12)
    # corner c takes the high end on axis x when bit 2 - x of c is set, as the walk's
    # compiled prune (term_kernels.prune_pairs) builds them
    corners = np.array([[c >> 2 & 1, c >> 1 & 1, c & 1] for c in range(8)], dtype=bool)
    for trial in range(300):
        lo = rng.normal(size=3) * 2
        hi = lo + rng.uniform(0, 2, size=3)
        if trial % 3 == 1:
            hi[trial % 2] = lo[trial % 2]  # a flat box
        elif trial % 3 == 2:
            lo[0] = 0.0  # the origin on the plane of a face
        gens = np.where(corners, hi, lo)[None]
        full = compact(cone_normals(gens))
        assert _same_open_set(full, compact(cone_normals(gens, pairs=BOX_EDGE_PAIRS)), d)


def test_walk_with_a_domain_gives_the_dense_set_inside_it():
    # near leaf pairs first (domain given): the pruned union equals the dense terms on every
    # sampled direction of the domain cells, for the blind peg and the bolt (bore contacts);
    # some triangle pairs are left out before their terms are made, their facing half-space
    # already inside a kept piece (_Walk._open_sides)
    skipped = 0
    for name in ("peg-blind", "bolt-plain"):
        asm = ndbg_cli.load(f"assemblies/{name}.yaml")
        ca = analyze_contacts(asm)
        dom = free_domain(len(asm.parts), contact_pairs(asm, ca), ca.angle_tolerance)
        assert dom is not None and dom.mean() < 0.05
        tris = bc.part_triangles(asm)
        eps = asm.length_tolerance
        # directions inside the domain: random cell centres and points near the cap centres
        f, row, col = np.nonzero(dom)
        rng = np.random.default_rng(3)
        k = rng.integers(0, len(f), 4000)
        s = -1.0 + (col[k] + rng.uniform(0, 1, len(k))) * 2.0 / RASTER
        t = -1.0 + (row[k] + rng.uniform(0, 1, len(k))) * 2.0 / RASTER
        d = FACES[f[k], 0] + s[:, None] * FACES[f[k], 1] + t[:, None] * FACES[f[k], 2]
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        assert (face_of(d)[0] == f[k]).all()
        stats: dict = {}
        a, b = 0, 1
        walked, circ = bc.pruned_pair_cones(tris[a][0], tris[a][1], bc.tri_tree(tris[a][0]),
                                            tris[b][0], tris[b][1], bc.tri_tree(tris[b][0]),
                                            eps, stats=stats, domain=dom)
        dense, circ_dense = bc.pair_cones(tris[a][0], tris[a][1], tris[b][0], tris[b][1], eps)
        assert stats["kept"] < len(dense) / 3
        assert _same_open_set(dense, walked, d)
        assert _inside(dense, d).any() and not _inside(dense, d).all()
        assert len(circ) == len(circ_dense)
        skipped += stats["side_skipped"]
    assert skipped > 0


def test_worker_processes_give_the_same_ndbg(monkeypatch):
    # the pairs computed by two worker processes (in an order of their own) give the same
    # NDBG as one process: same regions, directions, DBGs, pieces; with a domain too
    from ndbg_cli.ndbg.infinite import pair_workers

    monkeypatch.setattr(pair_workers, "MIN_PARALLEL_PAIRS", 0)
    for name, restricted in (("fig2-sandwich-5", False), ("fig11-nonlinear", True)):
        asm = ndbg_cli.load(f"assemblies/{name}.yaml")
        dom = None
        if restricted:
            ca = analyze_contacts(asm)
            dom = free_domain(len(asm.parts), contact_pairs(asm, ca), ca.angle_tolerance)
        one = infinite.build_infinite(asm, domain=dom, workers=1)
        two = infinite.build_infinite(asm, domain=dom, workers=2)
        assert one.regions == two.regions and len(one.regions) > 5
        assert one.stats["pieces"] == two.stats["pieces"]
