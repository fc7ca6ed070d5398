"""The exact local-freedom test: a linear program over infinitesimal rigid motions.

Given a split of an assembly into a moved set ``S`` and the rest, is there a twist of ``S``
that respects every contact between them and breaks at least one (paper section 5.2)? The
rows, the scaled twist and the tolerances (``LP_SLACK``, ``slide_tol``, ``break_tol``) are
those of :mod:`ndbg_cli.twist`. Threads (declared screw joints) restrict the relative twist
of their two parts to the screw's line.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse
from scipy.optimize import linprog

from .assembly import Assembly
from .dbg import bits
from .twist import (
    LP_SLACK,
    TRANSLATION_FRACTION,
    ContactRows,
    Motion,
    classify,
    contact_rows,
    from_scaled,
    to_scaled,
    twist,
)

#: Rounds of the centring LP (see :func:`_centre`).
CENTRE_ROUNDS = 3


@dataclass(frozen=True)
class Thread:
    """A threaded pair: parts ``a`` (index) and ``b`` may only move relative to each other by
    the screw ``twist`` ``(6,)`` (origin twist, either sense)."""

    a: int
    b: int
    twist: tuple[float, ...]


def split_rows(rows: ContactRows, moved: int, rest: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows between ``moved`` and ``rest`` (bitmasks): ``(G, idx)`` with ``G`` ``(m, 6)`` in
    the LP's scaled units, oriented so that ``G x <= 0`` is allowed for ``moved`` moving by
    ``x``, and ``idx`` the row indices into ``rows``."""
    inm = np.array([(moved >> i) & 1 for i in range(rows.n)], dtype=bool)
    inr = np.array([(rest >> i) & 1 for i in range(rows.n)], dtype=bool)
    if len(rows.a) == 0:
        return np.zeros((0, 6)), np.zeros(0, dtype=int)
    fwd = inm[rows.a] & inr[rows.b]
    bwd = inr[rows.a] & inm[rows.b]
    idx = np.flatnonzero(fwd | bwd)
    sign = np.where(fwd[idx], 1.0, -1.0)
    n = rows.normals[idx]
    mom = np.cross(rows.points[idx] - rows.center, n) / rows.scale
    return np.hstack([n, mom]) * sign[:, None], idx


def free_motion_rows(rows: ContactRows, moved: int, rest: int, *,
                     threads: Sequence[Thread] = (), translation_only: bool = False,
                     allow_sliding: bool = False, prefer_translation: bool = True
                     ) -> Motion | None:
    """Is there an infinitesimal rigid motion of ``moved`` relative to ``rest`` (bitmasks)
    that respects every contact between them and breaks at least one? Returns the motion or
    ``None``.

    LP over the scaled twist ``x`` (6) and one slack ``s_k`` per row::

        maximise sum s_k   subject to   G_k x + s_k <= LP_SLACK,  0 <= s_k <= 1,
                                        |x_i| <= 1 (x_4..6 = 0 if translation_only),
                                        x = lambda_t sigma_t for each threaded pair crossing
                                        the split (sigma_t its scaled screw twist).

    A motion exists iff the optimal ``x`` separates some row faster than ``break_tol``. The LP
    is solved first with ``w = 0``, so a translation is returned whenever one exists (unless
    ``prefer_translation`` is False). When nothing touches across the split, any motion frees
    it: the answer is a translation along +z (+x in 2D) with ``broken = 0``. With
    ``allow_sliding``, when no motion breaks a contact, a motion along which every contact
    slides (``broken = 0``, e.g. a pin sliding along its hole) is returned if one exists
    (translations preferred).
    """
    G, _ = split_rows(rows, moved, rest)
    crossing = [t for t in threads if ((moved >> t.a) & 1 and (rest >> t.b) & 1)
                or ((moved >> t.b) & 1 and (rest >> t.a) & 1)]
    if len(G) == 0 and not crossing:
        away = np.array([1.0, 0, 0, 0, 0, 0]) if rows.planar else np.array([0, 0, 1.0, 0, 0, 0])
        return classify(away, length_tol=rows.length_tol, scale=rows.scale, center=rows.center)
    # Simplest motion first: a translation when one exists, else a general twist.
    stages = (False,) if translation_only else (False, True) if prefer_translation else (True,)
    for rot in stages:
        x = _solve(rows, G, crossing, rot)
        if x is None or len(G) == 0:
            continue
        if float((-(G @ x)).max()) <= rows.break_tol:
            continue
        if rot:  # a translation's direction needs no centring: it is reported as found
            x = _centre(rows, G, crossing, rot, x)
        x = _polish(rows, G, x, rot, crossing)
        sep = -(G @ x)
        margin = float(sep.max())
        if margin > rows.break_tol:
            return classify(from_scaled(rows, x), length_tol=rows.length_tol,
                            scale=rows.scale, center=rows.center,
                            broken=int(np.sum(sep > rows.break_tol)), margin=margin)
    if allow_sliding:
        return _sliding(rows, G, crossing, translation_only)
    return None


def sliding_motion(rows: ContactRows, moved: int, rest: int, *,
                   threads: Sequence[Thread] = (), translation_only: bool = False
                   ) -> Motion | None:
    """A nonzero motion of ``moved`` along which every contact with ``rest`` slides (within
    ``slide_tol``; translations preferred), or ``None``. No LP: a null-space computation."""
    G, _ = split_rows(rows, moved, rest)
    crossing = [t for t in threads if ((moved >> t.a) & 1 and (rest >> t.b) & 1)
                or ((moved >> t.b) & 1 and (rest >> t.a) & 1)]
    return _sliding(rows, G, crossing, translation_only)


def _polish(rows: ContactRows, G: np.ndarray, x: np.ndarray, rotate: bool,
            crossing: Sequence[Thread]) -> np.ndarray:
    """Remove the LP's slack from ``x``: project it onto the null space of the rows it nearly
    slides along (``|G_k x| <= slide_tol``) so that they slide exactly, and keep the result
    when it violates no row more than ``x`` did (nor ``LP_SLACK``) and still breaks one. (A
    vertex of the LP may carry a slack-sized tilt or drift that would otherwise show up as a
    slightly wrong axis.)"""
    g = G @ x
    act = np.abs(g) <= rows.slide_tol
    if not act.any() or np.all(act) or crossing:
        return x  # with threads x is fixed up to scale by the screw already
    k = 6 if rotate else 3  # stay a translation when the LP was one
    y = x.copy()
    y[:k] -= np.linalg.pinv(G[act][:, :k], rcond=1e-10) @ g[act]
    gy = G @ y
    if np.all(gy <= max(LP_SLACK, float(g.max()))) and float(-gy.min()) > rows.break_tol:
        return y
    return x


def _solve(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread], rotate: bool,
           broken: np.ndarray | None = None) -> np.ndarray | None:
    """The LPs of :func:`free_motion_rows`; returns the optimal scaled twist ``x`` ``(6,)``.

    Without ``broken``: maximise the sum of the capped slacks (finds a breaking motion if one
    exists). With ``broken`` (bool ``(m,)``): maximise the smallest separation ``t`` of those
    rows, every row still allowed (``G x <= LP_SLACK``, ``G_B x + t <= 0``, ``t <= 1``).
    """
    m, T = len(G), len(crossing)
    k = m if broken is None else 1
    nv = 6 + T + k
    cost = np.zeros(nv)
    cost[6 + T:] = -1.0
    if broken is None:
        a_ub = sparse.hstack([sparse.csr_matrix(G), sparse.csr_matrix((m, T)),
                              sparse.identity(m, format="csr")], format="csr")
        b_ub = np.full(m, LP_SLACK)
    else:
        nb = int(broken.sum())
        a_ub = np.vstack([np.hstack([G, np.zeros((m, T + 1))]),
                          np.hstack([G[broken], np.zeros((nb, T)), np.ones((nb, 1))])])
        b_ub = np.r_[np.full(m, LP_SLACK), np.zeros(nb)]
    a_eq = b_eq = None
    if T:
        a_eq = np.zeros((6 * T, nv))
        for t, th in enumerate(crossing):
            sig = to_scaled(rows, np.asarray(th.twist, float))
            sig = sig / np.abs(sig).max()
            a_eq[6 * t:6 * t + 6, :6] = np.eye(6)
            a_eq[6 * t:6 * t + 6, 6 + t] = -sig
        b_eq = np.zeros(6 * T)
    free = rows.free_axes & np.array([True] * 3 + [rotate] * 3)
    bounds = ([(-1.0, 1.0) if f else (0.0, 0.0) for f in free] + [(None, None)] * T
              + [(0.0, 1.0)] * k)
    res = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                  method="highs")
    return None if res.status != 0 else np.asarray(res.x[:6])


def _centre(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread], rotate: bool,
            x: np.ndarray) -> np.ndarray:
    """Move a breaking motion ``x`` to the middle of the freeing motions: repeatedly maximise
    the smallest separation of the rows it breaks (which may then break more rows) until the
    broken set stops growing (at most :data:`CENTRE_ROUNDS` LPs). A vertex of the first LP
    can be any freeing motion (for a key turning in a symmetric pocket, a rotation about a
    corner of the set of admissible centres); this picks the most robust one."""
    broken = -(G @ x) > rows.break_tol
    for _ in range(CENTRE_ROUNDS):
        y = _solve(rows, G, crossing, rotate, broken)
        if y is None:
            break
        more = -(G @ y) > rows.break_tol
        if not more.any():
            break
        x = y
        if np.array_equal(more, broken) or not np.all(more[broken]):
            break
        broken = more
    return x


def _sliding(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread],
             translation_only: bool) -> Motion | None:
    """A nonzero twist keeping every row within the slide tolerance (all contacts slide),
    preferring a translation; ``None`` when the split is locked. When no breaking motion
    exists the allowed cone is the subspace ``G x = 0`` (within tolerance): the singular
    vectors of ``G`` (restricted to the allowed basis) with singular value <= ``slide_tol``."""
    eye = np.eye(6)
    if crossing:
        sig = [to_scaled(rows, np.asarray(t.twist, float)) for t in crossing]
        sig = [s / np.linalg.norm(s) for s in sig]
        if any(min(np.linalg.norm(s - sig[0]), np.linalg.norm(s + sig[0])) > 1e-9
               for s in sig[1:]):
            return None  # two different screws: locked
        if translation_only and np.linalg.norm(sig[0][3:]) > TRANSLATION_FRACTION:
            return None
        bases = [sig[0][:, None]]
    else:
        free = rows.free_axes
        bases = [eye[:, :3][:, free[:3]]] + ([] if translation_only else [eye[:, free]])
    for basis in bases:
        if len(G) == 0:
            x = basis[:, 0]
        else:
            gb = G @ basis  # singular values of gb: square roots of the eigenvalues below
            lam, vec = np.linalg.eigh(gb.T @ gb)
            null = np.flatnonzero(np.sqrt(np.maximum(lam, 0.0)) <= rows.slide_tol)
            if len(null) == 0:
                continue
            x = basis @ vec[:, null[0]]
        x = x / np.abs(x).max()
        return classify(from_scaled(rows, x), length_tol=rows.length_tol, scale=rows.scale,
                        center=rows.center, broken=0, margin=0.0)
    return None


def assembly_threads(asm: Assembly, threads_as_cylinders: bool = False) -> list[Thread]:
    """One :class:`Thread` per declared ``screw`` joint (none with ``threads_as_cylinders``):
    the joint's screw ``v = -w x point + pitch / (2 pi) w`` with ``w`` its unit axis."""
    if threads_as_cylinders:
        return []
    return [Thread(asm.index(j.parts[0]), asm.index(j.parts[1]),
                   tuple(twist("screw", j.axis, j.point, j.pitch).tolist()))
            for j in asm.joints if j.type == "screw"]


def free_motion(asm: Assembly, contacts: Iterable[Any] | ContactRows, moved_mask: int,
                rest_mask: int | None = None, *, threads: Sequence[Thread] | None = None,
                threads_as_cylinders: bool = False, translation_only: bool = False,
                allow_sliding: bool = False) -> Motion | None:
    """:func:`free_motion_rows` from an assembly and its contacts (or prebuilt
    :class:`~ndbg_cli.twist.ContactRows`, faster when called per split). ``rest_mask``
    defaults to every part not in ``moved_mask`` (pass ``mask & ~moved`` inside a
    subassembly ``mask``); ``threads`` default to the assembly's declared screw joints
    (:func:`assembly_threads`)."""
    rows = contacts if isinstance(contacts, ContactRows) else contact_rows(asm, contacts)
    full = (1 << len(asm)) - 1
    rest = full & ~moved_mask if rest_mask is None else rest_mask
    thr = assembly_threads(asm, threads_as_cylinders) if threads is None else threads
    return free_motion_rows(rows, moved_mask, rest, threads=thr,
                            translation_only=translation_only, allow_sliding=allow_sliding)


def moved_ids(asm: Assembly, mask: int) -> list[str]:
    """Part ids of a bitmask, in assembly order."""
    return [asm.parts[i].id for i in bits(mask)]
