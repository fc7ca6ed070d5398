"""Which candidate pairs' narrow phases run, in which order, from the cache or on a
:class:`~ndbg_cli.core.pools.Mapper` (:func:`pair_results`, for
:func:`ndbg_cli.contacts.contacts3d.analyze_contacts`).

A pair's narrow phase has two parts: for a pair whose surfaces cross, the interference test
(an overlap volume, :mod:`ndbg_cli.contacts.interference`), and, unless it finds an
interference, the surface contacts (the triangle pairs). When the caller makes each group
of clashing parts one unit and finds the units' contacts again (``units_later``), the
contacts of a clashing part are not wanted, and which parts clash is known only once every
crossing pair is tested. So the two parts are two items of the mapper, handed out in this
order:

1. the crossing pairs' interference tests, the costliest first;
2. the pairs no clash can leave out (neither part is in a crossing pair);
3. the crossing pairs' surface contacts and the other pairs.

Once the tests are in, the items of 3 with a clashing part that no worker has started are
dropped: the surface contacts of a pair with a clashing part, most of a crossing pair's
cost, are then not computed (on the engine GLB, 106 such pairs, 0.6 CPU-s). Nor are those
of a pair that interferes (its fit's contacts are its result). Without ``units_later``
every pair is one item, whole.

Cache entries (:mod:`ndbg_cli.core.cache`, stage ``contacts``) hold a pair's whole result;
a crossing pair of a clashing part that does not interfere, whose whole result is not
known, has its test's, so that a warm run computes nothing again. Each pair counts one
lookup: its whole result, else (with ``units_later``, a crossing pair) its test's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

from ..core.cache import PairCache
from ..core.pools import Mapper
from .interference import Interference

__all__ = ["WHOLE", "INTERFERENCE", "SURFACE", "PairWork", "pair_results", "clashing_parts"]

#: A pair's whole narrow phase: the interference test when its surfaces cross, then the
#: surface contacts unless it interferes.
WHOLE = "whole"
#: The interference test alone (a crossing pair; its fit's contacts when it interferes).
INTERFERENCE = "interference"
#: The surface contacts alone (a crossing pair whose test found no interference).
SURFACE = "surface"

#: ``(interference or None, approximate, contacts, triangle pairs, seconds of the
#: interference test)``: one pair's result.
Result = tuple


@dataclass(frozen=True)
class PairWork:
    """What :func:`pair_results` computes from: ``fn(context, (a, b, crossing, part))`` is a
    pair's narrow phase (``part``: :data:`WHOLE`, :data:`INTERFERENCE` or :data:`SURFACE`),
    run by ``mapper``; ``pairs`` the candidate pairs ``(a, b, crossing)``; ``size[k]`` pair
    ``k``'s triangles (the costliest go first); ``small(triangles)`` whether that much work
    is too little for worker processes; ``cache`` or None, with ``keys`` (the parts' content
    hashes) and ``tolerances`` (in each pair's cache key) and ``check`` (validates a cached
    entry, raising when it is not one)."""

    fn: Callable[[Any, tuple], Result]
    context: Any
    pairs: Sequence[tuple[int, int, bool]]
    size: Sequence[int]
    small: Callable[[int], bool]
    mapper: Mapper
    cache: PairCache | None = None
    keys: Sequence[Any] = ()
    tolerances: tuple = ()
    check: Callable[[Any], tuple] | None = None

    def key(self, k: int, part: str) -> Any:
        a, b, crossing = self.pairs[k]
        tail = (bool(crossing),) if part == WHOLE else (part,)
        return self.cache.key("contacts", self.keys[a], self.keys[b], *self.tolerances, *tail)

    def lookup(self, k: int, part: str = WHOLE, *, final: bool = True) -> Result | None:
        """Pair ``k``'s cached result (``part``: :data:`WHOLE` or :data:`INTERFERENCE`),
        renumbered to its parts, or None (``final`` False: a miss is not counted, the
        caller looks again; :meth:`~ndbg_cli.core.cache.PairCache.get`)."""
        if self.cache is None:
            return None
        got = self.cache.get("contacts", self.key(k, part), self.check, final=final)
        if got is None:
            return None
        a, b, _ = self.pairs[k]
        found, approximate, cs, count = got
        return (None if found is None else dataclasses.replace(found, a=a, b=b), approximate,
                [dataclasses.replace(c, a=a, b=b) for c in cs], count, 0.0)

    def store(self, k: int, part: str, result: Result) -> None:
        """Cache pair ``k``'s ``result`` (``part``: :data:`WHOLE` or :data:`INTERFERENCE`)."""
        if self.cache is not None:
            self.cache.put("contacts", self.key(k, part), result[:4])

    def run(self, jobs: list[tuple[int, str]], meanwhile: Callable[[], Any] | None,
            drop: set[int] | None = None) -> Iterator[tuple[int, str, Result]]:
        """``(k, part, fn(context, (*pairs[k], part)))`` for the ``(k, part)`` of ``jobs``
        (handed out in that order; ``drop``: as :meth:`~ndbg_cli.core.pools.Mapper.imap`'s,
        indices into ``jobs``)."""
        items = [(*self.pairs[k], part) for k, part in jobs]
        # each pair's triangles once, however many of its parts are items
        small = self.small(sum(self.size[k] for k in {k for k, _ in jobs})) \
            and meanwhile is None
        more = {} if drop is None else {"drop": drop}
        for x, res in self.mapper.imap(self.fn, self.context, items, small=small,
                                       meanwhile=meanwhile, **more):
            yield (*jobs[x], res)


def clashing_parts(found: Sequence[Interference | None]) -> set[int]:
    """The parts of the clashes among ``found``."""
    return {p for x in found if x is not None and x.kind == "clash" for p in (x.a, x.b)}


def pair_results(work: PairWork, clashing: set[int] | None,
                 meanwhile: Callable[[], Any] | None = None) -> tuple[list, set[int] | None]:
    """Each candidate pair's result (None: left out) and, with ``clashing`` (the parts of
    the clashes known beforehand, e.g. nested parts; None: every pair whole), the parts of
    every clash. With ``clashing``, the result of a pair of a clashing part may hold its
    interference test alone, or be None (the items dropped, in the module's description).
    ``meanwhile`` is called once while the mapper works."""
    n = len(work.pairs)
    # the costliest first to the workers: the crossing pairs (an overlap boolean), then
    # by their triangles
    by_cost = sorted(range(n), key=lambda k: (-bool(work.pairs[k][2]), -work.size[k], k))
    if clashing is None:
        results: list = [work.lookup(k) for k in range(n)]
        for k, _, res in work.run([(k, WHOLE) for k in by_cost if results[k] is None],
                                  meanwhile):
            results[k] = res
            work.store(k, WHOLE, res)
        return results, None
    results, tested = _cached(work)
    clashing = clashing | clashing_parts([r[0] for r in results if r is not None])
    jobs = _jobs(work, by_cost, results, tested, clashing)
    left = sum(1 for _, part in jobs if part == INTERFERENCE)
    surface_item = {k: y for y, (k, part) in enumerate(jobs) if part == SURFACE}
    drop: set[int] = set()  # items not to start: see the module's description
    surfaces: dict[int, Result] = {}
    fresh: set[int] = set()  # tests computed now (the others came from the cache)
    for k, part, res in work.run(jobs, meanwhile, drop):
        if part == SURFACE:  # merged with its test's below (a cluster may send it first)
            surfaces[k] = res
            continue
        if part == WHOLE or res[0] is not None:  # interfering: its fit's contacts, whole
            results[k] = res
            work.store(k, WHOLE, res)
        else:
            tested[k] = res
            fresh.add(k)
        if part == INTERFERENCE:
            left -= 1
            clashing |= clashing_parts([res[0]])
            if res[0] is not None and k in surface_item:
                drop.add(surface_item[k])
            if not left:
                drop.update(y for y, (j, _) in enumerate(jobs)
                            if clashing & set(work.pairs[j][:2]))
    for k, res in tested.items():
        if results[k] is None:
            if k in surfaces:  # the test's verdict and time, the contacts found apart
                surf = surfaces[k]
                res = (None, res[1], surf[2], surf[3], res[4])
                work.store(k, WHOLE, res)
            elif k in fresh:  # a clashing part's: its test alone
                work.store(k, INTERFERENCE, res)
            results[k] = res
    return results, clashing


def _cached(work: PairWork) -> tuple[list, dict[int, Result]]:
    """The pairs' whole results found in the cache, and the crossing pairs' tests found
    there without an interference (their surface contacts still to find)."""
    results: list = [None] * len(work.pairs)
    tested: dict[int, Result] = {}
    for k, (_, _, crossing) in enumerate(work.pairs):
        if not crossing:
            results[k] = work.lookup(k)
            continue
        results[k] = work.lookup(k, WHOLE, final=False)
        if results[k] is None:
            got = work.lookup(k, INTERFERENCE)
            if got is not None and got[0] is None:
                tested[k] = got
            else:
                results[k] = got
    return results, tested


def _jobs(work: PairWork, by_cost: list[int], results: list, tested: dict[int, Result],
          clashing: set[int]) -> list[tuple[int, str]]:
    """The items ``(k, part)`` to compute, in the order of the module's description."""
    pairs = work.pairs
    testing = [k for k in by_cost if pairs[k][2] and results[k] is None and k not in tested]
    suspect = clashing | {p for k in testing for p in pairs[k][:2]}
    safe = [k for k in by_cost if results[k] is None and not pairs[k][2]
            and not suspect & set(pairs[k][:2])]
    first = set(safe)
    rest = [(k, SURFACE if pairs[k][2] else WHOLE) for k in by_cost
            if results[k] is None and k not in first and not clashing & set(pairs[k][:2])]
    return [(k, INTERFERENCE) for k in testing] + [(k, WHOLE) for k in safe] + rest
