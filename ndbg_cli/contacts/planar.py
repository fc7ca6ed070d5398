"""Planar contacts (paper 5.1: face contacts): two parts' coplanar faces of opposite normals,
their polygons intersected in the common plane.

Two routes to the same contacts: from the coplanar triangle pairs the narrow phase found
(:func:`planar_contacts`), and, before any triangle pairs, facet to facet where the facets are
big (:func:`coplanar_facets`: a CAD exporter's sliver fans would otherwise pair with nearly
every triangle of the mating face). Both intersect the two sides' triangle unions in the plane
(:func:`plane_contact`).
"""

from __future__ import annotations

import numpy as np
import shapely

from ..geometry.vectors import plane_basis
from .facets import PartGeometry

#: Planar facets of at least this many triangles are matched facet to facet before any
#: triangle pairs (:func:`coplanar_facets`) ...
FACET_MIN = 16
#: ... when the matched facets of one plane would make at least this many triangle pairs.
FACET_PAIRS = 100_000

def planar_contacts(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                    tol: float, ang: float) -> tuple[list[dict], np.ndarray]:
    """Planar contacts from coplanar opposite pairs ``(i, j)``. Returns the contacts (dicts of
    :class:`ndbg_cli.contacts.contacts3d.Contact` fields) and a mask ``(p,)`` of the pairs they
    used.

    A pair is planar when the normals are opposite within the angular tolerance and each
    triangle's vertices are within ``tol`` of the other's plane (and not both triangles part of
    tessellated curved surfaces). Per plane, the A and the B triangles are merged into polygons
    in the common plane (shapely) and intersected; the contact is kept when the intersection is
    thicker than ``tol`` (mean width ``2 area / perimeter > tol``); thinner overlaps are edge
    contacts."""
    used = np.zeros(len(i), dtype=bool)
    out: list[dict] = []
    if len(i) == 0:
        return out, used
    fa, fb = ga.facet[i], gb.facet[j]
    n_plane = ga.facet_normal[fa]
    d_mid = (ga.facet_offset[fa] - gb.facet_offset[fb]) / 2.0
    group = -np.ones(len(i), dtype=np.int64)
    seeds: list[tuple[np.ndarray, float]] = []
    cos = np.cos(ang)
    k = 0
    while True:  # loop over planes, each resolved for all pairs at once
        # the next pair not grouped yet (found with numpy: there are many pairs, few planes)
        rest = np.flatnonzero(group[k:] < 0)
        if len(rest) == 0:
            break
        k += int(rest[0])
        n0, d0 = n_plane[k], d_mid[k]
        member = (group < 0) & (n_plane @ n0 >= cos) & (np.abs(d_mid - d0) <= tol)
        group[member] = len(seeds)
        seeds.append((n0, d0))
        k += 1
    for g, (n0, d0) in enumerate(seeds):
        sel = group == g
        got = plane_contact(ga.triangles[np.unique(i[sel])], gb.triangles[np.unique(j[sel])],
                            n0, d0, tol)
        if got is not None:
            out.append(got)
            used |= sel
    return out, used


def plane_contact(ta: np.ndarray, tb: np.ndarray, n0: np.ndarray, d0: float, tol: float
                  ) -> dict | None:
    """The planar contact of triangles ``ta`` (A's) and ``tb`` (B's) lying in the plane
    ``n0 . x = d0``: their unions intersected in that plane (shapely), kept when thicker than
    ``tol`` (mean width ``2 area / perimeter``); ``None`` otherwise (an edge contact)."""
    u, v = plane_basis(n0)
    inter = shapely.intersection(_union_2d(ta, u, v), _union_2d(tb, u, v))
    area = float(inter.area)
    if area <= 0 or 2.0 * area / max(float(inter.length), 1e-300) <= tol:
        return None
    hull = np.asarray(shapely.convex_hull(inter).exterior.coords)[:-1]
    pts = d0 * n0 + hull[:, :1] * u + hull[:, 1:2] * v
    return dict(kind="planar", normals=n0[None, :].copy(), points=pts,
                point_normals=np.repeat(n0[None, :], len(pts), axis=0), area=area,
                _plane=(n0, d0, u, v, inter))


def coplanar_facets(ga: PartGeometry, gb: PartGeometry, tol: float, ang: float
                    ) -> tuple[list[dict], np.ndarray, np.ndarray]:
    """Planar contacts found facet by facet, before any triangle pairs, where that saves
    work: the big planar facets of A and B (at least :data:`FACET_MIN` triangles) that lie in
    one plane with opposite normals. Returns the contacts (as :func:`planar_contacts`) and
    masks ``(f_a,)``, ``(f_b,)`` of the triangles of the facets they hold, which the triangle
    pairs then leave out.

    Why: a CAD exporter triangulates a plate's face around its holes into fans of slivers
    whose boxes overlap nearly all of the mating face's (a gearbox's housing and cover at
    146,000 triangles: 10.8 million coplanar triangle pairs, 30 s), while the contact is just
    the two faces' polygons intersected. Leaving the facets' triangles out loses no normal:
    anything else touching the facet there touches a face of normal ``n`` or lies on the
    contact's rim, which the triangle pairs drop anyway (see :mod:`ndbg_cli.contacts.features`,
    known simplification). A plane whose polygons meet only thinly is left to the triangle
    pairs (its edges may be edge contacts)."""
    skip_a = np.zeros(len(ga.triangles), dtype=bool)
    skip_b = np.zeros(len(gb.triangles), dtype=bool)
    big_a = _big_facets(ga)
    big_b = _big_facets(gb)
    if len(big_a) == 0 or len(big_b) == 0:
        return [], skip_a, skip_b
    cos = np.cos(ang)
    na, nb = ga.facet_normal[big_a], gb.facet_normal[big_b]
    same = (na @ nb.T <= -cos) & (np.abs(ga.facet_offset[big_a][:, None]
                                         + gb.facet_offset[big_b][None, :]) <= tol)
    fa, fb = np.nonzero(same)
    out: list[dict] = []
    done = np.zeros(len(fa), dtype=bool)
    for k in range(len(fa)):
        if done[k]:
            continue
        # one plane: every matched facet pair in it (the plane of the first, within tol)
        n0, d0 = na[fa[k]], ga.facet_offset[big_a[fa[k]]]
        plane = ~done & (na[fa] @ n0 >= cos) & (np.abs(ga.facet_offset[big_a[fa]] - d0) <= tol)
        done |= plane
        ta = np.flatnonzero(np.isin(ga.facet, big_a[np.unique(fa[plane])]))
        tb = np.flatnonzero(np.isin(gb.facet, big_b[np.unique(fb[plane])]))
        if len(ta) * len(tb) < FACET_PAIRS:
            continue  # cheap enough as triangle pairs, which give the same contact
        got = plane_contact(ga.triangles[ta], gb.triangles[tb], n0, d0, tol)
        if got is None:
            continue
        out.append(got)
        skip_a[ta] = True
        skip_b[tb] = True
    return out, skip_a, skip_b


def _big_facets(g: PartGeometry) -> np.ndarray:
    """Facets of ``g`` with at least :data:`FACET_MIN` triangles."""
    return np.flatnonzero(np.bincount(g.facet, minlength=len(g.facet_normal)) >= FACET_MIN)


def _union_2d(tri: np.ndarray, u: np.ndarray, v: np.ndarray):
    """Union of triangles ``(k, 3, 3)`` projected on the plane spanned by ``u, v``."""
    xy = np.stack([tri @ u, tri @ v], axis=-1)
    rings = np.concatenate([xy, xy[:, :1]], axis=1)
    polys = shapely.polygons(rings)
    polys = polys[shapely.area(polys) > 0]
    # the triangles of a facet tile it (edge to edge): a coverage union is exact and fast; it
    # is checked (same area, valid) and the general union used where the tiling is imperfect
    total = float(shapely.area(polys).sum())
    try:
        merged = shapely.coverage_union_all(polys)
        if merged.is_valid and abs(merged.area - total) <= 1e-9 * max(total, 1e-300):
            return merged
    except shapely.errors.GEOSException:
        pass
    return shapely.union_all(polys)


