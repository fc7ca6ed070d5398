"""Turning raw geometry into validated parts: :func:`make_part` scales and places a mesh,
repairs what can be repaired without changing the shape, and checks it;
:func:`make_polygon_part` does the same for 2D polygon parts.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon
from shapely.validation import explain_validity

from ..core.assembly import Diagnostic, Part, PartCheck, content_hash
from ..core.errors import InputError

#: Relative size below which a face's edge counts as degenerate (times the part's diagonal).
DEGENERATE_RELATIVE = 1e-9
#: Largest coordinate (in the assembly unit, after scaling and placement) a part may have:
#: volumes multiply three coordinates, so beyond about 1e102 they overflow to infinity. No
#: real model comes near; a damaged number (``1e300``) does.
MAX_COORDINATE = 1e100


def make_part(part_id: str, vertices: np.ndarray, faces: np.ndarray, *,
              transform: np.ndarray | None = None, scale: float = 1.0, source: str = "",
              fixed: bool = False) -> tuple[Part, list[Diagnostic]]:
    """Build a validated 3D :class:`Part`.

    ``vertices`` ``(v, 3)`` are in the source unit and frame; they are multiplied by ``scale``
    (source unit to assembly unit) and then mapped by ``transform`` (4x4, translation in the
    assembly unit). Raises :class:`InputError` for geometry that cannot be analysed.

    * vertices are merged ignoring normals and texture coordinates (STEP tessellations split
      vertices along sharp edges, which would make every solid look open);
    * duplicate and zero-area faces are dropped (zero area: below ``(tol_rel * size)^2``);
    * a closed mesh with inward-facing normals (negative volume) is inverted, with a warning;
    * NaN or infinite coordinates, an empty mesh, or a mesh whose faces all vanish are errors;
    * an open (non-watertight) or inconsistently wound mesh is a warning: the analysis still
      runs where it can, but volumes and interference checks need closed solids.
    """
    where = {"file": source or None, "part": part_id}
    v = np.asarray(vertices, dtype=np.float64)
    f = np.asarray(faces)
    if v.ndim != 2 or v.shape[1] != 3 or v.shape[0] == 0 or f.size == 0:
        raise InputError("empty mesh (no vertices or no faces)", **where)
    if f.ndim != 2 or f.shape[1] != 3:
        raise InputError(f"faces must be triangles, got shape {f.shape}", **where)
    if not np.all(np.isfinite(v)):
        bad = int(np.count_nonzero(~np.all(np.isfinite(v), axis=1)))
        raise InputError(f"{bad} vertex coordinate(s) are NaN or infinite", **where)
    f = f.astype(np.int64)
    if f.min() < 0 or f.max() >= len(v):
        raise InputError("face indices out of range of the vertex array", **where)
    T = np.eye(4) if transform is None else np.asarray(transform, dtype=float)
    source_hash = content_hash(v, f, np.array([scale]), T)
    v = v * scale
    v = v @ T[:3, :3].T + T[:3, 3]
    big = float(np.max(np.abs(v))) if np.all(np.isfinite(v)) else math.inf
    if big > MAX_COORDINATE:
        raise InputError(f"coordinates reach {big:.3g} once scaled and placed, beyond "
                         f"{MAX_COORDINATE:g}: a damaged number or a wrong unit", **where)

    mesh = trimesh.Trimesh(vertices=v, faces=f, process=False, validate=False)
    mesh.merge_vertices(merge_tex=True, merge_norm=True)
    size = float(np.linalg.norm(mesh.extents)) if len(mesh.vertices) else 0.0
    if size <= 0.0:
        raise InputError("degenerate mesh: all vertices coincide", **where)
    tri = mesh.triangles
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    keep = area2 > (DEGENERATE_RELATIVE * size) ** 2
    diags: list[Diagnostic] = []
    if not keep.any():
        raise InputError("degenerate mesh: every face has zero area", **where)
    unique = np.zeros(len(mesh.faces), dtype=bool)
    unique[trimesh.grouping.unique_rows(np.sort(mesh.faces, axis=1))[0]] = True
    keep &= unique
    dropped = int(len(mesh.faces) - keep.sum())
    if dropped:
        mesh.update_faces(keep)
        mesh.remove_unreferenced_vertices()
    boundary, nonmanifold, closed = edge_stats(mesh)
    # A closed surface whose edges pair up with their reverses bounds a well-defined volume even
    # where four faces meet at an edge (voxel-like parts touching themselves along an edge).
    # (trimesh's own tests, a graph of the faces, only when the edges do not already tell)
    watertight = closed or bool(mesh.is_watertight)
    winding = closed or bool(mesh.is_winding_consistent)
    volume = float(mesh.volume) if watertight and winding else 0.0
    if watertight and winding and volume < 0:
        mesh.invert()
        volume = -volume
        diags.append(Diagnostic("warning", "inverted-normals",
                                "normals pointed inward; the mesh was inverted", **where))
    if watertight and winding and volume <= DEGENERATE_RELATIVE * size**3:
        raise InputError("degenerate mesh: closed but encloses no volume", **where)
    if not watertight:
        diags.append(Diagnostic("warning", "not-watertight",
                                f"mesh is not watertight ({boundary} open, {nonmanifold} "
                                "non-manifold edges): volumes and interference checks are "
                                "approximate", **where))
    elif nonmanifold:
        diags.append(Diagnostic("warning", "non-manifold",
                                f"closed but with {nonmanifold} non-manifold edge(s) (more than "
                                "two faces meet)", **where))
    elif not winding:
        diags.append(Diagnostic("warning", "inconsistent-winding",
                                "faces are not consistently wound", **where))
    if dropped:
        diags.append(Diagnostic("warning", "degenerate-faces",
                                f"dropped {dropped} duplicate or zero-area face(s)", **where))
    bounds = mesh.bounds
    check = PartCheck(triangles=int(len(mesh.faces)), vertices=int(len(mesh.vertices)),
                      watertight=watertight, winding_consistent=winding, volume=volume,
                      area=float(mesh.area),
                      bounds=(tuple(map(float, bounds[0])), tuple(map(float, bounds[1]))))
    part = Part(id=part_id, transform=T, source=source, hash=source_hash, check=check,
                mesh=mesh, fixed=fixed)
    return part, diags


def edge_stats(mesh: trimesh.Trimesh) -> tuple[int, int, bool]:
    """``(boundary edges, non-manifold edges, closed)`` of a triangle mesh.

    A boundary edge has one face, a non-manifold edge more than two. The mesh is *closed* when
    every directed edge ``(u, v)`` occurs as often as its reverse ``(v, u)``: then the
    surface is a consistently oriented cycle and its signed volume is meaningful.

    One sort of integer keys: each directed edge is keyed by its undirected edge
    ``(min, max)`` and, in the lowest bit, its direction, so that a run of equal undirected
    keys is one edge (its length: the faces on it) holding its two directions in turn.

    >>> tetra = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]],
    ...                         [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]], process=False)
    >>> edge_stats(tetra), edge_stats(trimesh.Trimesh(tetra.vertices, tetra.faces[:3]))
    ((0, 0, True), (3, 0, False))
    """
    d = np.asarray(mesh.faces, dtype=np.int64)[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
    if not len(d):
        return 0, 0, False
    lo, hi = np.minimum(d[:, 0], d[:, 1]), np.maximum(d[:, 0], d[:, 1])
    size = int(hi.max()) + 1
    keys = np.sort((lo * size + hi) * 2 + (d[:, 0] > d[:, 1]))
    edge = keys >> 1
    start = np.flatnonzero(np.r_[True, edge[1:] != edge[:-1]])
    counts = np.diff(np.r_[start, len(keys)])
    backward = np.add.reduceat(keys & 1, start)
    # an edge from a vertex to itself (a face repeating a vertex) is its own reverse
    balanced = (2 * backward == counts) | (edge[start] // size == edge[start] % size)
    boundary = int(np.count_nonzero(counts == 1))
    nonmanifold = int(np.count_nonzero(counts > 2))
    return boundary, nonmanifold, bool(balanced.all())


def make_polygon_part(part_id: str, exterior, holes=(), *, transform: np.ndarray | None = None,
                      scale: float = 1.0, source: str = "", fixed: bool = False
                      ) -> tuple[Part, list[Diagnostic]]:
    """Build a validated 2D :class:`Part` from an exterior ring ``(k, 2)`` and hole rings.

    ``transform`` is a 3x3 homogeneous 2D placement applied after ``scale``. The stored polygon
    has a counter-clockwise exterior and clockwise holes; consecutive duplicate and collinear
    vertices are removed. Self-intersecting or zero-area polygons are errors.
    """
    where = {"file": source or None, "part": part_id}
    rings = [exterior, *holes]
    arrays = []
    for ring in rings:
        try:
            a = np.asarray(ring, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputError("polygon vertices must be [x, y] number pairs", **where) from None
        if a.ndim != 2 or a.shape[1] != 2 or len(a) < 3:
            raise InputError("a polygon ring needs at least 3 [x, y] vertices", **where)
        if not np.all(np.isfinite(a)):
            raise InputError("polygon coordinates are NaN or infinite", **where)
        arrays.append(a)
    T = np.eye(3) if transform is None else np.asarray(transform, dtype=float)
    source_hash = content_hash(*arrays, np.array([scale]), T)
    placed = [(a * scale) @ T[:2, :2].T + T[:2, 2] for a in arrays]
    poly = Polygon(placed[0], placed[1:])
    if not poly.is_valid:
        reason = explain_validity(poly)
        raise InputError(f"invalid polygon: {reason}", **where)
    if poly.area <= 0:
        raise InputError("degenerate polygon: zero area", **where)
    size = float(np.hypot(*(np.ptp(placed[0], axis=0))))
    poly = shapely.simplify(shapely.geometry.polygon.orient(poly, 1.0), DEGENERATE_RELATIVE * size)
    lo, hi = np.array(poly.bounds[:2]), np.array(poly.bounds[2:])
    nverts = len(poly.exterior.coords) - 1 + sum(len(r.coords) - 1 for r in poly.interiors)
    check = PartCheck(triangles=0, vertices=nverts, watertight=True, winding_consistent=True,
                      volume=0.0, area=float(poly.area),
                      bounds=(tuple(map(float, lo)), tuple(map(float, hi))))
    part = Part(id=part_id, transform=T, source=source, hash=source_hash, check=check,
                polygon=poly, fixed=fixed)
    return part, []
