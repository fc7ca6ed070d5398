"""The chart pieces of a pair's cones and their union (:mod:`ndbg_cli.ndbg.infinite.chart_union`,
:mod:`ndbg_cli.kernels._union_kernels`): hand-worked containment cases, and the union of the
kept pieces against the plain union of every piece on random fans of cones meeting at an axis
(the shape of a contact pair's set, where most pieces lie inside another)."""

from __future__ import annotations

import numpy as np
import pytest
import shapely

from ndbg_cli.kernels import _union_kernels as uk
from ndbg_cli.ndbg.infinite import chart_union as cu
from ndbg_cli.ndbg.infinite.cubemap import clip_halfplanes


def _pad(polys: list[list[tuple[float, float]]]) -> tuple[np.ndarray, np.ndarray]:
    m = max(len(p) for p in polys)
    out = np.zeros((len(polys), m, 2))
    for k, p in enumerate(polys):
        out[k, :len(p)] = p
    return out, np.array([len(p) for p in polys], dtype=np.int64)


def _kept(polys: list[list[tuple[float, float]]]) -> list[int]:
    poly, cnt = _pad(polys)
    area, boxes = uk.piece_boxes(poly, cnt)
    order = np.argsort(-area, kind="stable")
    return np.flatnonzero(uk.maximal_pieces(poly, cnt, boxes, order)).tolist()


def _sq(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]  # counter-clockwise


def test_piece_areas_and_boxes():
    poly, cnt = _pad([_sq(0, 0, 2, 1), [(0, 0), (4, 0), (0, 3)], [(1, 1), (2, 2)]])
    area, boxes = uk.piece_boxes(poly, cnt)
    assert area.tolist() == [2.0, 6.0, 0.0]  # two vertices: no area
    assert boxes.tolist() == [[0, 0, 2, 1], [0, 0, 4, 3], [1, 1, 2, 2]]


def test_maximal_pieces_by_hand():
    outer = _sq(0, 0, 4, 4)
    # nested: only the outer one; the inner one's order in the list does not matter
    assert _kept([_sq(1, 1, 2, 2), outer]) == [1]
    assert _kept([outer, _sq(1, 1, 2, 2)]) == [0]
    # a piece touching the outer one's side from inside (vertices on its edges) is inside
    assert _kept([outer, _sq(0, 0, 4, 1), [(0, 0), (4, 4), (0, 4)]]) == [0]
    # exact duplicates: the first is kept
    assert _kept([_sq(1, 1, 3, 2), _sq(1, 1, 3, 2)]) == [0]
    # sticking out by 1e-9 (its box held, a vertex past the hypotenuse): both kept
    tri = [(0, 0), (4, 0), (0, 4)]
    assert _kept([tri, [(1, 1), (2 + 1e-9, 2), (1, 2)]]) == [0, 1]
    assert _kept([tri, [(1, 1), (2, 2), (1, 2)]]) == [0]
    # overlapping, neither inside the other: both
    assert _kept([_sq(0, 0, 2, 2), _sq(1, 1, 3, 3)]) == [0, 1]
    # a wedge fan at the origin: the half-plane holds the wedges in it, not the one across
    half = [(-1, 0), (1, 0), (1, 1), (-1, 1)]
    w1 = [(0, 0), (1, 0.5), (1, 1)]
    w2 = [(0, 0), (-1, 1), (-1, 0.2)]
    w3 = [(0, 0), (1, -0.5), (1, 0.5)]
    assert _kept([w1, half, w2, w3]) == [1, 3]
    # a piece inside only the union of two others is kept (single pieces only)
    assert _kept([_sq(0, 0, 2, 2), _sq(2, 0, 4, 2), _sq(1, 0, 3, 2)]) == [0, 1, 2]


def _fan(rng: np.random.Generator, axis: np.ndarray, count: int) -> np.ndarray:
    """``count`` open cones ``(count, 4, 3)`` around ``axis``: wedges and half-spaces whose
    facet planes all hold the axis (every one reaches it), many repeated or nested."""
    u = np.cross(axis, [0.3, 0.5, 0.8])
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    cones = np.zeros((count, 4, 3))
    # half on a grid of 24 angles (repeated and nested pieces), half anywhere
    angles = rng.choice(np.linspace(0, 2 * np.pi, 24, endpoint=False), size=(count, 2))
    angles[count // 2:] = rng.uniform(0, 2 * np.pi, size=(count - count // 2, 2))
    for k in range(count):
        a0, a1 = np.sort(angles[k])
        n0 = np.cos(a0) * u + np.sin(a0) * v
        cones[k, 0] = np.cross(axis, n0)  # facet planes through the axis
        if rng.random() < 0.7:
            n1 = np.cos(a1) * u + np.sin(a1) * v
            cones[k, 1] = -np.cross(axis, n1)
        if rng.random() < 0.5:  # a far cap: not through the axis
            cones[k, 2] = axis - 0.2 * n0
            cones[k, 2] /= np.linalg.norm(cones[k, 2])
    return cones


@pytest.mark.parametrize("seed", range(6))
def test_kept_pieces_union_is_the_union_of_all(seed):
    rng = np.random.default_rng(seed)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    cones = _fan(rng, axis, 300)
    windows = [None] * 6
    face = int(np.argmax(np.abs(axis)))
    # a window round the axis's chart point on its face, as the domain gives them
    entries = cu.cones_to_face_geoms(cones)
    for f in range(6):
        got = entries[f]
        poly, cnt = clip_halfplanes(cones, f)
        keep = cnt >= 3
        if not keep.any():
            assert got is None
            continue
        k = np.arange(poly.shape[1])[None, :] < cnt[keep][:, None]
        rings = shapely.linearrings(poly[keep][k], indices=np.repeat(np.arange(keep.sum()),
                                                                       cnt[keep]))
        pieces = shapely.convex_hull(shapely.polygons(rings))
        big = shapely.area(pieces) > cu.GRID ** 2
        plain = shapely.union_all(pieces[big])
        if plain.is_empty:
            assert got is None
            continue
        union, boxes, index = got
        assert shapely.symmetric_difference(union, plain).area < 1e-12
        # every piece is listed, with its exact box, for the open re-test; the shoelace
        # area and GEOS's may disagree on slivers of no area (1e-16 against 0, either way)
        listed = dict(zip(index.tolist(), boxes.tolist()))
        ids = np.flatnonzero(keep)
        for k, piece, b in zip(ids, pieces, shapely.bounds(pieces).tolist()):
            if k in listed:
                assert listed.pop(k) == b
            else:
                assert piece.area < 1e-12
        assert all(pieces[np.searchsorted(ids, k)].area < 1e-12 for k in listed)
        windows[f] = shapely.bounds(plain) if f == face else None
    # the same in a window round the axis
    if windows[face] is not None:
        x0, y0, x1, y1 = windows[face]
        rect = ((x0 + x1) / 2 - 0.05, (y0 + y1) / 2 - 0.05, (x0 + x1) / 2 + 0.05,
                (y0 + y1) / 2 + 0.05)
        win = [None] * 6
        win[face] = rect
        got = cu.cones_to_face_geoms(cones, win)[face]
        poly, cnt = clip_halfplanes(cones, face, rect=rect)
        pieces = [shapely.Polygon(poly[k, :cnt[k]]) for k in range(len(cnt)) if cnt[k] >= 3]
        plain = shapely.union_all([p for p in pieces if p.area > cu.GRID ** 2])
        assert shapely.symmetric_difference(got[0], plain).area < 1e-12
        kept = len(cu.face_pieces(cones, face, rect=rect)[0])
        assert kept < len(pieces) / 2  # a fan's pieces are mostly nested or repeated


def test_inset_convex_by_hand():
    # the unit square either way round, a right triangle, and an L (not convex: left out)
    polys = [_sq(0, 0, 1, 1), _sq(0, 0, 1, 1)[::-1], [(0, 0), (4, 0), (0, 3)],
             [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]]
    xy = np.array([v for p in polys for v in p], dtype=float)
    cnt = np.array([len(p) for p in polys], dtype=np.int64)
    start = np.r_[0, np.cumsum(cnt)[:-1]]
    inner, num = uk.inset_convex(xy, start, cnt, np.array([0.1, 0.25, 0.5, 0.1]))
    assert num.tolist() == [4, 4, 3, 0]
    for k, (lo, hi) in enumerate(((0.1, 0.9), (0.25, 0.75))):
        got = inner[k, :4]
        np.testing.assert_allclose(got.min(axis=0), [lo, lo], atol=1e-12)
        np.testing.assert_allclose(got.max(axis=0), [hi, hi], atol=1e-12)
    # 3-4-5 triangle: the incircle has radius 1, so the inset by 0.5 is the triangle scaled
    # by 1/2 about the incentre (1, 1)
    tri = inner[2, :3]
    want = np.array([(0, 0), (4, 0), (0, 3)]) * 0.5 + 0.5 * np.array([1.0, 1.0])
    np.testing.assert_allclose(tri[np.lexsort(tri.T[::-1])], want[np.lexsort(want.T[::-1])],
                               atol=1e-12)
    # an inset wider than the polygon leaves nothing
    assert uk.inset_convex(xy[:4], start[:1], cnt[:1], np.array([0.6]))[1].tolist() == [0]
