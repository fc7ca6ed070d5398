"""The direct per-direction test's polygon kernels (:mod:`ndbg_cli.ndbg.infinite.sweep`), against
areas worked out by hand, and the test itself on two boxes with known answers."""

import numpy as np
import pytest
import trimesh

from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.infinite.sweep import SweepChecker, _area, _clip, _plane


def _poly(*pts):
    p = np.array(pts, float)[None]
    return p, np.array([len(pts)])


def test_clip_square_by_half_planes_has_the_hand_worked_areas():
    sq, n = _poly((0, 0), (2, 0), (2, 2), (0, 2))
    assert _area(sq, n)[0] == pytest.approx(4.0)
    # x <= 0.5: a 0.5 x 2 strip
    p, c = _clip(sq, n, np.array([[1.0, 0.0]]), np.array([0.5]))
    assert c[0] == 4 and _area(p, c)[0] == pytest.approx(1.0)
    # x + y <= 1: the corner triangle of legs 1
    p, c = _clip(sq, n, np.array([[1.0, 1.0]]), np.array([1.0]))
    assert c[0] == 3 and _area(p, c)[0] == pytest.approx(0.5)
    # the whole square kept, or none of it
    p, c = _clip(sq, n, np.array([[1.0, 0.0]]), np.array([5.0]))
    assert _area(p, c)[0] == pytest.approx(4.0)
    p, c = _clip(sq, n, np.array([[1.0, 0.0]]), np.array([-1.0]))
    assert c[0] == 0 and _area(p, c)[0] == 0.0


def test_clip_many_polygons_at_once_keeps_each_its_own_answer():
    tri = np.array([[(0, 0), (1, 0), (0, 1)], [(0, 0), (4, 0), (0, 4)]], float)
    p, c = _clip(tri, np.array([3, 3]), np.array([[0.0, 1.0], [0.0, 1.0]]),
                 np.array([0.5, 2.0]))
    # below y = 0.5 of the unit triangle: 0.5 - 0.125; below y = 2 of the big one: 8 - 2
    assert _area(p, c) == pytest.approx([0.375, 6.0])


def test_plane_of_a_projected_triangle():
    # z = 1 + 2 u - 2 v through three points in general position
    tri = np.array([[[0, 0, 1.0], [2, 1, 3.0], [1, 3, -3.0]]])
    assert _plane(tri)[0] == pytest.approx([1.0, 2.0, -2.0])


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


def test_clipped_overlaps_match_shapely_on_random_triangle_pairs():
    # an independent reference: shapely's intersection of the two triangles, then of that
    # with a large polygon on the inner side of the depth line
    import shapely

    rng = np.random.default_rng(7)
    k = 400
    ti = rng.uniform(-1, 1, size=(k, 3, 2))
    tj = rng.uniform(-1, 1, size=(k, 3, 2))
    # orientation of t_j (the kernel reads it), and a half-plane a . x <= b per pair
    e = np.roll(tj, -1, axis=1) - tj
    orient = np.sign(e[:, 0, 0] * e[:, 1, 1] - e[:, 0, 1] * e[:, 1, 0])
    poly, cnt = ti.copy(), np.full(k, 3)
    for m in range(3):
        a = orient[:, None] * np.stack([e[:, m, 1], -e[:, m, 0]], axis=1)
        poly, cnt = _clip(poly, cnt, a, np.einsum("ij,ij->i", a, tj[:, m]))
    over = _area(poly, cnt)
    a = rng.normal(size=(k, 2))
    b = rng.uniform(-0.5, 0.5, size=k)
    cut = _area(*_clip(poly, cnt, a, b))
    for q in range(k):
        ref = shapely.Polygon(ti[q]).intersection(shapely.Polygon(tj[q]))
        assert over[q] == pytest.approx(ref.area, abs=1e-12)
        # the half-plane a . x <= b as a big polygon: the line's two far points, pushed back
        n = a[q] / np.linalg.norm(a[q])
        p0 = n * b[q] / np.linalg.norm(a[q])
        t = np.array([-n[1], n[0]])
        half = shapely.Polygon([p0 + 10 * t, p0 - 10 * t, p0 - 10 * t - 10 * n,
                                p0 + 10 * t - 10 * n])
        assert cut[q] == pytest.approx(ref.intersection(half).area, abs=1e-12)
    assert (over > 0).sum() > 50 and ((cut > 0) & (cut < over)).sum() > 20
