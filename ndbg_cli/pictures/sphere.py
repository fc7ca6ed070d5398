"""The direction sphere of each motion family, its regions coloured by their DBG (the
paper's Figs. 4, 6 and 8).

What the report allows, family by family:

- **infinitesimal translation**: the report lists every contact's normals (out of ``a``)
  and the angle tolerance, which is all the family's DBG at a direction depends on
  (:func:`ndbg_cli.ndbg.infinitesimal.build.blocking_sides`, the same rule as the NDBG's
  builder). So the sphere is sampled (an icosphere's face centres, or points of the circle
  in 2D), each sample gets the DBG of its direction and is matched to the report's list of
  distinct DBGs: the coloured areas *are* the open regions. The lower-dimensional regions
  (arcs and vertices) are drawn as their representative directions.
- **infinite translation**: its regions come from blocked-direction sets that the report
  does not keep; only each region's representative direction is drawn, and the picture
  says so (dots, not areas).
- **generalized** motions are not directions; the family has no sphere.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from html import escape

import numpy as np

#: Icosphere subdivisions of the sampled sphere: 5120 faces, each about 3 degrees across.
SPHERE_SUBDIVISIONS = 4

#: Samples of the direction circle of a 2D assembly.
CIRCLE_SAMPLES = 720

#: Free sets listed per DBG (hover text); the rest are counted.
MAX_FREE_SETS = 8


@dataclass(frozen=True)
class DbgInfo:
    """One distinct DBG of a family: its index in the report's ``dbgs``, arcs and minimal
    free sets (part ids), and how many regions of each dimension have it."""

    index: int
    arcs: tuple[tuple[str, str], ...]
    free_sets: tuple[tuple[str, ...], ...]
    regions: dict[int, int]

    def label(self) -> str:
        """The hover text (HTML, part names escaped): the DBG, its regions, its free sets."""
        dims = ", ".join(f"{n} of dim {d}" for d, n in sorted(self.regions.items()))
        arcs = "; ".join(f"{escape(a)}->{escape(b)}" for a, b in self.arcs[:12])
        more = f" (+{len(self.arcs) - 12} arcs)" if len(self.arcs) > 12 else ""
        free = ", ".join("{" + escape(", ".join(s)) + "}"
                         for s in self.free_sets[:MAX_FREE_SETS])
        if len(self.free_sets) > MAX_FREE_SETS:
            free += f", ... ({len(self.free_sets)} in all)"
        return (f"DBG {self.index} - regions: {dims or 'none listed'}<br>"
                f"{len(self.arcs)} arcs (i->j: j blocks i): {arcs or 'none'}{more}<br>"
                f"minimal free sets: {free or 'none (interlocked)'}")


@dataclass
class SphereMap:
    """A family's sphere: ``samples`` ``(S, 3)`` unit directions with ``sample_dbg`` (index
    into the report's ``dbgs``, -1 where no listed DBG matched); for 3D region maps also the
    icosphere (``vertices``, ``faces``, ``face_dbg``). ``representatives``: each listed
    region's ``(direction, dbg, dimension)``; ``plan``: ``(step, direction)`` of the plan's
    translations in this family. ``mode`` is ``"regions"`` (areas are regions) or
    ``"representatives"`` (dots only); ``note`` says what is drawn, for the captions."""

    family: str
    mode: str
    dbgs: list[DbgInfo]
    samples: np.ndarray
    sample_dbg: np.ndarray
    representatives: list[tuple[tuple[float, float, float], int, int]]
    plan: list[tuple[int, tuple[float, float, float]]]
    note: str
    vertices: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    faces: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    face_dbg: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    @property
    def distinct_drawn(self) -> list[int]:
        """The DBG indices drawn (sampled areas and representatives), sorted."""
        drawn = {int(k) for k in self.sample_dbg if k >= 0}
        drawn |= {k for _, k, _ in self.representatives}
        return sorted(drawn)


def _pad3(v) -> tuple[float, float, float]:
    a = [float(x) for x in v][:3]
    a += [0.0] * (3 - len(a))
    return (a[0], a[1], a[2])


def _dbg_infos(section: dict, ids: list[str]) -> list[DbgInfo]:
    """The family's distinct DBGs with their minimal free sets."""
    from ..ndbg.dbg import DBG, bits, minimal_free_subsets

    index = {p: k for k, p in enumerate(ids)}
    counts: dict[int, dict[int, int]] = {}
    for r in section.get("region_list") or []:
        c = counts.setdefault(int(r["dbg"]), {})
        c[int(r["dimension"])] = c.get(int(r["dimension"]), 0) + 1
    out = []
    for k, g in enumerate(section.get("dbgs") or []):
        arcs = tuple((a, b) for a, b in g["arcs"])
        dbg = DBG.from_arcs(len(ids), [(index[a], index[b]) for a, b in arcs])
        free = sorted(tuple(ids[i] for i in bits(m)) for m in minimal_free_subsets(dbg))
        out.append(DbgInfo(k, arcs, tuple(sorted(free, key=lambda s: (len(s), s))),
                           counts.get(k, {})))
    return out


def _sample_dbgs(report: dict, section: dict, directions: np.ndarray,
                 ids: list[str]) -> np.ndarray:
    """The index into ``section['dbgs']`` of the infinitesimal DBG at each direction, by
    the builder's own blocking rule on the report's contact normals; -1 where it matches
    none of the listed DBGs. Arcs every listed DBG has (threaded pairs, blocked both ways
    whatever the direction) are added to each sample's."""
    from ..ndbg.infinitesimal.build import blocking_sides

    dim = directions.shape[1]
    tol = float(section.get("angle_tolerance") or 0.0)
    columns: list[np.ndarray] = []
    names: list[tuple[str, str]] = []
    for c in report.get("contacts") or []:
        normals = np.asarray(c["normals"], dtype=float).reshape(-1, dim)
        normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
        fwd, back = blocking_sides(directions @ normals.T, c.get("blocking", "any"), tol)
        columns += [fwd, back]
        names += [(c["a"], c["b"]), (c["b"], c["a"])]
    arcs = (np.column_stack(columns) if columns
            else np.zeros((len(directions), 0), dtype=bool))
    listed = [frozenset(map(tuple, g["arcs"])) for g in section.get("dbgs") or []]
    common = frozenset.intersection(*listed) if listed else frozenset()
    lookup = {g: k for k, g in enumerate(listed)}
    # samples with the same blocking pattern share one lookup (patterns packed to bytes:
    # a row of bits is one comparable key)
    packed = np.packbits(arcs, axis=1)
    keys = packed.view(np.dtype((np.void, packed.shape[1]))).reshape(-1)
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    table = np.array([lookup.get(frozenset(names[i] for i in np.flatnonzero(arcs[f])) | common,
                                 -1) for f in first], dtype=np.int64)
    return table[inverse.reshape(-1)]


def _icosphere() -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=SPHERE_SUBDIVISIONS)
    return np.asarray(s.vertices, dtype=float), np.asarray(s.faces, dtype=np.int64)


def _plan_directions(report: dict, family: str) -> list[tuple[int, tuple[float, float, float]]]:
    plan = report.get("plan") or {}
    return [(int(s["step"]), _pad3(s["direction"])) for s in plan.get("sequence") or []
            if s.get("family", plan.get("family")) == family
            and s.get("direction") is not None]


def sphere_map(report: dict, family: str) -> SphereMap | None:
    """The sphere of one family of ``report``; ``None`` when it has no listed regions
    (skipped, generalized, or an error record)."""
    section = (report.get("ndbg") or {}).get(family) or {}
    regions = section.get("region_list")
    if not regions or "dbgs" not in section:
        return None
    from ._scene import node_ids

    ids = node_ids(report)
    dim = int(report["assembly"].get("dimension", 3))
    infos = _dbg_infos(section, ids)
    reps = [(_pad3(r["direction"]), int(r["dbg"]), int(r["dimension"])) for r in regions
            if r.get("direction") is not None]
    plan = _plan_directions(report, family)
    truncated = " (region list truncated)" if section.get("region_list_truncated") else ""
    if family != "infinitesimal_translation":
        note = (f"{len(reps)} regions, shown by their representative directions only: the "
                f"report does not give this family's region boundaries{truncated}")
        return SphereMap(family, "representatives", infos, np.zeros((0, 3)),
                         np.zeros(0, dtype=np.int64), reps, plan, note)
    if dim == 2:
        t = (np.arange(CIRCLE_SAMPLES) + 0.5) * (2 * np.pi / CIRCLE_SAMPLES)
        samples2 = np.column_stack([np.cos(t), np.sin(t)])
        sample_dbg = _sample_dbgs(report, section, samples2, ids)
        samples = np.column_stack([samples2, np.zeros(len(t))])
        note = (f"direction circle sampled every {360 / CIRCLE_SAMPLES:g} degrees, each "
                f"sample coloured by its DBG; points: the arc and point regions{truncated}")
        return SphereMap(family, "regions", infos, samples, sample_dbg, reps, plan, note)
    vertices, faces = _icosphere()
    centres = vertices[faces].mean(axis=1)
    centres /= np.linalg.norm(centres, axis=1, keepdims=True)
    face_dbg = _sample_dbgs(report, section, centres, ids)
    unmatched = int((face_dbg < 0).sum())
    note = (f"sphere sampled at {len(faces)} directions, each coloured by its DBG (the "
            f"open regions); dots: the arcs and vertices of the arrangement{truncated}"
            + (f"; {unmatched} samples match no listed DBG (grey)" if unmatched else ""))
    return SphereMap(family, "regions", infos, centres, face_dbg, reps, plan, note,
                     vertices, faces, face_dbg)


def sphere_maps(report: dict) -> list[SphereMap]:
    """The spheres of every family of ``report`` that has one, in family-name order."""
    out = []
    for family in sorted(report.get("ndbg") or {}):
        m = sphere_map(report, family)
        if m is not None:
            out.append(m)
    return out


def dbg_grid(report: dict, m: SphereMap, width: int = 360, height: int = 180) -> np.ndarray:
    """For a 3D region map: the DBG index (-1: none listed) at the centre of each cell of a
    longitude x latitude grid, ``(height, width)``, north (+z) on the first row; for the
    static images, where the samples must fill a flat map."""
    from ._scene import node_ids

    lon = (np.arange(width) + 0.5) / width * 2 * np.pi - np.pi
    lat = np.pi / 2 - (np.arange(height) + 0.5) / height * np.pi
    lo, la = np.meshgrid(lon, lat)
    dirs = np.column_stack([(np.cos(la) * np.cos(lo)).ravel(),
                            (np.cos(la) * np.sin(lo)).ravel(), np.sin(la).ravel()])
    section = report["ndbg"][m.family]
    return _sample_dbgs(report, section, dirs, node_ids(report)).reshape(height, width)
