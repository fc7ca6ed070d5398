"""The proofs of a generalized plan's steps: each moved side follows its rotation or screw
motion over a finite angle without crossing the rest
(:func:`ndbg_cli.ndbg.generalized.finite.check_motion`), then leaves by one translation to
infinity (the direct sweep test, :mod:`ndbg_cli.ndbg.infinite.sweep`); a translation step is
the sweep test alone.

How far to turn: a rotation is tried up to each angle where a face of the moved side comes to
face the same way as a face of the rest
(:func:`~ndbg_cli.ndbg.generalized.finite.alignment_angles`: a key turned until its sides line
up with its slot), the first angle from which a natural direction (the axis, the coordinate
axes) frees it being the step's. A screw motion is proven only along a declared joint
(``joints:`` in the manifest, same line, same hand and pitch): the meshes do not model the
thread, so the joint is what says the part turns rather than slides out; it turns until the
moved side has advanced past the jointed part (the thread is disengaged). Every pair of parts
is checked during the motion, the jointed one included, except, between the two parts of a
declared joint of the motion, a cylindrical surface about the axis (as a whole within its
allowance) against the other part across it: the shank against its threaded hole's wall and
rim, a pin against its bore (:func:`~ndbg_cli.ndbg.generalized.finite.cylinder_bands`).
"""

from __future__ import annotations

import numpy as np

from ..contacts.facets import graph_components, part_geometry
from ..core.assembly import Assembly
from ..core.constants import CONTACT_ANGLE_TOL_RAD
from ..geometry.vectors import unique_rows
from ..io.validate import make_part
from ..ndbg.generalized.finite import Screw, alignment_angles, check_motion, cylinder_bands
from ..ndbg.infinite.sweep import SweepChecker

#: Rounding allowance of the motion check, times the model's size: far below the length
#: tolerance (1e-4 of the size by default; at most a hundredth of an explicit one), above the
#: rounding of float32 mesh files (about 1e-7 of the size), so sliding faces pass and
#: crossing ones do not.
MOTION_EPS = 1e-6
#: Narrowest angle interval (radians) the motion check halves down to.
MIN_STEP = 1e-5
#: Angles a rotation is tried up to, at most (the first ones where faces line up).
MAX_ANGLES = 64
#: Face normals per side that :func:`_angles` lines up, at most (the largest faces').
NORMALS = 1000
#: Triangle pairs the motion check may test per step (about a microsecond each).
PAIR_BUDGET = 2_000_000


def prove_generalized(asm: Assembly, section: dict) -> dict:
    """The ``verified`` field of a generalized plan ``section`` (the report's plan), and a
    ``proof`` on each step it proves. Every step proven: ``value`` true; otherwise false, with
    the first step it could not prove and why."""
    steps = section.get("sequence") or []
    if asm.dimension != 3:
        return _unproven(0, "2D generalized motions are not checked by a finite-motion test")
    index = {p.id: k for k, p in enumerate(asm.parts)}
    for step in steps:
        moved = [index[x] for x in step["moved"]]
        rest = [index[x] for x in step["onto"]]
        proof, why = prove_step(asm, moved, rest, step.get("motion") or {})
        if proof is None:
            return _unproven(step["step"], why)
        step["proof"] = proof
    return {"verified": {
        "value": True, "steps": len(steps),
        "why": "every step is proven: its moved side follows the stated rotation or screw "
               "motion over the stated angle without crossing the rest (convex hulls of its "
               "triangles' paths, checked over angle intervals), then leaves by one "
               "translation to infinity (direct sweep test)"}}


def _unproven(step: int, why: str) -> dict:
    return {"verified": {
        "value": False, "steps": 0,
        "why": "a plan of generalized motions (rotations, screw motions): each step's moved "
               "side is free for an infinitesimal motion of its kind, a necessary condition; "
               + (f"step {step} is not proven: {why}" if step else why)}}


def prove_step(asm: Assembly, moved: list[int], rest: list[int], motion: dict
               ) -> tuple[dict | None, str]:
    """``(proof, "")`` for one step (parts ``moved`` leaving ``rest`` by ``motion``, a step's
    motion record), or ``(None, why)``."""
    kind = motion.get("type")
    if kind == "translation":
        d = np.asarray(motion.get("direction") or motion.get("axis"), dtype=float)
        d = d / np.linalg.norm(d)
        if _frees(asm, moved, rest, None, 0.0, d):
            return {"test": "sweep", "source": "region"}, ""
        return None, "the translation is blocked further away"
    if kind not in ("rotation", "screw") or motion.get("axis") is None:
        return None, f"no finite-motion test for a motion of type {kind}"
    axis = np.asarray(motion["axis"], dtype=float)
    # the named motion (its axis signed by its sense, its pitch per turn), not the LP's
    # twist, whose zero components carry the solver's noise
    screw = Screw(np.asarray(motion.get("point") or np.zeros(3), dtype=float),
                  axis / np.linalg.norm(axis),
                  float(motion.get("pitch") or 0.0) / (2 * np.pi) if kind == "screw" else 0.0)
    joined = _joined(asm, moved, rest, screw)
    if screw.advance != 0 and not joined:
        return None, "a screw motion along no declared joint"
    tris = {k: np.asarray(asm.parts[k].mesh.triangles, dtype=float) for k in moved + rest}
    moving = np.concatenate([tris[k] for k in moved])
    fixed = np.concatenate([tris[k] for k in rest])
    angles = _angles(asm, moved, rest, screw, joined)
    bands = _joint_bands(asm, moved, rest, screw, joined, screw.advance * max(angles, default=0))
    eps = min(MOTION_EPS * asm.size, asm.length_tolerance / 100)  # an explicit, finer tolerance
    dirs = _directions(screw)
    start, intervals = 0.0, 0
    for angle in angles:
        got = check_motion(screw, moving, fixed, angle, eps, MIN_STEP, budget=PAIR_BUDGET,
                           start=start, bands=bands)
        intervals += got.intervals
        if not got.free:
            at = f"{np.degrees(got.blocked_at):.4g} degrees"
            if got.over_budget:
                return None, f"the motion check is over its budget after {at}"
            a, b = asm.ids[_owner(moved, tris, got.moving)], \
                asm.ids[_owner(rest, tris, got.fixed)]
            return None, f"turning, {a} meets {b} after {at}"
        start = angle
        sweep = _checker(asm, moved, rest, screw, angle)
        for d in dirs:
            if sweep.frees(*_sides(moved, rest), d):
                proof = {"test": "motion", "motion": "screw" if screw.advance else "rotation",
                         "angle": round(float(angle), 9),
                         "then": [round(float(x), 12) + 0.0 for x in d],
                         "intervals": intervals}
                if joined:
                    proof["joints"] = [[asm.ids[a], asm.ids[b]] for a, b in joined]
                return proof, ""
    return None, "no angle tried frees it by a translation along the axis or a coordinate axis"


def _joint_bands(asm: Assembly, moved: list[int], rest: list[int], screw: Screw,
                 joined: list[tuple[int, int]], shift: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~ndbg_cli.ndbg.generalized.finite.cylinder_bands` of the moving and the fixed
    triangles (``moved``'s and ``rest``'s, concatenated), with a fifth column: the index of
    the joint of ``joined`` a triangle's part belongs to (-1 for none: its cylinder facets
    are tested like any triangle). ``shift``: the motion's whole advance along the axis.

    A cylinder facet keeps its mark only as part of a connected surface of such facets
    that lies, as a whole, within the allowance (a slightly oval cam passes facet by facet,
    not as a surface), and only when the jointed part lies wholly across it over the length
    the surface sweeps: every triangle of the other part that the moving one passes there
    no nearer the axis than the surface less the allowance (a shank's) or no farther than
    it plus the allowance (a bore's). A hole narrower than its screw, a step in its mouth,
    would otherwise hide material behind its own rim."""
    tol = asm.length_tolerance
    info: dict[int, tuple] = {}
    for k in moved + rest:
        g = part_geometry(asm.parts[k], tol, CONTACT_ANGLE_TOL_RAD)
        # a facet's normal is off the radius at its centroid by up to half its facet angle
        b = cylinder_bands(g.triangles, screw, tol + g.sag,
                           g.smooth_angle / 2 + CONTACT_ANGLE_TOL_RAD)
        label = _surfaces(b, g.adjacency)
        z = screw.cylindrical(g.triangles)[0]
        info[k] = (b, label, z.min(axis=1), z.max(axis=1))
    for a, c in joined:  # a moves, c stays
        for mine, other, moves in ((a, c, shift), (c, a, -shift)):
            _across(info[mine], info[other], moves, tol)
    out = []
    for parts in (moved, rest):
        rows = []
        for k in parts:
            b = info[k][0]
            group = next((i for i, pair in enumerate(joined) if k in pair), -1)
            rows.append(np.column_stack([b, np.full(len(b), float(group))]))
        out.append(np.concatenate(rows))
    return out[0], out[1]


def _surfaces(bands: np.ndarray, adjacency: np.ndarray) -> np.ndarray:
    """Label ``(k,)`` of the connected surface of cylinder facets of one kind each facet of
    ``bands`` belongs to (-1 for other triangles); unmarks (kind 0) the facets of surfaces
    spreading over more radii than their largest allowance."""
    kind = bands[:, 3]
    facet = np.abs(kind) == 1
    label = np.full(len(bands), -1)
    if not facet.any():
        return label
    e = adjacency[facet[adjacency].all(axis=1)]
    e = e[kind[e[:, 0]] == kind[e[:, 1]]]
    comp = graph_components(len(bands), e)
    n = int(comp.max()) + 1
    lo, hi, allow = np.full(n, np.inf), np.full(n, -np.inf), np.zeros(n)
    np.minimum.at(lo, comp[facet], bands[facet, 0])
    np.maximum.at(hi, comp[facet], bands[facet, 1])
    np.maximum.at(allow, comp[facet], bands[facet, 2])
    keep = facet & ~(hi - lo > allow)[comp]
    bands[facet & ~keep, 3] = 0.0
    label[keep] = comp[keep]
    return label


def _across(mine: tuple, other: tuple, shift: float, tol: float) -> None:
    """Unmark the surfaces of ``mine`` (bands, labels, axial extents) that ``other``'s part
    does not lie wholly across over the length they sweep relative to it (``shift``: how far
    ``mine``'s part advances along the axis relative to ``other``'s)."""
    bands, label, z0, z1 = mine
    ob, _, oz0, oz1 = other
    for s in np.unique(label[label >= 0]):
        rows = np.flatnonzero(label == s)
        if bands[rows[0], 3] == 0:
            continue
        allow = bands[rows, 2].max()
        lo = z0[rows].min() + min(shift, 0.0) + tol
        hi = z1[rows].max() + max(shift, 0.0) - tol
        near = (oz1 > lo) & (oz0 < hi)
        if bands[rows[0], 3] > 0:  # a shank: the other part beyond it
            ok = (ob[near, 0] >= bands[rows, 0].min() - allow).all()
        else:  # a bore: the other part within it
            ok = (ob[near, 1] <= bands[rows, 1].max() + allow).all()
        if not ok:
            bands[rows, 3] = 0.0


def _owner(parts: list[int], tris: dict[int, np.ndarray], k: int) -> int:
    """The part of ``parts`` whose triangles (concatenated in that order) hold index ``k``."""
    ends = np.cumsum([len(tris[p]) for p in parts])
    return parts[int(np.searchsorted(ends, k, side="right"))]


def _joined(asm: Assembly, moved: list[int], rest: list[int], screw: Screw
            ) -> list[tuple[int, int]]:
    """Pairs ``(moved part, rest part)`` of a declared joint whose motion is ``screw``'s: the
    same line and the same advance per radian (either sense)."""
    out = []
    for j in asm.joints:
        a, b = asm.index(j.parts[0]), asm.index(j.parts[1])
        pair = (a, b) if a in moved and b in rest else (b, a) if b in moved and a in rest else None
        if pair is None:
            continue
        axis = np.asarray(j.axis, dtype=float) / np.linalg.norm(j.axis)
        off = np.asarray(j.point, dtype=float) - screw.center
        same_line = (abs(abs(axis @ screw.axis) - 1) <= 1e-9
                     and np.linalg.norm(off - (off @ screw.axis) * screw.axis)
                     <= 1e-9 * max(asm.size, 1.0))
        pitch = j.pitch / (2 * np.pi) if j.type == "screw" else 0.0
        # the hand of a thread is the sign of its advance along the turn's own axis, which
        # either sense of the turn keeps
        if same_line and abs(screw.advance - pitch) <= 1e-9 * max(asm.size, 1.0):
            out.append(pair)
    return out


def _angles(asm: Assembly, moved: list[int], rest: list[int], screw: Screw,
            joined: list[tuple[int, int]]) -> list[float]:
    """The angles the step is tried up to, ascending. A screw: the turn after which the moved
    side lies wholly past its jointed parts along the advance. A rotation: where faces line
    up (:data:`MAX_ANGLES` at most)."""
    if screw.advance:
        u = screw.axis * np.sign(screw.advance)
        far = max(float((np.asarray(asm.parts[b].mesh.vertices) @ u).max()) for _, b in joined)
        near = min(float((np.asarray(asm.parts[a].mesh.vertices) @ u).min()) for a in moved)
        return [max(far - near, 0.0) / abs(screw.advance) + 1e-9]
    return list(alignment_angles(_normals(asm, moved), _normals(asm, rest), screw.axis,
                                 1e-6)[:MAX_ANGLES])


def _normals(asm: Assembly, parts: list[int]) -> np.ndarray:
    """The distinct face normals (rounded to 1e-9) of ``parts``, those of the
    :data:`NORMALS` largest faces when there are more (a fine curved surface's facets)."""
    n = np.concatenate([np.asarray(asm.parts[k].mesh.face_normals) for k in parts])
    area = np.concatenate([np.asarray(asm.parts[k].mesh.area_faces) for k in parts])
    rounded = np.round(n, 9)
    first, inv = unique_rows(rounded)
    u = rounded[first]
    if len(u) > NORMALS:
        weight = np.bincount(inv, weights=area, minlength=len(u))
        u = u[np.sort(np.argsort(-weight, kind="stable")[:NORMALS])]
    return u


def _directions(screw: Screw) -> list[np.ndarray]:
    """Translations tried after the motion: along the advance (or the axis both ways), then
    the coordinate axes."""
    first = [screw.axis * np.sign(screw.advance)] if screw.advance else [screw.axis,
                                                                         -screw.axis]
    out: list[np.ndarray] = []
    for d in first + [s * e for e in np.eye(3) for s in (1.0, -1.0)]:
        if not any(np.allclose(d, x, atol=1e-12) for x in out):
            out.append(d)
    return out


def _frees(asm: Assembly, moved: list[int], rest: list[int], screw: Screw | None,
           angle: float, d: np.ndarray) -> bool:
    """Whether the parts ``moved``, turned by ``screw`` through ``angle`` (unmoved without a
    screw), leave the parts ``rest`` by a translation to infinity along ``d``."""
    return _checker(asm, moved, rest, screw, angle).frees(*_sides(moved, rest), d)


def _sides(moved: list[int], rest: list[int]) -> tuple[int, int]:
    """The bitmasks of the moved and the rest parts in a :func:`_checker` (moved first)."""
    m = (1 << len(moved)) - 1
    return m, ((1 << (len(moved) + len(rest))) - 1) ^ m


def _checker(asm: Assembly, moved: list[int], rest: list[int], screw: Screw | None,
             angle: float) -> SweepChecker:
    """The direct sweep test over the parts ``moved`` (first, turned by ``screw`` through
    ``angle``) and ``rest``, at the assembly's length tolerance."""
    parts = []
    for k in moved + rest:
        p = asm.parts[k]
        if screw is not None and k in moved:
            m = p.mesh
            p = make_part(p.id, screw.move(np.asarray(m.vertices, dtype=float), angle),
                          np.asarray(m.faces))[0]
        parts.append(p)
    return SweepChecker(Assembly(asm.name, tuple(parts), units=asm.units,
                                 tolerance=asm.length_tolerance))
