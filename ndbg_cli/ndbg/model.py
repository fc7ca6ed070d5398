"""The non-directional blocking graph (NDBG): regular regions of motion directions, each with
its DBG, and the candidate partitionings they yield (paper sections 4.2 and 4.4).

Every motion family produces an :class:`NDBG`: ``infinitesimal_translation`` (regions of the
arrangement induced by the contact cones; necessary conditions), ``infinite_translation``
(regions of the arrangement of the blocked sets B_ij; sufficient conditions) and
``generalized`` (one "region" per suggested rotation or screw). A region's DBG has an arc
``i -> j`` when ``j`` blocks ``i`` moving along the region's motion while ``j`` stays.
Subassemblies are bitmasks over ``NDBG.ids``; nothing here touches geometry again.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

from ..core.memo import kept
from .dbg import DBG, bits, free_subsets, mask_of, reach


@dataclass(frozen=True)
class Region:
    """A regular region: its dimension (2, 1 or 0 on S^2; 1 or 0 on S^1; for suggested
    generalized motions ``-1``), a representative motion and the DBG over it.

    ``direction`` is a unit vector (length 2 or 3) for translations, ``None`` otherwise; ``motion``
    describes a generalized motion (``{"type": "rotation"|"screw", "axis": ..., "point": ...,
    "pitch": ...}``) and is ``None`` for translations. ``sliding``: the number of distinct contact
    normals perpendicular to ``direction`` (infinite translations: the contacts it slides along
    exactly; not reported), which ranks the lower-dimensional regions of a move
    (:func:`ndbg_cli.planning.plans.pick_region`). ``thin``: a full-dimensional region too narrow
    for its direction to be trusted as open, ranked with the lower-dimensional ones by
    ``pick_region`` (infinite translations in 2D: an arc of S^1 at most
    :data:`ndbg_cli.ndbg.infinite.equator.BAND_ETA` ``eta`` wide, which may be one of the erosion's
    tolerance bands beside a sliding direction, see :mod:`ndbg_cli.ndbg.infinite.equator`; not
    reported).
    """

    dimension: int
    direction: tuple[float, ...] | None
    dbg: DBG
    motion: dict | None = None
    sliding: int = 0
    thin: bool = False


@dataclass(frozen=True)
class NDBG:
    """All regions of one motion family over parts ``ids`` (the node order of every DBG).

    ``geometry``: what the regions were computed from, when its builder keeps it: the
    infinitesimal 3D NDBG's arrangement (:class:`ndbg_cli.geometry.sphere.Arrangement`, regions in
    :meth:`~ndbg_cli.geometry.sphere.Arrangement.regions` order), the infinite NDBG's blocked sets
    (:class:`ndbg_cli.ndbg.infinite.build.BlockedSets`: direction lookups and the grasp's cells);
    ``None`` otherwise. Kept by ``dataclasses.replace`` (e.g. threaded pairs blocked)."""

    family: str
    ids: tuple[str, ...]
    regions: tuple[Region, ...]
    space_dimension: int = 3
    stats: dict = field(default_factory=dict)
    geometry: object = field(default=None, compare=False, repr=False)

    @property
    def n(self) -> int:
        return len(self.ids)

    def distinct(self) -> list[tuple[DBG, list[int]]]:
        """Distinct DBGs with the indices of the regions having them, in first-seen order."""
        return [(self.regions[regs[0]].dbg, list(regs)) for regs in self._groups()[1]]

    def dbg_group(self) -> tuple[int, ...]:
        """For each region, the index of its DBG among :meth:`distinct`'s: regions of one
        group have equal DBGs, so a search over induced DBGs visits one region per group
        (the engine: 110 distinct DBGs over 6,934 regions).

        >>> from ndbg_cli.ndbg.dbg import DBG
        >>> a, b = DBG((0b10, 0)), DBG((0, 0))
        >>> NDBG("f", ("x", "y"), tuple(Region(0, None, g) for g in (a, b, a))).dbg_group()
        (0, 1, 0)
        """
        return self._groups()[0]

    def _groups(self) -> tuple[tuple[int, ...], tuple[tuple[int, ...], ...]]:
        return kept(self, "_dbg_groups", self._make_groups)  # once per NDBG

    def _make_groups(self) -> tuple[tuple[int, ...], tuple[tuple[int, ...], ...]]:
        seen: dict[tuple[int, ...], int] = {}
        group, members = [], []
        for k, r in enumerate(self.regions):
            g = seen.setdefault(r.dbg.succ, len(seen))
            if g == len(members):
                members.append([])
            members[g].append(k)
            group.append(g)
        return tuple(group), tuple(map(tuple, members))

    def region_counts(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        for r in self.regions:
            counts[str(r.dimension)] = counts.get(str(r.dimension), 0) + 1
        return counts

    def mask(self, part_ids) -> int:
        index = {pid: k for k, pid in enumerate(self.ids)}
        return mask_of(index[p] for p in part_ids)

    def names(self, mask: int) -> list[str]:
        return [self.ids[i] for i in bits(mask)]

    def mutual_blocks(self, pairs) -> DBG | None:
        """The DBG with arcs ``a -> b`` and ``b -> a`` for each pair of part ids (threaded
        pairs: neither may translate away from the other); pairs naming absent parts are
        skipped; ``None`` when none is left."""
        index = {pid: k for k, pid in enumerate(self.ids)}
        arcs = [(index[a], index[b]) for a, b in pairs if a in index and b in index]
        return DBG.from_arcs(self.n, arcs + [(j, i) for i, j in arcs]) if arcs else None


@dataclass(frozen=True)
class Partitioning:
    """A candidate partitioning of a subassembly into ``moved`` and ``rest`` (bitmasks):
    ``moved`` is free along every region listed in ``regions`` (indices into the NDBG)."""

    moved: int
    rest: int
    family: str
    regions: tuple[int, ...]


def partitionings(ndbg: NDBG, mask: int | None = None, *, limit: int | None = None,
                  connected: ConnectivityTest | None = None
                  ) -> tuple[list[Partitioning], bool]:
    """Every candidate partitioning of the subassembly ``mask`` (default: all parts).

    For each distinct DBG (induced on ``mask``), every free subset ``S`` gives the partitioning
    ``{S, mask \\ S}`` with ``S`` moving. Partitionings are deduplicated across regions by the
    (moved, rest) pair, collecting the regions where ``moved`` is free. With ``connected``,
    both sides must be connected (e.g. in the contact graph). Returns ``(list, truncated)``;
    ``truncated`` is True when ``limit`` stopped the enumeration.

    When ``limit`` cuts, the most useful sets are kept: a first pass takes, in every distinct
    DBG, the single parts that are free (no outgoing arc inside ``mask``: ``O(n)`` per DBG),
    so every part that comes out on its own is listed; the output-sensitive
    enumeration of all free sets fills the rest of the budget. The regions listed for a set
    are complete when nothing was cut (after a cut, the remaining DBGs are not visited).
    """
    m = (1 << ndbg.n) - 1 if mask is None else mask
    found: dict[int, set[int]] = {}
    truncated = False
    seen_dbgs: dict[tuple[int, ...], list[int]] = {}
    full = m == (1 << ndbg.n) - 1
    members = list(bits(m))
    for dbg, regs in ndbg.distinct():  # equal DBGs induce equal ones: one key per group
        key = dbg.succ if full else tuple(dbg.succ[i] & m for i in members)
        seen_dbgs.setdefault(key, []).extend(regs)
    groups = [(ndbg.regions[ids[0]].dbg, ids) for ids in seen_dbgs.values()]

    def take(s: int, region_ids: list[int]) -> bool:
        """Record ``s``; False when the limit is reached."""
        if s in found:
            found[s].update(region_ids)
            return True
        if connected is not None and not (connected(s) and connected(m & ~s)):
            return True
        if limit is not None and len(found) >= limit:
            return False
        found[s] = set(region_ids)
        return True

    if limit is not None:
        for dbg, region_ids in groups:
            singles = [1 << i for i in members if not dbg.succ[i] & m and 1 << i != m]
            if not all(take(c, region_ids) for c in singles):
                truncated = True
                break
    for dbg, region_ids in groups:
        if truncated:
            break
        for s in free_subsets(dbg, m):
            if not take(s, region_ids):
                truncated = True
                break
    out = [Partitioning(moved=s, rest=m & ~s, family=ndbg.family,
                        regions=tuple(sorted(regs))) for s, regs in found.items()]
    out.sort(key=lambda p: (p.moved.bit_count(), p.moved))
    return out, truncated


class ConnectivityTest:
    """``test(mask)``: is the subassembly ``mask`` connected in an undirected graph given as
    neighbour bitmasks (e.g. the contact graph)? Answers are memoised (the AND/OR graph asks
    for the same sides again and again), up to :attr:`MEMO` of them."""

    #: Answers kept (then the memo starts over).
    MEMO = 1 << 18

    def __init__(self, neighbours: list[int]):
        self.neighbours = neighbours
        self._memo: dict[int, bool] = {}

    def __call__(self, mask: int) -> bool:
        got = self._memo.get(mask)
        if got is not None:
            return got
        if mask == 0:
            return False
        seen = reach(mask & -mask, self.neighbours, mask)
        if len(self._memo) >= self.MEMO:
            self._memo.clear()
        self._memo[mask] = got = seen == mask
        return got


def iter_free_regions(ndbg: NDBG, moved: int, mask: int | None = None) -> Iterator[int]:
    """Indices of the regions in which ``moved`` is free inside ``mask``."""
    for k, r in enumerate(ndbg.regions):
        if r.dbg.is_free(moved, mask):
            yield k
