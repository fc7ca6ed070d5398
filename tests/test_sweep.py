"""The direct per-direction test's polygon kernels (:mod:`ndbg_cli.sweep`), against areas
worked out by hand, and the test itself on two boxes with known answers."""

import numpy as np
import pytest
import trimesh

from ndbg_cli.assembly import Assembly
from ndbg_cli.sweep import SweepChecker, _area, _clip, _plane
from ndbg_cli.validate import make_part


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
