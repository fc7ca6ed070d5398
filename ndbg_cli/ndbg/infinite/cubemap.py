"""Direction-space machinery: the gnomonic cube map of the unit sphere S^2 and open polyhedral
cones clipped to its six faces.

A direction ``d`` is charted on the cube face whose axis ``e`` has the largest ``d . e``, at
``(s, t) = (d . u, d . v) / (d . e)`` in ``[-1, 1]^2``. Central projection maps great circles
to lines, so a convex spherical polygon is a convex polygon on each face it meets, and the
open half-sphere ``d . m > 0`` the open half-plane ``m.e + s m.u + t m.v > 0``. A *cone* is
given by normals ``m_k`` (``(k, 3)``): ``{d : d . m_k > 0 for all k}``; a zero normal is no
constraint, so batches are zero-padded (:func:`cone_normals` makes them from generators).
"""

from __future__ import annotations

import numpy as np

from ...kernels.compiled import loaded
from ...kernels.cube_faces import FACES

#: Slight enlargement of the chart square so that directions on a cube edge are covered on
#: both faces (chart units).
SQUARE_MARGIN = 1e-9


def face_of(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Chart ``(n,)`` face indices and ``(n, 2)`` chart coordinates of directions ``(n, 3)``."""
    d = np.atleast_2d(np.asarray(d, dtype=float))
    dots = d @ FACES[:, 0].T  # (n, 6)
    f = np.argmax(dots, axis=1)
    e = dots[np.arange(len(d)), f]
    u = np.einsum("ij,ij->i", d, FACES[f, 1])
    v = np.einsum("ij,ij->i", d, FACES[f, 2])
    return f, np.stack([u / e, v / e], axis=1)


def direction_of(face: int, st: np.ndarray) -> np.ndarray:
    """Unit directions ``(n, 3)`` of chart points ``st`` ``(n, 2)`` on ``face``."""
    st = np.atleast_2d(np.asarray(st, dtype=float))
    e, u, v = FACES[face]
    d = e[None, :] + st[:, :1] * u[None, :] + st[:, 1:2] * v[None, :]
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def cone_normals(gens: np.ndarray, rel_tol: float = 1e-9,
                 pairs: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """H-representation of the conic hulls of generator sets.

    ``gens`` is ``(p, g, 3)``: ``p`` sets of ``g`` vectors. Returns ``(p, g(g-1)/2, 3)`` unit
    normals ``m`` (zero rows where a candidate is not a facet) with ``cone = {d : d . m >= 0}``
    for all rows; its interior, the open cone, is ``{d : d . m > 0}``. A candidate is the plane
    through the origin spanned by two generators, kept (with its sign) when every generator
    lies on one side within ``rel_tol`` (relative to the generator's length). If the generators
    all lie in one plane through the origin, both orientations survive and the open cone is
    empty, as it should be. ``pairs`` (two index arrays) restricts the candidates to those
    generator pairs (:data:`DIFFERENCE_PAIRS` for the 9 vertex differences of two triangles).
    Pointed or not, the hull comes out right (a half-space, a wedge, a line-containing cone);
    a set whose hull contains the origin in its interior gives no facet, i.e. every direction.
    """
    kernels = loaded("_cone_kernels")
    gens = np.ascontiguousarray(gens, dtype=float)
    a, b = np.triu_indices(gens.shape[1], k=1) if pairs is None else pairs
    return kernels.cone_normals(gens, np.asarray(a, dtype=np.int64),
                                np.asarray(b, dtype=np.int64), rel_tol)


def _difference_pairs() -> tuple[np.ndarray, np.ndarray]:
    # generator 3 v + w is vertex v of one triangle minus vertex w of the other
    a, b = np.triu_indices(9, k=1)
    keep = (a // 3 == b // 3) | (a % 3 == b % 3)
    return a[keep], b[keep]


#: The generator pairs of the 9 differences ``t_j[v] - t_i[w]`` (index ``3 v + w``) that can
#: span a facet of their conic hull: those sharing ``v`` or ``w`` (18 of 36). A facet of the
#: cone over the Minkowski difference touches it along an edge, and every edge of a Minkowski
#: sum is an edge of one summand plus a vertex of the other (parallel edges: a union of such).
DIFFERENCE_PAIRS = _difference_pairs()


def _box_edge_pairs() -> tuple[np.ndarray, np.ndarray]:
    a, b = np.triu_indices(8, k=1)
    keep = np.isin(a ^ b, (1, 2, 4))
    return a[keep], b[keep]


#: The corner pairs of a box (corner ``4 x + 2 y + z`` takes the high end along the axes
#: flagged) that are its 12 edges: the only pairs that can span a facet of the cone over it.
BOX_EDGE_PAIRS = _box_edge_pairs()


def clip_halfplanes(normals: np.ndarray, face: int, max_vertices: int = 48,
                    shrink: float = 0.0, rect: tuple[float, float, float, float] | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """Clip the chart square of ``face`` by the open cones ``normals`` ``(p, k, 3)``.

    With ``shrink > 0`` every cone facet (not the chart square) is moved inward by ``shrink``
    chart units: the polygons are eroded, which is what a test "strictly inside some cone"
    needs. With ``rect`` (``x0, y0, x1, y1``, chart units) that rectangle is clipped instead
    of the square (a window: cones missing it are skipped at the cost of four corner tests).

    Returns ``(poly, count)``: ``poly`` ``(p, m, 2)`` vertices (counter-clockwise, padded) and
    ``count`` ``(p,)`` vertex counts (0 or < 3: the cone misses the face): see
    :func:`ndbg_cli.kernels._cone_kernels.clip_cones`.
    """
    kernels = loaded("_cone_kernels")
    r = 1.0 + SQUARE_MARGIN
    x0, y0, x1, y1 = (-r, -r, r, r) if rect is None else rect
    sq = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], dtype=float)
    # Sutherland-Hodgman per cone, compiled; a half-plane that excludes the four corners
    # excludes the square (it is convex): most cones meet one or two faces, so that test,
    # made first, spares the clipping of the others.
    return kernels.clip_cones(np.ascontiguousarray(normals, dtype=float), face, sq,
                              float(shrink), max_vertices)


def random_directions(n: int, seed: int = 0, dim: int = 3) -> np.ndarray:
    """``(n, dim)`` uniformly distributed unit vectors (deterministic for a seed)."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, dim))
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def compact(normals: np.ndarray) -> np.ndarray:
    """Drop zero rows and duplicates (rows equal when rounded to 1e-9) per cone, trimming the
    padding ``(p, k, 3)``: :func:`ndbg_cli.kernels._cone_kernels.compact`. Two different facets can
    share the sort number (a circle of unit normals does): only equal rows are duplicates (dropping
    a different facet would enlarge the cone)."""
    kernels = loaded("_cone_kernels")
    if not len(normals):
        return normals
    return kernels.compact(np.ascontiguousarray(normals, dtype=float))
