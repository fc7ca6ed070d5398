"""The direct per-direction test's polygon kernels (:mod:`ndbg_cli.ndbg.infinite.sweep`), against
areas worked out by hand, and the test itself on two boxes with known answers."""

import numpy as np
import pytest
import trimesh

from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.kernels._sweep_kernels import (
    MAX_VERTICES,
    clip_half_plane,
    front_overlap,
    plane,
    polygon_area,
)
from ndbg_cli.ndbg.infinite.build import build_infinite
from ndbg_cli.ndbg.infinite.sweep import SweepChecker


def _clip(poly, a, b):
    """``poly`` (vertices) clipped to ``a . x <= b`` by the kernel, and the result's area."""
    p = np.asarray(poly, float)
    px, py = np.zeros(MAX_VERTICES), np.zeros(MAX_VERTICES)
    px[:len(p)], py[:len(p)] = p[:, 0], p[:, 1]
    qx, qy = np.zeros(MAX_VERTICES), np.zeros(MAX_VERTICES)
    n = clip_half_plane(px, py, len(p), float(a[0]), float(a[1]), float(b), qx, qy)
    return n, polygon_area(qx, qy, n)


def test_clip_square_by_half_planes_has_the_hand_worked_areas():
    sq = [(0, 0), (2, 0), (2, 2), (0, 2)]
    xs, ys = np.array(sq, float).T
    assert polygon_area(xs, ys, 4) == pytest.approx(4.0)
    # x <= 0.5: a 0.5 x 2 strip
    assert _clip(sq, (1.0, 0.0), 0.5) == (4, pytest.approx(1.0))
    # x + y <= 1: the corner triangle of legs 1
    assert _clip(sq, (1.0, 1.0), 1.0) == (3, pytest.approx(0.5))
    # the whole square kept, or none of it
    assert _clip(sq, (1.0, 0.0), 5.0)[1] == pytest.approx(4.0)
    assert _clip(sq, (1.0, 0.0), -1.0) == (0, 0.0)


def test_plane_of_a_projected_triangle():
    # z = 1 + 2 u - 2 v through three points in general position
    tri = np.array([[0, 0, 1.0], [2, 1, 3.0], [1, 3, -3.0]])
    assert plane(tri) == pytest.approx((1.0, 2.0, -2.0))


def _box(pid, lo, hi):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return make_part(pid, m.vertices, m.faces)[0]


def test_box_on_box_blocked_down_free_up_and_sideways_only_when_clear():
    # a unit cube resting on a 3 x 3 slab: down blocked, up free; sideways the cube slides
    # along the slab's top face (a sliding contact does not block)
    asm = Assembly("t", (_box("slab", (-1.5, -1.5, -1), (1.5, 1.5, 0)),
                         _box("cube", (-0.5, -0.5, 0), (0.5, 0.5, 1))))
    s = SweepChecker(asm)
    assert s.blocked(1, 0, np.array([0, 0, -1.0]))
    assert not s.blocked(1, 0, np.array([0, 0, 1.0]))
    assert not s.blocked(1, 0, np.array([1.0, 0, 0]))
    # slightly downwards the cube digs into the slab; slightly upwards it clears it
    assert s.blocked(1, 0, np.array([1.0, 0, -0.05]))
    assert not s.blocked(1, 0, np.array([1.0, 0, 0.05]))
    assert s.dbg(np.array([0, 0, -1.0])).succ != s.dbg(np.array([0, 0, 1.0])).succ


def _in_front(ti, tj, amin, tau, area_min, buf):
    """Whether ``ti`` and ``tj`` overlap over an area above ``amin`` and ``tj`` is in front
    over an area above ``area_min``, by the kernel (:func:`front_overlap`'s polygon)."""
    out = np.empty((2, MAX_VERTICES))
    n = front_overlap(ti, tj, amin, tau, buf, out)
    return polygon_area(out[0], out[1], n) > area_min


def test_triangle_pair_test_matches_shapely_on_random_pairs():
    # an independent reference: shapely's intersection of the two triangles (their overlap),
    # then of that with the region where t_j is in front of t_i (z_j - z_i >= -tau)
    import shapely

    rng = np.random.default_rng(7)
    buf = np.empty((4, MAX_VERTICES))
    ti = rng.uniform(-1, 1, size=(400, 3, 3))
    tj = rng.uniform(-1, 1, size=(400, 3, 3))
    seen = {"overlap": 0, "in_front": 0, "partly": 0}
    for q in range(len(ti)):
        ref = shapely.Polygon(ti[q, :, :2]).intersection(shapely.Polygon(tj[q, :, :2]))
        ci, cj = np.array(plane(ti[q])), np.array(plane(tj[q]))
        dc = cj - ci  # z_j - z_i = dc0 + dcu u + dcv v >= 0 on a big polygon
        n = -dc[1:] / max(np.linalg.norm(dc[1:]), 1e-300)
        p0 = n * (dc[0] / max(np.linalg.norm(dc[1:]), 1e-300))
        t = np.array([-n[1], n[0]])
        half = shapely.Polygon([p0 + 10 * t, p0 - 10 * t, p0 - 10 * t - 10 * n,
                                p0 + 10 * t - 10 * n])
        front = ref.intersection(half).area
        for amin, amin2 in ((0.0, 0.0), (ref.area * 0.999, 0.0), (0.0, front * 1.001),
                            (0.0, front * 0.999)):
            want = ref.area > amin and front > amin2
            if abs(ref.area - amin) < 1e-9 or abs(front - amin2) < 1e-9:
                continue
            assert _in_front(ti[q], tj[q], amin, 0.0, amin2, buf) == want, q
        seen["overlap"] += ref.area > 0
        seen["in_front"] += front > 0
        seen["partly"] += 0 < front < ref.area - 1e-9
    assert seen["overlap"] > 50 and seen["partly"] > 20


@pytest.mark.parametrize("inverted", [False, True])
def test_an_open_cup_over_a_boss_is_blocked_sideways_whichever_way_it_is_wound(inverted):
    # A cup given as an open shell (a 16-sided tube of radius 1.2 with a top and no bottom:
    # a surface export), standing over a closed boss of radius 1 and height 2. By
    # construction the cup comes off upwards only: sideways or down its wall, or its top,
    # meets the boss. An open shell has no outside, so the test must not depend on the way
    # its triangles are wound (the engine's pins, in ../shared/data/engine, are such cups;
    # the test used to free them sideways through their bosses).
    boss = trimesh.creation.cylinder(radius=1.0, height=2.0, sections=16)
    boss.apply_translation([0, 0, 1.0])
    shell = trimesh.creation.cylinder(radius=1.2, height=2.4, sections=16)
    shell.apply_translation([0, 0, 1.2])
    keep = shell.triangles_center[:, 2] > 1e-6  # drop the bottom cap: an open cup
    faces = shell.faces[keep][:, ::-1] if inverted else shell.faces[keep]
    cup, diags = make_part("cup", shell.vertices, faces)
    assert not cup.check.watertight and any(d.code == "not-watertight" for d in diags)
    asm = Assembly("cup", (make_part("boss", boss.vertices, boss.faces)[0], cup))
    s = SweepChecker(asm)
    assert not s.blocked(1, 0, np.array([0, 0, 1.0]))
    for d in ([1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -0.6, 0.8], [0, 0, -1.0]):
        assert s.blocked(1, 0, np.array(d)), d
        assert s.blocked(0, 1, -np.array(d)), d  # and the boss, moved the other way
    # the arrangement (paper 5.3) sees the same shell: the cup is free in one region only,
    # about +z (the clearance of 0.2 lets it tilt a little)
    nd = build_infinite(asm)
    free = [reg.direction for reg in nd.regions
            if reg.direction is not None and reg.dbg.is_free(0b10, 0b11)]
    assert len(free) == 1 and free[0][2] > 0.95


def _twisted_rod(radius: float, sections: int, length: float) -> trimesh.Trimesh:
    """A rod along z whose end circles are tessellated half a facet apart, as STEP exports
    often are: its side triangles join a corner of one end to the facet between two corners
    of the other, so they lean slightly off the axis and face along it (by about
    ``pi / sections`` of the rod's radius over its length)."""
    a = 2 * np.pi * np.arange(sections) / sections
    ring = np.c_[radius * np.cos(a), radius * np.sin(a)]
    ring2 = np.c_[radius * np.cos(a + np.pi / sections), radius * np.sin(a + np.pi / sections)]
    v = np.vstack([np.c_[ring, np.full(sections, -length / 2)],
                   np.c_[ring2, np.full(sections, length / 2)],
                   [(0, 0, -length / 2), (0, 0, length / 2)]])
    n, f = sections, []
    for k in range(n):
        k2 = (k + 1) % n
        f += [(k, k2, n + k), (n + k, k2, n + k2), (2 * n, k2, k), (2 * n + 1, n + k, n + k2)]
    rod = trimesh.Trimesh(v, np.array(f), process=True)
    rod.fix_normals()
    assert rod.is_watertight and rod.is_volume
    return rod


def _rod_in_ring(sections: int) -> Assembly:
    """A twisted rod (:func:`_twisted_rod`, radius 5, 40 long) through a ring (hole of radius
    5, outside 20, 4 thick), both with ``sections`` facets; tolerance 0.006 (about the default
    of a 60 mm model)."""
    ring = trimesh.creation.annulus(r_min=5.0, r_max=20.0, height=4.0, sections=sections)
    rod = _twisted_rod(5.0, sections, 40.0)
    return Assembly("rod", (make_part("ring", ring.vertices, ring.faces)[0],
                            make_part("rod", rod.vertices, rod.faces)[0]), tolerance=0.006)


@pytest.mark.parametrize("sections", [96, 128])
def test_a_faceted_rod_slides_through_a_faceted_hole_of_its_own_radius(sections):
    # Worked out by hand: the rod's side facets lean off its axis (:func:`_twisted_rod`), so
    # they face along it and their shadows, between the rod's two end polygons, cross the
    # hole's chords; the slivers where they leave the hole's shadow are no wider than the
    # sagitta
    # 5 (1 - cos(pi / sections)) (0.0027 at 96 facets), under the tolerance (0.006). Each
    # sliver has an area (about half the sagitta times a facet's
    # chord, 4e-4 at 96) above the square of the tolerance, so the triangle-pair test alone
    # blocked the rod; the real rod slides.
    d = np.array([0, 0, 1.0])
    asm = _rod_in_ring(sections)
    sagitta = 5 * (1 - np.cos(np.pi / sections))
    assert sagitta < 0.5 * asm.length_tolerance
    assert sagitta * 2 * np.pi * 5 / sections / 2 > asm.length_tolerance ** 2
    s = SweepChecker(asm)
    for sense in (1, -1):
        assert not s.blocked(1, 0, sense * d) and not s.blocked(0, 1, sense * d)
    # sideways the rod meets the ring's inside wall
    assert s.blocked(1, 0, np.array([1.0, 0, 0])) and s.blocked(1, 0, np.array([0, -1.0, 0]))


def test_a_face_tessellated_into_slivers_still_blocks():
    # A 10 x 10 x 1 slab whose top face is 1,000 strips 0.01 wide (each strip two triangles,
    # every one narrower than the tolerance 0.02 given), under a 4 x 4 x 1 block resting on
    # it: no single triangle pair's overlap holds a disk of diameter 0.02, their union (the
    # block's whole footprint) does, so the block is blocked downwards; upwards it is free.
    n, w = 1000, 0.01
    xs = np.arange(n + 1) * w
    top = [(x, y, 1.0) for x in xs for y in (0.0, 10.0)]
    bottom = [(x, y, 0.0) for x in (0.0, 10.0) for y in (0.0, 10.0)]
    v = np.array(top + bottom, float)
    f = [(2 * k, 2 * k + 2, 2 * k + 3) for k in range(n)]
    f += [(2 * k, 2 * k + 3, 2 * k + 1) for k in range(n)]
    b = 2 * (n + 1)
    f += [(b, b + 3, b + 2), (b, b + 1, b + 3)]  # bottom, two triangles
    f += [(2 * k, b, 2 * k + 2) for k in range(n)]  # side y = 0: a fan from a bottom corner
    f += [(2 * n, b, b + 2)]
    f += [(2 * k + 1, 2 * k + 3, b + 3) for k in range(n)]  # side y = 10
    f += [(1, b + 3, b + 1)]
    f += [(0, 1, b + 1), (0, b + 1, b)]  # end x = 0
    f += [(2 * n, b + 2, b + 3), (2 * n, b + 3, 2 * n + 1)]  # end x = 10
    slab = trimesh.Trimesh(v, np.array(f), process=True)
    slab.fix_normals()
    assert slab.is_watertight and len(slab.faces) > 2 * n
    block = trimesh.creation.box(bounds=[(3.0, 3.0, 1.0), (7.0, 7.0, 2.0)])
    asm = Assembly("slivers", (make_part("slab", slab.vertices, slab.faces)[0],
                               make_part("block", block.vertices, block.faces)[0]),
                   tolerance=0.02)
    s = SweepChecker(asm)
    assert s.blocked(1, 0, np.array([0, 0, -1.0]))
    assert not s.blocked(1, 0, np.array([0, 0, 1.0]))
    at = s.witness(1, 0, np.array([0, 0, -1.0]))
    assert at is not None and abs(at[2] - 1.0) < 1e-9 and 3 <= at[0] <= 7 and 3 <= at[1] <= 7


def _disk_search(polys, eps):
    """:class:`sweep._DiskSearch` on convex polygons (vertex lists), as ``_wide_union`` calls
    it, and the answer of one union of them all (closed by ``tiny``, shrunk by ``eps / 2``)."""
    import shapely

    from ndbg_cli.ndbg.infinite.sweep import _DiskSearch

    rings = [np.vstack([p, p[:1]]) for p in map(np.asarray, polys)]
    coords = np.vstack(rings).astype(float)
    counts = np.array([len(r) for r in rings], np.int64)
    shapes = shapely.polygons([shapely.linearrings(r) for r in rings])
    tiny = 1e-9
    found = _DiskSearch(coords, counts, eps, tiny).run()
    one = shapely.union_all(shapes).buffer(tiny, join_style="mitre", mitre_limit=2.0)
    one = one.buffer(-(0.5 * eps + tiny), join_style="mitre", mitre_limit=2.0)
    return found is not None, not one.is_empty


def _strips(x0, y0, width, height, n):
    """A ``width`` x ``height`` rectangle cut into ``n`` vertical strips."""
    xs = x0 + np.linspace(0.0, width, n + 1)
    return [[(a, y0), (b, y0), (b, y0 + height), (a, y0 + height)] for a, b in zip(xs, xs[1:])]


@pytest.mark.parametrize("side, holds", [(1.2, True), (0.9, False)])
def test_the_window_search_finds_a_disk_astride_its_windows(side, holds):
    # A square of ``side`` eps, cut into 300 slivers, sits across the middle of a field of
    # 400 thin strips spread over 40 eps: the search splits the field into windows (more
    # than 64 overlaps, wider than 4 eps) whose halves overlap by eps, so the disk of
    # diameter eps inside the square (side 1.2) lies inside one window; none fits in 0.9.
    eps = 1.0
    field = [[(x, -20.0), (x + 0.01, -20.0), (x + 0.01, 20.0), (x, 20.0)]
             for x in np.linspace(-20.0, 19.9, 400)]
    square = _strips(-0.5 * side, -0.5 * side, side, side, 300)
    found, one = _disk_search(field + square, eps)
    assert one is holds and found is holds


def test_the_window_search_agrees_with_one_union_on_random_slivers():
    rng = np.random.default_rng(7)
    agree = []
    for _ in range(40):
        polys = []
        for _ in range(rng.integers(50, 300)):
            x, y = rng.uniform(-5.0, 5.0, 2)
            a = rng.uniform(0, np.pi)
            u, v = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
            length, width = rng.uniform(0.5, 4.0), rng.uniform(0.01, 0.3)
            c = np.array([x, y])
            polys.append([c, c + length * u, c + length * u + width * v, c + width * v])
        agree.append(_disk_search(polys, 0.5))
    assert all(found == one for found, one in agree)
    assert {one for _, one in agree} == {True, False}  # both answers met


def test_meets_cell_and_clipped_areas_match_shapely():
    import shapely

    from ndbg_cli.kernels._sweep_kernels import _meets_cell, clipped_areas

    rng = np.random.default_rng(3)
    for _ in range(300):
        t = np.c_[rng.uniform(0, 4, (3, 2)), np.zeros(3)]
        cu, cv = rng.integers(0, 4, 2)
        cell = shapely.box(cu, cv, cu + 1, cv + 1)
        tri = shapely.Polygon(t[:, :2])
        if tri.area > 1e-9 and shapely.box(*tri.bounds).intersects(cell):  # as the kernel asks
            assert _meets_cell(t, 0.0, 0.0, 1.0, 1.0, cu, cv, 0.0) == tri.intersects(cell)
        ring = np.vstack([t[:, :2], t[:1, :2]])
        got = clipped_areas(ring, np.zeros(1, np.int64), np.array([4]), np.zeros(1, np.int64),
                            float(cu), float(cv), cu + 1.0, cv + 1.0)[0]
        assert got == pytest.approx(tri.intersection(cell).area, abs=1e-12)
