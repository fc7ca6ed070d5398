"""The assembly model: named rigid parts placed in one frame.

An :class:`Assembly` is immutable. Each :class:`Part` holds its geometry already placed in the
assembly frame and in the assembly's unit: 3D parts a ``trimesh.Trimesh`` (``Part.mesh``,
float64 vertices, int64 faces, outward normals), 2D parts a ``shapely.Polygon``
(``Part.polygon``, counter-clockwise exterior, clockwise holes). Later stages cache per part
and part pair through :attr:`Part.hash` (a content hash of the source geometry and the
placement), so a subassembly (:meth:`Assembly.subset`) shares its parts and their caches with
the whole. Treat the meshes as read-only: they are shared, not copied.
"""

from __future__ import annotations

import dataclasses
import hashlib
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .constants import DEFAULT_RELATIVE_TOLERANCE, MIN_TOLERANCE
from .errors import InputError
from .memo import kept


@dataclass(frozen=True)
class Diagnostic:
    """A warning or error about the input, kept in the report.

    ``level`` is ``"warning"`` or ``"error"``; ``code`` a short stable identifier such as
    ``"not-watertight"``; ``message`` one human-readable line.
    """

    level: str
    code: str
    message: str
    part: str | None = None
    file: str | None = None

    def record(self) -> dict:
        return {"level": self.level, "code": self.code, "message": self.message,
                "part": self.part, "file": self.file}


@dataclass(frozen=True)
class PartCheck:
    """Validation facts about one part (3D: of its mesh; 2D: of its polygon).

    ``volume`` is in unit^3 (3D) and ``area`` in unit^2 (the mesh's surface area in 3D, the
    polygon's area in 2D). ``bounds`` is ``((xmin, ymin[, zmin]), (xmax, ymax[, zmax]))``.
    """

    triangles: int
    vertices: int
    watertight: bool
    winding_consistent: bool
    volume: float
    area: float
    bounds: tuple[tuple[float, ...], tuple[float, ...]]


@dataclass(frozen=True)
class Joint:
    """A motion hint declared in the manifest (used by the generalized-motion analysis).

    ``type`` is ``"screw"`` or ``"revolute"``; ``parts`` the two part ids (the first moves
    relative to the second); ``axis`` a unit vector and ``point`` a point on the axis, in the
    assembly frame and unit; ``pitch`` the advance per turn (assembly unit; 0 for revolute),
    positive for a right-hand thread.
    """

    type: str
    parts: tuple[str, str]
    axis: tuple[float, float, float]
    point: tuple[float, float, float]
    pitch: float = 0.0


@dataclass(frozen=True, eq=False)
class Part:
    """One rigid part, placed in the assembly frame, in the assembly's unit.

    ``transform`` is the 4x4 placement that was applied to the source geometry (after unit
    scaling); ``source`` names where the geometry came from (a file, or ``file#node``), as
    the loader found it (a manifest's mesh files resolved); a report writes it relative to
    its root folder (:func:`ndbg_cli.core.paths.portable_source`).
    """

    id: str
    transform: np.ndarray
    source: str
    hash: str
    check: PartCheck
    mesh: Any = None  # trimesh.Trimesh for 3D parts
    polygon: Any = None  # shapely.Polygon for 2D parts
    fixed: bool = False

    @property
    def bounds(self) -> np.ndarray:
        """``(2, dim)`` array: min and max corner of the part's placed geometry."""
        return np.asarray(self.check.bounds, dtype=float)


def content_hash(*arrays: np.ndarray, extra: str = "") -> str:
    """SHA-256 (hex, 16 chars) of arrays' dtype, shape and bytes, plus an optional string."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(extra.encode())
    return h.hexdigest()[:16]


@dataclass(frozen=True, eq=False)
class Assembly:
    """A set of parts in their assembled pose.

    ``units`` is the unit of every length (``mm``, ``cm``, ``m`` or ``in``); ``tolerance`` the
    explicit length tolerance from the manifest or command line, or ``None`` for the default
    (see :attr:`length_tolerance`). ``base`` names an optional fixed base part. ``expect`` is
    the manifest's free-form ``expect:`` block (answers worked out by hand, for tests).
    ``source`` is the manifest, model file or folder as it was given to the loader; a report
    writes it relative to its root folder (:func:`ndbg_cli.core.paths.portable`).
    """

    name: str
    parts: tuple[Part, ...]
    units: str = "mm"
    dimension: int = 3
    tolerance: float | None = None
    source: str = ""
    base: str | None = None
    joints: tuple[Joint, ...] = ()
    expect: dict = field(default_factory=dict)
    diagnostics: tuple[Diagnostic, ...] = ()
    metadata: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        ids = [p.id for p in self.parts]
        if len(set(ids)) != len(ids):
            dup = sorted({i for i in ids if ids.count(i) > 1})
            raise InputError(f"duplicate part id(s): {', '.join(dup)}", file=self.source or None)
        object.__setattr__(self, "_index", {pid: k for k, pid in enumerate(ids)})

    # -- access ---------------------------------------------------------------------------
    def __len__(self) -> int:
        return len(self.parts)

    def __iter__(self) -> Iterator[Part]:
        return iter(self.parts)

    @property
    def ids(self) -> list[str]:
        """Part ids in assembly order (the order of node indices in every blocking graph)."""
        return [p.id for p in self.parts]

    def index(self, part_id: str) -> int:
        """Position of ``part_id`` in :attr:`parts`; ``InputError`` if there is no such part."""
        try:
            return self._index[part_id]  # type: ignore[attr-defined]
        except KeyError:
            raise InputError(f"no part named '{part_id}' (parts: {', '.join(self.ids)})",
                             file=self.source or None) from None

    def part(self, part_id: str) -> Part:
        return self.parts[self.index(part_id)]

    # -- geometry -------------------------------------------------------------------------
    @property
    def bounds(self) -> np.ndarray:
        """``(2, dim)`` array: the min and max corners over all parts."""
        if not self.parts:
            return np.zeros((2, self.dimension))
        b = np.array([p.bounds for p in self.parts])
        return np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    @property
    def diagonal(self) -> float:
        """Length of the bounding-box diagonal, in the assembly unit."""
        lo, hi = self.bounds
        return float(np.linalg.norm(hi - lo))

    @property
    def size(self) -> float:
        """The model's size, in the assembly unit, the same in any frame: twice the largest
        distance of a vertex from the centroid of the parts' convex hull (a box's diagonal,
        as :attr:`diagonal` gives it in the box's own frame). The bounding box's diagonal
        changes when the model turns (by up to a factor of 1.7), and so did every tolerance
        derived from it: the engine's default tolerance was 0.084 in its file's frame and
        0.098 after a turn, and a contact became an interference (issue 34's invariance)."""
        return self._measure()[0]

    @property
    def centre(self) -> np.ndarray:
        """The centroid of the parts' convex hull (the point :attr:`size` is measured from):
        a point of the model that moves with it, unlike the bounding box's centre."""
        return self._measure()[1].copy()

    def _measure(self) -> tuple[float, np.ndarray]:
        return kept(self, "_size", lambda: _size(self))

    @property
    def length_tolerance(self) -> float:
        """The length tolerance in the assembly unit.

        The explicit ``tolerance`` when one was given, else ``DEFAULT_RELATIVE_TOLERANCE``
        (1e-4) times the model's :attr:`size`: 0.02 mm for a 200 mm product. It scales with
        the model and turns with it, so converting the same model from mm to m, or turning
        it, changes no answer.
        """
        if self.tolerance is not None:
            return float(self.tolerance)
        return max(DEFAULT_RELATIVE_TOLERANCE * self.size, MIN_TOLERANCE)

    # -- derived assemblies ---------------------------------------------------------------
    def subset(self, part_ids: Iterable[str]) -> Assembly:
        """The subassembly made of ``part_ids`` (in this assembly's order), sharing the parts."""
        keep = set(part_ids)
        missing = keep - set(self.ids)
        if missing:
            self.index(sorted(missing)[0])  # raises a clear InputError
        parts = tuple(p for p in self.parts if p.id in keep)
        joints = tuple(j for j in self.joints if set(j.parts) <= keep)
        base = self.base if self.base in keep else None
        return dataclasses.replace(self, parts=parts, joints=joints, base=base)

    def replace(self, **changes: Any) -> Assembly:
        """A copy with some fields changed (parts are shared, not copied)."""
        return dataclasses.replace(self, **changes)

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.level == "warning"]


def _size(asm: Assembly) -> tuple[float, np.ndarray]:
    """:attr:`Assembly.size` and :attr:`Assembly.centre`: :func:`point_extent` of every
    vertex (2D: polygon corner)."""
    pts = [np.asarray(p.mesh.vertices, float) if p.mesh is not None
           else np.asarray(p.polygon.exterior.coords, float)[:, :asm.dimension]
           for p in asm.parts if p.mesh is not None or p.polygon is not None]
    if not pts:
        lo, hi = asm.bounds
        return float(np.linalg.norm(hi - lo)), (lo + hi) / 2
    return point_extent(np.concatenate(pts))


def point_extent(points: np.ndarray) -> tuple[float, np.ndarray]:
    """``(size, centre)`` of a point set, the same in any frame and point order: twice the
    largest distance of a point from the volume (area) centroid of their convex hull, and
    that centroid; points that span no volume (flat, or none but one) are measured from
    their mean instead. A bounding box's diagonal changes when the points turn (by up to a
    factor of 1.7), and so would every tolerance or threshold drawn from it.

    Examples
    --------
    >>> import numpy as np
    >>> cube = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    >>> size, centre = point_extent(cube)
    >>> round(size, 6), centre.round(6).tolist()
    (1.732051, [0.5, 0.5, 0.5])
    """
    from scipy.spatial import ConvexHull, QhullError

    x = np.asarray(points, dtype=float)
    x = x[np.lexsort(x.T[::-1])]  # one order whatever the input order: the same float sums
    try:
        hull = ConvexHull(x)
        v = x[hull.vertices]
        o = v.mean(axis=0)
        simplices = x[hull.simplices] - o  # (f, dim, dim): simplices with the apex o
        w = np.abs(np.linalg.det(simplices))
        c = o + (simplices.sum(axis=1) * w[:, None]).sum(axis=0) / (
            (len(o) + 1) * max(float(w.sum()), 1e-300))
    except (QhullError, ValueError):
        v = x
        c = x.mean(axis=0)
    return 2.0 * float(np.sqrt(((v - c) ** 2).sum(axis=1).max())), c
