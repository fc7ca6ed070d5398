"""Infinitesimal rigid motions (twists): the 6D contact constraints, their tolerances and the
naming of a motion (paper section 5.2, Fig. 5 and 6). The LP over these rows is
:mod:`ndbg_cli.ndbg.generalized.motion_lp`.

A twist ``X = (v, w)`` moves a point ``p`` with velocity ``v + w x p`` (about the assembly
origin). A contact point ``p`` between parts ``a`` and ``b`` has a unit normal ``n`` out of
``a`` into ``b``; moving ``a`` (``b`` staying) pushes into ``b`` iff ``n . u(p) > 0``, the
translation rule of paper section 4.3 applied to each point's velocity. So the row
``g = (n, p x n)`` allows ``X`` iff ``g . X <= 0`` (breaks the contact if ``< 0``, slides if
``= 0``); the paper's ``n_F J_V dX >= 0`` uses the fixed face's normal ``-n``. When ``b`` is
the part that moves, the row is ``-g``.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import cached_property, lru_cache
from typing import Any

import numpy as np
from scipy.spatial import ConvexHull

from ...core.assembly import Assembly
from ...geometry.vectors import plane_basis, unit

# Scaling. With L the model's size and c its centre (Assembly.size and .centre: they turn with
# the model, as the bounding box's diagonal and centre do not), the LP works with the scaled,
# centred twist x = (v + w x c, L w): both halves are speeds in assembly units (the rotational
# half is that of a point at distance L from the axis), so the box |x_i| <= 1 treats
# translation and rotation alike and every row g' = (n, (p - c) x n / L) has speeds of order 1.
# The tolerances below are dimensionless in these units, hence scale-invariant.

#: Angular tolerance (radians) for comparing directions: the project's sphere tolerance.
ANGLE_TOL = 1e-6
#: Largest ``|G_k x|`` of a sliding row, in the LP's scaled speed units (null-space and
#: polishing computations).
SLIDE_TOL = 1e-6
#: Smallest separation speed of a broken row, in the LP's scaled speed units: 1000 times
#: :data:`LP_SLACK`, so a spurious motion would need ``L / r > 1000``. A screw of pitch ``h``
#: separates at about ``h / (2 pi L)`` (4e-3 for a 1.25 mm thread on a 50 mm model): threads
#: finer than ``2 pi L BREAK_TOL`` (0.6 mm on a 1 m model) are missed.
BREAK_TOL = 1e-4
#: Allowed violation of each LP row, ``G x <= LP_SLACK`` (scaled units): the order of the
#: rounding in CAD normals and axes and of HiGHS's own feasibility tolerance. A larger
#: allowance lets a part turn about an axis close to a small pin (radius ``r``) while
#: violating the pin's rows by the allowance, breaking far contacts ``L / r`` times faster (the
#: bell's armature "came out" about its 1.5 mm peg with 1e-4). Noise in the contact data is
#: removed before (exact planar normals, radial cylinder normals).
LP_SLACK = 1e-7
#: A twist whose rotational speed ``L |w|`` is below this fraction of its largest component is
#: read as a pure translation.
TRANSLATION_FRACTION = 1e-6
#: Largest angle (radians) between a curved contact's normals and the radial directions
#: about a declared joint's axis for the contact to be read as a surface of revolution about
#: it: 20 degrees, i.e. cylinders tessellated with at least 9 facets per turn.
REVOLUTION_ANGLE = float(np.radians(20.0))
#: A screw whose advance per turn is at most ``PITCH_FACTOR`` length tolerances is a rotation.
PITCH_FACTOR = 10.0
#: Two twists are the same motion when their normalised scaled twists differ by at most this.
TWIST_TOL = 1e-6


@dataclass(frozen=True)
class ContactRows:
    """Every contact point of an assembly, flattened (built once, sliced per split).

    ``points`` ``(K, 3)`` and ``normals`` ``(K, 3)`` (unit, out of part ``a[k]`` into part
    ``b[k]``), ``a``/``b`` ``(K,)`` part indices, ``contact`` ``(K,)`` the index of the contact
    each row comes from, ``group`` ``(K,)`` non-decreasing group ids (see
    :func:`contact_rows`). ``center`` ``(3,)`` and ``scale`` (``L``) define the LP's scaled
    twist; ``length_tol`` is the assembly's length tolerance.
    """

    points: np.ndarray
    normals: np.ndarray
    a: np.ndarray
    b: np.ndarray
    contact: np.ndarray
    n: int
    center: np.ndarray
    scale: float
    length_tol: float
    group: np.ndarray
    planar: bool = False

    @cached_property
    def scaled(self) -> np.ndarray:
        """``(K, 6)`` rows ``(n, (p - c) x n / L)`` in the LP's scaled units, part ``a[k]``
        moving (built once; the LP of a split takes its rows from here)."""
        mom = np.cross(self.points - self.center, self.normals) / self.scale
        return np.hstack([self.normals, mom]).reshape(-1, 6)

    @property
    def free_axes(self) -> np.ndarray:
        """``(6,)`` bool: the scaled twist components that may move (2D assemblies, embedded
        at z = 0: only ``v_x``, ``v_y`` and ``w_z``)."""
        return np.array([True, True, False, False, False, True]) if self.planar \
            else np.ones(6, dtype=bool)

    @property
    def slide_tol(self) -> float:
        """Largest ``|G_k x|`` of a sliding row (scaled units, dimensionless)."""
        return SLIDE_TOL

    @property
    def break_tol(self) -> float:
        """Separation speed above which a row is broken, in the LP's scaled units."""
        return BREAK_TOL


def _part_index(asm: Assembly, ref: Any) -> int:
    if isinstance(ref, (int, np.integer)):
        return int(ref)
    return asm.index(str(ref))


#: Multiplier of the normal hash in :func:`_reduce_keep` (a prime above 2 ** 31).
_HASH = 2_147_483_659


def _raw_rows(c: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
    """The first step of :func:`contact_points`: points ``(m, 3)``, point normals ``(m, 3)``
    and the contact's normals ``(g, 3)`` (2D embedded at z = 0), and whether the point
    normals are final (one unit planar normal per point); else they are still to be made
    unit and signed (:func:`~ndbg_cli.geometry.vectors.unit`, :func:`_signed`)."""
    pts = _pad3(np.asarray(c.points, dtype=float)).reshape(-1, 3)
    if getattr(c, "kind", None) == "planar" and np.size(c.normals) in (2, 3):  # one normal
        n0 = _pad3(np.asarray(c.normals, dtype=float)).reshape(-1, 3)[0]
        return pts, np.repeat(unit(n0)[None, :], len(pts), axis=0), np.zeros((0, 3)), True
    pn = getattr(c, "point_normals", None)
    gens = _pad3(np.asarray(c.normals, dtype=float)).reshape(-1, 3)
    if pn is None and len(gens) == len(pts) and not hasattr(c, "kind"):
        pn = gens  # 2D contacts: one normal per point
    pn = None if pn is None else _pad3(np.asarray(pn, dtype=float)).reshape(-1, 3)
    if pn is None or len(pn) != len(pts):
        pn = np.repeat(gens[:1], len(pts), axis=0)
    return pts, pn, gens, False


def _signed(pn: np.ndarray, gens: np.ndarray) -> np.ndarray:
    """Unit point normals ``pn`` ``(m, 3)``, negated as a whole when they agree better
    with ``-gens`` than with the contact's normals ``gens`` ``(g, 3)``."""
    if len(gens) and len(pn):
        dots = pn @ gens.T  # (m, g); -pn @ gens.T is exactly -dots
        if (-dots.min(axis=1)).sum() > dots.max(axis=1).sum():
            return -pn
    return pn


def _lines(c: Any, joint_axes: Sequence[tuple[np.ndarray, np.ndarray]]
           ) -> list[tuple[np.ndarray, np.ndarray, bool]]:
    """The axis lines ``(unit axis, point, check)`` a contact's points may be turned about
    (:func:`contact_points`): its own cylinder axis (not checked), else, for a curved
    contact, the ``joint_axes`` (checked for a surface of revolution)."""
    axis, center = getattr(c, "axis", None), getattr(c, "center", None)
    if getattr(c, "surface", None) == "cylinder" and axis is not None and center is not None:
        return [(unit(np.asarray(axis, dtype=float)), np.asarray(center, dtype=float), False)]
    if getattr(c, "kind", None) == "curved":
        return [(np.asarray(ax, float), np.asarray(q, float), True) for ax, q in joint_axes]
    return []


def contact_points(c: Any, length_tol: float,
                   joint_axes: Sequence[tuple[np.ndarray, np.ndarray]] = ()
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Rows of one contact: points ``(m, 3)`` and unit normals ``(m, 3)`` (out of ``a``).

    Uses ``point_normals`` when it matches ``points`` (flipped as a whole if they disagree in
    sign with the contact's ``normals``), else the contact's first normal. On a cylinder with
    ``axis`` and ``center``, and on a curved contact of a declared joint's two parts that is a
    surface of revolution about one of the ``joint_axes`` ``(unit axis, point)`` (every
    normal within :data:`REVOLUTION_ANGLE` of the radial direction, either sign, about that
    axis), each normal loses its axial component and each point is turned about the axis,
    at its own radius and height, onto the line where that normal is exactly radial: the
    rows then let the part turn about the axis exactly; of the points sharing a normal only
    the lowest and highest along the axis are kept (exact, see :func:`reduce_points`).
    (:func:`contact_rows` does the same for all contacts at once.) Without this, a tessellated
    cylinder's facet normals, radial only on each facet's centre line, would spuriously block
    the rotation about the cylinder's own axis.
    """
    pts, pn, gens, final = _raw_rows(c)
    if final:
        return pts, pn
    pn = _signed(unit(pn), gens)
    if len(pts) == 0:
        return pts, pn
    start = np.zeros(1, dtype=np.int64)
    for ax, q, check in _lines(c, joint_axes):
        moved, across, ok, keep = _turn(pts, pn, ax[None, :], q[None, :], start, check,
                                        length_tol)
        if ok[0]:
            return moved[keep], across[keep]
    return pts, pn


def _turn(pts: np.ndarray, pn: np.ndarray, axes: np.ndarray, centres: np.ndarray,
          starts: np.ndarray, check: bool, length_tol: float
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`contact_points`' turn about an axis line for ``E`` contacts at once: ``pts``,
    ``pn`` ``(M, 3)`` their points and unit normals, contact ``e``'s rows from ``starts[e]``
    (``(E,)``, increasing, none empty); ``axes`` (unit) and ``centres`` ``(E, 3)`` their
    lines. Returns the turned points and radial unit normals ``(M, 3)``, ``ok`` ``(E,)``
    (turned: radii above ``length_tol``, normals off the axis by more than 1e-9, with
    ``check`` within :data:`REVOLUTION_ANGLE` of radial) and ``keep`` ``(M,)`` (a turned
    contact's lowest and highest point per normal, angle rounded to 1e-6 rad; every row of
    the others). Products with a contact's own vectors are taken per contact, as for one
    contact (the same rows bit for bit)."""
    counts = np.diff(np.r_[starts, len(pts)])
    seg = np.repeat(np.arange(len(starts)), counts)
    bounds = list(zip(starts.tolist(), (starts + counts).tolist()))
    ax_rows = axes[seg]
    rel = pts - centres[seg]
    h = np.concatenate([rel[s:e] @ ax for (s, e), ax in zip(bounds, axes)])
    ph = np.concatenate([pn[s:e] @ ax for (s, e), ax in zip(bounds, axes)])
    radial = rel - h[:, None] * ax_rows
    r = np.linalg.norm(radial, axis=1)
    across = pn - ph[:, None] * ax_rows
    na = np.linalg.norm(across, axis=1)
    ok = ~np.logical_or.reduceat((r <= length_tol) | (na <= 1e-9), starts)
    with np.errstate(divide="ignore", invalid="ignore"):  # rows of contacts not turned
        across /= na[:, None]
        cos = np.sum(radial * across, axis=1) / r
    if check:
        ok &= np.logical_and.reduceat(np.abs(ph) <= np.sin(REVOLUTION_ANGLE), starts)
        ok &= np.logical_and.reduceat(np.abs(cos) >= np.cos(REVOLUTION_ANGLE), starts)
    side = np.where(cos < 0, -1.0, 1.0)
    # the point moves round the axis onto the line where its facet normal is radial
    moved = centres[seg] + h[:, None] * ax_rows + (r * side)[:, None] * across
    # rows sharing a normal differ only by the height h (the radius drops out of p x n):
    # keep the lowest and highest point of each normal (one angle about the axis each)
    ang = np.zeros(len(pts))
    for (s, e), ax, turned in zip(bounds, axes, ok.tolist()):
        if turned:
            e1, e2 = _across(ax)
            ang[s:e] = np.arctan2(across[s:e] @ e2, across[s:e] @ e1)
    # one integer per (contact, angle): the angles are multiples of 1e-6 rad, |angle| <= pi
    code = seg * 2 ** 23 + (np.rint(np.round(ang, 6) * 1e6).astype(np.int64) + 2 ** 22)
    order = np.argsort(code, kind="stable")
    new = np.r_[True, code[order][1:] != code[order][:-1]]
    keep = ~ok[seg]
    keep[order[_extreme(h[order], new, low=True)]] = True
    keep[order[_extreme(h[order], new, low=False)]] = True
    return moved, across, ok, keep


def _extreme(v: np.ndarray, new: np.ndarray, low: bool) -> np.ndarray:
    """Per run of ``v`` ``(M,)`` (a run starts where ``new`` is set, ``new[0]`` is), the
    position of its smallest value, the first one if several (``low``), else of its largest
    value, the last one if several: a stable sort's first and last element by ``v``."""
    starts = np.flatnonzero(new)
    run = np.cumsum(new) - 1
    best = (np.minimum if low else np.maximum).reduceat(v, starts)
    pos = np.flatnonzero(v == best[run])
    r = run[pos]
    change = r[1:] != r[:-1]
    return pos[np.r_[True, change]] if low else pos[np.r_[change, True]]


def reduce_points(pts: np.ndarray, nrm: np.ndarray, tol: float
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Drop the rows implied by others: for one normal ``n`` the speed
    ``n . v + p . (n x w)`` is affine in the point ``p`` and depends only on its component
    across ``n``, so over points sharing a normal (equal within 1e-9) only the vertices of
    the convex hull of their projection on the plane across ``n`` matter (two extremes when
    they are collinear, within ``tol``). Exact; it shrinks a tessellated cylinder's rows to
    about four per facet direction."""
    keep = _reduce_keep(pts, nrm, np.zeros(len(pts), dtype=np.int64), tol)
    return pts[keep], nrm[keep]


def _reduce_keep(pts: np.ndarray, nrm: np.ndarray, seg: np.ndarray, tol: float
                 ) -> np.ndarray:
    """:func:`reduce_points` for many contacts at once: ``seg`` ``(M,)`` the contact of each
    row of ``pts``/``nrm`` ``(M, 3)``; returns the rows kept ``(M,)`` bool. A group of rows
    sharing a contact and a normal (rounded to 1e-9) keeps every row when it has at most
    three, else its 2D hull's (:func:`_hull_2d`)."""
    keep = np.ones(len(pts), dtype=bool)
    if len(pts) <= 2:
        return keep
    # rounded normals: multiples of 1e-9 in [-1, 1], three exact integers, hashed with the
    # contact into one int64 (wrapping); a hash of over 3 rows is checked for collisions
    m = np.rint(np.round(nrm, 9) * 1e9).astype(np.int64) + 2 ** 30
    code = ((seg * _HASH + m[:, 0]) * _HASH + m[:, 1]) * _HASH + m[:, 2]
    order = np.argsort(code, kind="stable")
    starts = np.flatnonzero(np.r_[True, code[order][1:] != code[order][:-1]])
    sizes = np.diff(np.r_[starts, len(order)])
    key = np.column_stack([seg, m])
    for g in np.flatnonzero(sizes > 3).tolist():
        idx = np.sort(order[starts[g]:starts[g] + sizes[g]])
        if np.any(key[idx] != key[idx[0]]):  # a collision: the exact groups
            _, inv = np.unique(key[idx], axis=0, return_inverse=True)
            groups = [idx[inv.ravel() == k] for k in range(int(inv.max()) + 1)]
        else:
            groups = [idx]
        for idx in groups:
            if len(idx) > 3:
                e1, e2 = _across(nrm[idx[0]])
                q = np.stack([pts[idx] @ e1, pts[idx] @ e2], axis=1)
                keep[idx] = False
                keep[idx[_hull_2d(q, tol)]] = True
    return keep


def _across(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal basis of the plane across the unit vector ``n`` (two read-only
    ``(3,)`` arrays; memoised by the bytes of ``n``: contacts share few axes and normals)."""
    return _across_of(np.asarray(n, dtype=float).tobytes())


@lru_cache(maxsize=4096)
def _across_of(key: bytes) -> tuple[np.ndarray, np.ndarray]:
    n = np.frombuffer(key, dtype=float)
    e1, e2 = plane_basis(n)
    e1.flags.writeable = e2.flags.writeable = False
    return e1, e2


def _hull_2d(q: np.ndarray, tol: float) -> np.ndarray:
    """Indices of the extreme points of ``q`` ``(k, 2)``: convex-hull vertices, or the two
    ends when the points are collinear within ``tol``, or one point when they coincide."""
    c = q - q.mean(axis=0)
    _, sv, vt = np.linalg.svd(c, full_matrices=False)
    t = c @ vt[0]
    if sv[0] <= tol:
        return np.array([0])
    if len(sv) < 2 or np.abs(c @ vt[1]).max() <= tol:
        return np.unique([int(np.argmin(t)), int(np.argmax(t))])
    return np.asarray(ConvexHull(q).vertices)


def _pad3(v: np.ndarray) -> np.ndarray:
    """2D points or vectors ``(..., 2)`` embedded at z = 0 as ``(..., 3)``; 3D unchanged."""
    if v.shape[-1] == 3:
        return v
    return np.concatenate([v, np.zeros(v.shape[:-1] + (1,))], axis=-1)


def contact_rows(asm: Assembly, contacts: Iterable[Any]) -> ContactRows:
    """Flatten ``contacts`` (objects with ``a``, ``b`` (ids or indices), ``points``,
    ``point_normals``/``normals``, optional ``surface``/``axis``/``center``/``blocking``) into
    rows: one per convex-hull vertex of a planar contact's polygon (Fig. 6), one per contact
    point of a curved contact; rows sharing a normal are reduced to the extreme points
    (:func:`reduce_points`).

    Curved contacts between the two parts of a declared joint get radial normals about the
    joint's axis when they are surfaces of revolution about it (:func:`contact_points`).

    2D contacts (:class:`ndbg_cli.contacts.contacts2d.Contact2D`: ``points`` ``(k, 2)`` with one of
    ``normals`` ``(k, 2)`` each) are embedded at z = 0 and the rows are marked ``planar``.

    A contact with ``blocking == "all"`` (edge and point contacts: its ``normals`` generate
    the cone of possible separating normals, and it blocks only when *every* one is pushed
    into) gives one row per point and generator, and the rows of one point form a *group*:
    :func:`group_blocks` blocks a group only when all its rows do (exact), while the LP
    requires every row (conservative: it may miss a motion that slides round a vertex).

    The rows are, bit for bit, :func:`contact_points` then (curved) :func:`reduce_points`
    per contact, computed for all contacts at once (:func:`_turn`, :func:`_reduce_keep`;
    curved contacts of a joint's parts one by one: several axes to try).
    """
    tol = asm.length_tolerance
    joints: dict[frozenset, list[tuple[np.ndarray, np.ndarray]]] = {}
    for j in getattr(asm, "joints", ()):
        key = frozenset(asm.index(p) for p in j.parts)
        joints.setdefault(key, []).append((unit(np.asarray(j.axis, float)),
                                           np.asarray(j.point, float)))
    info, pts_l, nrm_l, todo, lines, every, curved = [], [], [], [], {}, {}, []
    for k, c in enumerate(contacts):  # per contact: the rows before any turn or reduction
        a, b = _part_index(asm, c.a), _part_index(asm, c.b)
        jax = joints.get(frozenset((a, b)), ())
        pts, pn, gens, final = _raw_rows(c)
        line = [] if final or len(pts) == 0 else _lines(c, jax)
        if len(pn) != len(pts) or len(line) > 1 or (line and line[0][2]):
            (pts, pn), final, line = contact_points(c, tol, jax), True, []
        if len(pts) == 0:
            continue
        if not final:
            todo.append((len(pts_l), gens))
        if line:
            lines[len(pts_l)] = line[0]
        if getattr(c, "blocking", "any") == "all":
            every[len(pts_l)] = np.asarray(c.normals, dtype=float).reshape(-1, 3)
        curved.append(getattr(c, "kind", None) == "curved")
        info.append((k, a, b))
        pts_l.append(pts)
        nrm_l.append(pn)
    centre, scale = _frame_free(asm, tol)
    planar = getattr(asm, "dimension", 3) == 2
    if not info:
        z = np.zeros((0, 3))
        e = np.zeros(0, dtype=int)
        return ContactRows(z, z, e, e, e, len(asm), centre, scale, tol, e, planar)
    if todo:  # unit point normals, signed per contact
        normed = unit(np.concatenate([nrm_l[i] for i, _ in todo]))
        at = np.cumsum([0] + [len(nrm_l[i]) for i, _ in todo]).tolist()
        for (i, gens), s, e in zip(todo, at[:-1], at[1:]):
            nrm_l[i] = _signed(normed[s:e], gens)
    counts = np.array([len(p) for p in pts_l])
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    P, N = np.concatenate(pts_l), np.concatenate(nrm_l)
    seg = np.repeat(np.arange(len(info)), counts)
    keep = np.ones(len(P), dtype=bool)
    if lines:  # every cylinder contact turned about its axis at once
        cyl = list(lines)
        sub = np.concatenate([np.arange(starts[i], starts[i] + counts[i]) for i in cyl])
        moved, across, ok, kept = _turn(P[sub], N[sub], np.array([lines[i][0] for i in cyl]),
                                        np.array([lines[i][1] for i in cyl]),
                                        np.r_[0, np.cumsum(counts[cyl])[:-1]], False, tol)
        turned = ok[np.repeat(np.arange(len(cyl)), counts[cyl])]
        P[sub[turned]], N[sub[turned]] = moved[turned], across[turned]
        keep[sub] = kept
    red = np.array(curved)
    red[list(every)] = False
    if red.any():  # curved contacts: rows implied by others dropped
        sub = np.flatnonzero(keep & red[seg])
        keep[sub] = _reduce_keep(P[sub], N[sub], seg[sub], tol)
    P, N, seg = P[keep], N[keep], seg[keep]
    new = np.ones(len(P), dtype=bool)
    if every:  # blocking "all": one row per point and generator, grouped by point
        at = np.searchsorted(seg, np.arange(len(info) + 1)).tolist()
        parts = [(P[s:e], N[s:e], new[s:e]) for s, e in zip(at[:-1], at[1:])]
        for i, gens in every.items():
            pts, gens = parts[i][0], unit(gens)
            parts[i] = (np.repeat(pts, len(gens), axis=0), np.tile(gens, (len(pts), 1)),
                        np.arange(len(pts) * len(gens)) % len(gens) == 0)
        P, N, new = (np.concatenate(x) for x in zip(*parts))
        seg = np.repeat(np.arange(len(info)), [len(x[0]) for x in parts])
    ids = np.array(info, dtype=np.int64)[seg]
    return ContactRows(P, N, ids[:, 1], ids[:, 2], ids[:, 0], len(asm), centre, scale,
                       tol, np.cumsum(new) - 1, planar)


def group_blocks(rows: ContactRows, values: np.ndarray) -> np.ndarray:
    """Per row, whether its group blocks: ``values`` ``(K,)`` or ``(K, R)`` (positive = this
    row pushes in) reduced by minimum over each group and broadcast back, as bool."""
    if len(values) == 0:
        return np.zeros(values.shape, dtype=bool)
    starts = np.flatnonzero(np.r_[True, rows.group[1:] != rows.group[:-1]])
    if len(starts) == len(values):
        return values > 0
    gmin = np.minimum.reduceat(values, starts, axis=0)
    counts = np.diff(np.r_[starts, len(values)])
    return np.repeat(gmin, counts, axis=0) > 0


# ----------------------------------------------------------------------------- twists
def twist(kind: str, axis: Sequence[float], point: Sequence[float] = (0.0, 0.0, 0.0),
          pitch: float = 0.0, sense: int = 1) -> np.ndarray:
    """The twist ``(v, w)`` ``(6,)`` about the origin of a unit-speed motion.

    ``translation``: ``v = sense * axis``, ``w = 0``. ``rotation`` about the line through
    ``point`` along ``axis``: ``w = sense * axis`` (1 rad per unit time, right-hand rule),
    ``v = -w x point``. ``screw``: the rotation plus an advance of ``pitch`` (assembly units
    per turn; positive = right-hand) along ``w``: ``v = -w x point + pitch / (2 pi) * w``.
    """
    ax = unit(np.asarray(axis, dtype=float)) * float(sense)
    if kind == "translation":
        return np.concatenate([ax, np.zeros(3)])
    q = np.asarray(point, dtype=float)
    if ax.shape == q.shape == (3,):  # -(ax x q): np.cross's operations on Python floats
        (a0, a1, a2), (q0, q1, q2) = ax.tolist(), q.tolist()
        v = -np.array([a1 * q2 - a2 * q1, a2 * q0 - a0 * q2, a0 * q1 - a1 * q0])
    else:
        v = -np.cross(ax, q)
    if kind == "screw":
        v = v + pitch / (2.0 * np.pi) * ax
    return np.concatenate([v, ax])


def to_scaled(rows: ContactRows, xi: np.ndarray) -> np.ndarray:
    """Origin twist ``(v, w)`` -> the LP's scaled centred twist ``(v + w x c, L w)``."""
    v, w = xi[:3], xi[3:]
    return np.concatenate([v + np.cross(w, rows.center), rows.scale * w])


def from_scaled(rows: ContactRows, x: np.ndarray) -> np.ndarray:
    """Inverse of :func:`to_scaled`."""
    w = x[3:] / rows.scale
    return np.concatenate([x[:3] - np.cross(w, rows.center), w])


def same_twist(rows: ContactRows, x1: np.ndarray, x2: np.ndarray) -> bool:
    """Whether two origin twists are the same motion up to a positive or negative factor:
    their normalised scaled twists differ by at most :data:`TWIST_TOL`."""
    s1, s2 = to_scaled(rows, x1), to_scaled(rows, x2)
    s1, s2 = s1 / np.linalg.norm(s1), s2 / np.linalg.norm(s2)
    return min(np.linalg.norm(s1 - s2), np.linalg.norm(s1 + s2)) <= TWIST_TOL


def _velocities(rows: ContactRows, xi: np.ndarray) -> np.ndarray:
    """``(K, 3)`` velocity ``v + w x p`` of every row's point under the origin twist."""
    v, w, p = xi[:3], xi[3:], rows.points
    return np.stack([v[0] + w[1] * p[:, 2] - w[2] * p[:, 1],
                     v[1] + w[2] * p[:, 0] - w[0] * p[:, 2],
                     v[2] + w[0] * p[:, 1] - w[1] * p[:, 0]], axis=1)


def normal_speeds(rows: ContactRows, xi: np.ndarray) -> np.ndarray:
    """``(K,)`` ``n . (v + w x p)`` per row for part ``a[k]`` moving by the origin twist
    ``xi`` relative to ``b[k]``: positive = penetration, negative = separation."""
    return np.einsum("ij,ij->i", rows.normals, _velocities(rows, xi))


def block_tolerance(rows: ContactRows, xi: np.ndarray) -> np.ndarray:
    """``(K,)`` penetration speed below which a row does not block the twist ``xi``:
    ``length_tol * |w| + ANGLE_TOL * |u(p)|`` (scale-invariant: the point may be off by the
    length tolerance, the velocity's direction by the angular tolerance)."""
    u = _velocities(rows, xi)
    return rows.length_tol * float(np.linalg.norm(xi[3:])) + ANGLE_TOL * np.linalg.norm(u, axis=1)


# ----------------------------------------------------------------------------- motions
@dataclass(frozen=True)
class Motion:
    """A classified infinitesimal rigid motion of a moved set relative to the rest.

    ``twist`` ``(6,)``: ``(v, w)`` about the origin, normalised (``|w| = 1`` rad per unit time
    for rotations and screws, ``|v| = 1`` for translations). ``type`` is ``"translation"``,
    ``"rotation"`` or ``"screw"``; ``axis`` the unit direction (the translation direction, or
    the rotation axis by the right-hand rule); ``point`` the point of the axis closest to the
    model centre (``None`` for translations); ``pitch`` the advance per turn along ``axis`` in
    assembly units (0 for rotations, ``None`` for translations). ``broken`` counts the contact
    points the motion separates; ``margin`` is the largest separation speed in the LP's scaled
    units.
    """

    type: str
    twist: tuple[float, ...]
    axis: tuple[float, float, float]
    point: tuple[float, float, float] | None
    pitch: float | None
    broken: int = 0
    margin: float = 0.0

    def reversed(self) -> Motion:
        """The same motion seen from the other side (the rest moving relative to the moved
        set): the twist negated, so the axis flips; point, pitch (``w . v`` is unchanged),
        ``broken`` and ``margin`` stay."""
        flip = tuple(-x + 0.0 for x in self.twist)
        return Motion(self.type, flip, tuple(-x + 0.0 for x in self.axis), self.point,
                      self.pitch, self.broken, self.margin)

    def record(self) -> dict:
        """JSON-ready description."""
        return {"type": self.type, "axis": list(self.axis),
                "point": None if self.point is None else list(self.point),
                "pitch": self.pitch, "twist": list(self.twist), "broken_contacts": self.broken,
                "margin": self.margin}


def classify(xi: np.ndarray, *, length_tol: float, scale: float,
             center: Sequence[float] = (0.0, 0.0, 0.0), broken: int = 0,
             margin: float = 0.0) -> Motion:
    """Name the motion of the origin twist ``xi``: translation when ``L |w|`` is below
    ``TRANSLATION_FRACTION`` of ``max(|v_c|, L |w|)``; else rotation when the advance per turn
    ``2 pi (w . v) / |w|^2`` is at most ``PITCH_FACTOR * length_tol``, else screw."""
    v, w = np.asarray(xi[:3], float), np.asarray(xi[3:], float)
    c = np.asarray(center, float)
    rot = scale * float(np.linalg.norm(w))
    lin = float(np.linalg.norm(v + np.cross(w, c)))
    if rot <= TRANSLATION_FRACTION * max(rot, lin) or rot == 0.0:
        d = unit(v)
        return Motion("translation", tuple(np.concatenate([d, np.zeros(3)]).tolist()),
                      tuple(d.tolist()), None, None, broken, margin)
    k = float(np.linalg.norm(w))
    v, w = v / k, w / k
    h = float(w @ v)  # advance per radian
    q = np.cross(w, v)  # point of the axis closest to the origin
    q = q + float((c - q) @ w) * w
    pitch = 2.0 * np.pi * h
    kind = "screw"
    if abs(pitch) <= PITCH_FACTOR * length_tol:
        kind, pitch = "rotation", 0.0
    return Motion(kind, tuple(np.concatenate([v, w]).tolist()), tuple(w.tolist()),
                  tuple(q.tolist()), pitch, broken, margin)


def _frame_free(asm: Assembly, tol: float) -> tuple[np.ndarray, float]:
    """The LP's centre ``c`` and scale ``L`` (see the scaling note above): the model's
    :attr:`~ndbg_cli.core.assembly.Assembly.centre` and
    :attr:`~ndbg_cli.core.assembly.Assembly.size`, which move and turn with it (a bounding
    box's centre and diagonal do not: the engine's generalized partitionings changed with a
    turn); an empty model's, the unit box's."""
    if not len(asm):
        return np.full(3, 0.5), max(float(np.sqrt(3.0)), tol)
    return _pad3(np.asarray(asm.centre, float)), max(float(asm.size), tol, 1e-12)
