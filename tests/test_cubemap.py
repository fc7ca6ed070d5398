"""The cube faces of the gnomonic cube map (``ndbg_cli.kernels.cube_faces.FACES``), pinned:
numba's cache of the kernels that freeze them would not see a change (it watches their own
file only)."""

import numpy as np

from ndbg_cli.kernels.cube_faces import FACES


def test_the_faces_are_the_six_axes_each_with_a_right_handed_chart():
    axes = {tuple(int(x) for x in e) for e in FACES[:, 0]}
    assert axes == {(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)}
    for e, u, v in FACES:
        assert np.array_equal(np.cross(u, v), e)  # (u, v, e) right-handed
    assert FACES.tolist() == [
        [[1, 0, 0], [0, 1, 0], [0, 0, 1]], [[-1, 0, 0], [0, 0, 1], [0, 1, 0]],
        [[0, 1, 0], [0, 0, 1], [1, 0, 0]], [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
        [[0, 0, 1], [1, 0, 0], [0, 1, 0]], [[0, 0, -1], [0, 1, 0], [1, 0, 0]]]
