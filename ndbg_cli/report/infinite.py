"""The report section of the NDBG for infinite translations (see
``schemas/fragments/infinite.json``) and its text summary."""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..core.constants import INFINITE
from ..ndbg.model import NDBG, Partitioning
from .infinitesimal import partitioning_record

if TYPE_CHECKING:
    from ..core.assembly import Assembly



# --------------------------------------------------------------------------------------------

def partitioning_records(ndbg: NDBG, parts: list[Partitioning]) -> list[dict]:
    """Partitionings as report records
    (:func:`~ndbg_cli.ndbg.infinitesimal.build.partitioning_record`: at most
    ``MAX_DIRECTIONS`` region directions, lowest-dimensional first, and the number of regions,
    which may run into thousands for one part)."""
    return [partitioning_record(ndbg, p) for p in parts]


def infinite_section(asm: Assembly, ndbg: NDBG, partitionings: list[Partitioning],
                     truncated: bool) -> dict:
    """The report's ``infinite`` section (see ``schemas/fragments/infinite.json``)."""
    distinct = ndbg.distinct()
    index = {dbg.succ: k for k, (dbg, _) in enumerate(distinct)}
    region_list = [{"dimension": r.dimension, "direction": list(r.direction),
                    "dbg": index[r.dbg.succ]} for r in ndbg.regions]
    dbgs = [{"arcs": [[ndbg.ids[i], ndbg.ids[j]] for i, j in dbg.arcs()],
             "regions": len(rs)} for dbg, rs in distinct]
    stats = ndbg.stats
    extra = {"exact_cells_skipped": stats["exact_cells_skipped"]} \
        if stats.get("exact_cells_skipped") else {}
    return {
        **extra,
        "family": INFINITE,
        "regions_by_dimension": stats.get("regions_by_dimension", ndbg.region_counts()),
        "regions": len(ndbg.regions), "distinct_dbgs": len(distinct),
        "length_tolerance": asm.length_tolerance,
        "angular_tolerance": stats.get("angular_tolerance"),
        "region_list": region_list, "dbgs": dbgs,
        "partitionings": partitioning_records(ndbg, partitionings),
        "partitionings_truncated": bool(truncated),
    }


def infinite_text(section: dict) -> list[str]:
    """Human-readable lines summarising an ``infinite`` section."""
    byd = section["regions_by_dimension"]
    lines = [f"infinite translations: {section['regions']} regions "
             f"({', '.join(f'{v} of dim {k}' for k, v in sorted(byd.items(), reverse=True))}), "
             f"{section['distinct_dbgs']} distinct DBGs"]
    parts = section["partitionings"]
    more = " (truncated)" if section.get("partitionings_truncated") else ""
    lines.append(f"  {len(parts)} partitionings removable by one translation{more}")
    for p in parts[:20]:
        d = p["directions"][0] if p["directions"] else []
        ds = ", ".join(f"{x:.3f}" for x in d)
        lines.append(f"  - move {{{', '.join(p['moved'])}}} along ({ds}), "
                     f"{len(p['directions'])} region(s)")
    if len(parts) > 20:
        lines.append(f"  ... and {len(parts) - 20} more")
    return lines
