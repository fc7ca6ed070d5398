"""Contact analysis: which parts touch, where, and with which normals (issue 3).

:func:`analyze_contacts` finds every pair of touching parts of a 3D assembly and describes each
contact by the unit normals that block part A's translations (``d . n > 0`` penetrates B) and by
contact points for generalized (6D) motion constraints ``n . (v + w x p) >= 0``.

Tolerance model (all lengths in the assembly unit):

* ``tol``: the length tolerance, ``asm.length_tolerance`` unless given: the manifest's or the
  command line's ``tolerance``, else 1e-4 times the assembly's bounding-box diagonal. It scales
  with the model, so a change of unit changes no answer. Planes closer than ``tol`` coincide,
  gaps up to ``tol`` count as touching, contact polygons thinner than ``tol`` are edges.
* chord sag: a tessellated cylinder, cone or sphere departs from the true surface by the sag
  ``r (1 - cos(pi / N))`` of its ``N``-segment tessellation (estimated per triangle from the
  dihedral angles, see :class:`ndbg_cli.facets.PartGeometry`). Two tessellations of one
  nominal surface (a 24-facet shaft in a 64-facet hole) leave gaps up to the coarser side's sag
  and cross each other by up to the finer side's sag. Hence triangles ``i``, ``j`` touch when
  their separation is at most ``tol + sag_i + sag_j``, and an overlap counts as an
  interference only when its mean thickness exceeds ``tol + min(sag_A, sag_B)``
  (:mod:`ndbg_cli.interference`).
* ``angle_tolerance`` (radians, default :data:`DEFAULT_ANGLE_TOLERANCE` = 1 degree): normals
  closer than this are one normal; faces whose normals are opposite within it can be coplanar.
  Curved contacts keep the facet normals themselves (clustered within this angle): for a
  facetted shaft in a hole they are the blocking cone.

Phases (timed in ``stats``, seconds): ``bvh_s`` (python-fcl BVH, R-tree and triangle data
per part, cached by part hash: :func:`ndbg_cli.facets.fcl_model`,
:func:`ndbg_cli.facets.part_geometry`), ``broad_s`` (bounding-box pruning, then
``fcl.collide`` / ``fcl.distance`` per candidate pair), ``narrow_s`` (triangle pairs from the
parts' R-trees, plane and separating-axis tests, features: :mod:`ndbg_cli.contact_features`),
``interference_s`` (manifold3d overlap volumes, or the open-mesh fallback).

Pairs that interfere get no contacts. Parts wholly inside another (surfaces apart, boxes
nested) are found by overlap volume when both are closed.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import fcl
import numpy as np

from .assembly import Assembly, content_hash
from .cache import PairCache
from .contact_features import classify_pairs, curved_contacts, edge_point_contacts, planar_contacts
from .errors import InputError
from .facets import PartGeometry, fcl_model, fcl_object, manifold_model, part_geometry, sat_gap
from .interference import Interference, check_interference_policy, interference, meshes_intersect

__all__ = ["Contact", "Interference", "ContactAnalysis", "analyze_contacts", "contacts_section",
           "contacts_text", "check_interference_policy", "fcl_model", "DEFAULT_ANGLE_TOLERANCE"]

#: Default angular tolerance (radians): 1 degree.
DEFAULT_ANGLE_TOLERANCE = float(np.radians(1.0))

#: Triangle pairs processed per numpy batch (bounds memory to ~100 MB).
_CHUNK = 200_000


@dataclass(frozen=True)
class Contact:
    """One contact between parts ``a < b`` (indices in ``asm.parts``).

    ``kind``: ``"planar" | "curved" | "edge" | "point"``. ``normals`` ``(k, 3)``: distinct unit
    normals pointing out of A into B (clustered within the angular tolerance). For planar and
    curved contacts A translating along ``d`` penetrates B iff ``d . n > 0`` for some ``n``
    (``blocking == "any"``). For edge and point contacts they generate the cone of admissible
    separating normals, and A penetrates B iff ``d . n > 0`` for all of them
    (``blocking == "all"``; treating them as ``"any"`` is conservative).
    ``points`` ``(m, 3)`` (assembly frame and unit): planar = contact polygon's convex-hull
    vertices; curved = facet centroids of both sides of the patch; edge = the two endpoints;
    point = the point. ``point_normals`` ``(m, 3)``: the normal (out of A) at each point.
    ``area``: unit^2 (curved: the smaller side's patch area, an upper bound; edge/point: 0).
    Curved contacts recognised as ``surface`` ``"cylinder"``/``"cone"`` carry a unit ``axis``,
    a ``center`` on it and the ``radius``; ``"sphere"`` carries ``center`` and ``radius``.
    """

    a: int
    b: int
    kind: str
    normals: np.ndarray
    points: np.ndarray
    point_normals: np.ndarray
    area: float
    axis: np.ndarray | None = None
    center: np.ndarray | None = None
    radius: float | None = None
    surface: str | None = None
    blocking: str = "any"


@dataclass(frozen=True)
class ContactAnalysis:
    """The result of :func:`analyze_contacts`. ``contacts`` sorted by ``(a, b, kind, normals,
    points)``; ``interferences`` by ``(a, b)``; ``tolerance`` in the assembly unit;
    ``angle_tolerance`` in radians; ``stats`` counts and phase timings (seconds)."""

    contacts: tuple[Contact, ...]
    interferences: tuple[Interference, ...]
    tolerance: float
    angle_tolerance: float
    stats: dict = field(default_factory=dict)

    def pairs(self) -> list[tuple[int, int]]:
        """Touching part pairs ``(a, b)``, ``a < b``, sorted."""
        return sorted({(c.a, c.b) for c in self.contacts})

    def normals_by_pair(self) -> dict[tuple[int, int], np.ndarray]:
        """All contact normals ``(k, 3)`` of each touching pair (out of ``a`` into ``b``)."""
        out: dict[tuple[int, int], list[np.ndarray]] = {}
        for c in self.contacts:
            out.setdefault((c.a, c.b), []).append(c.normals)
        return {k: np.concatenate(v) for k, v in sorted(out.items())}


def analyze_contacts(asm: Assembly, *, tolerance: float | None = None,
                     angle_tolerance: float = DEFAULT_ANGLE_TOLERANCE,
                     cache: PairCache | None = None) -> ContactAnalysis:
    """Find the contacts and interferences between the parts of a 3D assembly.

    ``tolerance`` (assembly unit) overrides ``asm.length_tolerance``; ``angle_tolerance`` is in
    radians. See the module documentation for the tolerance model. With ``cache``, each
    candidate pair's narrow-phase result is looked up by the two parts' content hashes and the
    tolerances (:mod:`ndbg_cli.cache`). Raises :class:`InputError` for a 2D assembly or a
    non-positive tolerance.
    """
    if asm.dimension != 3:
        raise InputError("contact analysis needs a 3D assembly", file=asm.source or None)
    tol = float(asm.length_tolerance if tolerance is None else tolerance)
    ang = float(angle_tolerance)
    if not tol > 0 or not 0 < ang < np.pi / 2:
        raise InputError(f"tolerances must be positive (got {tol}, {ang} rad)",
                         file=asm.source or None)
    stats: dict = {"parts": len(asm), "triangles": int(sum(p.check.triangles for p in asm))}
    t0 = time.perf_counter()
    geos = [part_geometry(p, tol, ang) for p in asm.parts]
    for p in asm.parts:
        fcl_model(p)
    t1 = time.perf_counter()
    pairs, nested = _broad_phase(asm, geos, tol)
    t2 = time.perf_counter()
    contacts: list[Contact] = []
    interferences: list[Interference] = []
    approx: list[tuple[str, str]] = []
    tri_pairs = 0
    t_int = 0.0
    # content hashes of the validated, placed meshes (what this stage really reads), once each
    gkeys = ([content_hash(np.asarray(p.mesh.vertices), np.asarray(p.mesh.faces))
              for p in asm.parts] if cache is not None else [])
    for a, b, crossing in pairs:
        ga, gb = geos[a], geos[b]
        key = None
        if cache is not None:
            key = cache.key("contacts", gkeys[a], gkeys[b], tol, ang, bool(crossing))
            got = cache.get("contacts", key, _check_entry)
            if got is not None:
                found, approximate, cs, count = got
                if approximate:
                    approx.append((asm.parts[a].id, asm.parts[b].id))
                if found is not None:
                    interferences.append(dataclasses.replace(found, a=a, b=b))
                contacts += [dataclasses.replace(c, a=a, b=b) for c in cs]
                tri_pairs += count
                continue
        found, approximate, before = None, False, len(contacts)
        count = 0
        if crossing:
            ti = time.perf_counter()
            allowance = tol + min(float(ga.sag.max()), float(gb.sag.max()))
            found, approximate = interference(a, b, asm.parts[a], asm.parts[b], ga, gb,
                                              allowance, tol)
            t_int += time.perf_counter() - ti
            if approximate:
                approx.append((asm.parts[a].id, asm.parts[b].id))
            if found is not None:
                interferences.append(found)
        if found is None:
            i, j = _plane_filter(ga, gb, *_triangle_candidates(ga, gb, tol), tol)
            count = len(i)
            tri_pairs += count
            if len(i):
                contacts += _pair_contacts(a, b, ga, gb, i, j, tol, ang)
        if key is not None:
            cache.put("contacts", key, (found, approximate, contacts[before:], count))
    ti = time.perf_counter()
    interferences += _nested(asm, nested, tol)
    t_int += time.perf_counter() - ti
    t3 = time.perf_counter()
    contacts.sort(key=_sort_key)
    stats.update({
        "candidate_pairs": len(pairs), "triangle_pairs": tri_pairs,
        "touching_pairs": len({(c.a, c.b) for c in contacts}), "contacts": len(contacts),
        "by_kind": {k: sum(1 for c in contacts if c.kind == k)
                    for k in ("planar", "curved", "edge", "point")},
        "interferences": len(interferences),
        "interference_approximate_pairs": [list(p) for p in approx],
        "interference_method": ("manifold3d overlap volume; open meshes: fcl crossing-triangle "
                                "depth (approximate)"),
        "bvh_s": t1 - t0, "broad_s": t2 - t1, "narrow_s": t3 - t2 - t_int,
        "interference_s": t_int,
    })
    return ContactAnalysis(tuple(contacts), tuple(sorted(interferences, key=lambda x: (x.a, x.b))),
                           tol, ang, stats)


def _check_entry(value):
    """A cached pair result, validated (any mismatch raises: a cache miss)."""
    found, approximate, cs, count = value
    if found is not None and not isinstance(found, Interference):
        raise TypeError("not an interference")
    if not all(isinstance(c, Contact) for c in cs):
        raise TypeError("not contacts")
    return found, bool(approximate), list(cs), int(count)


def _broad_phase(asm: Assembly, geos: list[PartGeometry], tol: float
                 ) -> tuple[list[tuple[int, int, bool]], list[tuple[int, int]]]:
    """Part pairs ``(a, b, crossing)``, ``a < b``, whose distance is within the gap allowance
    ``tol + max sag_a + max sag_b``: their bounding boxes inflated by ``tol + max sag`` overlap
    (numpy), then python-fcl confirms: ``fcl.collide`` (``crossing``: the surfaces meet, touching
    included) or else ``fcl.distance``. Also returns the pairs farther apart whose boxes nest
    (one part may lie wholly inside the other)."""
    n = len(asm)
    if n < 2:
        return [], []
    reach = np.array([tol + (g.sag.max() if len(g.sag) else 0.0) for g in geos])
    b = np.array([p.bounds for p in asm.parts])
    lo, hi = b[:, 0] - reach[:, None], b[:, 1] + reach[:, None]
    overlap = np.all((lo[:, None] <= hi[None]) & (lo[None] <= hi[:, None]), axis=2)
    inside = np.all((b[:, None, 0] >= b[None, :, 0]) & (b[:, None, 1] <= b[None, :, 1]), axis=2)
    ia, ib = np.nonzero(np.triu(overlap, 1))
    out, nested = [], []
    for a, c in zip(ia.tolist(), ib.tolist()):
        if meshes_intersect(asm.parts[a], asm.parts[c]):
            out.append((a, c, True))
            continue
        d = fcl.distance(fcl_object(asm.parts[a]), fcl_object(asm.parts[c]),
                         fcl.DistanceRequest(), fcl.DistanceResult())
        if d <= reach[a] + reach[c] - tol:
            out.append((a, c, False))
        elif inside[a, c] or inside[c, a]:
            nested.append((a, c))
    return out, nested


def _triangle_candidates(ga: PartGeometry, gb: PartGeometry, tol: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Triangle pairs ``(i, j)`` whose boxes, inflated by the largest possible gap allowance,
    overlap: each part's triangles near the other's box, the fewer of them querying the other
    part's R-tree."""
    reach = tol + float(ga.sag.max()) + float(gb.sag.max())
    sa = _near_box(ga, gb.lo.min(axis=0) - reach, gb.hi.max(axis=0) + reach)
    sb = _near_box(gb, ga.lo.min(axis=0) - reach, ga.hi.max(axis=0) + reach)
    if len(sa) == 0 or len(sb) == 0:
        return sa[:0], sb[:0]
    if len(sa) <= len(sb):
        ids, counts = gb.tree.intersection_v(ga.lo[sa] - reach, ga.hi[sa] + reach)
        i = np.repeat(sa, np.asarray(counts, dtype=np.int64))
        return i.astype(np.int64), np.asarray(ids, dtype=np.int64)
    ids, counts = ga.tree.intersection_v(gb.lo[sb] - reach, gb.hi[sb] + reach)
    j = np.repeat(sb, np.asarray(counts, dtype=np.int64))
    return np.asarray(ids, dtype=np.int64), j.astype(np.int64)


def _near_box(g: PartGeometry, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Indices of the triangles of ``g`` whose boxes meet the box ``[lo, hi]``."""
    return np.nonzero(np.all((g.lo <= hi) & (g.hi >= lo), axis=1))[0]


def _plane_filter(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray,
                  tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Candidate pairs ``(i, j)`` not separated by more than ``g = tol + sag_i + sag_j`` along
    either triangle's normal (the two cheapest separating axes)."""
    keep_i, keep_j = [i[:0]], [j[:0]]
    for s in range(0, len(i), _CHUNK):
        ci, cj = i[s:s + _CHUNK], j[s:s + _CHUNK]
        ta, tb = ga.triangles[ci], gb.triangles[cj]
        g = (tol + ga.sag[ci] + gb.sag[cj])[:, None]
        sb = np.einsum("pvd,pd->pv", tb - ta[:, :1], ga.normals[ci])
        sa = np.einsum("pvd,pd->pv", ta - tb[:, :1], gb.normals[cj])
        ok = (np.any(sb <= g, axis=1) & np.any(sb >= -g, axis=1)
              & np.any(sa <= g, axis=1) & np.any(sa >= -g, axis=1))
        keep_i.append(ci[ok])
        keep_j.append(cj[ok])
    return np.concatenate(keep_i), np.concatenate(keep_j)


def _touching(ga: PartGeometry, gb: PartGeometry, i: np.ndarray, j: np.ndarray, tol: float
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``(i, j)`` whose separation along all 11 separating axes is at most
    ``g = tol + sag_i + sag_j``. Returns ``i, j, g`` of those touching pairs."""
    keep = [sat_gap(ga.triangles[i[s:s + _CHUNK]], gb.triangles[j[s:s + _CHUNK]])
            for s in range(0, len(i), _CHUNK)]
    g = tol + ga.sag[i] + gb.sag[j]
    ok = np.concatenate(keep) <= g if keep else np.zeros(0, dtype=bool)
    return i[ok], j[ok], g[ok]


def _nested(asm: Assembly, nested: list[tuple[int, int]], tol: float) -> list[Interference]:
    """Interferences of part pairs whose surfaces are apart but where one part's box lies
    inside the other's: one part may sit wholly inside the other (closed parts only: the
    overlap volume decides, as in :func:`ndbg_cli.interference.interference`)."""
    out = []
    for a, b in nested:
        ma, mb = manifold_model(asm.parts[a]), manifold_model(asm.parts[b])
        if ma is None or mb is None:
            continue
        overlap = ma ^ mb
        vol, area = float(overlap.volume()), float(overlap.surface_area())
        depth = 2.0 * vol / area if area > 0 else 0.0
        if depth > tol:
            out.append(Interference(a, b, vol, depth, "volume"))
    return out


def _pair_contacts(a: int, b: int, ga: PartGeometry, gb: PartGeometry, i: np.ndarray,
                   j: np.ndarray, tol: float, ang: float) -> list[Contact]:
    """The contact features between parts ``a`` and ``b`` from their candidate triangle pairs
    (those passing :func:`_plane_filter`). Facing pairs go to the planar and curved features
    as they are (their polygons are intersected exactly; for them the plane test is the
    separation test); the others must also pass the full separating-axis test."""
    planar, curved = classify_pairs(ga, gb, i, j, tol, ang)
    feats, used = planar_contacts(ga, gb, i[planar], j[planar], tol, ang)
    planar_used = np.zeros(len(i), dtype=bool)
    planar_used[np.nonzero(planar)[0][used]] = True
    feats += curved_contacts(ga, gb, i[curved], j[curved], ang, tol)
    # pairs with a triangle of a planar or curved contact are that contact's rim (an edge of
    # B lying on A's contact face adds no normal the face does not already give)
    in_patch = planar_used | curved
    patch_a = np.zeros(len(ga.normals), dtype=bool)
    patch_b = np.zeros(len(gb.normals), dtype=bool)
    patch_a[i[in_patch]] = True
    patch_b[j[in_patch]] = True
    rest = ~in_patch & ~patch_a[i] & ~patch_b[j]
    ri, rj, gap = _touching(ga, gb, i[rest], j[rest], tol)
    feats += edge_point_contacts(ga, gb, ri, rj, gap, ang, list(feats))
    return [Contact(a=a, b=b, **{k: v for k, v in f.items() if not k.startswith("_")})
            for f in feats]


def _sort_key(c: Contact) -> tuple:
    return (c.a, c.b, c.kind, tuple(np.round(c.normals, 9).ravel()),
            tuple(np.round(c.points, 9).ravel()))


# -- report ---------------------------------------------------------------------------------

def _r(x: float) -> float:
    """A float rounded to 10 significant digits (stable JSON across platforms)."""
    return float(f"{float(x):.10g}")


def _vecs(a: np.ndarray | None) -> list | None:
    if a is None:
        return None
    a = np.asarray(a, dtype=float)
    return [_r(x) for x in a] if a.ndim == 1 else [[_r(x) for x in row] for row in a]


def contacts_section(asm: Assembly, result: ContactAnalysis) -> dict:
    """JSON-ready report sections ``{"contacts": [...], "interferences": [...],
    "contact_stats": {...}}`` (schema: ``schemas/fragments/contacts.json``). Parts are named by
    id; vectors are in the assembly frame and unit; order is deterministic."""
    ids = asm.ids
    contacts = [{
        "a": ids[c.a], "b": ids[c.b], "kind": c.kind, "blocking": c.blocking,
        "normals": _vecs(c.normals), "points": _vecs(c.points),
        "point_normals": _vecs(c.point_normals), "area": _r(c.area),
        "surface": c.surface, "axis": _vecs(c.axis), "center": _vecs(c.center),
        "radius": None if c.radius is None else _r(c.radius),
    } for c in result.contacts]
    interferences = [{"a": ids[x.a], "b": ids[x.b], "volume": _r(x.volume),
                      "depth": _r(x.depth), "method": x.method} for x in result.interferences]
    s = result.stats
    stats = {
        "units": asm.units, "tolerance": _r(result.tolerance),
        "angle_tolerance_deg": _r(np.degrees(result.angle_tolerance)),
        "touching_pairs": [[ids[a], ids[b]] for a, b in result.pairs()],
        "contacts": len(result.contacts), "by_kind": dict(s.get("by_kind", {})),
        "interferences": len(result.interferences),
        "candidate_pairs": int(s.get("candidate_pairs", 0)),
        "triangle_pairs": int(s.get("triangle_pairs", 0)),
        "interference_method": s.get("interference_method", ""),
        "interference_approximate_pairs": s.get("interference_approximate_pairs", []),
        "timings_s": {k: _r(s.get(k, 0.0))
                      for k in ("bvh_s", "broad_s", "narrow_s", "interference_s")},
    }
    return {"contacts": contacts, "interferences": interferences, "contact_stats": stats}


def contacts_text(asm: Assembly, result: ContactAnalysis) -> list[str]:
    """Readable contact table lines: one line per contact (pair, kind, area, normals), then
    the interferences and a summary line."""
    ids, unit = asm.ids, asm.units
    lines = [f"{'part A':<16} {'part B':<16} {'kind':<7} {'area':>12}  normals (out of A)"]
    for c in result.contacts:
        ns = " ".join("(" + ", ".join(f"{x:+.3f}" for x in n) + ")" for n in c.normals[:4])
        if len(c.normals) > 4:
            ns += f" ... {len(c.normals)} normals"
        extra = ""
        if c.surface in ("cylinder", "cone") and c.radius is not None:
            extra = f"  {c.surface} r={c.radius:.4g} axis=(" + ", ".join(
                f"{x:+.3f}" for x in c.axis) + ")"
        area = f"{c.area:.4g} {unit}^2" if c.area else "-"
        lines.append(f"{ids[c.a]:<16} {ids[c.b]:<16} {c.kind:<7} {area:>12}  {ns}{extra}")
    for x in result.interferences:
        lines.append(f"INTERFERENCE {ids[x.a]} / {ids[x.b]}: volume {x.volume:.4g} {unit}^3, "
                     f"depth {x.depth:.4g} {unit} ({x.method})")
    lines.append(f"{len(result.pairs())} touching pairs, {len(result.contacts)} contacts, "
                 f"{len(result.interferences)} interferences (tolerance {result.tolerance:.3g} "
                 f"{unit}, {np.degrees(result.angle_tolerance):.3g} deg)")
    return lines
