"""Proven assembly plans: every step checked by an exact test of infinite translation (paper
sections 5.3 and 7.1), or the subassembly no tried direction splits.

A step moves ``S`` out of subassembly ``M`` along ``d``: every part of ``S`` translates to
infinity without meeting the interior of ``M \\ S``. The test is a :class:`BlockingTest`
(``j`` blocks ``i`` along ``d``, pairwise; the pipeline passes the direct sweep test
:class:`ndbg_cli.ndbg.infinite.sweep.SweepChecker`), never a collision library: planners depend
on this protocol only.

Blocking under infinite translation is a relation between part pairs. So when ``S`` leaves
``M`` along ``d``, every ``S' ⊆ S`` leaves every ``M' ⊇ S'`` inside ``M`` along ``d``: a plan of
the product restricts to a plan of any subset of its parts (drop the parts outside it, keep
each split's direction). Two consequences shape the search:

* a greedy search that splits each subassembly along any direction of a fixed set ``D`` never
  needs to backtrack: it finds a plan exactly when some plan uses only directions of ``D``;
* where it stops, the subassembly ``X`` no direction of ``D`` splits proves that no plan with
  directions of ``D`` exists; and when the infinitesimal NDBG has no candidate partitioning of
  ``X`` (paper 4.4: no direction moves any part of ``X`` even infinitesimally), that no plan of
  single translations exists at all.

``D`` (:func:`directions`) puts natural directions first (the coordinate axes, then the
contacts' normals and cylinder axes, by how many contacts share them) and then one
representative of each region of the proposing NDBG: a step states the direction it was
proven along, exactly, e.g. ``(0, 0, -1)``. :func:`prove` first tries the candidate tree the
strategies chose (optimal among candidates: each step along the best freeing direction of
``D``), then, if a step of it fails, searches greedily (:func:`greedy`).
"""

from __future__ import annotations

import heapq
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from ..core.constants import ANGLE_TOL_RAD
from ..core.pools import Helper, spare_workers
from ..ndbg.dbg import bits, tarjan
from ..ndbg.model import NDBG, ConnectivityTest

__all__ = ["BlockingTest", "Direction", "directions", "snap", "Rows", "Split", "Outcome",
           "Chooser", "Clearance", "chooser", "greedy", "prove_tree", "prove", "measures",
           "why_stuck",
           "SNAP_TOL", "GREEDY_WIDE", "SOURCES"]

#: Components of a candidate direction below this (unit vector) are set to zero before it is
#: tested: a region's representative ``(1.6e-08, -6.2e-10, 1)`` is tested, and reported, as
#: ``(0, 0, 1)``. The snapped direction is the one proven, so snapping costs no soundness.
SNAP_TOL = 1e-6

#: Natural directions :func:`greedy` compares at every subassembly (the axes and the three
#: most shared contact lines, both ways); the others are tried only while none splits it.
GREEDY_WIDE = 12

#: Source ranks: the order in which directions are tried and preferred.
SOURCES = ("axis", "contact normal", "cylinder axis", "region")


class BlockingTest(Protocol):
    """An exact pairwise test of infinite translation."""

    def blocked(self, i: int, j: int, d: np.ndarray) -> bool:
        """Whether part ``j`` blocks part ``i`` translating to infinity along ``d``."""

    def blockers(self, i: int, d: np.ndarray, among: int | None = None) -> int:
        """The bitmask of the parts that block part ``i`` along ``d``, of those in bitmask
        ``among`` (default: all; only they are tested)."""

    def witness(self, i: int, j: int, d: np.ndarray) -> tuple[float, ...] | None:
        """A point where ``j`` blocks ``i`` along ``d`` (``None`` when it does not)."""


@dataclass(frozen=True)
class Direction:
    """A candidate removal direction: its unit vector, exactly as tested, and where it came
    from (one of :data:`SOURCES`)."""

    vector: tuple[float, ...]
    source: str
    #: the proposing NDBG's region it represents (``source == "region"``): only where that
    #: region's DBG frees something can this direction free anything (paper 4.4)
    region: int | None = None


def snap(d: Sequence[float], tol: float = SNAP_TOL) -> tuple[float, ...]:
    """``d`` normalised with components below ``tol`` set to zero (and ``-0.0`` to ``0.0``).

    >>> snap((1.6e-08, -6.2e-10, 2.0))
    (0.0, 0.0, 1.0)
    """
    v = np.asarray(d, dtype=float)
    v = v / np.linalg.norm(v)
    v = np.where(np.abs(v) < tol, 0.0, v)
    v = v / np.linalg.norm(v)
    return tuple(float(x) + 0.0 for x in v)


#: Cosine above which two unit directions are one (:data:`~ndbg_cli.core.constants.ANGLE_TOL_RAD`).
_SAME = float(np.cos(ANGLE_TOL_RAD))


def _seen(kept: np.ndarray, u: Sequence[float]) -> bool:
    """Whether unit ``u`` lies within :data:`~ndbg_cli.core.constants.ANGLE_TOL_RAD` of a row
    of ``kept``: the same direction of ``D``."""
    return bool(len(kept)) and float((kept @ np.asarray(u)).max()) >= _SAME


def directions(dimension: int, natural: Sequence[tuple[Sequence[float], str]],
               regions: Sequence[tuple[int, Sequence[float]]]) -> list[Direction]:
    """The candidate set ``D``: the ``2 dimension`` coordinate axes, then ``natural``
    (``(vector, source)``, e.g. contact normals and cylinder axes, in the given order) and
    ``regions`` (``(region, representative)``), each snapped (:func:`snap`) and followed by
    its opposite; a direction within :data:`~ndbg_cli.core.constants.ANGLE_TOL_RAD` of an earlier
    one is that one (two cylinder axes fitted 1e-9 rad apart are one axis, in any frame: kept
    apart, they made one plan count two directions after a turn).

    A region's representative comes without its opposite (that is another region's).

    >>> [(d.source, [round(x, 4) for x in d.vector])
    ...  for d in directions(2, [((1, 1), "contact normal")], [(7, (0, -1))])]
    ... # doctest: +NORMALIZE_WHITESPACE
    [('axis', [1.0, 0.0]), ('axis', [-1.0, 0.0]), ('axis', [0.0, 1.0]), ('axis', [0.0, -1.0]),
     ('contact normal', [0.7071, 0.7071]), ('contact normal', [-0.7071, -0.7071])]
    """
    kept = np.zeros((0, dimension))
    out: list[Direction] = []

    def add(v: Sequence[float], source: str, signs=(1.0, -1.0), region=None) -> None:
        nonlocal kept
        for s in signs:
            u = snap([s * x for x in v])
            if _seen(kept, u):
                continue
            kept = np.vstack([kept, u])
            out.append(Direction(u, source, region))

    for k in range(dimension):
        add([float(k == j) for j in range(dimension)], "axis")
    for v, source in natural:
        add(v, source)
    for r, v in regions:
        add(v, "region", (1.0,), r)
    return out


def _direction_rows(rows: Rows, k: int) -> list[int]:
    """Every part's row along ``rows.dirs[k]`` (:meth:`Rows.fill`'s unit of work)."""
    return [rows.row(k, i) for i in range(rows.n)]


class Rows:
    """Blocking rows per direction, computed when first asked: ``row(k, i)`` is the bitmask of
    the parts that block part ``i`` along ``dirs[k]``, over the whole product."""

    def __init__(self, test: BlockingTest, n: int, dirs: Sequence[Direction],
                 proposer: NDBG | None = None) -> None:
        self.test, self.n, self.dirs, self.proposer = test, n, list(dirs), proposer
        # (k, i) -> (the parts tested so far, those of them that block i)
        self._rows: dict[tuple[int, int], tuple[int, int]] = {}
        self._preds: dict[int, list[int]] = {}
        self._vec = [np.asarray(d.vector, dtype=float) for d in self.dirs]
        self._all = (1 << n) - 1

    def row(self, k: int, i: int, within: int | None = None) -> int:
        """The parts that block part ``i`` along ``dirs[k]``, of those in bitmask ``within``
        (default: all). Only parts not asked about before are tested: a small subassembly's
        rows cost its own pairs, not the whole product's."""
        want = self._all if within is None else within & self._all
        known, got = self._rows.get((k, i), (0, 0))
        todo = want & ~known
        if todo:
            got |= self.test.blockers(i, self._vec[k], None if todo == self._all else todo)
            known |= todo
            self._rows[k, i] = (known, got)
        return got & want

    def fill(self, ks: Sequence[int], workers: int = 1) -> None:
        """Every part's row along each direction ``dirs[k]``, ``k`` in ``ks``, computed now
        (the greedy searches read them all), every other direction in a forked
        :class:`~ndbg_cli.core.pools.Helper` meanwhile when ``workers`` is over 1 and a
        process is spare: the same rows as asked one by one."""
        todo = [k for k in ks if any(self._rows.get((k, i), (0,))[0] != self._all
                                     for i in range(self.n))]
        if len(todo) < 2 or spare_workers(workers) < 1:
            for k in todo:
                _direction_rows(self, k)
            return
        with Helper(_direction_rows, self) as helper:
            for k, got in zip(todo, helper.share(todo)):
                for i, row in enumerate(got):
                    self._rows[k, i] = (self._all, row)

    def blocked_by(self, k: int) -> list[int]:
        """``blocked_by(k)[i]``: the parts that part ``i`` blocks along ``dirs[k]`` (the rows
        read the other way, every part's row computed), over the whole product."""
        got = self._preds.get(k)
        if got is None:
            got = [0] * self.n
            for j in range(self.n):
                for i in bits(self.row(k, j)):
                    got[i] |= 1 << j
            self._preds[k] = got
        return got

    def extend(self, more: Sequence[Direction]) -> int:
        """Append the directions of ``more`` not already in ``dirs`` (within
        :data:`~ndbg_cli.core.constants.ANGLE_TOL_RAD`); returns how many were added."""
        have = np.array([d.vector for d in self.dirs], dtype=float).reshape(-1, len(self._vec[0]))
        added = 0
        for d in more:
            if not _seen(have, d.vector):
                have = np.vstack([have, d.vector])
                self.dirs.append(d)
                self._vec.append(np.asarray(d.vector, dtype=float))
                added += 1
        return added

    def may_split(self, k: int, mask: int) -> bool:
        """Whether ``dirs[k]`` can split ``mask`` at all: not when it represents a region of
        the proposing NDBG whose DBG frees nothing in ``mask`` (a necessary condition)."""
        r = self.dirs[k].region
        if r is None or self.proposer is None:
            return True
        return len(tarjan(list(self.proposer.regions[r].dbg.succ), mask)[0]) > 1

    def may_free(self, k: int, moved: int, mask: int) -> bool:
        """Whether ``dirs[k]`` can free ``moved`` in ``mask`` (as :meth:`may_split`)."""
        r = self.dirs[k].region
        if r is None or self.proposer is None:
            return True
        return self.proposer.regions[r].dbg.is_free(moved, mask)

    def frees(self, k: int, moved: int, rest: int) -> bool:
        """Whether ``moved`` leaves ``rest`` along ``dirs[k]`` (both bitmasks)."""
        return all(self.row(k, i, rest) == 0 for i in bits(moved))

    def components(self, k: int, mask: int) -> list[int]:
        """Strong components of the blocking graph along ``dirs[k]`` induced on ``mask``,
        sinks first (a prefix of the list is free along ``dirs[k]``)."""
        succ = [0] * self.n
        for i in bits(mask):
            succ[i] = self.row(k, i, mask)
        return tarjan(succ, mask)[0]


@dataclass(frozen=True)
class Split:
    """One proven step: ``moved`` leaves ``mask`` along ``sense * dirs[k]`` (blocking is a
    relation of relative motion: ``moved`` leaving along ``-d`` is the rest leaving along
    ``d``)."""

    mask: int
    moved: int
    k: int
    sense: int = 1

    @property
    def rest(self) -> int:
        return self.mask & ~self.moved

    def vector(self, dirs: Sequence[Direction]) -> tuple[float, ...]:
        """The removal direction of ``moved``, exactly as proven."""
        return tuple(self.sense * x + 0.0 for x in dirs[self.k].vector)


@dataclass
class Outcome:
    """What :func:`prove` found: ``splits`` (mask -> :class:`Split`) forming a tree of
    ``root`` when ``found``; else ``stuck``, the subassembly no direction of ``dirs`` splits,
    and ``failed_step``, the candidate tree's first step no direction frees (1-based, in
    assembly order; ``None`` when the candidate tree passed or was not given)."""

    root: int
    dirs: list[Direction]
    splits: dict[int, Split] = field(default_factory=dict)
    found: bool = True
    stuck: int | None = None
    failed_step: int | None = None
    searched: bool = False  #: the greedy search ran (the candidate tree failed)
    #: the tree is the greedy search's from the root, better for the strategy than the
    #: candidate tree repaired (:func:`prove`)
    restarted: bool = False


def _options(rows: Rows, k: int, mask: int, base: int | None) -> list[tuple[int, int]]:
    """The ``(moved, sense)`` splits ``dirs[k]`` offers in ``mask``: each sink component (a
    minimal free set) and each proper prefix of its strong components in reverse topological
    order, leaving along ``dirs[k]``, and their complements leaving along its opposite;
    never the base."""
    comps = rows.components(k, mask)
    if len(comps) < 2:
        return []
    free, acc = [], 0
    for c in comps[:-1]:  # every proper prefix (sinks first) is free
        acc |= c
        free.append(acc)
    # sinks: components with no arc to another component of mask
    free += [c for c in comps if all(rows.row(k, i, mask) & ~c == 0 for i in bits(c))]
    out = {(s, 1) for s in free} | {(mask & ~s, -1) for s in free}
    return sorted(o for o in out
                  if 0 < o[0] != mask and (base is None or not o[0] >> base & 1))


def _singletons(rows: Rows, k: int, mask: int, base: int | None) -> list[tuple[int, int]]:
    """The one-part ``(moved, sense)`` splits ``dirs[k]`` offers in ``mask``: a part no other
    part of ``mask`` blocks leaves along ``dirs[k]``, and a part that blocks no other leaves
    along its opposite (the rest leaving along ``dirs[k]``); never the base. Read from the
    rows alone, without the strong components :func:`_options` needs."""
    back = rows.blocked_by(k)
    out = []
    for i in bits(mask):
        if i == base:
            continue
        others = mask & ~(1 << i)
        if rows.row(k, i) & others == 0:
            out.append((1 << i, 1))
        if back[i] & others == 0:
            out.append((1 << i, -1))
    return out


class Clearance(Protocol):
    """``clearance(moved, rest, d)``: how far inside the directions that free ``moved``
    locally ``d`` lies (e.g. the least ``-n . d`` over the contact normals ``n`` out of
    ``moved`` into ``rest``; 0 when sliding along a contact): larger is preferred, as a
    designer lifts a part off a face rather than sliding it along the face.
    ``touching(i)``: the parts whose contacts with part ``i`` it reads (a symmetric relation):
    the clearance of ``{i}`` against a rest does not change while none of them leaves it."""

    def __call__(self, moved: int, rest: int, d: tuple[float, ...]) -> float: ...

    def touching(self, i: int) -> int: ...


@dataclass(frozen=True)
class Chooser:
    """The preference key of a proven split ``(mask, moved, k, sense)`` (smaller is better),
    in two parts: :meth:`head`, cheap, and :meth:`tail`, which reads the clearance. The key is
    ``head + tail``; :func:`greedy` ranks every split by its head and reads the tail only where
    heads tie (on a product of hundreds of parts a subassembly offers hundreds of splits, and
    the clearance of each costs its contacts). Made by :func:`chooser`."""

    strategy: str
    connected: ConnectivityTest | None
    used: set[int]
    dirs: Sequence[Direction]
    clearance: Clearance | None = None

    def head(self, mask: int, moved: int, k: int, sense: int) -> tuple:
        rest = mask & ~moved
        apart = 0 if self.connected is None or (self.connected(moved)
                                                and self.connected(rest)) else 1
        size = max(moved.bit_count(), rest.bit_count())
        goal: tuple = ((moved.bit_count() > 1, size) if self.strategy == "linear" else
                       (k not in self.used, size) if self.strategy == "fewest-directions"
                       else (size,))
        return (apart, *goal, SOURCES.index(self.dirs[k].source))

    def tail(self, mask: int, moved: int, k: int, sense: int) -> tuple:
        d = tuple(sense * x for x in self.dirs[k].vector)
        room = 0.0 if self.clearance is None else -round(
            self.clearance(moved, mask & ~moved, d), 9)
        return (room, k, -sense, moved)

    def __call__(self, mask: int, moved: int, k: int, sense: int) -> tuple:
        return self.head(mask, moved, k, sense) + self.tail(mask, moved, k, sense)

    def one_part_head(self, k: int) -> int:
        """What :meth:`head` tells apart among the one-part splits of one subassembly when
        there is no ``connected`` test: the source of the direction (the rest of the head,
        the sides' sizes, is the same for all of them)."""
        return SOURCES.index(self.dirs[k].source)


def chooser(strategy: str, connected: ConnectivityTest | None, used: set[int],
            dirs: Sequence[Direction], clearance: Clearance | None = None) -> Chooser:
    """The preference key of a proven split ``(mask, moved, k, sense)`` for ``strategy``: both
    sides contact-connected first (when ``connected``), then the strategy's objective (one
    part at a time for ``linear``, the most balanced split otherwise, directions already used
    first for ``fewest-directions``), then natural directions before regions', the larger
    ``clearance`` and the order of ``dirs``."""
    return Chooser(strategy, connected, used, dirs, clearance)


def _one_part(rows: Rows, mask: int, base: int | None, ks: Iterable[int]) -> list[Split]:
    """The one-part splits (:func:`_singletons`) of ``mask`` along the directions ``ks``."""
    return [Split(mask, s, k, sense) for k in ks for s, sense in _singletons(rows, k, mask, base)]


def _best(key: Chooser, options: list[Split]) -> Split | None:
    """The split of ``options`` with the least ``key``: heads first, tails among the ties."""
    if not options:
        return None
    heads = [key.head(sp.mask, sp.moved, sp.k, sp.sense) for sp in options]
    low = min(heads)
    ties = [sp for sp, h in zip(options, heads) if h == low]
    return min(ties, key=lambda sp: key.tail(sp.mask, sp.moved, sp.k, sp.sense))


def greedy(rows: Rows, root: int, *, base: int | None = None, key: Chooser,
           natural: int, used: set[int] | None = None) -> Outcome:
    """Split ``root`` recursively along the directions of ``rows``: at each subassembly the
    first ``natural`` directions (at most :data:`GREEDY_WIDE`) are all tried and the best
    split by ``key`` is taken; only when none splits it are the others tried, in order, up to
    the first that does. No
    backtracking is needed (see the module docstring); ``used`` collects the directions used."""
    out = Outcome(root, rows.dirs, searched=True)
    used = set() if used is None else used
    stack = [root]
    # (a clearance that cannot tell which parts it reads, a plain function, is ranked afresh)
    peel = key.strategy == "linear" and key.connected is None and \
        hasattr(key.clearance, "touching")
    while stack:
        m = stack.pop()
        if peel and m.bit_count() >= 2:
            m = _peel(rows, m, base, key, min(natural, GREEDY_WIDE), out, used)
        if m.bit_count() < 2:
            continue
        # One part at a time is what the linear key ranks first: when a part of m leaves
        # alone along a natural direction, with both sides connected where that is asked, no
        # split of the strong components can rank before it, and their search (a Tarjan per
        # direction: quadratic over a linear tree of many parts) is not needed.
        wide = min(natural, GREEDY_WIDE)
        options = _one_part(rows, m, base, range(wide)) if key.strategy == "linear" else []
        if key.strategy == "linear" and not options:
            # then along any direction that may split m: one part at a time wherever one is
            # free keeps the search complete for linear trees along D (a linear tree
            # restricts to a linear tree of every subassembly)
            options = _one_part(rows, m, base, (k for k in range(wide, len(rows.dirs))
                                                if k < natural or rows.may_split(k, m)))
        sp = _best(key, options)
        if sp is None or key.head(m, sp.moved, sp.k, sp.sense)[0] != 0:
            for k in range(len(rows.dirs)):
                if k >= wide and options:
                    break
                if k >= natural and not rows.may_split(k, m):
                    continue
                options += [Split(m, s, k, sense) for s, sense in _options(rows, k, m, base)]
            sp = _best(key, options)
        if sp is None:
            out.found, out.stuck, out.splits = False, m, {}
            return out
        out.splits[m] = sp
        used.add(sp.k)
        stack.extend((sp.rest, sp.moved))
    return out


def _peel(rows: Rows, root: int, base: int | None, key: Chooser, wide: int, out: Outcome,
          used: set[int]) -> int:
    """:func:`greedy`'s linear key without a ``connected`` test, along the chain of one-part
    splits it takes from ``root``, kept up to date part by part: the same splits, recorded in
    ``out`` and ``used`` in the same order, without ranking every part of every subassembly
    afresh (quadratic in the parts: a thousand-part rack peeled one part at a time read 2.4
    million clearances). Per direction of the first ``wide``, each part counts the parts of
    the subassembly that block it and that it blocks; a one-part split is free when a count is
    0, and counts only fall as parts leave. The free splits wait in a heap by their rank
    (:meth:`Chooser.one_part_head`, then :meth:`Chooser.tail`); a tail reads the clearance, so
    it is computed again only when a part the moved part touches leaves. Returns the
    subassembly where no one-part split along those directions is left (one part when the
    chain ends), for :func:`greedy` to go on from."""
    m = root
    ks = range(wide)
    fwd = [{i: rows.row(k, i) for i in bits(m)} for k in ks]  # who blocks i
    back = [rows.blocked_by(k) for k in ks]  # whom i blocks
    count = {(i, k, s): ((fwd[k][i] if s > 0 else back[k][i]) & m & ~(1 << i)).bit_count()
             for i in bits(m) if i != base for k in ks for s in (1, -1)}
    version: dict[tuple[int, int, int], int] = {}
    heap: list = []

    def push(i: int, k: int, s: int) -> None:
        v = version[i, k, s] = version.get((i, k, s), 0) + 1
        heapq.heappush(heap, (key.one_part_head(k), key.tail(m, 1 << i, k, s), v, i, k, s))

    for (i, k, s), c in count.items():
        if c == 0:
            push(i, k, s)
    while m.bit_count() >= 2:
        while heap and (not m >> heap[0][3] & 1 or heap[0][2] != version[heap[0][3:]]):
            heapq.heappop(heap)
        if not heap:
            return m
        *_, i, k, s = heapq.heappop(heap)
        out.splits[m] = Split(m, 1 << i, k, s)
        used.add(k)
        m &= ~(1 << i)
        for k2 in ks:  # i no longer blocks, nor is blocked
            for j, s2 in [(j, 1) for j in bits(back[k2][i] & m)] + \
                    [(j, -1) for j in bits(fwd[k2][i] & m)]:
                if j != base:
                    count[j, k2, s2] -= 1
                    if count[j, k2, s2] == 0:
                        push(j, k2, s2)
        for j in bits(key.clearance.touching(i) & m):  # their clearances change
            for op in ((j, k2, s2) for k2 in ks for s2 in (1, -1)):
                if count.get(op) == 0:
                    push(*op)
    return m


def prove_tree(rows: Rows, steps: Sequence[tuple[int, int, Sequence[float] | None]],
               natural: int, clearance: Clearance | None = None
               ) -> tuple[dict[int, Split], int | None]:
    """Each candidate step ``(mask, moved, region direction)`` (in assembly order) proven
    along a direction of ``rows`` (:func:`_prove_step`). Returns the splits proven and the
    first failing step (1-based), or ``None`` when all pass."""
    out: dict[int, Split] = {}
    failed = None
    for n_step, (mask, moved, near) in enumerate(steps, start=1):
        sp = _prove_step(rows, mask, moved, near, natural, clearance)
        if sp is None:
            failed = n_step if failed is None else failed
        else:
            out[mask] = sp
    return out, failed


def _prove_step(rows: Rows, mask: int, moved: int, near: Sequence[float] | None,
                natural: int, clearance: Clearance | None) -> Split | None:
    """A step proven: the first ``natural`` directions in the order of :func:`_score` (largest
    ``clearance``, then nearest the region's direction ``near``), the first that frees it;
    else the first other direction that frees it (or frees the rest: ``moved`` leaves along
    its opposite). Only the directions tried are tested."""
    rest = mask & ~moved
    order = sorted(range(natural), key=lambda k: _score(rows, k, moved, rest, near, clearance),
                   reverse=True)
    k = next((k for k in order if rows.frees(k, moved, rest)), None)
    if k is not None:
        return Split(mask, moved, k)
    got = next(((k, sense) for k in range(natural, len(rows.dirs))
                for sense, a, b in ((1, moved, rest), (-1, rest, moved))
                if rows.may_free(k, a, mask) and rows.frees(k, a, b)), None)
    return None if got is None else Split(mask, moved, *got)


def _score(rows: Rows, k: int, moved: int, rest: int, near: Sequence[float] | None,
           clearance: Clearance | None) -> tuple:
    """:func:`prove_tree`'s preference among freeing directions (larger is better)."""
    d = rows.dirs[k].vector
    ref = np.zeros(len(d)) if near is None else np.asarray(near)
    room = 0.0 if clearance is None else round(clearance(moved, rest, d), 9)
    return room, round(float(np.dot(d, ref)), 9), -k


def prove(rows: Rows, root: int, candidate: Sequence[tuple[int, int, Sequence[float] | None]],
          *, natural: int, key: Chooser, base: int | None = None,
          clearance: Clearance | None = None, used: set[int] | None = None,
          objective: str | None = None) -> Outcome:
    """A proven tree of ``root``: the candidate tree, top down, each of its steps proven
    (:func:`prove_tree`) kept, and each subassembly whose candidate step fails split by
    :func:`greedy` instead (a subassembly of a product with a proven tree has one, its
    restriction: the repair fails only where no proven tree exists); or the subassembly where
    the search stops. ``used``: the directions the tree uses (shared with ``key`` for
    ``fewest-directions``). When the candidate tree was repaired, the tree :func:`greedy`
    finds from the root is taken instead where it is better for ``objective`` (a strategy,
    :func:`measures`): a repair keeps the candidate's proven steps, not its optimality."""
    used = set() if used is None else used
    splits, failed = prove_tree(rows, candidate, natural, clearance) if candidate else ({}, None)
    if candidate and failed is None:
        used.update(sp.k for sp in splits.values())
        return Outcome(root, rows.dirs, splits)
    out = Outcome(root, rows.dirs, searched=True, failed_step=failed)
    stack = [root]
    while stack:
        m = stack.pop()
        if m.bit_count() < 2:
            continue
        sp = splits.get(m)
        if sp is None:
            sub = greedy(rows, m, base=base, key=key, natural=natural, used=used)
            if not sub.found:
                out.found, out.stuck, out.splits = False, sub.stuck, {}
                return out
            out.splits.update(sub.splits)
            continue
        out.splits[m] = sp
        used.add(sp.k)
        stack.extend((sp.rest, sp.moved))
    if objective is not None and candidate:
        kept = set(used)
        used.clear()  # the key reads it: the fresh search starts with no direction used
        fresh = greedy(rows, root, base=base, key=key, natural=natural, used=used)
        if fresh.found and _goal(objective, measures(rows, root, fresh.splits)) < _goal(
                objective, measures(rows, root, out.splits)):
            fresh.failed_step, fresh.restarted = failed, True
            return fresh
        used.clear()
        used.update(kept)
    return out


def measures(rows: Rows, root: int, splits: dict[int, Split]) -> dict[str, int]:
    """A proven tree's ``depth``, ``nonlinear_steps`` (steps whose both sides have more than
    one part) and ``directions`` (distinct removal vectors, as proven)."""
    depth: dict[int, int] = {}

    def height(m: int) -> int:
        if m.bit_count() < 2:
            return 0
        if m not in depth:
            sp = splits[m]
            depth[m] = 1 + max(height(sp.moved), height(sp.rest))
        return depth[m]

    return {"depth": height(root),
            "nonlinear_steps": sum(1 for sp in splits.values()
                                   if sp.moved.bit_count() > 1 and sp.rest.bit_count() > 1),
            "directions": len({sp.vector(rows.dirs) for sp in splits.values()})}


def _goal(strategy: str, m: dict[str, int]) -> tuple[int, ...]:
    """What ``strategy`` minimises over proven trees, from :func:`measures`."""
    if strategy == "linear":
        return m["nonlinear_steps"], m["depth"]
    if strategy == "fewest-directions":
        return m["directions"], m["depth"]
    return m["depth"], m["nonlinear_steps"]


def why_stuck(rows: Rows, test: BlockingTest, nd: NDBG, stuck: int, limit: int = 12
              ) -> list[dict]:
    """Why subassembly ``stuck`` cannot be split: for each region of ``nd`` with a candidate
    side in it (a minimal free set of the region's DBG, the smaller side first), the part pair
    that blocks that side along the region's direction (snapped) and a point where it does,
    found by ``test``. At most ``limit`` entries."""
    out: list[dict] = []
    seen: set[tuple[int, tuple[float, ...]]] = set()
    for r, reg in enumerate(nd.regions):
        if reg.direction is None:
            continue
        comps = tarjan(list(reg.dbg.succ), stuck)[0]
        sinks = [c for c in comps if reg.dbg.is_free(c, stuck) and c != stuck]
        d = snap(reg.direction)
        for s in sinks:
            if (s, d) in seen:
                continue
            seen.add((s, d))
            v = np.asarray(d)
            pair = next(((i, j) for i in bits(s) for j in bits(stuck & ~s)
                         if test.blocked(i, j, v)), None)
            if pair is None:
                continue
            out.append({"moved": s, "region": r, "direction": d, "pair": pair,
                        "point": test.witness(pair[0], pair[1], v)})
            if len(out) >= limit:
                return out
    return out
