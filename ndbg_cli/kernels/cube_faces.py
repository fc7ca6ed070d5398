"""The cube faces of the gnomonic cube map (:mod:`ndbg_cli.ndbg.infinite.cubemap`), a constant
of the compiled kernels (:mod:`._cone_kernels` freezes it into its code) and of their wrappers.

Its own module, at the lowest layer and without numba, so that a wrapper reads it without
starting numba (about 0.15 s to import, and 0.25 s more at the first kernel) in a run that
calls no kernel of :mod:`._cone_kernels`.
"""

from __future__ import annotations

import numpy as np

#: The six cube faces of the gnomonic cube map, (axis e, chart u, chart v) as rows of a
#: (6, 3, 3) array; frozen into the kernels when they compile. Defined here, the lowest
#: layer, so that the kernels import no wrapper (:mod:`ndbg_cli.ndbg.infinite.cubemap` uses
#: it). Numba's cache of :mod:`._cone_kernels` does not see a change made here (it watches
#: its own file): clear its ``__pycache__`` after one (``tests/test_cubemap.py`` pins the
#: values).
FACES = np.array([
    [[1, 0, 0], [0, 1, 0], [0, 0, 1]],
    [[-1, 0, 0], [0, 0, 1], [0, 1, 0]],
    [[0, 1, 0], [0, 0, 1], [1, 0, 0]],
    [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
    [[0, 0, 1], [1, 0, 0], [0, 1, 0]],
    [[0, 0, -1], [0, 1, 0], [1, 0, 0]],
], dtype=np.float64)
