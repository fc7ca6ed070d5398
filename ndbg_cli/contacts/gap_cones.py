"""Blocked cones of near misses: triangle pairs the length tolerance counts as touching while
they are apart.

Two tessellated surfaces diverging from a contact's rim (a peg's rounded tip in the rounded
top of its hole) stay within the gap allowance ``g = tol + sag_i + sag_j`` for a while, with
face normals pointing anywhere the surfaces curve: taken as contact normals they would block
motions that only slide the surfaces past each other (lifting a bar off its peg). Here such a
pair blocks A along ``d`` only when moving A by at most ``g`` along ``d`` closes the gap
(:func:`sweep_cone`); each kept cone is a contact with ``blocking == "all"`` over its inward
facet normals, widened by the DBGs' angular tolerance (:func:`widen`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

from ..geometry.directions import circle_frames
from ..geometry.vectors import cross

#: Pairs farther apart than this fraction of the length tolerance are near misses with a
#: gap direction; closer ones are touching.
GAP_FRACTION = 0.05

#: Widest angle (radians) from its gap direction a cone may reach once widened by
#: :func:`widen` (the chart's scale grows as ``sec^2``).
WIDEN_LIMIT = np.radians(80.0)

#: Slack of the containment tests (unit vectors): a cone counts as inside another when its
#: rays are on the inner side of every facet within this.
CONTAIN_SLACK = 1e-9


#: Products per numpy block of :func:`maximal` (bounds its memory to ~100 MB).
_BLOCK = 4_000_000


@dataclass(frozen=True)
class GapCone:
    """The open cone of translations of A that close a near miss within the allowance.

    ``facets`` ``(k, 3)``: unit inward facet normals (blocked iff ``d . m > 0`` for all);
    ``rays`` ``(k, 3)``: unit extreme rays; ``point`` ``(3,)``: midpoint of the pair's
    closest points; ``normal`` ``(3,)``: the gap direction (A to B). Units: the assembly's."""

    facets: np.ndarray
    rays: np.ndarray
    point: np.ndarray
    normal: np.ndarray


def _cut_points(ta: np.ndarray, tb: np.ndarray, n: np.ndarray, reach: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """Points ``(p, 45, 3)`` whose cone is the sweep cone of each pair (triangles ``(p, 3,
    3)``, unit gap directions ``n`` ``(p, 3)``, sweep lengths ``reach`` ``(p,)``) and their
    validity ``(p, 45)``: the 9 vertex differences within reach and the points where the 36
    segments between them cross ``n . x = reach`` (``conv`` of those is the cut polytope)."""
    v = (tb[:, :, None, :] - ta[:, None, :, :]).reshape(-1, 9, 3)
    h = np.einsum("pkd,pd->pk", v, n) - reach[:, None]
    i, j = np.triu_indices(9, 1)
    hi, hj = h[:, i], h[:, j]
    cut = hi * hj < 0
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(cut, hi / (hi - hj), 0.0)
    w = np.concatenate([v, v[:, i] + t[:, :, None] * (v[:, j] - v[:, i])], axis=1)
    ok = np.concatenate([h <= 0, cut], axis=1) & (np.einsum("pkd,pd->pk", w, n) > 0)
    return w, ok


def sweep_cone(ta: np.ndarray, tb: np.ndarray, n: np.ndarray, reach: float
               ) -> tuple[np.ndarray, np.ndarray] | None:
    """``(rays, facets)`` ``(k, 3)`` of the cone over ``(T_b - T_a) & {n . x <= reach}``
    (triangles ``(3, 3)``, ``n`` the unit gap direction, ``reach`` the sweep length), or
    ``None`` when it has no interior (nothing within reach, or a flat cone).

    A pair at distance ``delta > 0`` blocks A along ``d`` when the ray ``s d``, ``0 < s <= g``,
    enters the Minkowski difference ``P = T_b - T_a`` (the hull of the 9 vertex differences).
    The blocked set is the open cone over ``P`` cut by the slab ``delta <= n . x <= g`` (``P``
    lies beyond ``n . x = delta``). The slab contains the ball of radius ``g``, so the cone is
    a superset of the exact one (conservative), and it tends to the pair's local blocking cone
    as ``delta`` goes to 0."""
    w, ok = _cut_points(ta[None], tb[None], n[None], np.array([float(reach)]))
    return _cone(w[0][ok[0]], n)


def _cone(w: np.ndarray, n: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """Extreme rays and inward facet normals (unit, ``(k, 3)``, in order round the cone) of
    the cone over the points ``w`` ``(m, 3)`` (all with ``n . w > 0``), or ``None`` when it
    is flat: the convex hull of their central projection on ``n . x = 1``."""
    if len(w) < 3:
        return None
    u, e = (b[0] for b in circle_frames(n))
    xy = np.stack([w @ u, w @ e], axis=1) / (w @ n)[:, None]
    try:
        hull = ConvexHull(xy)
    except QhullError:  # collinear: a flat fan, no interior
        return None
    if hull.volume <= 1e-12:
        return None
    corner = n + xy[hull.vertices, :1] * u + xy[hull.vertices, 1:] * e
    m = cross(corner, np.roll(corner, -1, axis=0))
    m *= np.sign(m @ corner.mean(axis=0))[:, None]
    rays = corner / np.linalg.norm(corner, axis=1)[:, None]
    return rays, m / np.linalg.norm(m, axis=1)[:, None]


#: ``(dist (p,), unit direction (p, 3), midpoint (p, 3))`` from
#: :func:`ndbg_cli.contacts.facets.triangle_gap`.
Gaps = tuple


def touching(gaps: Gaps, tol: float) -> np.ndarray:
    """Mask ``(p,)`` of the pairs closer than ``GAP_FRACTION * tol`` (``gaps`` from
    :func:`ndbg_cli.contacts.facets.triangle_gap`): touching, no gap direction."""
    return gaps[0] <= GAP_FRACTION * tol


def near_miss_cones(ta: np.ndarray, tb: np.ndarray, reach: np.ndarray, gaps: Gaps, tol: float,
                    blocked: np.ndarray | None = None) -> list[GapCone]:
    """The blocked cones of the triangle pairs ``ta``, ``tb`` ``(p, 3, 3)`` that are near misses
    (not :func:`touching`) within their allowances ``reach`` ``(p,)``; ``gaps``:
    :func:`ndbg_cli.contacts.facets.triangle_gap` of the pairs. Pairs farther apart than their
    reach, or whose cone is flat, give none; nor do those inside one closed half-space ``{d . b >=
    0}`` of the unit normals ``blocked`` ``(q, 3)`` (the face contacts': all the cone's points on
    its side, ``CONTAIN_SLACK``), the usual case along a face contact's rim. ``tol``: the length
    tolerance."""
    dist, direction, mid = gaps
    todo = np.flatnonzero(~touching(gaps, tol) & (dist <= reach))
    if len(todo) == 0:
        return []
    w, ok = _cut_points(ta[todo], tb[todo], direction[todo], np.asarray(reach, float)[todo])
    if blocked is not None and len(blocked):
        unit = w / np.maximum(np.linalg.norm(w, axis=2), 1e-300)[:, :, None]
        side = np.where(ok[:, :, None], unit @ np.asarray(blocked, float).T, np.inf)
        inside = (side.min(axis=1) >= -CONTAIN_SLACK).any(axis=1)
        todo, w, ok = todo[~inside], w[~inside], ok[~inside]
    out = []
    for x, k in enumerate(todo.tolist()):
        got = _cone(w[x][ok[x]], direction[k])
        if got is not None:
            out.append(GapCone(facets=got[1], rays=got[0], point=mid[k], normal=direction[k]))
    return out


# Cones inside another of the set, or inside the blocked set of the pair's face contacts (no
# direction those leave free meets the cone's interior, decided by a small LP: meets_free),
# add nothing and are dropped; most near misses along a face contact's rim are. A cone the
# face contacts' open half-spaces cover is their rim: its directions within the DBGs' angular
# tolerance of a face's plane are that face's sliding band.
def maximal(cones: list[GapCone]) -> list[int]:
    """Indices of the cones not inside another of ``cones`` (of equal ones, the first)."""
    if not cones:
        return []
    k = max(len(c.rays) for c in cones)
    rays = np.zeros((len(cones), k, 3))
    facets = np.zeros((len(cones), k, 3))
    for x, c in enumerate(cones):  # pad with repeats: they change no test
        rays[x] = c.rays[np.arange(k) % len(c.rays)]
        facets[x] = c.facets[np.arange(k) % len(c.facets)]
    # inside[a, b]: every ray of a on the inner side of every facet of b (in blocks of rows:
    # memory ~ block x cones x k^2)
    inside = np.zeros((len(cones), len(cones)), dtype=bool)
    step = max(1, _BLOCK // (len(cones) * k * k))
    for s in range(0, len(cones), step):
        inside[s:s + step] = np.einsum("aid,bjd->abij", rays[s:s + step],
                                       facets).min(axis=(2, 3)) >= -CONTAIN_SLACK
    np.fill_diagonal(inside, False)
    equal = inside & inside.T
    later = np.triu(np.ones_like(inside), 1).T.astype(bool)  # b before a
    drop = (inside & ~equal).any(axis=1) | (equal & later).any(axis=1)
    return np.flatnonzero(~drop).tolist()


def meets_free(facets: np.ndarray, normals: np.ndarray, hints: np.ndarray | None = None
               ) -> bool:
    """Whether the open cone ``{d . m > 0 for m in facets}`` holds a direction outside the
    open half-spaces ``{d . n > 0}`` of ``normals`` ``(q, 3)`` (the face contacts'): the LP
    ``max t`` over ``|d_i| <= 1`` with ``facets d >= t`` and ``normals d <= 0`` exceeds
    ``1e-9``. An LP that fails says ``True`` (the cone is kept). ``hints`` ``(h, 3)``:
    directions tried first (the cone's gap direction, its rays pulled inward): one inside the
    cone by more than ``1e-9`` and outside every half-space answers without the LP."""
    normals = normals.reshape(-1, 3)
    if len(normals) == 0:
        return True
    if hints is not None and len(hints):
        inside = (hints @ facets.T).min(axis=1) > 1e-9
        if np.any(inside & ((hints @ normals.T).max(axis=1) <= 0.0)):
            return True
    k = len(facets)
    a = np.vstack([np.hstack([-facets, np.ones((k, 1))]),
                   np.hstack([normals, np.zeros((len(normals), 1))])])
    res = linprog(np.array([0.0, 0.0, 0.0, -1.0]), A_ub=a, b_ub=np.zeros(len(a)),
                  bounds=[(-1, 1)] * 3 + [(None, 1)], method="highs")
    return bool(res.status != 0 or -res.fun > 1e-9)


def surrounds(normals: np.ndarray) -> bool:
    """Whether the origin lies inside the convex hull of ``normals`` ``(q, 3)`` by more than
    ``1e-9``: then every direction ``d`` has ``d . n > 0`` for some ``n`` (the open
    half-spaces cover the sphere), and no cone meets what they leave free."""
    if len(normals) < 4:
        return False
    try:
        hull = ConvexHull(normals)
    except QhullError:  # flat: the origin is not inside
        return False
    return bool(np.all(hull.equations[:, -1] < -1e-9))


def widen(cone: GapCone, tol: float) -> np.ndarray | None:
    """Facet normals ``(k, 3)`` of a cone holding every direction within the angle
    ``theta = 1.01 asin(tol)`` of ``cone``, so that each direction of ``cone`` clears every
    facet by more than ``tol`` (``d . m > tol``: an ``"all"`` contact blocks all of it under
    the DBGs' tolerance, and cones side by side leave no unblocked seam between them).

    The widened cone is the cone over octagons of angular circumradius ``theta / cos(pi /
    8)`` round each ray (each holds the ``theta``-cap round its ray), so it reaches at most
    that angle beyond ``cone``. The claim is checked exactly: on a unit direction ``d . m``
    is concave where positive, so over the closed cone its least value is at a ray; the
    radius grows by 10 % until it holds. ``None`` when the cone reaches :data:`WIDEN_LIMIT`
    from its gap direction (the chart blows up) or the check keeps failing."""
    theta = 1.01 * float(np.arcsin(min(max(tol, 0.0), 1.0))) + 1e-12
    n = cone.normal
    phi = float(np.arccos(np.clip((cone.rays @ n).min(), -1.0, 1.0)))
    rho = theta / np.cos(np.pi / 8)
    for _ in range(5):
        if phi + rho >= WIDEN_LIMIT:
            return None
        pts = _octagons(cone.rays, rho)
        got = _cone(pts, n) if np.all(pts @ n > 0) else None
        if got is not None and (cone.rays @ got[1].T).min() > tol:
            return got[1]
        rho *= 1.1
    return None


def _octagons(rays: np.ndarray, rho: float) -> np.ndarray:
    """``(8 k, 3)`` unit directions at the angle ``rho`` round each unit ray ``(k, 3)``, at
    8 even bearings."""
    u, v = circle_frames(rays)
    a = np.arange(8) * (np.pi / 4)
    side = np.cos(a)[None, :, None] * u[:, None] + np.sin(a)[None, :, None] * v[:, None]
    return (np.cos(rho) * rays[:, None] + np.sin(rho) * side).reshape(-1, 3)
