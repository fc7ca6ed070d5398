"""Exact local-freedom checks of splits, memoised, with cheap witnesses before the LP.

:class:`MotionSolver` answers whether some infinitesimal rigid motion frees ``moved`` from
``rest`` (:func:`ndbg_cli.ndbg.generalized.motion_lp.free_motion_rows`, memoised; a split's
reverse reuses its answer) and whether it needs a rotation. Before an LP it tries
*witnesses* (suggested twists, :meth:`MotionSolver.witness`; a few translations,
:meth:`MotionSolver.translation_frees`) checked on the split's rows with the LP's own
tolerances: a witness is a feasible LP point, so it decides the split exactly as the LP
would; only the motion shown may differ. Row speeds are reduced once per ordered part pair
(:class:`PairSpeeds`), so checking many motions on many splits is a few array operations.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence

import numpy as np

from ..dbg import bit_rows
from .motion_lp import Thread, free_motion_rows, sliding_motion
from .twist import LP_SLACK, ContactRows, Motion, classify, from_scaled, same_twist

#: Most frequent distinct contact normals tried (both senses) as translations by
#: :meth:`MotionSolver.translation_frees`, besides the axes and the suggested translations.
WITNESS_NORMALS = 24


class PairSpeeds:
    """Speeds ``G_k x`` of every contact row under a fixed set of scaled twists ``X``
    ``(R, 6)`` (the LP's units, ``|x_i| <= 1``), reduced per ordered part pair ``(a, b)`` of
    the rows: largest and smallest speed, rows separating faster than ``break_tol`` either
    way, and the sum of squares. :meth:`check` combines the pairs crossing a split, so
    checking ``R`` motions on a split costs a few array operations over the pairs."""

    def __init__(self, solver: MotionSolver, X: np.ndarray) -> None:
        self.solver = solver
        rows = solver.rows
        self.X = np.asarray(X, float).reshape(-1, 6)
        # rows along the last axis: reduceat over it is several times faster than over
        # the first (the per-pair arrays are transposed back, (P, R))
        St = self.X @ solver.scaled_rows.T  # (R, K); see generalized.motion_dbgs
        starts = solver.pair_starts
        r = len(self.X)
        self._motions: dict[int, Motion] = {}
        if St.shape[1]:
            self.hi = np.maximum.reduceat(St, starts, axis=1).T
            self.lo = np.minimum.reduceat(St, starts, axis=1).T
            self.broken_fwd = np.add.reduceat((St < -rows.break_tol).view(np.int8), starts,
                                              axis=1, dtype=np.int64).T
            self.broken_bwd = np.add.reduceat((St > rows.break_tol).view(np.int8), starts,
                                              axis=1, dtype=np.int64).T
            self.squares = np.add.reduceat(St * St, starts, axis=1).T
        else:
            self.hi = self.lo = self.squares = np.zeros((0, r))
            self.broken_fwd = self.broken_bwd = np.zeros((0, r), dtype=np.int64)
        self._done: dict[tuple[int, int], tuple[np.ndarray, ...]] = {}

    def prefetch(self, splits: Sequence[tuple[int, int]]) -> None:
        """:meth:`check` of many ``(moved, rest)`` splits at once (vectorised over the
        splits, in chunks); the answers are kept for :meth:`check`."""
        if not splits:
            return
        n = self.solver.rows.n
        pa, pb = self.solver.pair_a, self.solver.pair_b
        P, r = self.hi.shape
        step = max(1, 1_000_000 // max(P * r, 1))
        for lo in range(0, len(splits), step):
            part = splits[lo:lo + step]
            inm = bit_rows([m for m, _ in part], n)
            inr = bit_rows([q for _, q in part], n)
            f = (inm[:, pa] & inr[:, pb])[:, :, None]
            b = (inr[:, pa] & inm[:, pb])[:, :, None]
            pen = np.maximum(np.where(f, self.hi, -np.inf).max(axis=1, initial=-np.inf),
                             np.where(b, -self.lo, -np.inf).max(axis=1, initial=-np.inf))
            sep = np.maximum(np.where(f, -self.lo, -np.inf).max(axis=1, initial=-np.inf),
                             np.where(b, self.hi, -np.inf).max(axis=1, initial=-np.inf))
            f2, b2 = f[:, :, 0].astype(np.int64), b[:, :, 0].astype(np.int64)
            broken = f2 @ self.broken_fwd + b2 @ self.broken_bwd
            norm = np.sqrt((f2 | b2).astype(float) @ self.squares)
            for k, key in enumerate(part):
                self._done[key] = (pen[k], sep[k], broken[k], norm[k])

    def check(self, moved: int, rest: int) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                    np.ndarray]:
        """Per motion, for ``moved`` moving by it against ``rest``: the largest penetration
        speed, the largest separation speed, the rows separating faster than ``break_tol``
        and ``|G x|`` (``-inf``, ``-inf``, 0, 0 when no row crosses)."""
        got = self._done.get((moved, rest))
        if got is not None:
            return got
        f, b = self.solver.crossing_pairs(moved, rest)
        r = len(self.X)
        pen = np.full(r, -np.inf)
        sep = np.full(r, -np.inf)
        if f.any():
            pen = np.maximum(pen, self.hi[f].max(axis=0))
            sep = np.maximum(sep, -self.lo[f].min(axis=0))
        if b.any():
            pen = np.maximum(pen, -self.lo[b].min(axis=0))
            sep = np.maximum(sep, self.hi[b].max(axis=0))
        broken = self.broken_fwd[f].sum(axis=0) + self.broken_bwd[b].sum(axis=0)
        norm = np.sqrt(self.squares[f | b].sum(axis=0))
        return pen, sep, broken, norm


class MotionSolver:
    """Memoised exact local-freedom checks over one assembly's rows and threads: the same
    split is asked for by several checks (needs-rotation, candidate validation).

    ``solver(moved, rest)`` is :func:`~ndbg_cli.ndbg.generalized.motion_lp.free_motion_rows` with
    ``allow_sliding`` (its locking certificates skip the LPs of locked stages); the answer
    for ``(rest, moved)``, when known, is reused reversed (:meth:`Motion.reversed`: the same
    LP with its rows negated). Cheaper *witnesses* decide most splits that do come apart
    without an LP: :meth:`witness` checks given twists (the suggested motions) on the split's
    rows and :meth:`translation_frees` a fixed set of translations (see there). ``stats``
    counts ``lp`` (HiGHS solves), ``certified`` (LP stages skipped by a certificate) and
    ``witnessed`` (splits decided by a witness)."""

    def __init__(self, rows: ContactRows, thread_list: Sequence[Thread] = (),
                 directions: Iterable[Sequence[float]] = ()) -> None:
        self.rows = rows
        self.threads = list(thread_list)
        self.stats: dict[str, int] = {"lp": 0, "certified": 0, "witnessed": 0}
        self._memo: dict[tuple[int, int], Motion | None] = {}
        self._directions = [np.asarray(d, float) for d in directions]
        self._translations: PairSpeeds | None = None
        self._trans_free: set[tuple[int, int]] = set()
        self._scaled: np.ndarray | None = None

    # -- row layout shared by the witnesses
    @property
    def scaled_rows(self) -> np.ndarray:
        """``(K, 6)`` rows ``(n, (p - c) x n / L)`` (part ``a[k]`` moving), LP units, sorted
        by part pair ``(a, b)``; the pairs start at ``pair_starts``."""
        if self._scaled is None:
            r = self.rows
            code = r.a.astype(np.int64) * r.n + r.b
            order = np.argsort(code, kind="stable")
            sc = code[order]
            self.pair_starts = np.flatnonzero(np.r_[True, sc[1:] != sc[:-1]]) if len(sc) \
                else np.zeros(0, dtype=np.int64)
            self.pair_a = r.a[order][self.pair_starts]
            self.pair_b = r.b[order][self.pair_starts]
            self._scaled = r.scaled[order]
        return self._scaled

    def crossing_pairs(self, moved: int, rest: int) -> tuple[np.ndarray, np.ndarray]:
        """Bool masks over the row pairs: ``a`` moved and ``b`` resting, and the reverse."""
        self.scaled_rows  # noqa: B018 (builds the layout)
        inm, inr = bit_rows([moved, rest], self.rows.n)
        return inm[self.pair_a] & inr[self.pair_b], inr[self.pair_a] & inm[self.pair_b]

    def crossing_threads(self, moved: int, rest: int) -> list[int]:
        return [k for k, t in enumerate(self.threads)
                if ((moved >> t.a) & 1 and (rest >> t.b) & 1)
                or ((moved >> t.b) & 1 and (rest >> t.a) & 1)]

    def speeds(self, X: np.ndarray) -> PairSpeeds:
        """Per-pair speeds of the scaled twists ``X`` ``(R, 6)`` for :meth:`witness`."""
        return PairSpeeds(self, X)

    # -- exact answers
    def __call__(self, moved: int, rest: int) -> Motion | None:
        key = (moved, rest)
        if key not in self._memo:
            back = self._memo.get((rest, moved), False)
            if back is not False:
                self._memo[key] = None if back is None else back.reversed()
            else:
                self._memo[key] = free_motion_rows(self.rows, moved, rest, threads=self.threads,
                                                   allow_sliding=True, stats=self.stats)
        return self._memo[key]

    def witness(self, speeds: PairSpeeds, moved: int, rest: int, order: Iterable[int],
                sliding: Iterable[int] = ()) -> tuple[int, Motion] | None:
        """The first motion ``k`` of ``order`` (indices into ``speeds.X``) under which
        ``moved`` comes apart from ``rest``, checked on their rows with the LP's tolerances:
        no row pushes in faster than ``LP_SLACK`` and one separates faster than
        ``break_tol`` (so the LP has a breaking motion), or, for ``k`` in ``sliding``, every
        row slides (``|G x| <= slide_tol |x|``: the LP's sliding fallback finds a motion
        too). Threads crossing the split must be that very motion. Returns ``(k, motion)``
        (normalised, with the rows it breaks and its margin) or ``None``."""
        rows = self.rows
        pen, sep, broken, norm = speeds.check(moved, rest)
        cross = self.crossing_threads(moved, rest)
        slide = set(sliding)
        for k in order:
            x = speeds.X[k]
            breaks = pen[k] <= LP_SLACK and sep[k] > rows.break_tol
            slides = k in slide and norm[k] <= rows.slide_tol * float(np.linalg.norm(x))
            if not (breaks or slides):
                continue
            if any(not same_twist(rows, from_scaled(rows, x), np.asarray(self.threads[t].twist))
                   for t in cross):
                continue
            self.stats["witnessed"] += 1
            if k not in speeds._motions:
                speeds._motions[k] = classify(from_scaled(rows, x), length_tol=rows.length_tol,
                                              scale=rows.scale, center=rows.center)
            mo = dataclasses.replace(speeds._motions[k],
                                     broken=int(broken[k]) if breaks else 0,
                                     margin=float(sep[k]) if breaks else 0.0)
            if mo.type == "translation":
                self._trans_free.add((min(moved, rest), max(moved, rest)))
            return k, mo
        return None

    def translation_frees(self, moved: int, rest: int) -> bool:
        """Cheap witness that some translation breaks a contact between ``moved`` and
        ``rest`` (no row pushing in faster than ``LP_SLACK``) or slides along all of them:
        tried are the free coordinate axes, the ``directions`` given to the solver (the
        suggested translations) and the :data:`WITNESS_NORMALS` most frequent contact
        normals, both senses each; also a translation found by :meth:`witness`. ``False``
        means "not shown" (threads crossing the split: never)."""
        if (min(moved, rest), max(moved, rest)) in self._trans_free:
            return True
        if self.crossing_threads(moved, rest):
            return False
        sp = self.translation_speeds()
        pen, sep, _, norm = sp.check(moved, rest)
        box = np.abs(sp.X).max(axis=1)
        slack, brk = LP_SLACK * box, self.rows.break_tol * box
        # -d: the speeds negate, so penetration and separation swap
        ok = ((pen <= slack) & (sep > brk)) | ((sep <= slack) & (pen > brk)) \
            | (norm <= self.rows.slide_tol * np.linalg.norm(sp.X, axis=1))
        if ok.any():
            self.stats["witnessed"] += 1
            self._trans_free.add((min(moved, rest), max(moved, rest)))
            return True
        return False

    def translation_speeds(self) -> PairSpeeds:
        """The per-pair speeds of the translations :meth:`translation_frees` tries (built
        once; :meth:`PairSpeeds.prefetch` them for many splits at once)."""
        if self._translations is None:
            self._translations = self.speeds(self._translation_set())
        return self._translations

    def _translation_set(self) -> np.ndarray:
        rows = self.rows
        free = rows.free_axes[:3]
        dirs = [e for e in np.eye(3)[free]] + [d for d in self._directions if np.any(d)]
        if len(rows.normals):  # distinct normals to 1e-5 (one integer key each)
            q = np.round(rows.normals * 1e5).astype(np.int64) + 100_001
            key = (q[:, 0] * 200_003 + q[:, 1]) * 200_003 + q[:, 2]
            _, first, counts = np.unique(key, return_index=True, return_counts=True)
            top = np.argsort(-counts, kind="stable")[:WITNESS_NORMALS]
            dirs += [rows.normals[first[i]] for i in sorted(top)]
        out = []
        for d in dirs:  # one sense each: translation_frees tries both
            d = np.where(free, d, 0.0)
            if np.linalg.norm(d) > 0:
                out.append(np.r_[d / np.linalg.norm(d), 0, 0, 0])
        return np.array(out).reshape(-1, 6)

    def needs_rotation(self, moved: int, rest: int) -> Motion | None:
        """The freeing non-translational motion when ``moved`` needs one, else ``None``:
        some twist breaks a contact (or screws along sliding contacts) while no
        translation breaks or slides (a pure rotation that only slides turns in place and
        frees nothing). A translation witness (:meth:`translation_frees`) answers first."""
        if self.translation_frees(moved, rest):
            return None
        mo = self(moved, rest)
        if mo is None or mo.type == "translation":
            return None
        if mo.broken == 0:
            return mo if mo.type == "screw" else None
        # the LP tried translations first: none breaks; one may still slide
        if sliding_motion(self.rows, moved, rest, threads=self.threads,
                          translation_only=True) is not None:
            return None
        return mo
