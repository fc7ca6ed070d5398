"""What every picture shares: the parts' display meshes, their colours and the plan's
exploded poses.

The plan of a report is an assembly sequence (step ``k`` inserts ``moved`` into ``onto``
along ``direction``); the pictures show it backwards, as a disassembly: disassembly step
``j`` undoes assembly step ``n + 1 - j`` by moving its ``moved`` parts along the step's
``removal_direction``. A pose is the assembly after ``j`` disassembly steps; a part's offset
in it is the sum of the moves of every step done so far that moved it, so parts that left
stay out and a subassembly taken out first is taken apart where it now is.
"""

from __future__ import annotations

import colorsys
from dataclasses import dataclass

import numpy as np

from ..core.assembly import Assembly

#: Triangles of all parts' display meshes together above which they are coarsened by vertex
#: clustering (:func:`display_meshes`): the bell has 9 thousand, AS1 about 330 thousand, and
#: a page or a GLB past a few hundred thousand triangles is slow to open and turn.
MAX_DISPLAY_TRIANGLES = 120_000

#: The clearance added to each disassembly move, times the assembly's bounding-box diagonal:
#: the moved side first clears the rest along the direction (projections apart), then this.
MOVE_MARGIN = 0.15

#: Thickness of a 2D assembly's parts when shown in 3D, times the diagonal.
EXTRUDE_2D = 0.04


def hsl_hex(h: float, s: float, lightness: float) -> str:
    """``#rrggbb`` of a hue (turns), saturation and lightness in [0, 1]."""
    r, g, b = colorsys.hls_to_rgb(h % 1.0, lightness, s)
    return "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in (r, g, b)))


def distinct_colour(k: int) -> str:
    """The ``k``-th of an endless sequence of colours that are pairwise different strings:
    hues spread by the golden ratio, three lightness levels, so that neighbours in the
    sequence (parts, or DBGs of one family) never look alike."""
    hue = (k * 0.6180339887498949) % 1.0
    lightness = (0.45, 0.62, 0.35)[(k // 7) % 3]
    colour = hsl_hex(hue, 0.68, lightness)
    return colour


def pale(colour: str, amount: float = 0.72) -> str:
    """``colour`` mixed with white (the parts that do not move in the current step)."""
    rgb = [int(colour[i:i + 2], 16) for i in (1, 3, 5)]
    return "#{:02x}{:02x}{:02x}".format(*(round(c + (255 - c) * amount) for c in rgb))


@dataclass(frozen=True)
class DisplayMesh:
    """One part as drawn: ``vertices`` ``(m, 3)`` float64, ``faces`` ``(k, 3)`` int64."""

    id: str
    vertices: np.ndarray
    faces: np.ndarray
    colour: str


def _part_mesh(part, height: float) -> tuple[np.ndarray, np.ndarray]:
    """A part's vertices and faces in 3D (a 2D part's polygon extruded by ``height``)."""
    if part.mesh is not None:
        return (np.asarray(part.mesh.vertices, dtype=float),
                np.asarray(part.mesh.faces, dtype=np.int64))
    import trimesh

    m = trimesh.creation.extrude_polygon(part.polygon, height)
    return np.asarray(m.vertices, dtype=float), np.asarray(m.faces, dtype=np.int64)


def cluster_vertices(vertices: np.ndarray, faces: np.ndarray, cell: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Coarsen a mesh by snapping its vertices to a grid of ``cell`` and dropping the faces
    that collapse. Deterministic (no random seeds, no iteration order), unlike quadric
    decimation, and it keeps every part's silhouette to within a cell."""
    keys = np.floor(vertices / cell).astype(np.int64)
    uniq, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.reshape(-1)
    sums = np.zeros((len(uniq), 3))
    np.add.at(sums, inverse, vertices)
    counts = np.bincount(inverse, minlength=len(uniq))[:, None]
    new_faces = inverse[faces]
    keep = ((new_faces[:, 0] != new_faces[:, 1]) & (new_faces[:, 1] != new_faces[:, 2])
            & (new_faces[:, 0] != new_faces[:, 2]))
    return sums / counts, new_faces[keep]


def display_meshes(asm: Assembly, max_triangles: int = MAX_DISPLAY_TRIANGLES
                   ) -> list[DisplayMesh]:
    """The parts' meshes as drawn, in assembly order, coarsened together (one grid for all
    parts, halved until the total fits) when they have more than ``max_triangles``."""
    diag = max(asm.diagonal, 1e-9)
    raw = [_part_mesh(p, EXTRUDE_2D * diag) for p in asm.parts]
    total = sum(len(f) for _, f in raw)
    cell = diag / 1600.0
    while total > max_triangles and cell < diag:
        raw = [cluster_vertices(v, f, cell) for v, f in raw]
        total = sum(len(f) for _, f in raw)
        cell *= 2.0
    return [DisplayMesh(p.id, v, f, distinct_colour(k))
            for k, (p, (v, f)) in enumerate(zip(asm.parts, raw))]


@dataclass(frozen=True)
class Move:
    """One disassembly step: ``parts`` leave ``rest`` along ``direction`` (a unit 3-vector)
    by ``distance``. ``step`` is the assembly step it undoes; ``text`` says both ways."""

    number: int
    step: int
    parts: tuple[str, ...]
    rest: tuple[str, ...]
    direction: tuple[float, float, float]
    distance: float
    text: str


def node_ids(report: dict) -> list[str]:
    """The analysis' node names in assembly order: the part ids, except that clashing parts
    kept together as one unit (``--interference``, :mod:`ndbg_cli.pipeline.units`) are one
    node named ``a+b`` at its first member's place, as the DBGs, contacts and plan name it."""
    parts = [p["id"] for p in report["assembly"]["parts"]]
    unit_of: dict[str, str] = {}
    for x in report.get("interferences") or []:
        members = x.get("unit") or []
        for m in members:
            unit_of[m] = "+".join(members)
    out: list[str] = []
    for p in parts:
        name = unit_of.get(p, p)
        if name not in out:
            out.append(name)
    return out


def members(name: str, parts: set[str]) -> list[str]:
    """The parts of a node name (a part, or a unit ``a+b`` of clashing parts)."""
    if name in parts:
        return [name]
    return [m for m in name.split("+") if m in parts]


def _vec3(v) -> np.ndarray:
    """A direction as a unit 3-vector (a 2D one gets z = 0); zero stays zero."""
    a = np.zeros(3)
    if v is not None:
        v = list(v)[:3]
        a[:len(v)] = v
    n = np.linalg.norm(a)
    return a / n if n > 0 else a


def _fmt_vec(v) -> str:
    return "(" + ", ".join(f"{x:+.3g}" for x in v) + ")"


#: Part names spelt out in a step's text; a larger side is shortened (the tree has them all).
MAX_NAMES = 6


def _names(parts: list[str]) -> str:
    """``{a, b, c}``, or ``{a, b, c, ... (12 parts)}`` past :data:`MAX_NAMES`."""
    if len(parts) <= MAX_NAMES:
        return "{" + ", ".join(parts) + "}"
    return "{" + ", ".join(parts[:MAX_NAMES - 2]) + f", ... ({len(parts)} parts)}}"


def _step_direction(step: dict, centres: dict[str, np.ndarray]) -> tuple[np.ndarray, str]:
    """The direction a step's moved side leaves along, and how the step says it moved: a
    translation's removal direction; for a rotation or a screw (generalized motions), the
    axis of the screw, or for a rotation the way from the rest's centre to the moved side's
    (the pictures show every step as a translation away)."""
    if step.get("removal_direction") is not None:
        return _vec3(step["removal_direction"]), "along " + _fmt_vec(step["direction"])
    m = step.get("motion") or {}
    how = f"by reverse {m.get('type', 'motion')} about {_fmt_vec(m.get('axis') or [])}"
    if m.get("type") == "screw" and m.get("axis") is not None:
        return _vec3(m["axis"]), how
    away = (np.mean([centres[p] for p in step["moved"]], axis=0)
            - np.mean([centres[p] for p in step["onto"]], axis=0))
    d = _vec3(away)
    return (d if np.linalg.norm(d) > 0 else np.array([0.0, 0.0, 1.0])), how


def disassembly(report: dict, meshes: list[DisplayMesh]) -> list[Move]:
    """The plan of ``report`` as disassembly moves (the reverse of its assembly sequence);
    empty when it has no plan. Each move's distance clears the moved side of the rest's
    extent along the direction, plus :data:`MOVE_MARGIN` of the diagonal."""
    plan = report.get("plan") or {}
    seq = (plan.get("sequence") or []) if plan.get("found") else []
    names = {m.id for m in meshes}
    by_id = {m.id: m for m in meshes}
    allv = np.vstack([m.vertices for m in meshes]) if meshes else np.zeros((1, 3))
    diag = float(np.linalg.norm(allv.max(axis=0) - allv.min(axis=0))) or 1.0
    centres = {m.id: m.vertices.mean(axis=0) if len(m.vertices) else np.zeros(3)
               for m in meshes}
    moves = []
    for j, s in enumerate(reversed(seq), start=1):
        s = {**s, "moved": [p for q in s["moved"] for p in members(q, names)],
             "onto": [p for q in s["onto"] for p in members(q, names)]}
        d, how = _step_direction(s, centres)
        moved = np.vstack([by_id[p].vertices for p in s["moved"]]) @ d
        rest = np.vstack([by_id[p].vertices for p in s["onto"]]) @ d
        clear = max(float(rest.max() - moved.min()), 0.0)
        verb = "press" if s.get("press") else "insert"
        text = (f"{j}/{len(seq)}: remove {_names(s['moved'])} from {_names(s['onto'])} "
                f"along {_fmt_vec(d)} (undoes assembly step {s['step']}: {verb} it {how})")
        moves.append(Move(j, int(s["step"]), tuple(s["moved"]), tuple(s["onto"]),
                          (float(d[0]), float(d[1]), float(d[2])),
                          clear + MOVE_MARGIN * diag, text))
    return moves


def poses(meshes: list[DisplayMesh], moves: list[Move]) -> np.ndarray:
    """``(len(moves) + 1, parts, 3)``: each part's offset after 0, 1, ... disassembly steps."""
    index = {m.id: k for k, m in enumerate(meshes)}
    out = np.zeros((len(moves) + 1, len(meshes), 3))
    for j, mv in enumerate(moves, start=1):
        out[j] = out[j - 1]
        for p in mv.parts:
            out[j, index[p]] += np.asarray(mv.direction) * mv.distance
    return out


def pose_bounds(meshes: list[DisplayMesh], offsets: np.ndarray) -> np.ndarray:
    """``(2, 3)``: the box holding every part in every pose (fixed axes: the view does not
    jump while the plan plays)."""
    lo = np.full(3, np.inf)
    hi = np.full(3, -np.inf)
    for k, m in enumerate(meshes):
        if not len(m.vertices):
            continue
        a, b = m.vertices.min(axis=0), m.vertices.max(axis=0)
        lo = np.minimum(lo, a + offsets[:, k].min(axis=0))
        hi = np.maximum(hi, b + offsets[:, k].max(axis=0))
    if not np.all(np.isfinite(lo)):
        return np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])
    return np.array([lo, hi])
