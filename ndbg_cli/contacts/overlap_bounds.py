"""Upper bounds on the mean thickness of two parts' overlap, from their triangles alone.

An interference is an overlap thicker than the allowance (its mean thickness ``2 V / S``,
:mod:`ndbg_cli.contacts.interference`), and the exact overlap is a manifold3d boolean. On
finely tessellated CAD that boolean costs seconds per pair exactly where the answer is "no":
coincident faces (a cover stacked on a housing) and coincident cylinders (a bolt in its hole,
its head on the plate) cut each other into tens of thousands of slivers. The bounds here prove
such pairs thinner than the allowance in milliseconds; a pair they cannot bound goes to the
boolean, so they change no answer.

Both rest on one argument (the divergence theorem): a field ``F`` with ``div F >= 1`` on the
overlap ``O`` and ``|F| <= m`` there gives ``V <= integral of F . n over the boundary
<= m S``, so ``2 V / S <= 2 m``.

* :func:`thin_slab`: ``O`` in a slab ``{a <= u . x <= a + w}``, ``F = (u . x - a - w / 2) u``:
  ``2 V / S <= w``;
* :func:`thin_shell`: a peg in its hole, possibly with a head or a shoulder resting on the
  hole's face (a bolt, a gear on its shaft, a bearing on its seat): ``O`` lies in a tube
  ``R_h <= r <= R_s`` about the axis and two slabs across it (:func:`shell_bound`).
"""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import numpy as np

from ..geometry.vectors import plane_basis
from .facets import PartGeometry, graph_components, max3, min3, origin_distance_2d
from .fits import fit_circle

__all__ = ["thin_slab", "thin_shell", "shell_bound", "SLAB_FACETS", "SHELL_AXES"]

#: Largest planar facets per part whose normals :func:`thin_slab` tries.
SLAB_FACETS = 8

#: Largest curved patches per part (near the other part) whose axes :func:`thin_shell` tries.
SHELL_AXES = 4

#: Where :func:`shell_bound` may put the cuts between its slabs and its tube: at the slabs'
#: outer faces moved in by these shares of the width to reach (an exported model's coincident
#: planes differ by its vertex grid, so the head's side may start a little below the plate).
_CUTS = (0.0, 0.0625, 0.125, 0.25, 0.5)


def thin_slab(ga: PartGeometry, gb: PartGeometry, width: float) -> bool:
    """Whether the two parts lie on either side of a slab at most ``width`` thick: along some
    direction ``u``, ``max_A u.x - min_B u.x <= width`` (or with A and B swapped).

    Their overlap then lies inside the slab, so its mean thickness ``2 V / S`` is at most
    ``width``: ``V <= width P`` and ``S >= 2 P`` for its projection ``P`` on the slab's plane
    (a line across the slab that meets the overlap's interior crosses its boundary twice). With
    ``width`` the interference allowance, the pair does not interfere, and the overlap boolean
    (whose cost on large coplanar faces, such as a cover stacked on a housing, is seconds per
    pair) is not needed. Directions tried: the axes and the normals of each part's
    :data:`SLAB_FACETS` largest planar facets (a stacked pair shares one)."""
    dirs = [np.eye(3)]
    for g in (ga, gb):
        if len(g.facet_normal):
            area = np.bincount(g.facet, weights=g.areas, minlength=len(g.facet_normal))
            top = np.argsort(-area, kind="stable")[:SLAB_FACETS]
            dirs.append(g.facet_normal[top])
    u = np.concatenate(dirs)
    pa, pb = ga.vertices @ u.T, gb.vertices @ u.T
    gap = np.minimum(pa.max(axis=0) - pb.min(axis=0), pb.max(axis=0) - pa.min(axis=0))
    return bool(gap.min() <= width)


def thin_shell(ga: PartGeometry, gb: PartGeometry, width: float, start: int = 0,
               stop: int | None = None) -> bool:
    """Whether :func:`shell_bound` proves the overlap of the two parts at most ``width``
    thick, with either part as the peg, about the axis of one of the :data:`SHELL_AXES`
    largest curved patches of either part near the other (:func:`patch_axes`), its head
    toward either end of the axis: the largest patch of each part first (a peg's shank or
    a bore), then the others (:func:`_largest_first`); only those from ``start`` to
    ``stop`` in that order (counting the axes skipped as not finite) when given.

    Examples
    --------
    A pin of radius 1 whose head (radius 2) rests on a plate, through a hole of radius 1 in
    the plate (both 64-gons, their sides coincide), with the allowance of
    :func:`~ndbg_cli.contacts.interference.interference`: a tolerance of 1e-3 plus the chord
    sag, ``1 - cos(pi / 64) = 1.2e-3``, since the bound reads each polygon as the band
    between its sides and its corners. A pin of radius 1.2 in the same hole overlaps the
    plate by 0.2 all round, which no bound hides.

    >>> import manifold3d as m3, numpy as np, trimesh
    >>> from ndbg_cli.contacts.facets import part_geometry
    >>> from ndbg_cli.io.validate import make_part
    >>> def geometry(solid, name):
    ...     mesh = solid.to_mesh()
    ...     part = make_part(name, np.asarray(mesh.vert_properties, float)[:, :3],
    ...                      np.asarray(mesh.tri_verts))[0]
    ...     return part_geometry(part, 1e-3, np.radians(1.0))
    >>> def cylinder(r, z0, z1):
    ...     return m3.Manifold.cylinder(z1 - z0, r, -1.0, 64).translate((0, 0, z0))
    >>> plate = m3.Manifold.cube((8, 8, 2)).translate((-4, -4, -2)) - cylinder(1, -3, 1)
    >>> pin = cylinder(1, -4, 0.5) + cylinder(2, 0, 1)
    >>> allowance = 1e-3 + (1 - np.cos(np.pi / 64))
    >>> thin_shell(geometry(pin, "pin"), geometry(plate, "plate"), allowance)
    True
    >>> fat = cylinder(1.2, -4, 0.5) + cylinder(2, 0, 1)
    >>> thin_shell(geometry(fat, "fat"), geometry(plate, "plate"), allowance)
    False
    """
    # the smaller part is the likelier peg: tried first
    a_first = _box_volume(ga) <= _box_volume(gb)
    for center, u in itertools.islice(_largest_first(ga, gb), start, stop):
        if not _finite_axis(center, u):
            continue
        for s in (1.0, -1.0):
            # each part seen once about this axis, as peg and as hole
            va, vb = _View(ga, center, s * u), _View(gb, center, s * u)
            roles = [(va, vb), (vb, va)] if a_first else [(vb, va), (va, vb)]
            if any(_bound(peg, hole, width) <= width for peg, hole in roles):
                return True
    return False


def _largest_first(ga: PartGeometry, gb: PartGeometry) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """:func:`patch_axes` of ``ga`` near ``gb`` and of ``gb`` near ``ga``: the first of each
    (two of one part when the other has none), then the others (``gb``'s computed only when
    asked for)."""
    a = patch_axes(ga, gb)
    yield from a[:1]
    b = patch_axes(gb, ga)
    yield from b[:1]
    yield from a[1:]
    yield from b[1:]


def _finite_axis(center: np.ndarray, u: np.ndarray) -> bool:
    """Whether the line through ``center`` along ``u`` is one (finite, ``u`` not zero)."""
    return bool(np.isfinite(center).all() and np.isfinite(u).all() and np.any(u))


def shell_bound(peg: PartGeometry, hole: PartGeometry, center: np.ndarray, u: np.ndarray,
                width: float) -> float:
    """An upper bound on the mean thickness ``2 V / S`` of the overlap of closed parts
    ``peg`` and ``hole`` (``inf`` when it finds none), in cylindrical coordinates ``(r, z)``
    about the line through ``center`` along the unit ``u`` (``z`` grows toward the peg's
    head).

    What the triangles prove (each triangle lies in a convex set, so it is tested exactly
    by its vertices, or by its distance to the axis):

    * the peg's triangles that reach below a height ``z0`` lie within ``r <= R_s``, so the
      peg lies in ``{r <= R_s} | {z >= z0}`` (a point outside both leaves along its outward
      radial ray without meeting the peg's surface), and above its lowest point ``z_lo``;
    * the hole's triangles that meet the column over the peg (its box across the axis, from
      ``z_lo`` up) all lie below ``z_top``, and those that reach above a height ``z1`` lie
      at ``r >= R_h``; so no point of the peg with ``z > z_top``, or with ``r < R_h`` and
      ``z > z1``, is in the hole's part (its ray along ``+u`` stays in the column and meets
      no triangle of it).

    So the overlap ``O`` lies in a slab ``z0 <= z <= z_top`` (the head on the plate), of
    width ``w_t``, a slab ``z_lo <= z <= z1`` (the peg's end on the bottom of a blind hole),
    of width ``w_b``, and between them a tube ``R_h <= r <= R_s``. With ``k = (w_b - w_t) / 2``
    the field ``F = (z - z0 + k) e_z`` in the top slab, ``(z - z1 + k) e_z`` in the bottom one
    and ``(r^2 - R_h R_s) / (2 r) e_r + k e_z`` in the tube has ``div F = 1`` everywhere and
    the same ``F . e_z = k`` on both sides of the cuts, and ``|F|`` is at most
    ``(w_t + w_b) / 2`` in the slabs and ``(R_s - R_h) / 2 + |k|`` in the tube, so (module
    docstring) ``2 V / S <= max(w_t + w_b, R_s - R_h + |w_b - w_t|)``; without a tube (the
    cuts cross, or ``R_s <= R_h``) it is ``w_t + w_b``. The cuts ``z0``, ``z1`` are tried at
    the slabs' outer faces and moved in by :data:`_CUTS` shares of ``width``; the least bound
    is returned, plus ``1e-9`` of the parts' extent for rounding (``inf`` for an axis that is
    not finite).
    """
    if not _finite_axis(center, u):
        return np.inf
    return _bound(_View(peg, center, u), _View(hole, center, u), width)


class _View:
    """A part about an axis (the line through ``center`` along ``u``): its vertices in the
    frame ``(e1, e2, u)`` centred there, and each triangle's least and greatest coordinates
    and its greatest distance to the axis, computed from its vertices (a corner's value is
    the vertex's, so these are what the triangles' corners give, bit for bit). One view
    serves the part both as peg and as hole."""

    def __init__(self, g: PartGeometry, center: np.ndarray, u: np.ndarray) -> None:
        u = np.asarray(u, dtype=float) / np.linalg.norm(u)
        e1, e2 = plane_basis(u)
        self.faces = g.faces
        self.v = (g.vertices - center) @ np.stack([e1, e2, u]).T
        corners = self.v[g.faces].swapaxes(1, 2)  # (f, coordinate, corner)
        self.lo, self.hi = min3(corners), max3(corners)
        self.rmax = max3(np.sqrt(self.v[:, 0] ** 2 + self.v[:, 1] ** 2)[g.faces])


def _bound(peg: _View, hole: _View, width: float) -> float:
    """:func:`shell_bound` of two parts seen about one axis."""
    pv = peg.v
    z_lo = float(pv[:, 2].min())
    a_zmin, a_rmax = peg.lo[:, 2], peg.rmax
    lo, hi = hole.lo, hole.hi
    plo, phi = pv[:, :2].min(axis=0), pv[:, :2].max(axis=0)
    near = np.all((lo[:, :2] <= phi) & (hi[:, :2] >= plo), axis=1) & (hi[:, 2] >= z_lo)
    if not near.any():
        return 0.0
    ht = hole.v[hole.faces[near]]
    b_zmax = hi[near, 2]
    b_rmin = origin_distance_2d(ht[:, :, :2])
    z_top = float(b_zmax.max())
    slack = 1e-9 * float(np.abs(pv).max() + np.abs(ht).max())
    # R_s(z0): the peg's largest radius among triangles reaching below z0 (running maximum
    # in the order of their lowest points); R_h(z1): the hole's least radius among those
    # reaching above z1 (running minimum from the highest down)
    order = np.argsort(a_zmin, kind="stable")
    a_z, r_s_run = a_zmin[order], np.maximum.accumulate(a_rmax[order])
    order = np.argsort(b_zmax, kind="stable")
    b_z, r_h_run = b_zmax[order], np.minimum.accumulate(b_rmin[order][::-1])[::-1]
    best = np.inf
    for d0 in _CUTS:
        z0 = z_top - d0 * width
        k = int(np.searchsorted(a_z, z0, side="left"))
        r_s = float(r_s_run[k - 1]) if k else 0.0
        for d1 in _CUTS:
            z1 = z_lo + d1 * width
            k = int(np.searchsorted(b_z, z1, side="right"))
            r_h = float(r_h_run[k]) if k < len(b_z) else np.inf
            w_t, w_b = max(z_top - z0, 0.0), max(z1 - z_lo, 0.0)
            if z1 >= z0 or r_s <= r_h:
                got = w_t + w_b  # no tube, or an empty one
            else:
                got = max(w_t + w_b, r_s - r_h + abs(w_b - w_t))
            best = min(best, got)
    return best + slack


def patch_axes(g: PartGeometry, other: PartGeometry) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(center, axis)`` of the :data:`SHELL_AXES` largest curved patches of ``g`` (smooth
    triangles, :attr:`PartGeometry.smooth_angle`, connected across their edges) whose
    triangles meet ``other``'s box, largest first. The axis is the direction along which the
    patch's normals vary least (a cylinder's or a cone's); the centre, the least-squares
    circle of its vertices across it. Patches whose normals vary about as much along every
    direction (spheres, freeform) are skipped. The axes only steer :func:`shell_bound`,
    which is a bound for any axis."""
    box_lo, box_hi = other.vertices.min(axis=0), other.vertices.max(axis=0)
    curved = (g.smooth_angle > 0) & np.all((g.lo <= box_hi) & (g.hi >= box_lo), axis=1)
    if not curved.any():
        return []
    edges = g.adjacency[curved[g.adjacency].all(axis=1)]
    label = graph_components(len(curved), edges)
    area = np.bincount(label[curved], weights=g.areas[curved], minlength=len(curved))
    out = []
    for patch in np.argsort(-area, kind="stable")[:SHELL_AXES]:
        if area[patch] <= 0:
            break
        members = np.flatnonzero(curved & (label == patch))
        n, w = g.normals[members], g.areas[members] / area[patch]
        dev = n - w @ n
        lam, vec = np.linalg.eigh((dev * w[:, None]).T @ dev)
        if len(members) < 3 or lam[0] > 0.1 * lam[1]:
            continue
        center, _ = fit_circle(g.vertices[np.unique(g.faces[members])], vec[:, 0])
        out.append((center, vec[:, 0]))
    return out


def _box_volume(g: PartGeometry) -> float:
    return float(np.prod(g.vertices.max(axis=0) - g.vertices.min(axis=0)))
