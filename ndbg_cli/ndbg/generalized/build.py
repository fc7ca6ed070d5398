"""The generalized-motion family: suggested rotations and screws (paper section 6), thread
semantics, and exact local-freedom checks with the twist LP (paper section 5.2;
:mod:`ndbg_cli.ndbg.generalized.twist`, :mod:`ndbg_cli.ndbg.generalized.motion_lp`).

Each motion suggested by the contacts and joints (:func:`suggested_motions`) becomes one
region of an ``NDBG(family="generalized")`` with its DBG (:func:`motion_dbgs`);
:func:`hybrid` adds them to the translations. :func:`generalized_partitionings` validates the
candidate partitionings exactly, and :func:`generalized_section` writes the report section.
Usage: ``rows = twist.contact_rows(asm, contacts)`` once per assembly, then the functions
above (and :func:`block_threads` on the translational NDBGs).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ...core.assembly import Assembly
from ...core.constants import GENERALIZED
from ..candidates import DEFAULT_CANDIDATE_LIMIT, connected_partitionings
from ..dbg import DBG
from ..model import NDBG, Partitioning, Region, partitionings
from .motion_lp import Thread, assembly_threads
from .motion_solver import MotionSolver
from .twist import ANGLE_TOL, ContactRows, Motion, contact_rows, group_blocks, same_twist, twist

#: Directions of two axis lines that differ by at most this angle (radians) are parallel.
AXIS_ANGLE_TOL = 1e-3
#: Two parallel axis lines are the same when each point is within this many length
#: tolerances of the other line.
LINE_FACTOR = 10.0
_SIN_AXIS = float(np.sin(AXIS_ANGLE_TOL))  # largest |a1 x a2| of parallel unit axes


def _canon(axis: np.ndarray) -> np.ndarray:
    """Unit axis with its first significant component positive (a line's direction)."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    k = int(np.argmax(np.abs(a) > 1e-9))
    return -a if a[k] < 0 else a


def _cross_norm(a: Sequence[float], b: Sequence[float]) -> float:
    """``|a x b|`` of two 3-vectors (scalar code: these are called per pair of lines)."""
    x = a[1] * b[2] - a[2] * b[1]
    y = a[2] * b[0] - a[0] * b[2]
    z = a[0] * b[1] - a[1] * b[0]
    return float((x * x + y * y + z * z) ** 0.5)


def _same_line(a1: np.ndarray, p1: np.ndarray, a2: np.ndarray, p2: np.ndarray,
               tol: float) -> bool:
    """Whether two axis lines (unit direction, point) coincide within the tolerances."""
    if _cross_norm(a1, a2) > _SIN_AXIS:
        return False
    d = [float(y) - float(x) for x, y in zip(p1, p2)]
    return _cross_norm(d, a1) <= tol and _cross_norm(d, a2) <= tol


def suggested_motions(asm: Assembly, contacts: Iterable[Any]) -> list[dict]:
    """Distinct suggested motion lines (one sense each), as dicts ``{"type", "axis",
    "point", "pitch", "sources"}`` (``point`` is ``None`` for translations, ``pitch`` 0 for
    rotations). The paper's hybrid considers all pure translations plus motions *suggested*
    by the contacts; here:

    * every cylindrical contact (``surface == "cylinder"`` with an ``axis``): the rotation
      about its axis line and the translation along it;
    * every manifest joint: ``revolute`` -> rotation about its axis line; ``screw`` -> the
      screw ``v = -w x point + pitch / (2 pi) w`` (advance ``pitch`` per turn).

    Motions of the same type on the same axis line are merged (``sources`` joined): two lines
    are the same when their directions differ by at most :data:`AXIS_ANGLE_TOL` (either
    orientation) and each one's point is within :data:`LINE_FACTOR` length tolerances of the
    other line; translations compare directions only; screws also need pitches within the
    length tolerance. Each becomes a region ``Region(-1, None, dbg, motion)`` (both senses)
    whose DBG has an arc ``i -> j`` iff ``i`` moving by the twist (``j`` fixed) penetrates
    ``j`` at some contact point: ``n . u > eps`` with
    :func:`~ndbg_cli.ndbg.generalized.twist.block_tolerance`."""
    tol = asm.length_tolerance
    line_tol = LINE_FACTOR * tol
    out: list[dict] = []
    flat: list[tuple[list[float], list[float] | None]] = []  # out's axis, point as floats

    def add(kind: str, axis, point, pitch: float, source: str) -> None:
        ax = _canon(np.asarray(axis, float))
        pt = None if point is None else np.asarray(point, float)
        if pt is not None:  # the point of the line closest to the origin
            pt = pt - float(pt @ ax) * ax
        fa, fp = ax.tolist(), None if pt is None else pt.tolist()
        for m, (ma, mp) in zip(out, flat):
            if m["type"] != kind:
                continue
            if kind == "translation":
                same = _cross_norm(ma, fa) <= _SIN_AXIS
            else:
                same = _same_line(ma, mp, fa, fp, line_tol) and abs(m["pitch"] - pitch) <= tol
            if same:
                if source not in m["sources"]:
                    m["sources"].append(source)
                return
        out.append({"type": kind, "axis": ax, "point": pt, "pitch": float(pitch),
                    "sources": [source]})
        flat.append((fa, fp))

    # Merging is first come, first kept (a line near two others may join either): the
    # contacts are read by their parts' names, so that the merged lines, and the
    # partitionings they give, do not depend on the part order (stable within a pair)
    cyl = [c for c in contacts
           if getattr(c, "surface", None) == "cylinder" and getattr(c, "axis", None) is not None]
    for c in sorted(cyl, key=lambda c: sorted((_pid(asm, c.a), _pid(asm, c.b)))):
        a, b = _pid(asm, c.a), _pid(asm, c.b)
        center = getattr(c, "center", None)
        src = f"cylinder contact {a}-{b}"
        if center is not None:
            add("rotation", c.axis, center, 0.0, src)
        add("translation", c.axis, None, 0.0, src)
    for j in asm.joints:
        src = f"{j.type} joint {j.parts[0]}-{j.parts[1]}"
        if j.type == "screw":
            add("screw", j.axis, j.point, float(j.pitch), src)
        else:
            add("rotation", j.axis, j.point, 0.0, src)
    return out


def _pid(asm: Assembly, ref: Any) -> str:
    return asm.parts[int(ref)].id if isinstance(ref, (int, np.integer)) else str(ref)


def motion_record(m: dict, sense: int) -> dict:
    """The ``Region.motion`` dict of a suggested line ``m`` in one sense: ``type``,
    ``axis`` (signed by ``sense`` for rotations/screws: right-hand rule; the direction for
    translations), ``point``, ``pitch`` (advance per turn along ``axis``), ``sense``,
    ``source`` (joined sources) and ``twist`` (origin twist, 6 floats)."""
    ax = m["axis"] * sense
    xi = twist(m["type"], m["axis"], m["point"] if m["point"] is not None else (0, 0, 0),
               m["pitch"], sense)
    rec = {"type": m["type"], "axis": [float(x) for x in ax],
           "point": None if m["point"] is None else [float(x) for x in m["point"]],
           "pitch": float(m["pitch"]) if m["type"] != "translation" else None,
           "sense": int(sense), "source": "; ".join(m["sources"]),
           "twist": [float(x) for x in xi]}
    if m["type"] == "translation":
        rec["direction"] = rec["axis"]
    return rec


# ----------------------------------------------------------------------------- threads
def threaded_pairs(asm: Assembly, threads_as_cylinders: bool = False) -> set[tuple[str, str]]:
    """``(moving, fixed)`` part ids of every declared screw joint (empty with
    ``threads_as_cylinders``): pairs that cannot translate relative to each other.

    Unless ``threads_as_cylinders``, a threaded pair may move relative to each other only by
    its screw (either sense): it gets arcs both ways in every translational region
    (:func:`block_threads`) and in every suggested motion that is not the joint's screw, and
    the LP constrains the relative twist to the screw's line
    (:class:`~ndbg_cli.ndbg.generalized.motion_lp.Thread`). With ``threads_as_cylinders`` the
    joint is no thread (its screw is still suggested) and the contact a plain cylinder."""
    if threads_as_cylinders:
        return set()
    return {(j.parts[0], j.parts[1]) for j in asm.joints if j.type == "screw"}


def threads(asm: Assembly, threads_as_cylinders: bool = False) -> list[Thread]:
    """The LP's :class:`~ndbg_cli.ndbg.generalized.motion_lp.Thread` constraints of the declared
    screw joints (:func:`ndbg_cli.ndbg.generalized.motion_lp.assembly_threads`)."""
    return assembly_threads(asm, threads_as_cylinders)


def block_threads(ndbg: NDBG, pairs: Iterable[tuple[str, str]]) -> NDBG:
    """``ndbg`` (a translational family) with arcs ``a -> b`` and ``b -> a`` added in every
    region for each threaded pair ``(a, b)`` (part ids; pairs naming absent parts are
    skipped): a nut on a thread cannot translate in any direction, only screw."""
    extra = ndbg.mutual_blocks(pairs)
    if extra is None:
        return ndbg
    regions = tuple(dataclasses.replace(r, dbg=r.dbg.union(extra)) for r in ndbg.regions)
    stats = dict(ndbg.stats)
    stats["threaded_pairs"] = sorted([list(p) for p in pairs])
    return dataclasses.replace(ndbg, regions=regions, stats=stats)


# ----------------------------------------------------------------------------- the family
def motion_dbg(rows: ContactRows, xi: np.ndarray, thread_list: Sequence[Thread] = ()) -> DBG:
    """DBG of the origin twist ``xi``: arc ``a -> b`` where ``a`` moving by ``xi`` pushes into ``b``
    faster than :func:`~ndbg_cli.ndbg.generalized.twist.block_tolerance`, ``b -> a`` where ``b``
    moving does (``-n . u > eps``); threaded pairs block each other unless ``xi`` is their screw."""
    return motion_dbgs(rows, np.asarray(xi, float)[None, :], thread_list)[0]


def motion_dbgs(rows: ContactRows, twists: np.ndarray, thread_list: Sequence[Thread] = ()
                ) -> list[DBG]:
    """:func:`motion_dbg` of every origin twist in ``twists`` ``(R, 6)``, vectorised: the
    speeds are one product ``[n, p x n] @ twists.T`` ``(K, R)``; the blocking rows are
    reduced per run of rows of one part pair, then per distinct arc, before any Python
    loop (which visits only the arcs found)."""
    X = np.asarray(twists, float).reshape(-1, 6)
    n = rows.n
    succ = [[0] * n for _ in range(len(X))]
    if len(rows.a):
        P, N = rows.points, rows.normals
        # a C-ordered right factor: with the transposed view OpenBLAS may split this small
        # product over threads, slow on a busy machine (same values either way)
        S = np.hstack([N, np.cross(P, N)]) @ np.ascontiguousarray(X.T)
        fwd, bwd = _pushes(P, S, X, rows.length_tol)
        fwd, bwd = group_blocks(rows, fwd), group_blocks(rows, bwd)
        a, b = rows.a, rows.b
        run = np.flatnonzero(np.r_[True, (a[1:] != a[:-1]) | (b[1:] != b[:-1])])
        blocked = np.vstack([np.logical_or.reduceat(fwd, run, axis=0),
                             np.logical_or.reduceat(bwd, run, axis=0)])  # (2 runs, R)
        code = np.r_[a[run] * n + b[run], b[run] * n + a[run]]  # arc i -> j as i n + j
        arcs, inv = np.unique(code, return_inverse=True)
        hit = np.zeros((len(arcs), len(X)), dtype=np.int64)
        np.add.at(hit, inv.ravel(), blocked.astype(np.int64))
        k, hit_r = np.nonzero(hit)
        for r, i, j in zip(hit_r.tolist(), (arcs[k] // n).tolist(), (arcs[k] % n).tolist()):
            if i != j:
                succ[r][i] |= 1 << j
    for r in range(len(X)):
        for t in thread_list:
            if not same_twist(rows, X[r], np.asarray(t.twist, float)):
                for i, j in ((t.a, t.b), (t.b, t.a)):
                    if i != j:
                        succ[r][i] |= 1 << j
    return [DBG(tuple(s)) for s in succ]


def _pushes(P: np.ndarray, S: np.ndarray, X: np.ndarray, length_tol: float,
            chunk: int = 1 << 15) -> tuple[np.ndarray, np.ndarray]:
    """Which rows push in under which twists: ``S`` ``(K, R)`` the normal speeds of the rows at
    ``P`` ``(K, 3)`` under the origin twists ``X`` ``(R, 6)``; returns ``S > eps`` (``a`` into
    ``b``) and ``S < -eps`` (``b`` into ``a``), bool ``(K, R)``, with ``eps = length_tol |w| +
    ANGLE_TOL |v + w x p|`` (:func:`~ndbg_cli.ndbg.generalized.twist.block_tolerance`). Computed in
    blocks of about ``chunk`` entries into reused buffers (cache-sized, no fresh pages per
    operation); each entry's arithmetic is the unblocked one."""
    K, R = S.shape
    fwd = np.empty((K, R), dtype=bool)
    bwd = np.empty((K, R), dtype=bool)
    V, W = X[:, :3], X[:, 3:]
    wtol = length_tol * np.linalg.norm(W, axis=1)
    step = max(1, chunk // max(R, 1))
    buf = np.empty((4, min(step, K), R))
    for lo in range(0, K, step):
        p = P[lo:lo + step]
        m = len(p)
        eps, tmp = buf[0, :m], buf[3, :m]
        for c, (i, j) in enumerate(((1, 2), (2, 0), (0, 1))):  # u_c = v_c + p_j w_i - p_i w_j
            uc = buf[c, :m]
            np.multiply.outer(p[:, j], W[:, i], out=uc)
            uc += V[:, c]
            np.multiply.outer(p[:, i], W[:, j], out=tmp)
            uc -= tmp
            uc *= uc
            if c:
                eps += uc
        np.sqrt(eps, out=eps)
        eps *= ANGLE_TOL
        eps += wtol
        s = S[lo:lo + step]
        np.greater(s, eps, out=fwd[lo:lo + step])
        np.negative(eps, out=eps)
        np.less(s, eps, out=bwd[lo:lo + step])
    return fwd, bwd


def generalized_ndbg(asm: Assembly, contacts: Sequence[Any] | None = None, *,
                     threads_as_cylinders: bool = False, rows: ContactRows | None = None
                     ) -> NDBG:
    """``NDBG(family="generalized")`` with one region per suggested motion and sense
    (:func:`suggested_motions`). ``stats``: ``suggested`` (lines), ``regions``,
    ``contact_points``."""
    contacts = list(contacts or [])
    rows = rows if rows is not None else contact_rows(asm, contacts)
    thr = threads(asm, threads_as_cylinders)
    lines = suggested_motions(asm, contacts)
    recs = [motion_record(m, sense) for m in lines for sense in (1, -1)]
    dbgs = motion_dbgs(rows, np.array([r["twist"] for r in recs]).reshape(-1, 6), thr)
    regions = [Region(-1, None, dbg, motion=rec) for rec, dbg in zip(recs, dbgs)]
    stats = {"suggested": len(lines), "regions": len(regions),
             "contact_points": int(len(rows.a)),
             "threaded_pairs": sorted([list(p) for p in threaded_pairs(asm,
                                                                       threads_as_cylinders)])}
    return NDBG(family=GENERALIZED, ids=tuple(asm.ids), regions=tuple(regions),
                space_dimension=asm.dimension, stats=stats)


def hybrid(translational: NDBG, suggested: NDBG) -> NDBG:
    """The paper's hybrid (section 6): the translational regions (with threads already
    blocked) followed by the suggested motions, as one ``generalized`` family."""
    if translational.ids != suggested.ids:
        raise ValueError("the two NDBGs are over different parts")
    stats = {"translational_regions": len(translational.regions),
             "suggested_regions": len(suggested.regions)}
    return NDBG(family=GENERALIZED, ids=suggested.ids,
                regions=translational.regions + suggested.regions,
                space_dimension=suggested.space_dimension, stats=stats)


def contact_neighbours(rows: ContactRows) -> list[int]:
    """Undirected contact graph as neighbour bitmasks (for :class:`ConnectivityTest`)."""
    nb = [0] * rows.n
    for a, b in set(zip(rows.a.tolist(), rows.b.tolist())):
        nb[a] |= 1 << b
        nb[b] |= 1 << a
    return nb


def _region_twists(rows: ContactRows, ndbg: NDBG) -> tuple[np.ndarray, list[int]]:
    """Scaled twists of the regions carrying a motion, normalised to the LP's box
    (``max |x_i| = 1``), with their region indices; a twist using a component the rows'
    LP may not (out of the plane of a 2D assembly) is left out."""
    ids = [k for k, r in enumerate(ndbg.regions)
           if r.motion is not None and r.motion.get("twist") is not None]
    xi = np.array([ndbg.regions[k].motion["twist"] for k in ids], float).reshape(-1, 6)
    X = np.hstack([xi[:, :3] + np.cross(xi[:, 3:], rows.center), rows.scale * xi[:, 3:]])
    big = np.abs(X).max(axis=1, initial=0.0)
    ok = (big > 0) & ~np.any(X[:, ~rows.free_axes] != 0.0, axis=1)
    return X[ok] / big[ok, None], [k for k, keep in zip(ids, ok) if keep]


def _validate(asm: Assembly, rows: ContactRows, ndbg_gen: NDBG, mask: int | None, *,
              connected: bool, limit: int | None, solver: MotionSolver
              ) -> tuple[list[tuple[Partitioning, Motion, str]], list[Partitioning], bool]:
    """:func:`generalized_partitionings` with each valid motion's source (``"suggested"`` or
    ``"lp"``) and whether the candidate list was truncated.

    The work stays near the cost of the NDBG itself. Candidates come from a search over
    connected sets per distinct DBG (:func:`connected_partitionings`; a motion and its
    reverse searched once), polynomial per candidate, not from enumerating every free set (a
    DBG with few arcs has exponentially many). A split that some translation frees needs no
    rotation: a few translations (axes, suggested translations, frequent normals) are
    checked on the rows first (:meth:`MotionSolver.translation_frees`). The rest get the LP
    (memoised; a split's reverse reuses its answer), whose stages a locking certificate
    skips when it proves them empty. Every shortcut decides a split exactly as the LP would
    (a witness is a feasible LP point; a certificate bounds every LP-feasible motion); only
    the motion shown may be a different freeing motion than the LP's."""
    if connected:
        cands, truncated = connected_partitionings(ndbg_gen, contact_neighbours(rows), mask,
                                                   limit=limit)
    else:
        cands, truncated = partitionings(ndbg_gen, mask, limit=limit)
    X, region_ids = _region_twists(rows, ndbg_gen)
    where = {k: i for i, k in enumerate(region_ids)}
    speeds = solver.speeds(X) if len(X) else None
    trans = {i for i, k in enumerate(region_ids)
             if ndbg_gen.regions[k].motion.get("type") == "translation"}
    if speeds is not None:
        speeds.prefetch([(p.moved, p.rest) for p in cands])
    valid, rejected = [], []
    for p in cands:
        found = None
        if speeds is not None:
            mine = [where[k] for k in p.regions if k in where]
            order = [i for i in mine if i in trans] + [i for i in mine if i not in trans]
            found = solver.witness(speeds, p.moved, p.rest, order, sliding=trans)
        if found is not None:
            valid.append((p, found[1], "suggested"))
            continue
        mo = solver(p.moved, p.rest)
        if mo is None or (mo.broken == 0 and mo.type == "rotation"):
            rejected.append(p)
        else:
            valid.append((p, mo, "lp"))
    return valid, rejected, truncated


def generalized_partitionings(asm: Assembly, contacts: Sequence[Any] | ContactRows,
                              ndbg_gen: NDBG, mask: int | None = None, *,
                              threads_as_cylinders: bool = False, connected: bool = True,
                              limit: int = DEFAULT_CANDIDATE_LIMIT,
                              solver: MotionSolver | None = None
                              ) -> tuple[list[tuple[Partitioning, Motion]], list[Partitioning]]:
    """Validate the candidate partitionings of ``ndbg_gen`` inside ``mask``.

    Returns ``(valid, rejected)``: ``valid`` pairs each candidate with a motion that frees
    ``moved`` from ``rest`` (1-handed monotone verdict for this subassembly: a candidate
    exists iff ``valid`` is non-empty); ``rejected`` are candidates the exact test refutes.
    A motion along which every contact slides counts (a pin sliding out of its hole, a
    screw turning out) unless it is a pure rotation, which keeps the parts in place.

    The motion is, when one is, a suggested motion of a region listing the candidate
    (translations first, then by region) checked on the split's contact rows with the LP's
    tolerances (:meth:`MotionSolver.witness`): the LP would then find a motion too, so it is
    not solved. Otherwise the LP decides (:class:`MotionSolver`; it proves locked stages
    with a certificate before solving). With ``connected`` both sides must be connected in
    the contact graph and the candidates come from :func:`connected_partitionings`; at most
    ``limit`` are checked.
    """
    rows = contacts if isinstance(contacts, ContactRows) else contact_rows(asm, contacts)
    solver = solver or MotionSolver(rows, threads(asm, threads_as_cylinders))
    valid, rejected, _ = _validate(asm, rows, ndbg_gen, mask, connected=connected,
                                   limit=limit, solver=solver)
    return [(p, mo) for p, mo, _ in valid], rejected


def needs_rotation(asm: Assembly, rows: ContactRows, ndbg_gen: NDBG | None = None, *,
                   candidates: Iterable[int] = (), threads_as_cylinders: bool = False,
                   limit: int = DEFAULT_CANDIDATE_LIMIT, solver: MotionSolver | None = None
                   ) -> list[tuple[int, Motion]]:
    """Subassemblies free under some twist but under no translation (the paper's Fig. 5),
    see :meth:`MotionSolver.needs_rotation`.

    Checked: each single part against the rest, the moved sides of ``ndbg_gen``'s candidate
    partitionings of the whole assembly (up to ``limit``), and ``candidates`` (bitmasks).
    A partition is reported once, moving the side without the base part (else the smaller
    side). Returns ``(moved mask, motion found by the full LP)`` pairs, in order of check.
    """
    full = (1 << len(asm)) - 1
    solver = solver or MotionSolver(rows, threads(asm, threads_as_cylinders),
                                    directions=translation_axes(ndbg_gen))
    todo = [1 << i for i in range(len(asm))]
    if ndbg_gen is not None:
        cands, _ = partitionings(ndbg_gen, full, limit=limit)
        todo += [p.moved for p in cands]
    todo += list(candidates)
    base = asm.index(asm.base) if asm.base is not None else None
    sides = list(dict.fromkeys(_moved_side(s, full, base) for s in todo if s not in (0, full)))
    solver.translation_speeds().prefetch([(s, full & ~s) for s in sides])
    out = []
    for s in sides:
        mo = solver.needs_rotation(s, full & ~s)
        if mo is not None:
            out.append((s, mo))
    return out


def _moved_side(s: int, full: int, base: int | None) -> int:
    """The side of the partition ``{s, full \\ s}`` reported as moving: the one without the
    base part, else the smaller one (ties: the one without the lowest part index)."""
    c = full & ~s
    if base is not None:
        return c if (s >> base) & 1 else s
    if c.bit_count() != s.bit_count():
        return s if s.bit_count() < c.bit_count() else c
    return s if not s & 1 else c


def translation_axes(ndbg: NDBG | None) -> list[list[float]]:
    """Directions of the suggested translations of a generalized NDBG (for
    :meth:`MotionSolver.translation_frees`)."""
    if ndbg is None:
        return []
    return [r.motion["axis"] for r in ndbg.regions
            if r.motion is not None and r.motion.get("type") == "translation"]


# ----------------------------------------------------------------------------- report
def generalized_section(asm: Assembly, ndbg: NDBG, contacts: Sequence[Any] | ContactRows, *,
                        threads_as_cylinders: bool = False,
                        limit: int = DEFAULT_CANDIDATE_LIMIT) -> dict:
    """The report's ``generalized`` section (schema: ``schemas/fragments/generalized.json``):
    the suggested motions with their DBG arcs (by part id), the threaded pairs, the
    subassemblies that need a rotation (with the LP's motion), and the validated candidate
    partitionings of the whole assembly (:func:`generalized_partitionings`, both sides
    contact-connected).

    ``candidates`` lists at most ``limit`` partitionings (``candidate_limit``;
    ``candidates_truncated`` says whether the limit or the search budget cut the list), each
    with ``motion_source``: ``"suggested"`` when the motion is a suggested one checked on the
    rows, ``"lp"`` when the LP found it. ``checks`` counts the work: ``lp`` HiGHS solves,
    ``certified`` LP stages proven empty by a locking certificate, ``witnessed`` splits
    decided without either. The needs-rotation motions always come from the LP."""
    rows = contacts if isinstance(contacts, ContactRows) else contact_rows(asm, contacts)
    motions = []
    for k, r in enumerate(ndbg.regions):
        if r.motion is None:
            continue
        motions.append({"region": k, **{key: r.motion.get(key) for key in
                                        ("type", "axis", "point", "pitch", "sense", "source")},
                        "arcs": [[ndbg.ids[i], ndbg.ids[j]] for i, j in r.dbg.arcs()]})
    solver = MotionSolver(rows, threads(asm, threads_as_cylinders),
                          directions=translation_axes(ndbg))
    valid, rejected, truncated = _validate(asm, rows, ndbg, None, connected=True, limit=limit,
                                           solver=solver)
    rot = needs_rotation(asm, rows, candidates=[p.moved for p, _, _ in valid], solver=solver)
    return {
        "threads_as_cylinders": threads_as_cylinders,
        "threaded_pairs": sorted([list(p) for p in threaded_pairs(asm, threads_as_cylinders)]),
        "tolerances": {"length": rows.length_tol, "scale": rows.scale,
                       "slide": rows.slide_tol, "break": rows.break_tol},
        "suggested_motions": motions,
        "needs_rotation": [{"parts": ndbg.names(s), "motion": mo.record()} for s, mo in rot],
        "candidates": [{"moved": ndbg.names(p.moved), "rest": ndbg.names(p.rest),
                        "regions": list(p.regions), "motion": mo.record(),
                        "motion_source": src}
                       for p, mo, src in valid],
        "rejected_candidates": [{"moved": ndbg.names(p.moved), "rest": ndbg.names(p.rest)}
                                for p in rejected],
        "candidate_limit": limit,
        "candidates_truncated": truncated,
        "checks": dict(solver.stats),
    }


