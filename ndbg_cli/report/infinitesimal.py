"""The report section of the NDBG for infinitesimal translations
(``schemas/fragments/infinitesimal.json``), the partitionings' records and the text summary."""

from __future__ import annotations

import heapq
from collections.abc import Sequence

from ..core.constants import ANGLE_TOL_RAD, INFINITESIMAL
from ..core.memo import kept
from ..ndbg.dbg import DBG, bits
from ..ndbg.model import NDBG, Partitioning

#: At most this many directions are listed per partitioning in the report.
MAX_DIRECTIONS = 32


def infinitesimal_section(asm, ndbg: NDBG, parts: Sequence[Partitioning],
                          truncated: bool, *, region_limit: int | None = None) -> dict:
    """The report section (under ``report["ndbg"]["infinitesimal_translation"]``; the
    ``partitionings`` list belongs under ``report["partitionings"]``). Deterministic: regions
    in arrangement order, DBGs in order of first appearance, arcs sorted. ``region_limit``
    caps ``region_list`` (``region_list_truncated`` says so); the counts stay complete."""
    ids = list(ndbg.ids)
    distinct = ndbg.distinct()
    which = {}
    for k, (_, members) in enumerate(distinct):
        for r in members:
            which[r] = k
    stats = ndbg.stats
    counts = {str(d): 0 for d in range(ndbg.space_dimension)}
    counts.update(ndbg.region_counts())
    section = {
        "family": INFINITESIMAL,
        "space_dimension": ndbg.space_dimension,
        "angle_tolerance": stats.get("angle_tolerance", ANGLE_TOL_RAD),
        "regions_by_dimension": counts,
        "regions": len(ndbg.regions),
        "distinct_dbgs": len(distinct),
        "contact_pairs": stats.get("pairs", 0),
        "normals": stats.get("normals", 0),
        "arrangement": {k: stats[k] for k in ("circles", "circles_total", "diameters",
                                              "refined") if k in stats},
        "region_list": [{"dimension": r.dimension, "direction": list(r.direction or ()),
                         "dbg": which[k]}
                        for k, r in enumerate(ndbg.regions[:region_limit])],
        "region_list_truncated": region_limit is not None and len(ndbg.regions) > region_limit,
        "dbgs": [{"arcs": sorted([ids[i], ids[j]] for i, j in g.arcs()),
                  "regions": len(members),
                  "strongly_connected": g.n > 0 and _strongly_connected(g)}
                 for g, members in distinct],
        "partitionings": [partitioning_record(ndbg, p) for p in parts],
        "partitionings_truncated": bool(truncated),
    }
    if asm is not None:
        section["assembly"] = asm.name
    return section


def _strongly_connected(g: DBG) -> bool:
    from ..ndbg.dbg import strong_components

    return len(strong_components(g)) == 1


def partitioning_record(ndbg: NDBG, p: Partitioning) -> dict:
    """One candidate partitioning for the report: moved and rest part ids, the motion family
    and the representative directions of (at most :data:`MAX_DIRECTIONS`) regions along which
    ``moved`` is free, lowest-dimensional regions first."""
    # the first MAX_DIRECTIONS of the regions sorted by (dimension, index), without sorting
    # them all (a partitioning of the engine is free in hundreds of regions)
    order = heapq.nsmallest(MAX_DIRECTIONS, p.regions, key=_ranks(ndbg).__getitem__)
    dirs = [list(ndbg.regions[k].direction or ()) for k in order]
    return {"moved": [ndbg.ids[i] for i in bits(p.moved)],
            "rest": [ndbg.ids[i] for i in bits(p.rest)],
            "family": p.family, "directions": dirs, "regions": len(p.regions)}


def _ranks(ndbg: NDBG) -> list[tuple[int, int]]:
    """``(dimension, index)`` of every region of ``ndbg`` (kept on the instance)."""
    return kept(ndbg, "_report_ranks",
                lambda: [(r.dimension, k) for k, r in enumerate(ndbg.regions)])


def _vec(v: Sequence[float]) -> str:
    return "(" + ", ".join(f"{x:+.3f}" for x in v) + ")"


def infinitesimal_text(section: dict, limit: int = 12) -> list[str]:
    """Readable lines for the text report."""
    c = section["regions_by_dimension"]
    dims = ", ".join(f"{c[k]} of dimension {k}" for k in sorted(c))
    lines = ["", "infinitesimal translations (NDBG, paper 4.2/5.1)",
             f"  {section['regions']} regular regions ({dims}), "
             f"{section['distinct_dbgs']} distinct DBGs, "
             f"{section['contact_pairs']} contacting pairs, angular tolerance "
             f"{section['angle_tolerance']:g} rad"]
    parts = section.get("partitionings", [])
    more = " (truncated)" if section.get("partitionings_truncated") else ""
    lines.append(f"  {len(parts)} candidate partitionings{more}")
    if section.get("conservative_contacts"):
        lines.append(f"  {section['conservative_contacts']} edge/point contacts read on every "
                     "face meeting there (more than they block): free splits may be missing")
    for p in parts[:limit]:
        d = _vec(p["directions"][0]) if p["directions"] else "-"
        lines.append(f"    move {{{', '.join(p['moved'])}}} from {{{', '.join(p['rest'])}}}"
                     f" along {d}" + (f" (+{p['regions'] - 1} more regions)"
                                      if p["regions"] > 1 else ""))
    if len(parts) > limit:
        lines.append(f"    ... {len(parts) - limit} more")
    return lines
