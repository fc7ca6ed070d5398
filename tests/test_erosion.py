"""The in-plane part of the erosion of near triangles (:mod:`ndbg_cli.ndbg.infinite.erosion`):
hand-worked
insets on a cube, none on a cylinder's smooth edges nor along a concave edge."""

from __future__ import annotations

import numpy as np
import trimesh

from ndbg_cli.ndbg.infinite.erosion import edge_insets


def _soup(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray]:
    tri = np.asarray(mesh.triangles, dtype=float)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return tri, n / np.linalg.norm(n, axis=1, keepdims=True)


def test_cube_triangles_pull_back_from_every_cube_edge():
    # each face of a unit cube is two right triangles: the legs lie on cube edges (convex,
    # 90 degrees: inset by r), the hypotenuse on the face's diagonal (flat: kept). Hand
    # answer: the inset triangle has its vertices at r and 1 - r in the face's coordinates.
    r = 0.1
    tri, n = _soup(trimesh.creation.box(extents=[1, 1, 1]))
    disp, gone = edge_insets(tri, n, r)
    assert not gone.any()
    new = tri + disp + 0.5  # cube from 0 to 1
    for t, nn in zip(new, n):
        axis = int(np.argmax(np.abs(nn)))
        inplane = np.delete(t, axis, axis=1)
        assert np.allclose(np.sort(np.unique(np.round(inplane, 12))), [r, 1 - r])
        # and the triangle stays in its face's plane
        assert np.allclose(t[:, axis], t[0, axis])
    # too narrow for the inset: gone
    assert edge_insets(tri * 0.1, n, r)[1].all()


def test_cylinder_long_edges_are_smooth():
    # 64 facets: 5.6 degrees between neighbours, below the sharp angle; the facets' ends on
    # the caps (90 degrees, convex) are inset, their long sides are not: a side triangle's
    # vertices on a cap move r towards the middle (along its other edges), the third stays
    r = 0.01
    cyl = trimesh.creation.cylinder(radius=1.0, height=4.0, sections=64)
    tri, n = _soup(cyl)
    disp, gone = edge_insets(tri, n, r)
    side = np.abs(n[:, 2]) < 1e-9
    assert not gone.any()
    t, d = tri[side], disp[side]
    # every side triangle has two vertices on one cap (its edge there is inset) and one on
    # the other, whose two edges are smooth: it stays
    z = t[:, :, 2]
    pair = (z == np.roll(z, 1, axis=1)) | (z == np.roll(z, -1, axis=1))
    assert (pair.sum(axis=1) == 2).all()
    moved_z = np.abs((t + d)[:, :, 2])
    assert np.allclose(moved_z[pair], 2.0 - r) and np.allclose(moved_z[~pair], 2.0)
    assert np.all(d[~pair] == 0.0)
    # ...and the long edges stay where they were: no vertex leaves its facet's plane or moves
    # round the axis by more than the slope of the facet's diagonal allows
    assert np.allclose(((d) * n[side][:, None, :]).sum(axis=2), 0.0, atol=1e-12)


def test_concave_edge_is_kept():
    # an L-shaped prism: the inner corner edge (concave) moves nothing; faces meeting there
    # pull back only from the convex edges
    a = trimesh.creation.box(bounds=[[0, 0, 0], [2, 1, 1]])
    b = trimesh.creation.box(bounds=[[0, 0, 0], [1, 2, 1]])
    ell = trimesh.boolean.union([a, b], engine="manifold")
    tri, n = _soup(ell)
    r = 0.05
    disp, gone = edge_insets(tri, n, r)
    new = tri + disp
    # the inner corner line is x = 1, y = 1 (z from 0 to 1): the faces x = 1 (y from 1 to 2)
    # and y = 1 (x from 1 to 2) still reach it
    for axis, other in ((0, 1), (1, 0)):
        on = (np.abs(n[:, axis] - 1.0) < 1e-9) & np.all(np.abs(tri[:, :, axis] - 1.0) < 1e-9,
                                                         axis=1)
        assert on.any()
        assert np.isclose(new[on][:, :, other].min(), 1.0)
