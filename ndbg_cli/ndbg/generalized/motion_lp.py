"""The exact local-freedom test: a linear program over infinitesimal rigid motions
(paper section 5.2).

Given a split of an assembly into a moved set ``S`` and the rest, is there a twist of ``S``
that respects every contact between them and breaks at least one
(:func:`free_motion_rows`)? Rows, scaled twist and tolerances are those of
:mod:`ndbg_cli.ndbg.generalized.twist`; threads (declared screw joints) restrict the relative
twist of their two parts to the screw's line. Most splits of a real product are locked, and
a cheap sound certificate (:func:`_locked`) skips most LPs that would prove it.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import sparse
from scipy.optimize import linprog, nnls

from ...core.assembly import Assembly
from ..dbg import bits
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
#: Row violation assumed of an LP solution by the locking certificate (:func:`_locked`):
#: ``LP_SLACK`` plus HiGHS's primal feasibility tolerance (1e-7; solutions were seen to use
#: all of it), times 2.5.
CERT_SLACK = 5 * LP_SLACK
#: Deviation (per component) assumed of an LP solution from a thread's screw line (HiGHS's
#: tolerance on the equality constraints, with room to spare).
CERT_EQ_SLACK = 1e-6
#: Rows given to the certificate's first NNLS per target (the best aligned with it); rows
#: are added by column generation when they do not suffice (:func:`_cone_weights`).
CERT_ROWS = 32


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
    return rows.scaled[idx] * sign[:, None], idx


def free_motion_rows(rows: ContactRows, moved: int, rest: int, *,
                     threads: Sequence[Thread] = (), translation_only: bool = False,
                     allow_sliding: bool = False, prefer_translation: bool = True,
                     stats: dict | None = None) -> Motion | None:
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

    Each stage first tries the locking certificate (:func:`_locked`): a stage it proves
    empty is skipped without an LP (same outcome); the general stage's is tried first, since
    it rules out translations too. ``stats`` counts ``lp`` and ``certified``.
    """
    G, _ = split_rows(rows, moved, rest)
    crossing = [t for t in threads if ((moved >> t.a) & 1 and (rest >> t.b) & 1)
                or ((moved >> t.b) & 1 and (rest >> t.a) & 1)]
    if len(G) == 0 and not crossing:
        away = np.array([1.0, 0, 0, 0, 0, 0]) if rows.planar else np.array([0, 0, 1.0, 0, 0, 0])
        return classify(away, length_tol=rows.length_tol, scale=rows.scale, center=rows.center)
    # Simplest motion first: a translation when one exists, else a general twist.
    stages = (False,) if translation_only else (False, True) if prefer_translation else (True,)
    unlocked = False  # the general stage's certificate was tried and failed
    if len(stages) == 2:  # no breaking twist means no breaking translation either
        if _locked(rows, G, crossing, True):
            _count(stats, "certified")
            stages = ()
        else:
            unlocked = True
    for rot in stages:
        if not (rot and unlocked) and _locked(rows, G, crossing, rot):
            _count(stats, "certified")
            continue
        x = _solve(rows, G, crossing, rot, stats=stats)
        if x is None or len(G) == 0:
            continue
        if float((-(G @ x)).max()) <= rows.break_tol:
            continue
        if rot:  # a translation's direction needs no centring: it is reported as found
            x = _centre(rows, G, crossing, rot, x, stats=stats)
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


def _count(stats: dict | None, key: str) -> None:
    if stats is not None:
        stats[key] = stats.get(key, 0) + 1


def _stage_basis(rows: ContactRows, crossing: Sequence[Thread], rotate: bool) -> np.ndarray:
    """Orthonormal basis ``(6, k)`` of the scaled twists a stage's LP may use: the free
    translation axes (and rotation axes with ``rotate``); with threads crossing the split,
    their common screw (``k = 0`` when two differ, or when the stage's bounds pin a component
    the screw needs: the LP can then only return ``x = 0``)."""
    free = rows.free_axes & np.array([True] * 3 + [rotate] * 3)
    if not crossing:
        return np.eye(6)[:, free]
    sig = [to_scaled(rows, np.asarray(t.twist, float)) for t in crossing]
    s0 = sig[0] / np.linalg.norm(sig[0])
    for s in sig[1:]:
        s = s / np.linalg.norm(s)
        if min(np.linalg.norm(s - s0), np.linalg.norm(s + s0)) > 1e-9:
            return np.zeros((6, 0))
    if np.any(s0[~free] != 0.0):
        return np.zeros((6, 0))
    return s0[:, None]


def _nnls(A: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, float]:
    """``scipy.optimize.nnls`` with its answer checked: ``z`` clipped to ``z >= 0`` and the
    residual norm ``|A z - q|`` recomputed (SciPy's own can be wrong when ``A`` is rank
    deficient; the certificate's bound must hold for the ``z`` it uses). ``inf`` when NNLS
    fails."""
    try:
        z, _ = nnls(A, q)
    except RuntimeError:
        return np.zeros(A.shape[1]), np.inf
    z = np.maximum(z, 0.0)
    return z, float(np.linalg.norm(A @ z - q))


def _cone_weights(P: np.ndarray, q: np.ndarray, cos: np.ndarray, whole: bool = False
                  ) -> tuple[np.ndarray, float]:
    """``z >= 0`` making ``|P.T z - q|`` small (non-negative least squares) and that
    residual norm (recomputed from ``z``), by column generation: NNLS on the
    :data:`CERT_ROWS` rows best aligned with ``q`` (``cos``: each row's cosine with it),
    then, while some other row ``k`` has ``P_k . (q - P.T z) > 0`` (the optimality
    condition of the full problem fails), again with the rows that most improve it added.
    ``whole``: one NNLS over all the rows (another solution when several exist, often with a
    smaller ``sum(z)``)."""
    m = len(P)
    z = np.zeros(m)
    if m <= CERT_ROWS or whole:
        return _nnls(P.T, q)
    sub = np.argpartition(-cos, CERT_ROWS)[:CERT_ROWS]
    grow = CERT_ROWS // 4
    for _ in range(32):
        sub = np.sort(sub)
        zs, res = _nnls(P[sub].T, q)
        z[:] = 0.0
        z[sub] = zs
        if res <= 1e-12 or not np.isfinite(res):
            break
        gain = P @ (q - P.T @ z)
        gain[sub] = -np.inf
        best = np.argpartition(-gain, grow)[:grow] if m - len(sub) > grow \
            else np.flatnonzero(np.isfinite(gain))
        best = best[gain[best] > 1e-12 * max(res, 1.0)]
        if not len(best):
            break  # no other row helps
        sub = np.concatenate([sub, best])
    return z, res


def _pivot_rows(P: np.ndarray) -> np.ndarray:
    """``d`` row indices of ``P`` ``(m, d)`` picked as QR with column pivoting of ``P.T``
    picks them (each the row farthest from the span of those before; Gram-Schmidt on the
    residuals, ``O(m d^2)``: LAPACK's pivoted QR of a wide ``6 x m`` matrix was the
    certificate's slowest step)."""
    Q = np.array(P, dtype=float)
    out = []
    for _ in range(P.shape[1]):
        k = int(np.argmax(np.einsum("ij,ij->i", Q, Q)))
        out.append(k)
        v = Q[k] / max(float(np.linalg.norm(Q[k])), 1e-300)
        Q -= np.outer(Q @ v, v)
    return np.array(out)


def _basis_bounds(P: np.ndarray, eps: float) -> np.ndarray | None:
    """Bounds ``A`` ``(d,)`` with ``|a_i| <= A_i`` for every ``a`` with ``P a <= eps`` and
    ``|a| <= sqrt(6)``, from one NNLS for all ``2 d`` targets (the fast path of
    :func:`_locked`), or ``None`` when ``P`` has no well-posed basis.

    ``d`` rows ``M = P_R`` are picked as by QR with column pivoting of ``P.T``
    (:func:`_pivot_rows`, a well conditioned basis); ``W = M^-T`` writes each target
    ``+-e_i`` on them, with negative weights. One NNLS (:func:`_cone_weights`, by column
    generation) gives ``u >= 0`` with ``P.T u = -M.T 1``, so ``y = 1_R + u`` is a
    non-negative combination of the rows summing to (nearly) zero with weight at least 1 on
    every basis row. Adding ``t y`` (``t`` the largest negative weight) makes each target's
    weights non-negative: ``z = +-w + t y >= 0``, ``P.T z = q + t P.T y``; the bound of
    :func:`_locked` then holds with this ``z`` and its residual, recomputed. Looser than
    the per-target NNLS (larger ``sum(z)``), but one solve instead of ``2 d``."""
    m, d = P.shape
    if m < d or d == 0:
        return None
    R = _pivot_rows(P)
    M = P[R]
    try:
        W = np.linalg.solve(M.T, np.eye(d))  # column i: weights on R giving e_i
    except np.linalg.LinAlgError:
        return None
    if not np.all(np.isfinite(W)):
        return None
    q = -M.sum(axis=0)
    nq = float(np.linalg.norm(q))
    if nq == 0.0:
        return None
    cos = (P @ q) / (np.maximum(np.linalg.norm(P, axis=1), 1e-300) * nq)
    u, res = _cone_weights(P, q, cos)
    if not np.isfinite(res):
        return None
    y = u
    y[R] += 1.0
    ry = P.T @ y
    sy = float(y.sum())
    eye = np.eye(d)
    A = np.zeros(d)
    for sgn in (1.0, -1.0):
        Ws = sgn * W
        t = np.maximum(0.0, (-Ws).max(axis=0))
        resid = np.linalg.norm(M.T @ Ws - sgn * eye + np.outer(ry, t), axis=0)
        A = np.maximum(A, eps * (Ws.sum(axis=0) + t * sy) + resid * np.sqrt(6.0))
    return A


def _locked(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread], rotate: bool) -> bool:
    """Whether no motion the stage's LP may return (``G x <= CERT_SLACK``, ``|x_i| <= 1``,
    in the stage's basis) separates any row faster than ``break_tol``: a sound certificate;
    ``False`` means "not proven", never "free".

    Proving a split locked is what costs: the LP has one slack per contact row (thousands on
    a bolted bracket). When the certificate holds, the stage is skipped with exactly the LP's
    outcome (no breaking motion; the sliding fallback still runs); it never claims a motion.

    The certificate (Farkas): let ``H = G B`` be the rows on the stage's orthonormal twist
    basis ``B`` (the translations; all free axes; or a thread's screw), ``x = B l``. Split
    ``H``'s right singular vectors into the sliding directions (singular value
    ``<= slide_tol``, moving every row by at most ``delta``) and the others ``V``,
    ``P = H V``. For each coordinate target ``q = +-e_i``, non-negative least squares
    (:func:`_cone_weights`: column generation from the rows best aligned with ``q``, once more
    over all rows if the bound fails) finds ``z >= 0`` with ``P.T z = q + r``. Every motion the
    LP may return has ``G x <= CERT_SLACK`` and ``|x_i| <= 1`` (so ``|a| <= sqrt(6)``), hence
    ``P a <= CERT_SLACK + delta = eps`` and ``q . a = z . P a - r . a <= eps sum(z) + |r|
    sqrt(6) = A_i``. A row then separates at most ``sum_i |P_ki| A_i + delta``; below
    ``break_tol`` for every row, the stage cannot break a contact. First one NNLS gives weights
    for all ``2 d`` targets at once (:func:`_basis_bounds`; looser, enough for most locked
    splits, at a third of the cost); the per-target weights are tried last."""
    B = _stage_basis(rows, crossing, rotate)
    if B.shape[1] == 0 or len(G) == 0:
        return True  # the LP can only return x = 0; with no rows its answer is not used
    H = G @ B
    _, sv, vt = np.linalg.svd(H, full_matrices=False)
    keep = sv > rows.slide_tol
    # the sliding directions (and any beyond the rank) move every row by at most this, and
    # so may a solution's deviation from a thread's line
    delta = float(sv[~keep].max()) * np.sqrt(6.0) if (~keep).any() else 0.0
    if crossing:
        delta += CERT_EQ_SLACK * float(np.abs(G).sum(axis=1).max())
    P = H @ vt[keep].T
    d = P.shape[1]
    eps = CERT_SLACK + delta
    absp = np.abs(P)
    A = _basis_bounds(P, eps)
    if A is not None and float((absp @ A).max(initial=0.0)) + delta < rows.break_tol:
        return True
    unit = P / np.maximum(np.linalg.norm(P, axis=1), 1e-300)[:, None]
    exact = True
    for whole in (False, True):
        if whole and (not exact or len(P) <= CERT_ROWS):
            return False
        bound_a = np.zeros(d)
        for i in range(d):
            for sgn in (1.0, -1.0):
                q = np.zeros(d)
                q[i] = sgn
                z, res = _cone_weights(P, q, sgn * unit[:, i], whole)
                if not np.isfinite(res):
                    return False
                exact = exact and res <= 1e-12
                bound_a[i] = max(bound_a[i], eps * float(z.sum()) + res * np.sqrt(6.0))
            if float((absp[:, :i + 1] @ bound_a[:i + 1]).max()) + delta >= rows.break_tol:
                break  # the bound fails (with these weights)
        else:
            return float((absp @ bound_a).max(initial=0.0)) + delta < rows.break_tol
    return False


def _solve(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread], rotate: bool,
           broken: np.ndarray | None = None, stats: dict | None = None) -> np.ndarray | None:
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
    _count(stats, "lp")
    res = linprog(cost, A_ub=a_ub, b_ub=b_ub, A_eq=a_eq, b_eq=b_eq, bounds=bounds,
                  method="highs")
    return None if res.status != 0 else np.asarray(res.x[:6])


def _centre(rows: ContactRows, G: np.ndarray, crossing: Sequence[Thread], rotate: bool,
            x: np.ndarray, stats: dict | None = None) -> np.ndarray:
    """Move a breaking motion ``x`` to the middle of the freeing motions: repeatedly maximise
    the smallest separation of the rows it breaks (which may then break more rows) until the
    broken set stops growing (at most :data:`CENTRE_ROUNDS` LPs). A vertex of the first LP
    can be any freeing motion (for a key turning in a symmetric pocket, a rotation about a
    corner of the set of admissible centres); this picks the most robust one."""
    broken = -(G @ x) > rows.break_tol
    for _ in range(CENTRE_ROUNDS):
        y = _solve(rows, G, crossing, rotate, broken, stats=stats)
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
    :class:`~ndbg_cli.ndbg.generalized.twist.ContactRows`, faster when called per split).
    ``rest_mask`` defaults to every part not in ``moved_mask`` (pass ``mask & ~moved`` inside a
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
