"""Interference (interpenetration) between two parts, and the interference policy.

Tessellated curved faces that nominally touch cross each other slightly (a 24-gon shaft's
edges poke into the chords of a 64-gon hole by up to the hole's chord sag), so "the meshes
intersect" is not an interference: a pair interferes when its overlap is *thicker* than
``tolerance + sag`` (``sag``: the smaller of the two parts' largest chord sags). Closed parts:
the exact overlap solid's mean thickness ``2 V / S`` (manifold3d). Open meshes: an
approximation from fcl's crossing triangle pairs (:func:`crossing_depth`; ``volume`` 0,
``method`` ``"fcl-depth"``).
"""

from __future__ import annotations

from dataclasses import dataclass

import fcl
import numpy as np

from ..core.assembly import Assembly, Diagnostic, Part, point_extent
from ..core.errors import InterferenceError
from .facets import PartGeometry, closed, fcl_model, fcl_object, manifold_model
from .fits import Fit, classify_overlap, fcl_separates, manifold_separates
from .overlap_bounds import thin_shell, thin_slab

#: Contacts fcl is asked for when approximating the interference of open meshes.
FCL_MAX_CONTACTS = 2000

POLICIES = ("error", "warn", "ignore")

#: Triangles of a pair (both parts) below which its overlap boolean costs milliseconds even
#: where coincident faces cut it into slivers (gearbox-48's pairs of 2-4 thousand: 1-4 ms);
#: above, tenths of a second to seconds (gearbox-1024's of 30-40 thousand: 0.03-0.5 s).
CHEAP_BOOLEAN_TRIANGLES = 20_000
#: Shell-bound axes tried before a cheap boolean (:func:`interference`).
FIRST_SHELL_AXES = 2


@dataclass(frozen=True)
class Interference:
    """Two parts whose interiors overlap beyond the tolerance (``a < b``, indices in
    ``asm.parts``). ``volume`` in unit^3 (0 when approximate), ``depth`` in unit (mean
    thickness of the overlap, or the approximate penetration for open meshes); ``method`` is
    ``"volume"`` (exact, manifold3d) or ``"fcl-depth"`` (approximate, open meshes); ``fit``
    what it is (:mod:`ndbg_cli.contacts.fits`: press fit, overlap or clash)."""

    a: int
    b: int
    volume: float
    depth: float
    method: str = "volume"
    fit: Fit | None = None

    @property
    def kind(self) -> str:
        return "clash" if self.fit is None else self.fit.kind


def meshes_intersect(pa: Part, pb: Part) -> bool:
    """Whether python-fcl finds any common point of the two meshes (touching counts)."""
    req = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
    return fcl.collide(fcl_object(pa), fcl_object(pb), req, fcl.CollisionResult()) > 0


def interference(ia: int, ib: int, pa: Part, pb: Part, ga: PartGeometry, gb: PartGeometry,
                 allowance: float, tol: float) -> tuple[Interference | None, bool]:
    """Test one pair whose surfaces meet. Returns ``(interference or None, approximate)`` where
    ``approximate`` tells that the open-mesh fallback was used. ``allowance`` (unit) is the
    depth up to which an overlap is read as touching: ``tol + min(sag_A, sag_B)`` with each
    part's largest chord sag.

    Closed parts whose overlap :mod:`ndbg_cli.contacts.overlap_bounds` proves no thicker
    than the allowance (stacked faces, a peg in its hole) are not interferences, and skip
    the manifold3d solids and their boolean. The bounds hold for any watertight,
    consistently wound mesh, including the few manifold3d rejects (four faces at an edge),
    which would otherwise take the open-mesh fallback.

    On a pair of fewer than :data:`CHEAP_BOOLEAN_TRIANGLES` triangles the shell bound
    tries the first :data:`FIRST_SHELL_AXES` axes before the boolean (each part's largest
    curved patch: a bound that holds holds about the peg's own shank or its bore, as on every
    pair of the shipped real products) and the others only for those rejects: a bound that
    fails costs the most when it tries every axis (two to five on them), more than such a
    boolean. A larger pair tries every axis first, since its boolean may cost seconds.
    Either order gives the same answer: the bounds are upper bounds on the boolean's
    ``2 V / S``."""
    solids = closed(pa) and closed(pb)
    light = len(ga.triangles) + len(gb.triangles) < CHEAP_BOOLEAN_TRIANGLES
    first = FIRST_SHELL_AXES if light else None
    if solids and (thin_slab(ga, gb, allowance) or thin_shell(ga, gb, allowance, stop=first)):
        return None, False
    ma, mb = manifold_model(pa), manifold_model(pb)
    if (ma is None or mb is None) and solids and light and thin_shell(ga, gb, allowance,
                                                                      start=first):
        return None, False
    if ma is not None and mb is not None:
        overlap = ma ^ mb
        vol = float(overlap.volume())
        area = float(overlap.surface_area())
        depth = 2.0 * vol / area if area > 0 else 0.0
        if depth > allowance:
            m = overlap.to_mesh()
            tri = np.asarray(m.vert_properties, dtype=float)[:, :3][np.asarray(m.tri_verts)]
            fit = _classify(tri, depth, pa, pb, manifold_separates(ma, mb, vol, tol), tol, vol)
            return Interference(ia, ib, vol, depth, "volume", fit), False
        return None, False
    req = fcl.CollisionRequest(num_max_contacts=FCL_MAX_CONTACTS, enable_contact=True)
    res = fcl.CollisionResult()
    fcl.collide(fcl_object(pa), fcl_object(pb), req, res)
    if not res.contacts:
        return None, True
    # the triangle ids of each contact, gathered column by column (faster than pairs)
    ids = np.array([[c.b1 for c in res.contacts], [c.b2 for c in res.contacts]],
                   dtype=np.int64).T
    ids = np.unique(ids, axis=0)
    depth = float(crossing_depth(ga.triangles[ids[:, 0]], ga.normals[ids[:, 0]],
                                 gb.triangles[ids[:, 1]], gb.normals[ids[:, 1]], tol).max())
    if depth > allowance:
        tri = np.concatenate([ga.triangles[np.unique(ids[:, 0])],
                              gb.triangles[np.unique(ids[:, 1])]])
        fit = _classify(tri, depth, pa, pb,
                        fcl_separates(fcl_model(pa), fcl_object(pb), tol), tol)
        return Interference(ia, ib, 0.0, depth, "fcl-depth", fit), True
    return None, True


def _classify(tri: np.ndarray, depth: float, pa: Part, pb: Part, separates, tol: float,
              volume: float = 0.0) -> Fit:
    """:func:`ndbg_cli.contacts.fits.classify_overlap` of the overlap surface ``tri``."""
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(cross, axis=1)
    keep = area > 0
    normals = cross[keep] / area[keep, None]
    # the smaller part's size, the same in any frame (a box diagonal is not)
    size = min(_part_size(p) for p in (pa, pb))
    return classify_overlap(tri[keep], normals, 0.5 * area[keep], depth, size, separates, tol,
                            volume)


def _part_size(p: Part) -> float:
    """:func:`ndbg_cli.core.assembly.point_extent` of a part's vertices (its box diagonal
    when it has none), once per :attr:`Part.hash` (a part in many crossing pairs: a
    crankcase, a housing)."""
    if p.mesh is None or len(p.mesh.vertices) == 0:
        return float(np.linalg.norm(np.ptp(p.bounds, axis=0)))
    size = _SIZES.get(p.hash)
    if size is None:
        size = _SIZES[p.hash] = point_extent(np.asarray(p.mesh.vertices, dtype=float))[0]
    return size


#: :func:`_part_size` by part hash.
_SIZES: dict[str, float] = {}


def crossing_depth(ta: np.ndarray, na: np.ndarray, tb: np.ndarray, nb: np.ndarray,
                   tol: float) -> np.ndarray:
    """Approximate penetration ``(p,)`` of triangle pairs ``(p, 3, 3)`` reported by fcl, with
    unit normals ``(p, 3)``: for a proper crossing (each triangle has vertices more than
    ``tol`` on both sides of the other's plane) the smaller of how far A's vertices reach
    behind B's plane and B's behind A's; 0 for pairs that only touch (coplanar faces, faces
    meeting along an edge)."""
    sa = np.einsum("pvd,pd->pv", ta - tb[:, :1], nb)  # A's vertices w.r.t. B's plane
    sb = np.einsum("pvd,pd->pv", tb - ta[:, :1], na)
    crossing = ((sa.min(axis=1) < -tol) & (sa.max(axis=1) > tol)
                & (sb.min(axis=1) < -tol) & (sb.max(axis=1) > tol))
    depth = np.minimum(-sa.min(axis=1), -sb.min(axis=1))
    return np.where(crossing, depth, 0.0)


def check_interference_policy(asm: Assembly, result, policy: str = "error") -> list[Diagnostic]:
    """Apply the ``interference`` policy to a :class:`ndbg_cli.contacts.contacts3d.ContactAnalysis`.

    Press fits and overlaps (:mod:`ndbg_cli.contacts.fits`) are contacts for planning, under
    every policy (the report lists them). Clashes: ``"error"`` raises
    :class:`InterferenceError` (exit code 2) naming every clashing pair; ``"warn"`` returns one
    warning :class:`Diagnostic` (code ``"interference"``) per pair, whose parts the pipeline
    keeps together as one unit; ``"ignore"`` keeps them together silently. Raises
    ``ValueError`` for an unknown policy.
    """
    if policy not in POLICIES:
        raise ValueError(f"unknown interference policy {policy!r} (use {', '.join(POLICIES)})")
    clashes = [it for it in result.interferences if it.kind == "clash"]
    if policy == "ignore" or not clashes:
        return []
    unit = asm.units
    lines = []
    for it in clashes:
        a, b = asm.parts[it.a].id, asm.parts[it.b].id
        how = (f"overlap volume {it.volume:.4g} {unit}^3, depth {it.depth:.4g} {unit}"
               if it.method == "volume" else
               f"approximate penetration {it.depth:.4g} {unit} (open meshes)")
        lines.append((a, b, how))
    if policy == "error":
        text = "; ".join(f"'{a}' and '{b}' interpenetrate ({how})" for a, b, how in lines)
        raise InterferenceError(f"interference: {text}", file=asm.source or None)
    return [Diagnostic("warning", "interference",
                       f"parts '{a}' and '{b}' interpenetrate ({how}), neither a press fit "
                       f"nor a shallow overlap: kept together as one unit", part=a,
                       file=asm.source or None) for a, b, how in lines]
