"""The pruning raster's quick tests and the triangle tree's node data, against direct
computations (clipping, per-node scans)."""

from __future__ import annotations

import numpy as np
import pytest

from ndbg_cli.kernels._cone_kernels import FACES
from ndbg_cli.ndbg.infinite import blocking_cones as bc
from ndbg_cli.ndbg.infinite.cover import Cover
from ndbg_cli.ndbg.infinite.cubemap import clip_halfplanes, compact, cone_normals


def _random_cones(rng: np.random.Generator, p: int, spread: float) -> np.ndarray:
    """Open cones ``(p, k, 3)`` spanned by 4 generators round random axes (uncompacted
    normals, zero rows included, as the walk's terms have them)."""
    axis = rng.normal(size=(p, 1, 3))
    gens = axis + spread * rng.normal(size=(p, 4, 3))
    return cone_normals(gens)


@pytest.mark.parametrize("seed", [0, 1])
def test_window_test_agrees_with_clipping(seed: int) -> None:
    """A cone the quick corner test calls outside a face's window has no polygon there
    (clipping to the window), and a cone :meth:`misses_open` reports missing every window
    is reported covered by :meth:`covers`; some cones do meet windows (the test can fail)."""
    rng = np.random.default_rng(seed)
    domain = np.zeros((6, 64, 64), dtype=bool)
    domain[0, 28:36, 28:36] = domain[1, 28:36, 28:36] = True  # caps round +x and -x
    domain[4, 10:20, 40:50] = domain[5, 44:54, 14:24] = True
    cover = Cover(domain=domain)
    cones = _random_cones(rng, 3000, 0.3)
    met = 0
    for face in range(6):
        out = cover._outside(cones, face)
        if out is None:
            assert cover.window(face) is None
            continue
        _, cnt = clip_halfplanes(cones, face, rect=cover.window(face))
        assert not np.any(out & (cnt >= 3))
        met += int((cnt >= 3).sum())
    assert met > 0
    miss = cover.misses_open(cones)
    assert miss.any() and not miss.all()
    assert cover.covers(cones)[miss].all()


def test_window_test_keeps_cones_through_a_window() -> None:
    """A cone round the centre of a face's window is never reported outside it, nor one
    with no facet (every direction)."""
    domain = np.zeros((6, 64, 64), dtype=bool)
    domain[4, 30:34, 30:34] = True
    cover = Cover(domain=domain)
    e = FACES[4, 0]
    gens = e + 1e-3 * np.array([[1, 0, 0], [0, 1, 0], [-1, -1, 0]], dtype=float)
    cones = np.concatenate([cone_normals(gens[None]), np.zeros((1, 3, 3))])
    assert not cover.misses_open(cones).any()
    assert not cover.covers(cones).any()


@pytest.mark.parametrize("n,leaf", [(1, 8), (7, 8), (9, 8), (200, 8), (1001, 8), (3, 2),
                                    (5, 1), (33, 16), (200, 3)])
def test_tree_nodes_match_a_scan(n: int, leaf: int) -> None:
    """Each node's box and two largest triangles (ties to the first in the tree's order)
    equal a direct scan of its triangles; equal areas are frequent (a grid of copies)."""
    rng = np.random.default_rng(n)
    base = rng.normal(size=(max(n // 4, 1), 3, 3))
    tri = np.concatenate([base + rng.integers(0, 5, size=(len(base), 1, 3))
                          for _ in range(4)])[:n]
    if len(tri) < n:
        tri = np.concatenate([tri, rng.normal(size=(n - len(tri), 3, 3))])
    tree = bc.tri_tree(tri, leaf)
    assert (tree.stop - tree.start)[tree.left < 0].max() <= max(leaf, 1)
    area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    for k, (a, b) in enumerate(zip(tree.start, tree.stop)):
        idx = tree.perm[a:b]
        pts = tri[idx].reshape(-1, 3)
        assert np.array_equal(tree.lo[k], pts.min(axis=0))
        assert np.array_equal(tree.hi[k], pts.max(axis=0))
        top = idx[np.argsort(-area[idx], kind="stable")[:2]][[0, -1]]
        assert np.array_equal(tree.big[k], top)


@pytest.mark.parametrize("seed", [0, 1])
def test_generator_window_test_agrees_with_clipping(seed: int) -> None:
    """A term (generators' cone cut by two open half-spaces) that the generator test calls
    outside every window has no polygon in any window once its facets are computed and
    clipped; the test does call some terms outside and not others."""
    rng = np.random.default_rng(seed)
    domain = np.zeros((6, 64, 64), dtype=bool)
    domain[4, 28:36, 20:44] = domain[5, 20:44, 28:36] = True  # a band round +z and -z
    cover = Cover(domain=domain)
    axis = rng.normal(size=(4000, 1, 3))
    gens = axis + 0.4 * rng.normal(size=(4000, 9, 3))
    facing = rng.normal(size=(4000, 2, 3))
    facing /= np.linalg.norm(facing, axis=2, keepdims=True)
    miss = cover.misses_spanned_open(gens, facing)
    assert 0.05 < miss.mean() < 0.95
    cones = np.concatenate([cone_normals(gens), facing], axis=1)
    for face in range(6):
        if cover.window(face) is None:
            continue
        _, cnt = clip_halfplanes(cones, face, rect=cover.window(face))
        assert not np.any(miss & (cnt >= 3))


def test_compact_keeps_different_facets_with_equal_keys() -> None:
    """``compact`` sorts a cone's facets by one number per row (n . (1, pi, e)); two
    different unit normals on the circle where that number is 1 share it and must both stay
    (dropping one would enlarge the cone); true duplicates and zero rows go."""
    from ndbg_cli.ndbg.infinite.cubemap import compact

    v = np.array([1.0, np.pi, np.e])
    a = v / np.linalg.norm(v) ** 2  # n . v = 1 for n = a + b w, w unit and orthogonal to v
    w = np.cross(v, [0.0, 0.0, 1.0])
    w /= np.linalg.norm(w)
    n1 = a + np.sqrt(1.0 - a @ a) * w
    n2 = a - np.sqrt(1.0 - a @ a) * w
    assert abs(n1 @ v - n2 @ v) < 1e-12 and np.linalg.norm(n1 - n2) > 1.0
    out = compact(np.array([[n1, np.zeros(3), n2, n1]]))
    assert out.shape == (1, 2, 3)
    assert sorted(map(tuple, out[0].round(12))) == sorted([tuple(n1.round(12)),
                                                            tuple(n2.round(12))])


def test_windows_sought_in_the_domain_block_are_the_whole_face_ones() -> None:
    """A cover with a domain seeks its windows in the block of cells the domain leaves open;
    they are the rectangles :func:`~ndbg_cli.ndbg.infinite.cover.cells_window` finds on the whole
    face, cube-edge margins included (blocks touching the face's border), as cells get marked."""
    from ndbg_cli.ndbg.infinite.cover import cells_window

    rng = np.random.default_rng(3)
    for trial in range(20):
        dom = np.zeros((6, 16, 16), dtype=bool)
        for f in range(6):
            r0, c0 = rng.integers(0, 14, size=2)
            dom[f, r0:r0 + rng.integers(1, 6), c0:c0 + rng.integers(1, 6)] = True
        dom[0, 0, :3] = True  # at the face's border
        cover = Cover(raster=64, domain=dom)
        for step in range(3):
            for f in range(6):
                assert cover.window(f) == cells_window(~cover.covered[f]), (trial, step, f)
            cones = compact(cone_normals(rng.normal(size=(30, 4, 3)), pairs=None))
            cover.add(cones)
