"""What an interference of real CAD is, and what it means for planning.

Real models carry interferences that are not modelling errors:

* ``press_fit``: coaxial cylindrical surfaces overlapping radially by a little (a bearing in
  its housing, a pin in its hole, a roller on its cam). The overlap is a thin tube whose
  surface normals are all perpendicular to one axis. For planning it is a cylindrical contact:
  the pair slides along the axis and nowhere else (the step that separates it says
  ``press``).
* ``overlap``: a thin slab where two parts cross by a fraction of their size (sheet-metal
  sides overlapping at a corner). Its surface normals lie along one line, and moving one part
  by the slab's thickness along that line separates the two. For planning it is a face
  contact with that normal: the part leaves along the separating direction.
* ``clash``: anything else. The ``--interference`` policy decides: ``error`` stops; otherwise
  the two parts are kept together as one unit (:func:`ndbg_cli.pipeline.units`), reported.

The classification reads the overlap's surface (closed parts: the exact overlap solid of
manifold3d; open meshes: the crossing triangles python-fcl reports) as the area-weighted
scatter of its unit normals ``M = sum a n n^T`` with eigenvalues ``l1 <= l2 <= l3``: a tube
has ``l1`` (along its axis) near 0 and ``l2``, ``l3`` of one size; a slab has ``l3`` near
``sum a``. The overlap's separation is then checked by moving the part (manifold3d volumes,
or python-fcl for open meshes), so a label is never given on the normals alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import fcl
import numpy as np

from ..geometry.vectors import line_direction, plane_basis, unit

__all__ = ["Fit", "classify_overlap", "PRESS_AXIAL", "PRESS_SPREAD", "PRESS_DEPTH",
           "SLAB_SHARE", "SLAB_DEPTH"]

#: A press fit: the share of the overlap's normal weight along its axis, at most.
PRESS_AXIAL = 0.05
#: ... and ``l2 / l3`` at least (normals spread round the axis over some 60 degrees or more).
PRESS_SPREAD = 0.2
#: ... and the radial interference (mean thickness) at most this share of the radius.
PRESS_DEPTH = 0.05
#: An overlap: the share of the normal weight along one line, at least.
SLAB_SHARE = 0.9
#: ... and its thickness along that line at most this share of the smaller part's diagonal.
SLAB_DEPTH = 0.05


@dataclass(frozen=True)
class Fit:
    """The kind of one interference (see the module docstring). ``axis``: the press fit's
    unit axis (sign: first nonzero component positive), ``center`` a point on it, ``radius``;
    ``direction``: the overlap's separating direction, along which part ``a`` leaves ``b``
    (unit), and ``center`` the overlap's middle; ``depth``: the radial interference or the
    slab's thickness (unit)."""

    kind: str
    depth: float
    axis: tuple[float, ...] | None = None
    center: tuple[float, ...] | None = None
    radius: float | None = None
    direction: tuple[float, ...] | None = None


def _scatter(normals: np.ndarray, areas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    m = (normals * areas[:, None]).T @ normals
    w, v = np.linalg.eigh(m)
    return w / max(float(areas.sum()), 1e-300), v


def fit_circle(points: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle (Kasa) of ``points`` projected on the plane normal to ``axis``:
    its centre (3D, on the plane through the points' mean) and radius."""
    u, v = plane_basis(axis)
    x, y = points @ u, points @ v
    a = np.column_stack([x, y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(a, x * x + y * y, rcond=None)
    cx, cy = sol[0] / 2, sol[1] / 2
    r = float(np.sqrt(max(sol[2] + cx * cx + cy * cy, 0.0)))
    mean = points.mean(axis=0)
    center = cx * u + cy * v + float(mean @ axis) * axis
    return center, r


def _line(v: np.ndarray) -> tuple[float, ...]:
    """The line along ``v`` (:func:`line_direction`), components below 1e-12 set to 0 first."""
    u = unit(v)
    return tuple(float(x) for x in line_direction(np.where(np.abs(u) < 1e-12, 0.0, u)))


def _sheets_removed(triangles: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                    tol: float) -> np.ndarray:
    """Weights ``(k,)`` of the overlap's triangles with zero-thickness sheets taken out: two
    faces that only touch (a bearing seated on a shoulder) leave, in the overlap solid, a
    sheet whose two sides lie in one plane with opposite normals. Per plane (:func:`_planes`)
    the signed areas are summed: a sheet cancels, a real face (a press fit's end ring, in the
    same plane as the sheet it borders) remains. Each triangle weighs its area times its
    plane's ``|sum| / total``."""
    inv, ref = _planes(triangles, normals, tol)
    sign = np.where(np.einsum("ij,ij->i", normals, normals[ref[inv]]) < 0, -1.0, 1.0)
    net = np.zeros(len(ref))
    tot = np.zeros(len(ref))
    np.add.at(net, inv, sign * areas)
    np.add.at(tot, inv, areas)
    share = np.abs(net) / np.maximum(tot, 1e-300)
    share[share < 1e-6] = 0.0
    return areas * share[inv]


#: Two triangles' planes are one when their normals' lines are this close (radians, about)
#: and their offsets within the length tolerance.
PLANE_ANGLE = 1e-5


def _planes(triangles: np.ndarray, normals: np.ndarray, tol: float
            ) -> tuple[np.ndarray, np.ndarray]:
    """``(plane of each triangle, a triangle of each plane)``: triangles whose planes agree
    up to :data:`PLANE_ANGLE` and ``tol`` (connected: a chain of near pairs is one plane).

    Keyed by ``n n^T`` and the plane's point nearest the origin ``(n . c) n``, which are the
    same for ``n`` and ``-n`` and turn with the part: rounding normals and offsets to a grid
    of the coordinates (as before issue 34) put a sheet's two sides in different cells in
    some frames, and the press-fit example was a clash after a turn."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = normals
    r2 = np.sqrt(2.0)
    outer = np.column_stack([n[:, 0] ** 2, n[:, 1] ** 2, n[:, 2] ** 2, r2 * n[:, 0] * n[:, 1],
                             r2 * n[:, 0] * n[:, 2], r2 * n[:, 1] * n[:, 2]])
    q = np.einsum("ij,ij->i", triangles.mean(axis=1), n)[:, None] * n
    key = np.column_stack([outer, q * (PLANE_ANGLE / max(tol, 1e-300))])
    pairs = cKDTree(key).query_pairs(PLANE_ANGLE, output_type="ndarray")
    k = len(n)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(k, k))
    count, inv = connected_components(graph, directed=False)
    ref = np.zeros(count, dtype=np.intp)
    ref[inv[::-1]] = np.arange(k)[::-1]  # each plane's first triangle
    return inv, ref


def classify_overlap(triangles: np.ndarray, normals: np.ndarray, areas: np.ndarray,
                     depth: float, size: float, separates, tol: float, volume: float = 0.0
                     ) -> Fit:
    """The :class:`Fit` of an overlap whose surface is ``triangles`` ``(k, 3, 3)`` with unit
    ``normals`` and ``areas``, of mean thickness ``depth`` and ``volume`` (0: unknown, open
    meshes), between parts whose smaller
    diagonal is ``size``. ``separates(direction, distance)`` says whether moving part ``a`` by
    ``distance`` along ``direction`` ends the overlap; ``tol`` is the length tolerance
    (zero-thickness sheets are left out first, :func:`_sheets_removed`)."""
    if len(areas) == 0 or float(areas.sum()) <= 0:
        return Fit("clash", depth)
    areas = _sheets_removed(triangles, normals, areas, tol)
    keep = areas > 0
    triangles, normals, areas = triangles[keep], normals[keep], areas[keep]
    if not len(areas):
        return Fit("clash", depth)
    w, v = _scatter(normals, areas)
    if w[0] <= PRESS_AXIAL and w[1] >= PRESS_SPREAD * w[2]:
        axis = np.asarray(_line(v[:, 0]))
        side = np.abs(normals @ axis) < 0.1  # the tube's walls (not its end rings)
        center, r = fit_circle(triangles[side].mean(axis=1), axis)
        # the radial interference: volume over one wall's area (both walls are counted)
        radial = 2.0 * volume / float(areas[side].sum()) if volume > 0 else depth
        if r > 0 and radial <= PRESS_DEPTH * r:
            center = np.where(np.abs(center) < 1e-9 * size, 0.0, center)
            return Fit("press_fit", radial, axis=_line(axis),
                       center=tuple(float(x) + 0.0 for x in center), radius=r)
    if w[2] >= SLAB_SHARE:
        s = v[:, 2]
        pts = triangles.reshape(-1, 3) @ s
        thick = float(pts.max() - pts.min())
        if thick <= SLAB_DEPTH * size:
            for sign in (1.0, -1.0):
                d = sign * s
                if separates(d, thick):
                    d = np.where(np.abs(d) < 1e-12, 0.0, d)
                    mid = (triangles.mean(axis=1) * areas[:, None]).sum(axis=0) / areas.sum()
                    mid = np.where(np.abs(mid) < 1e-9 * size, 0.0, mid)
                    return Fit("overlap", thick, center=tuple(float(x) + 0.0 for x in mid),
                               direction=tuple(float(x) + 0.0 for x in d))
    return Fit("clash", depth)


def fcl_separates(model_a: fcl.BVHModel, obj_b: fcl.CollisionObject, tol: float):
    """A ``separates`` for :func:`classify_overlap` on open meshes: python-fcl finds no
    contact once part ``a`` (its BVH ``model_a``) is moved by ``distance + 2 tol``."""

    def test(direction: np.ndarray, distance: float) -> bool:
        moved = fcl.CollisionObject(model_a,
                                    fcl.Transform(np.asarray(direction) * (distance + 2 * tol)))
        req = fcl.CollisionRequest(num_max_contacts=1, enable_contact=False)
        return fcl.collide(moved, obj_b, req, fcl.CollisionResult()) == 0

    return test


def manifold_separates(ma, mb, volume: float, tol: float):
    """A ``separates`` for closed parts: the overlap volume (manifold3d) falls below a
    thousandth of ``volume`` once part ``a`` is moved by ``distance + 2 tol``."""

    def test(direction: np.ndarray, distance: float) -> bool:
        t = np.asarray(direction) * (distance + 2 * tol)
        return float((ma.translate(tuple(float(x) for x in t)) ^ mb).volume()) <= 1e-3 * volume

    return test
