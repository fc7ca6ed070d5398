"""Narrow phase: turning the touching triangles of two parts into contact features.

Input: the candidate triangle pairs ``(i, j)`` (``i`` in part A, ``j`` in part B) whose boxes
come within the pair's gap allowance ``g_ij = tol + sag_i + sag_j`` (two tessellations of one
smooth surface are at most that far apart) and that no face plane separates by more than
``g_ij``. They are classified at once with numpy (:func:`classify_pairs`) into **planar**
(:func:`ndbg_cli.contacts.planar.planar_contacts`), **curved** (:func:`curved_contacts`) and
**edge** / **point** contacts (:func:`edge_point_contacts`, what remains besides the others'
rims).

Known simplification: an edge of B lying on a face of A that is already in a planar or curved
contact with B is taken as that contact's rim and produces no contact of its own (it adds no
translation normal; its contact points are not reported).
"""

from __future__ import annotations

import numpy as np
import shapely
from scipy.optimize import nnls

from ..geometry.normals import cluster_normals, one_cluster
from ..geometry.vectors import plane_basis, unique_rows
from .facets import (
    PartGeometry,
    box_pairs,
    graph_components,
    max3,
    min3,
    point_triangle_distance,
    segment_distance,
    triangle_gap,
)
from .gap_cones import maximal, meets_free, near_miss_cones, surrounds, touching, widen

#: Edge/point contacts where more distinct face normals than this meet on one side (messy or
#: overlapping display meshes) skip the exact normal-cone intersection (see
#: :func:`edge_point_contacts`).
MAX_CONE_FACES = 4

#: A component of near misses keeping more sweep cones than this becomes one contact
#: blocking on any of their gap directions (see :func:`_pair_by_pair`).
MAX_GAP_CONES = 8

#: Largest number of point x triangle box tests :func:`_near_triangles` does with
#: :func:`box_pairs` (beyond, the part's box hierarchy answers faster).
_BOX_PAIRS = 4_000_000

#: Share of the narrower triangle's least height by which two curved facets must overlap, seen
#: along their mean normal, to face each other when that is less than the length tolerance
#: (see :func:`classify_pairs`).
RIM_SHARE = 0.25

#: Rows per batched call of the triangle distance functions (bounds memory to ~50 MB).
_BATCH = 200_000


def classify_pairs(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                   tol: float, ang: float,
                   offsets: tuple[np.ndarray, np.ndarray] | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Boolean masks ``(planar, curved)`` over touching triangle pairs ``(i, j)``.

    ``offsets`` ``((p,), (p,))``: how far (unit) B's vertices reach from A's plane and A's from B's,
    when the caller has measured them already (``ndbg_cli.contacts.contacts3d._plane_filter``, the
    same arithmetic); otherwise they are computed here."""
    na, nb = ga.normals[i], gb.normals[j]
    c = np.einsum("ij,ij->i", na, nb)
    if offsets is None:
        ta, tb = ga.triangles[i], gb.triangles[j]
        sa = np.abs(np.einsum("pvd,pd->pv", tb - ta[:, :1], na)).max(axis=1)
        sb = np.abs(np.einsum("pvd,pd->pv", ta - tb[:, :1], nb)).max(axis=1)
    else:
        sa, sb = offsets
    tha, thb = ga.smooth_angle[i], gb.smooth_angle[j]
    coplanar = (c <= -np.cos(ang)) & (sa <= tol) & (sb <= tol)
    both_curved = (tha > 0) & (thb > 0)
    planar = coplanar & ~both_curved
    limit = np.minimum(ang + (tha + thb) / 2.0, np.pi / 2)
    curved = ~planar & (tha + thb > 0) & (c <= -np.cos(limit))
    k = np.nonzero(curved)[0]
    if len(k):
        # facing surfaces, not a rim: the triangles must overlap, seen along their mean
        # normal, by more than the tolerance (a ball's facet above the equator only touches
        # the socket's rim along a line, and must not add its upward-tilted normal), or by a
        # quarter of the narrower triangle's least height where facets are narrower than the
        # tolerance (a fine tessellation: 480 facets on a 3 mm bolt are 0.04 mm wide), since a
        # rim's overlap is zero whatever the facets' size
        ta, tb = ga.triangles[i[k]], gb.triangles[j[k]]
        least = np.minimum(least_height(ta, ga.areas[i[k]]), least_height(tb, gb.areas[j[k]]))
        need = np.minimum(tol, RIM_SHARE * least)
        curved[k[facing_overlap(ta, tb, na[k] - nb[k]) <= need]] = False
    return planar, curved


def least_height(tri: np.ndarray, areas: np.ndarray) -> np.ndarray:
    """Each triangle's least height ``(p,)``: twice its area over its longest edge."""
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    return 2.0 * areas / np.maximum(edges, 1e-300)


def facing_overlap(ta: np.ndarray, tb: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Overlap width ``(p,)`` (unit) of triangle pairs ``(p, 3, 3)`` projected along ``m``
    ``(p, 3)``: the smallest interval overlap over the six edge normals of the projected
    triangles (2D separating-axis test); ``<= 0`` when the projections are disjoint or meet
    along a segment only."""
    m = m / np.maximum(np.linalg.norm(m, axis=1), 1e-300)[:, None]
    u, v = plane_basis(m)
    # projected vertices (u, v coordinates, each (p, 3)), the six edges (A's, then B's) and
    # their unit normals in the plane (each (p, 6))
    au, av = np.einsum("pvd,pd->pv", ta, u), np.einsum("pvd,pd->pv", ta, v)
    bu, bv = np.einsum("pvd,pd->pv", tb, u), np.einsum("pvd,pd->pv", tb, v)
    eu = np.concatenate([np.roll(au, -1, axis=1) - au, np.roll(bu, -1, axis=1) - bu], axis=1)
    ev = np.concatenate([np.roll(av, -1, axis=1) - av, np.roll(bv, -1, axis=1) - bv], axis=1)
    nx, ny = -ev, eu
    length = np.maximum(np.sqrt(nx * nx + ny * ny), 1e-300)
    nx, ny = nx / length, ny / length
    # projections on the six normals (p, 6, 3): two-term sums, written out (the same numbers
    # as np.einsum, several times faster at these sizes); minima and maxima over the three
    # vertices and the six axes column by column (short-axis reductions are slow too)
    xa = nx[:, :, None] * au[:, None, :] + ny[:, :, None] * av[:, None, :]
    xb = nx[:, :, None] * bu[:, None, :] + ny[:, :, None] * bv[:, None, :]
    over = np.minimum(max3(xa), max3(xb)) - np.maximum(min3(xa), min3(xb))
    return np.minimum.reduce([over[:, k] for k in range(over.shape[1])])


def curved_contacts(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                    ang: float, tol: float) -> list[dict]:
    """One curved contact per connected set of curved pairs ``(i, j)``.

    Curved pairs: opposite-facing, not coplanar, at least one side a tessellated curved
    surface, normals opposite within ``angle_tol + (theta_i + theta_j) / 2`` (``theta``: each
    tessellation's facet angle ``2 pi / N``), projections along their mean normal overlapping
    by more than ``tol`` (:func:`facing_overlap`: a facet merely resting on the other surface's
    rim is not a facing pair). Pairs connected through shared triangles or mesh edges form one
    contact; its axis, centre and radius come from :func:`fit_surface`.

    A set where one side is flat (its normals form one cluster within ``ang``: a cylinder
    lying on a plane, a ball on a plane) is the tessellation of a line or point contact: it is
    reported as an ``edge`` (or ``point``) contact whose only normal is the flat side's; the
    curved side's facet normals there are artefacts of the tessellation."""
    out: list[dict] = []
    if len(i) == 0:
        return out
    ui, ii = np.unique(i, return_inverse=True)
    uj, jj = np.unique(j, return_inverse=True)
    # one contact per connected patch: facing pairs link A's and B's triangles, and the
    # triangles of each side that share an edge are linked too
    links = [np.stack([ii, len(ui) + jj], axis=1),
             _local_adjacency(ga.adjacency, ui), len(ui) + _local_adjacency(gb.adjacency, uj)]
    label = graph_components(len(ui) + len(uj), np.concatenate(links))
    for comp in np.unique(label):
        ta = ui[label[: len(ui)] == comp]
        tb = uj[label[len(ui):] == comp]
        normals = np.concatenate([ga.normals[ta], -gb.normals[tb]])
        weights = np.concatenate([ga.areas[ta], gb.areas[tb]])
        centroids = np.concatenate([ga.triangles[ta].mean(axis=1), gb.triangles[tb].mean(axis=1)])
        verts = np.concatenate([ga.triangles[ta].reshape(-1, 3), gb.triangles[tb].reshape(-1, 3)])
        flat_a = one_cluster(ga.normals[ta], ang)
        flat_b = one_cluster(gb.normals[tb], ang)
        if flat_a != flat_b:
            out.append(_flat_on_curved(ga, gb, ta, tb, flat_a, ang, tol))
            continue
        fit = fit_surface(normals, weights, centroids, verts, ang)
        out.append(dict(kind="curved", normals=cluster_normals(normals, ang, weights),
                        points=centroids, point_normals=normals,
                        area=float(min(ga.areas[ta].sum(), gb.areas[tb].sum())),
                        _triangle_ids=(ta, tb), **fit))
    return out


def _flat_on_curved(ga: PartGeometry, gb: PartGeometry, ta: np.ndarray, tb: np.ndarray,
                    flat_a: bool, ang: float, tol: float) -> dict:
    """The line or point contact of a curved patch resting on a flat one: the single normal
    of the flat side (out of A), and the curved side's vertices within ``tol`` plus its chord
    sag of the flat plane, reduced to a point (spread <= that gap) or a segment's ends."""
    flat, curved = (ga, gb) if flat_a else (gb, ga)
    tf, tc = (ta, tb) if flat_a else (tb, ta)
    n = cluster_normals(flat.normals[tf], ang, flat.areas[tf])[0]
    d = float(np.average(flat.triangles[tf].mean(axis=1) @ n, weights=flat.areas[tf]))
    gap = tol + float(curved.sag[tc].max())
    verts = np.unique(curved.triangles[tc].reshape(-1, 3), axis=0)
    near = verts[np.abs(verts @ n - d) <= gap]
    if len(near) == 0:
        near = verts[np.argsort(np.abs(verts @ n - d))[:1]]
    c = near.mean(axis=0)
    if len(near) > 1:
        e1 = np.linalg.svd(near - c, full_matrices=False)[2][0]
        t = (near - c) @ e1
    else:
        e1, t = np.array([1.0, 0.0, 0.0]), np.zeros(1)
    if np.ptp(t) <= gap:
        kind, points = "point", c[None, :]
    else:
        kind, points = "edge", np.array([c + t.min() * e1, c + t.max() * e1])
    normal = n if flat_a else -n
    return dict(kind=kind, normals=normal[None, :], points=points,
                point_normals=np.repeat(normal[None, :], len(points), axis=0), area=0.0,
                _triangle_ids=(ta, tb))


def _local_adjacency(adjacency: np.ndarray, members: np.ndarray) -> np.ndarray:
    """The edges ``(e, 2)`` of ``adjacency`` between triangles in sorted ``members``,
    renumbered as positions in ``members``."""
    if len(adjacency) == 0 or len(members) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    pos = np.searchsorted(members, adjacency)
    pos = np.minimum(pos, len(members) - 1)
    inside = np.all(members[pos] == adjacency, axis=1)
    return pos[inside]


def fit_surface(normals: np.ndarray, weights: np.ndarray, centroids: np.ndarray,
                verts: np.ndarray, ang: float) -> dict:
    """Recognise a cylinder, cone or sphere from facet normals ``(k, 3)`` (area ``weights``),
    facet centroids ``(k, 3)`` and the facets' vertices ``(m, 3)``.

    The axis is the unit vector along which the normals vary least (``n . axis`` constant):
    the smallest eigenvector of their weighted covariance. Axisymmetric when that variance is
    below ``sin(ang)^2``: a cylinder when ``|mean(n . axis)| <= sin(ang)``, else a cone. When
    the normals spread in every direction the patch is fitted as a sphere. Patches whose normals
    spread less than ``ang`` carry no surface. Returns ``axis``, ``center``, ``radius``,
    ``surface`` (all ``None`` when unrecognised); the radius is the mean distance of the
    vertices from the axis (cylinder, cone: at the centre's height) or centre (sphere)."""
    none = dict(axis=None, center=None, radius=None, surface=None)
    w = weights / max(weights.sum(), 1e-300)
    mean = w @ normals
    dev = normals - mean
    lam, vec = np.linalg.eigh((dev * w[:, None]).T @ dev)
    s2 = np.sin(ang) ** 2
    if lam[1] < s2:
        return none
    if lam[0] < s2:
        axis = vec[:, 0]
        axis = axis * (1 if axis[np.argmax(np.abs(axis))] > 0 else -1)
        u, v = plane_basis(axis)
        # normal lines meet the axis: in the plane across the axis each passes through it
        p2 = np.stack([centroids @ u, centroids @ v], axis=1)
        n2 = np.stack([normals @ u, normals @ v], axis=1)
        n2 /= np.maximum(np.linalg.norm(n2, axis=1), 1e-300)[:, None]
        rows = np.stack([n2[:, 1], -n2[:, 0]], axis=1)
        rhs = n2[:, 1] * p2[:, 0] - n2[:, 0] * p2[:, 1]
        ab = np.linalg.lstsq(rows * w[:, None], rhs * w, rcond=None)[0]
        h = float(np.mean(verts @ axis))
        center = ab[0] * u + ab[1] * v + h * axis
        rel = verts - center
        radial = rel - np.outer(rel @ axis, axis)
        radius = float(np.linalg.norm(radial, axis=1).mean())
        kind = "cylinder" if abs(float(mean @ axis)) <= np.sin(ang) else "cone"
        return dict(axis=axis, center=center, radius=radius, surface=kind)
    # sphere: centroid_k = c + rho * n_k in the least-squares sense
    k = len(normals)
    a = np.zeros((3 * k, 4))
    a[:, :3] = np.tile(np.eye(3), (k, 1))
    a[:, 3] = normals.reshape(-1)
    sol = np.linalg.lstsq(a, centroids.reshape(-1), rcond=None)[0]
    center = sol[:3]
    return dict(axis=None, center=center,
                radius=float(np.linalg.norm(verts - center, axis=1).mean()), surface="sphere")


def edge_point_contacts(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                        gap: np.ndarray, ang: float, patches: list[dict], tol: float
                        ) -> list[dict]:
    """Edge and point contacts from the touching pairs ``(i, j)`` not used by a planar or
    curved contact, with gap allowances ``gap`` ``(p,)``. Touch points within
    the allowance of one of the ``patches`` (the planar and curved contacts found: their rims)
    are dropped; pairs without any remaining point (the separating-axis test is a lower bound
    of the distance) produce nothing.

    The pairs must also pass the full 11-axis separating test
    (:func:`ndbg_cli.contacts.facets.sat_gap`). Contact points are the vertices within ``g_ij``
    of the other triangle and the closest points of edges within ``g_ij`` of each other; a set
    spanning at most ``g`` is a point contact, one within ``g`` of a line an edge contact (its
    two extreme points), anything else an edge contact listing all its points. Normals: the
    cone of admissible separating normals at the contact's middle, ``cone(n_A) & cone(-n_B)``
    over the faces of A and of B meeting there; A is blocked along ``d`` only when
    ``d . n > 0`` for *all* generators (``blocking == "all"``). Where more than
    :data:`MAX_CONE_FACES` distinct normals meet on a side (a ring round a tessellated peg), or
    the cones do not intersect (two fillets diverging from a face contact's rim), the component
    is taken pair by pair (:func:`_pair_by_pair`)."""
    out: list[dict] = []
    if len(i) == 0:
        return out
    pts, pair = _touch_points(ga, gb, i, j, gap)
    # touch points repeat (each vertex is shared by many pairs): test each distinct one once
    q = max(float(gap.min()) / 4.0, 1e-300)
    first, inv = unique_rows(np.round(pts / q))
    gmax = np.zeros(len(first))
    np.maximum.at(gmax, inv, gap[pair])
    keep = ~_near_patches(pts[first], gmax, patches, ga, gb)[inv]
    pts, pair = pts[keep], pair[keep]
    live = np.unique(pair)
    if len(live) == 0:
        return out
    remap = -np.ones(len(i), dtype=np.int64)
    remap[live] = np.arange(len(live))
    i, j, gap = i[live], j[live], gap[live]
    pair = remap[pair]
    ui, ii = np.unique(i, return_inverse=True)
    uj, jj = np.unique(j, return_inverse=True)
    label = graph_components(len(ui) + len(uj), np.stack([ii, len(ui) + jj], axis=1))[ii]
    lab = label[pair]
    # the points and the pairs of each component, grouped once (components in label order)
    comps, pts_of = _groups(lab)
    pairs_of = dict(zip(*_groups(label)))
    point_sets = _distinct_points(pts, pts_of)
    for comp, p in zip(comps.tolist(), point_sets):
        sel = pairs_of[comp]
        g = float(gap[sel].max())
        c = p.mean(axis=0)
        if len(p) > 1:
            e1 = np.linalg.svd(p - c, full_matrices=False)[2][0]
        else:
            e1 = np.array([1.0, 0.0, 0.0])
        t = (p - c) @ e1
        off = np.linalg.norm((p - c) - np.outer(t, e1), axis=1).max()
        if np.ptp(t) <= g and off <= g:
            kind, points = "point", c[None, :]
        elif off <= g:
            kind, points = "edge", np.array([c + t.min() * e1, c + t.max() * e1])
        else:
            kind, points = "edge", p
        q = points.mean(axis=0)
        ta, tb = np.unique(i[sel]), np.unique(j[sel])
        near = point_triangle_distance(np.repeat(q[None], len(ta) + len(tb), 0),
                                       np.concatenate([ga.triangles[ta], gb.triangles[tb]])) <= g
        near_a, near_b = near[:len(ta)], near[len(ta):]
        na = cluster_normals(ga.normals[ta[near_a]] if near_a.any() else ga.normals[ta], ang)
        nb = cluster_normals(-(gb.normals[tb[near_b]] if near_b.any() else gb.normals[tb]), ang)
        normals = (cone_intersection(na, nb, ang) if max(len(na), len(nb)) <= MAX_CONE_FACES
                   else np.zeros((0, 3)))
        if len(normals) == 0:
            # no proper cone (many faces meet there, or they disagree within the tolerance):
            # each triangle pair on its own (near misses: their sweep cones)
            out += _pair_by_pair(ga, gb, i[sel], j[sel], gap[sel], tol, ang, patches,
                                 kind, points)
            continue
        out.append(_line_contact(kind, normals, points, "all"))
    return out


def _line_contact(kind: str, normals: np.ndarray, points: np.ndarray, blocking: str) -> dict:
    """An edge or point contact over ``points`` ``(m, 3)``, each with the unit mean of
    ``normals`` as its point normal."""
    pn = np.repeat(normals.mean(axis=0, keepdims=True), len(points), axis=0)
    pn /= np.maximum(np.linalg.norm(pn, axis=1), 1e-300)[:, None]
    return dict(kind=kind, normals=normals, points=points, point_normals=pn, area=0.0,
                blocking=blocking)


def _pair_by_pair(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                  gap: np.ndarray, tol: float, ang: float, patches: list[dict], kind: str,
                  points: np.ndarray) -> list[dict]:
    """Contacts of a component whose faces admit no common separating cone, pair by pair.

    Touching pairs (:data:`ndbg_cli.contacts.gap_cones.GAP_FRACTION`) give one contact over the
    component's points with both face normals of each pair, blocking on any (conservative).
    Near misses give their sweep cones (:mod:`ndbg_cli.contacts.gap_cones`), less those inside
    another or inside what the pair's face contacts (``patches``) and the touching pairs
    block (their open half-spaces, :func:`ndbg_cli.contacts.gap_cones.meets_free`: such a cone is
    their rim, sliding with them within ``ang``); each left is a point contact blocking on all
    the facet normals of the cone widened by ``ang`` (:func:`ndbg_cli.contacts.gap_cones.widen`), so
    that all of it is blocked under that tolerance and cones side by side leave no seam.
    More than :data:`MAX_GAP_CONES` cones left (a ring of near misses round a part with no
    face contact, as on overlapping display meshes) make one contact blocking on any of
    their gap directions instead (a superset of their union, with a bounded number of
    normals for the NDBG's arrangement), and so do the cones too wide to widen (nearly
    half-spaces)."""
    out = []
    face = [np.asarray(f["normals"], float).reshape(-1, 3) for f in patches
            if f.get("blocking", "any") == "any"]
    ta, tb = ga.triangles[i], gb.triangles[j]
    gaps = triangle_gap(ta, tb)
    close = touching(gaps, tol)
    if close.any():
        normals = cluster_normals(np.concatenate([ga.normals[i[close]], -gb.normals[j[close]]]),
                                  ang)
        out.append(_line_contact(kind, normals, points, "any"))
        face.append(normals)
    blocked = np.concatenate(face) if face else np.zeros((0, 3))
    if surrounds(blocked):  # the faces block every direction: nothing for the cones to add
        return out
    cones = near_miss_cones(ta, tb, gap, gaps, tol, blocked)
    kept = [cones[k] for k in maximal(cones)
            if meets_free(cones[k].facets, blocked, _hints(cones[k]))]
    # a ring of near misses with no face contact to absorb it, or a cone too wide to widen
    # (nearly a half-space): blocking on any gap direction (a cone's directions are all
    # within its widest ray's angle of its gap direction: a superset, but for directions
    # within the tolerance of the plane across it, its sliding band as for a face)
    wide = [None if len(kept) > MAX_GAP_CONES else widen(c, ang) for c in kept]
    rows = np.array([c.normal for c, w in zip(kept, wide) if w is None]).reshape(-1, 3)
    if len(rows):
        normals = rows[np.sort(unique_rows(rows)[0])]
        out.append(_line_contact(kind, normals, points, "any"))
    return out + [dict(kind="point", normals=w, points=c.point[None, :],
                       point_normals=c.normal[None, :], area=0.0, blocking="all")
                  for c, w in zip(kept, wide) if w is not None]


def _hints(cone) -> np.ndarray:
    """Directions inside a sweep cone to try before an LP: its gap direction and its rays
    pulled a tenth of the way towards their mean."""
    mean = cone.rays.mean(axis=0)
    return np.vstack([cone.normal, 0.9 * cone.rays + 0.1 * mean])


def _groups(label: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
    """The distinct values of ``label`` ``(n,)`` (ascending) and, for each, the indices where
    it occurs (ascending): what ``np.nonzero(label == v)`` gives, from one stable sort."""
    order = np.argsort(label, kind="stable")
    values, start = np.unique(label[order], return_index=True)
    return values, np.split(order, start[1:])


def _distinct_points(pts: np.ndarray, groups: list[np.ndarray]) -> list[np.ndarray]:
    """``np.unique(pts[g], axis=0)`` for each index group ``g``, from one sort of all points.
    Where a coordinate is -0.0, the representative ``np.unique`` keeps of points equal but
    for the sign of a zero is not defined by the values, so those go to ``np.unique``."""
    if np.any(np.signbit(pts) & (pts == 0)):
        return [np.unique(pts[g], axis=0) for g in groups]
    first, inv = unique_rows(pts)
    rows = pts[first]
    return [rows[np.unique(inv[g])] for g in groups]


def _near_patches(pts: np.ndarray, gap: np.ndarray, patches: list[dict], ga: PartGeometry,
                  gb: PartGeometry) -> np.ndarray:
    """Mask ``(n,)`` of points within ``gap`` ``(n,)`` of a planar contact's polygon (in its
    plane) or of a curved contact's triangles (:func:`_near_triangles`)."""
    near = np.zeros(len(pts), dtype=bool)
    for f in patches:
        if f["kind"] == "planar":
            n0, d0, u, v, poly = f["_plane"]
            k = np.nonzero(~near & (np.abs(pts @ n0 - d0) <= gap))[0]
            if len(k):
                xy = shapely.points(np.stack([pts[k] @ u, pts[k] @ v], axis=1))
                near[k[shapely.dwithin(poly, xy, gap[k])]] = True
        else:
            ta, tb = f["_triangle_ids"]
            for geo, ids in ((ga, ta), (gb, tb)):
                near |= _near_triangles(pts, gap, geo, ids)
    return near


def _near_triangles(pts: np.ndarray, gap: np.ndarray, geo: PartGeometry,
                    ids: np.ndarray) -> np.ndarray:
    """Mask ``(n,)`` of points within ``gap`` ``(n,)`` of any triangle ``ids`` (distinct) of
    ``geo``: the triangles whose boxes meet each point's box ``+- gap``
    (:func:`box_pairs`, or the part's box hierarchy when there are many), then their
    distances."""
    if len(pts) * len(ids) <= _BOX_PAIRS:
        k, t = box_pairs(pts - gap[:, None], pts + gap[:, None], geo.lo[ids], geo.hi[ids])
        t = ids[t]
    else:
        member = np.zeros(len(geo.normals), dtype=bool)
        member[ids] = True
        k, t = geo.boxes.meeting(pts - gap[:, None], pts + gap[:, None])
        k, t = k[member[t]], t[member[t]]
    d = point_triangle_distance(pts[k], geo.triangles[t])
    near = np.zeros(len(pts), dtype=bool)
    near[k[d <= gap[k]]] = True
    return near


def _touch_points(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                  gap: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points where triangle pairs ``(i, j)`` come within ``gap`` ``(p,)``: vertices near the
    other triangle and midpoints of close edge pairs, with the index of their pair. Each
    distinct (vertex, triangle) combination is measured once (a vertex is shared by about six
    triangles). Order: A's corners near B's triangles, B's near A's (corner-major), then the
    nine edge pairs (A's edge ``k``, B's edge ``m``, ``k``-major), each in pair order.

    The distance functions work row by row, so they are called on batches (both sides'
    corners at once; the nine edge pairs at once, :data:`_BATCH` rows a call): the same
    numbers with far fewer numpy calls."""
    pair = np.arange(len(i))
    pts, labs = [], []
    sides = []
    for gx, gy, ix, iy in ((ga, gb, i, j), (gb, ga, j, i)):
        vid = gx.faces[ix].T.ravel()  # corner k of every pair, k = 0, 1, 2
        tri = np.tile(iy, 3)
        key = vid * np.int64(len(gy.faces)) + tri
        _, first, inv = np.unique(key, return_index=True, return_inverse=True)
        sides.append((gx, vid, inv, gx.vertices[vid[first]], gy.triangles[tri[first]]))
    d = point_triangle_distance(np.concatenate([sides[0][3], sides[1][3]]),
                                np.concatenate([sides[0][4], sides[1][4]]))
    for (gx, vid, inv, _, _), ds in zip(sides, np.split(d, [len(sides[0][3])])):
        near = ds[inv.ravel()] <= np.tile(gap, 3)
        pts.append(gx.vertices[vid[near]])
        labs.append(np.tile(pair, 3)[near])
    ta, tb = ga.triangles[i], gb.triangles[j]
    k, m = np.repeat(np.arange(3), 3), np.tile(np.arange(3), 3)
    dist, mid = np.empty((9, len(i))), np.empty((9, len(i), 3))
    step = max(1, _BATCH // 9)
    for s in range(0, len(i), step):
        ca, cb = ta[s:s + step], tb[s:s + step]
        d, c = segment_distance(_corner_rows(ca, k), _corner_rows(ca, (k + 1) % 3),
                                _corner_rows(cb, m), _corner_rows(cb, (m + 1) % 3))
        dist[:, s:s + step] = d.reshape(9, -1)
        mid[:, s:s + step] = c.reshape(9, -1, 3)
    near = dist <= gap
    pts.append(mid[near])
    labs.append(np.broadcast_to(pair, dist.shape)[near])
    return np.concatenate(pts), np.concatenate(labs)


def _corner_rows(t: np.ndarray, corner: np.ndarray) -> np.ndarray:
    """Corners ``corner`` ``(c,)`` of triangles ``t`` ``(p, 3, 3)`` as rows ``(c * p, 3)``,
    corner-major."""
    return t[:, corner].transpose(1, 0, 2).reshape(-1, 3)


def _in_cone(gens: np.ndarray, r: np.ndarray, eps: float = 1e-7) -> bool:
    """Whether ray ``r`` (unit) lies in the cone spanned by ``gens`` ``(k, 3)``."""
    if len(gens) == 0:
        return False
    _, res = nnls(gens.T, r)
    return bool(res <= eps)


def cone_intersection(ga: np.ndarray, gb: np.ndarray, ang: float) -> np.ndarray:
    """Generators ``(k, 3)`` of the intersection of the convex cones spanned by ``ga`` and
    ``gb`` (unit rows). Candidate rays: each cone's generators and the lines where a face plane
    of one cone meets a face plane of the other; kept when inside both cones (tolerance
    ``sin(ang)``), clustered within ``ang`` and reduced to the extreme ones."""
    eps = np.sin(ang)

    def planes(g: np.ndarray) -> list[np.ndarray]:
        out = []
        for a in range(len(g)):
            for b in range(a + 1, len(g)):
                m = np.cross(g[a], g[b])
                if np.linalg.norm(m) > 1e-9:
                    out.append(m / np.linalg.norm(m))
        return out

    cand = [*ga, *gb]
    for pa in planes(ga):
        for pb in planes(gb):
            r = np.cross(pa, pb)
            if np.linalg.norm(r) > 1e-9:
                cand += [r / np.linalg.norm(r), -r / np.linalg.norm(r)]
    keep = [r for r in cand if _in_cone(ga, r, eps) and _in_cone(gb, r, eps)]
    if not keep:
        return np.zeros((0, 3))
    rays = cluster_normals(np.array(keep), ang)
    extreme = [r for k, r in enumerate(rays)
               if not _in_cone(np.delete(rays, k, axis=0), r, 1e-9)]
    return np.array(extreme) if extreme else rays
