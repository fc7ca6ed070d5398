"""Contacts between polygonal parts in the plane (paper section 4.3), with shapely and numpy.

Every polygon ring is oriented with the material on its left (exterior counter-clockwise,
holes clockwise), so the outward normal of an edge ``p -> q`` is ``(q - p)`` turned clockwise.
Two parts touch where their boundaries meet within the length tolerance ``tol``: edge-edge
(:func:`_edge_edge`) and vertex-edge (:func:`_vertex_edge`) contacts. The normals of one pair
are returned unmerged; the NDBG stage merges them within its angular tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry.polygon import orient

from ..geometry.vectors import unit

#: Sine of the angle below which two edges count as parallel / a vertex as flat.
PARALLEL_SINE = 1e-9


@dataclass(frozen=True)
class Contact2D:
    """The contact between parts ``a < b`` (indices into the assembly): ``normals`` ``(k, 2)``
    unit vectors out of ``a`` into ``b`` (``a`` translating along ``d`` penetrates ``b`` iff
    ``d . n > 0`` for some ``n``), ``points`` ``(k, 2)`` where each applies, ``kinds``
    (``"edge-edge"`` or ``"vertex-edge"``) and ``length`` the total edge-edge overlap."""

    a: int
    b: int
    normals: np.ndarray
    points: np.ndarray
    kinds: tuple[str, ...]
    length: float


@dataclass(frozen=True)
class Contacts2D:
    """All contacts of a planar assembly, sorted by ``(a, b)``; ``skipped`` lists the convex
    vertex-on-convex-vertex point contacts ``(a, b, point)`` that were left out."""

    contacts: tuple[Contact2D, ...]
    skipped: tuple[tuple[int, int, tuple[float, float]], ...] = field(default=())

    def __iter__(self):
        return iter(self.contacts)

    def __len__(self) -> int:
        return len(self.contacts)


@dataclass(frozen=True)
class _Edges:
    p: np.ndarray  # (e, 2) start points
    q: np.ndarray  # (e, 2) end points
    normal: np.ndarray  # (e, 2) outward unit normals
    convex_p: np.ndarray  # (e,) the start vertex is convex (strictly)
    convex_q: np.ndarray  # (e,) the end vertex is convex


def polygon_edges(poly, tol: float = 0.0) -> _Edges:
    """Edges of every ring of ``poly`` (material on the left), dropping edges shorter than
    ``tol`` (repeated points)."""
    poly = orient(poly, 1.0)
    ps, qs, conv_p, conv_q = [], [], [], []
    for ring in [poly.exterior, *poly.interiors]:
        pts = np.asarray(ring.coords, dtype=float)[:-1]
        keep = np.linalg.norm(pts - np.roll(pts, 1, axis=0), axis=1) > max(tol, 0.0)
        pts = pts[keep] if keep.sum() >= 3 else pts
        prev, nxt = np.roll(pts, 1, axis=0), np.roll(pts, -1, axis=0)
        u, v = unit(pts - prev), unit(nxt - pts)
        convex = (u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]) > PARALLEL_SINE
        ps.append(pts)
        qs.append(nxt)
        conv_p.append(convex)
        conv_q.append(np.roll(convex, -1))
    p, q = np.vstack(ps), np.vstack(qs)
    d = unit(q - p)
    return _Edges(p, q, np.column_stack([d[:, 1], -d[:, 0]]), np.concatenate(conv_p),
                  np.concatenate(conv_q))


def _edge_edge(ea: _Edges, eb: _Edges, tol: float) -> tuple[np.ndarray, np.ndarray,
                                                             np.ndarray, float]:
    """Collinear overlapping edge pairs with opposite normals: (normals out of a, overlap
    midpoints, overlap segments (m, 2, 2), total length). Edges on one line (both ends of
    each within ``tol`` of the other's line), overlapping over more than ``tol``; the contact
    normal is ``a``'s outward normal."""
    anti = (ea.normal @ eb.normal.T) < -(1.0 - PARALLEL_SINE)
    ia, ib = np.nonzero(anti)
    if len(ia) == 0:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2, 2)), 0.0
    n = ea.normal[ia]
    dist_p = np.abs(np.einsum("ij,ij->i", eb.p[ib] - ea.p[ia], n))
    dist_q = np.abs(np.einsum("ij,ij->i", eb.q[ib] - ea.p[ia], n))
    t = np.column_stack([n[:, 1], -n[:, 0]]) * -1  # direction of a's edge
    s0 = np.zeros(len(ia))
    s1 = np.einsum("ij,ij->i", ea.q[ia] - ea.p[ia], t)
    u0 = np.einsum("ij,ij->i", eb.p[ib] - ea.p[ia], t)
    u1 = np.einsum("ij,ij->i", eb.q[ib] - ea.p[ia], t)
    lo = np.maximum(np.minimum(s0, s1), np.minimum(u0, u1))
    hi = np.minimum(np.maximum(s0, s1), np.maximum(u0, u1))
    ok = (dist_p <= tol) & (dist_q <= tol) & (hi - lo > tol)
    ia, ib, n, t, lo, hi = ia[ok], ib[ok], n[ok], t[ok], lo[ok], hi[ok]
    base = ea.p[ia]
    seg = np.stack([base + lo[:, None] * t, base + hi[:, None] * t], axis=1)
    return n, seg.mean(axis=1), seg, float((hi - lo).sum())


def _vertex_edge(ea: _Edges, eb: _Edges, tol: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices of ``a`` on edges of ``b``: (normals out of a into b, points, point-contact
    mask for the skipped convex-on-convex cases, point-contact points).

    A vertex within ``tol`` of the interior of an edge, or of an end of it that is a reflex
    (concave) vertex of ``b`` (a corner in a notch, paper assumption 2), gives the normal minus
    ``b``'s outward edge normal (``a``'s normal when ``b``'s vertex lies on ``a``'s edge). A
    vertex touching a *convex* vertex of the other part is a point contact whose blocked set is
    not a half plane: it is left out (the paper excludes it too) and listed in
    ``Contacts2D.skipped`` unless an edge-edge contact covers the point."""
    v, conv_v = ea.p, ea.convex_p
    d = eb.q - eb.p
    length = np.linalg.norm(d, axis=1)
    rel = v[:, None, :] - eb.p[None, :, :]
    t = np.clip(np.einsum("vej,ej->ve", rel, d) / np.maximum(length**2, 1e-300), 0.0, 1.0)
    foot = eb.p[None] + t[..., None] * d[None]
    dist = np.linalg.norm(v[:, None, :] - foot, axis=2)
    hit = dist <= tol
    at_p = t * length[None] <= tol
    at_q = (1.0 - t) * length[None] <= tol
    convex_end = (at_p & eb.convex_p[None]) | (at_q & eb.convex_q[None])
    iv, ie = np.nonzero(hit & ~convex_end)
    normals = -eb.normal[ie]
    points = v[iv]
    jv, _ = np.nonzero(hit & convex_end & conv_v[:, None])
    return normals, points, np.unique(v[jv], axis=0) if len(jv) else np.zeros((0, 2))


def _on_segments(point: np.ndarray, segs: np.ndarray, tol: float) -> bool:
    if len(segs) == 0:
        return False
    p, q = segs[:, 0], segs[:, 1]
    d = q - p
    t = np.clip(np.einsum("ij,ij->i", point - p, d) / np.maximum((d**2).sum(1), 1e-300), 0, 1)
    return bool((np.linalg.norm(point - (p + t[:, None] * d), axis=1) <= tol).any())


def contact_between(i: int, j: int, ei: _Edges, ej: _Edges, tol: float
                    ) -> tuple[Contact2D | None, list[tuple[float, float]]]:
    """The contact of parts ``i < j`` from their edges, and the skipped point contacts."""
    n_ee, p_ee, segs, length = _edge_edge(ei, ej, tol)
    n_ij, p_ij, skip_i = _vertex_edge(ei, ej, tol)  # vertices of i on edges of j
    n_ji, p_ji, skip_j = _vertex_edge(ej, ei, tol)  # vertices of j on edges of i
    normals = np.vstack([n_ee, n_ij, -n_ji])
    points = np.vstack([p_ee, p_ij, p_ji])
    kinds = ("edge-edge",) * len(n_ee) + ("vertex-edge",) * (len(n_ij) + len(n_ji))
    skipped = []
    for pt in np.vstack([skip_i, skip_j]):
        if not _on_segments(pt, segs, tol) and not any(
                np.linalg.norm(pt - q) <= tol for q in skipped):
            skipped.append((float(pt[0]), float(pt[1])))
    if len(normals) == 0:
        return None, skipped
    return Contact2D(i, j, normals, points, kinds, length), skipped


def find_contacts_2d(asm, tol: float | None = None) -> Contacts2D:
    """Contacts of every pair of polygonal parts of the planar assembly ``asm`` within
    ``tol`` (default ``asm.length_tolerance``); candidate pairs come from a shapely STRtree
    query (``dwithin``), so distant parts are never compared."""
    tol = asm.length_tolerance if tol is None else float(tol)
    polys = [p.polygon for p in asm.parts]
    return contacts_of_polygons(polys, tol)


def contacts_of_polygons(polys, tol: float) -> Contacts2D:
    """:func:`find_contacts_2d` for a plain list of shapely polygons."""
    if len(polys) < 2:
        return Contacts2D(())
    tree = shapely.STRtree(polys)
    src, dst = tree.query(polys, predicate="dwithin", distance=tol)
    cand = sorted({(int(a), int(b)) for a, b in zip(src, dst) if a < b})
    edges: dict[int, _Edges] = {}
    out, skipped = [], []
    for i, j in cand:
        for k in (i, j):
            if k not in edges:
                edges[k] = polygon_edges(polys[k], tol)
        contact, skip = contact_between(i, j, edges[i], edges[j], tol)
        if contact is not None:
            out.append(contact)
        skipped += [(i, j, s) for s in skip]
    return Contacts2D(tuple(out), tuple(skipped))
