"""How much of a report is written: ``--detail summary`` (the CLI's default) or ``full``.

A full report lists every contact point, every region of every NDBG with its DBG, every
candidate partitioning (up to ``--max-partitions`` per family) and every suggested motion:
16.7 MB for the 115-part engine, more than a person or a CI job opens. The summary keeps
every answer (the plan with its proofs, the classes, the interferences, the warnings, the
AND/OR graph counts, each family's counts and tolerances) and the first
:data:`SUMMARY_ITEMS` entries of the long lists, and says what it left out in
``options.detail``. The analysis itself does not change: only what is written (pictures are
drawn from the full report).
"""

from __future__ import annotations

import copy

__all__ = ["DETAILS", "SUMMARY_ITEMS", "summarize"]

#: The ``--detail`` levels.
DETAILS = ("summary", "full")
#: Entries kept of each long list (partitionings per family, suggested motions, candidates).
SUMMARY_ITEMS = 20
#: Per NDBG section: the lists a summary leaves out (their counts stay in the section).
_SECTION_LISTS = ("dbgs", "region_list")
#: Per contact: the arrays a summary leaves out (``point_count`` says how many points).
_CONTACT_ARRAYS = ("points", "point_normals")


def summarize(report: dict) -> dict:
    """``report`` (a report or an error record) as ``--detail summary`` writes it: a copy
    without each contact's points (``point_count`` instead), without each NDBG section's
    ``dbgs`` and ``region_list`` (its ``regions`` and ``distinct_dbgs`` counts stay), with
    the first :data:`SUMMARY_ITEMS` partitionings of each family and suggested motions and
    candidates of the generalized family; ``options.detail`` records what was cut.

    Examples
    --------
    >>> import ndbg_cli
    >>> full = ndbg_cli.analyze(ndbg_cli.load("assemblies/hover.yaml"))
    >>> short = summarize(full)
    >>> short["plan"] == full["plan"], "points" in short["contacts"][0]
    (True, False)
    >>> short["options"]["detail"]["level"]
    'summary'
    """
    if "error" in report:
        return report
    out = copy.copy(report)
    cut: dict = {}
    contacts = []
    for c in report.get("contacts") or []:
        short = {k: v for k, v in c.items() if k not in _CONTACT_ARRAYS}
        # a record built without its points (``Options.contact_points``) has their count
        short["point_count"] = (len(c.get("points") or []) if "point_count" not in c
                                else c["point_count"])
        contacts.append(short)
    out["contacts"] = contacts
    kept, per_family = [], {}
    for p in report.get("partitionings") or []:
        n = per_family.get(p.get("family"), 0)
        per_family[p.get("family")] = n + 1
        if n < SUMMARY_ITEMS:
            kept.append(p)
    out["partitionings"] = kept
    if len(kept) < sum(per_family.values()):
        cut["partitionings"] = dict(sorted(per_family.items()))
    out["ndbg"] = {fam: _section(fam, sec, cut) for fam, sec in (report.get("ndbg") or {}).items()}
    out["options"] = {**(report.get("options") or {}), "detail": {
        "level": "summary", "items": SUMMARY_ITEMS, "left_out": cut,
        "why": "contact points, each NDBG's regions and DBGs, and list entries past the "
               f"first {SUMMARY_ITEMS} are left out (counts kept); --detail full writes "
               "them"}}
    return out


def _section(family: str, sec: dict, cut: dict) -> dict:
    """One NDBG section as summarized (:func:`summarize`); what it drops goes to ``cut``."""
    if not isinstance(sec, dict):
        return sec
    out = {k: v for k, v in sec.items() if k not in _SECTION_LISTS}
    dropped = sorted(k for k in _SECTION_LISTS if k in sec)
    for key in ("suggested_motions", "candidates"):
        items = sec.get(key)
        if isinstance(items, list) and len(items) > SUMMARY_ITEMS:
            out[key] = items[:SUMMARY_ITEMS]
            dropped.append(f"{key} past {SUMMARY_ITEMS} of {len(items)}")
    if dropped:
        cut[family] = dropped
    return out
