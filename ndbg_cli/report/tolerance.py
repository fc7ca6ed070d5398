"""``near-tolerance`` warnings: answers the report gives that tolerance-level details of the
geometry may change (issue 34, item 3: a borderline answer is said to be one, not left to flip
silently between frames, units or tessellations).

The one such answer today is a finger count (paper 7.2) that is only the greedy placement's
upper bound (the exact minimum over its budget): the greedy count follows the NDBG's regions,
and those follow how contact normals within the angular tolerance are merged and how near
misses' cones are faceted, which a turn or a re-export of the same model can change. The
exact count, where it is computed, depends on neither and gets no warning.
"""

from __future__ import annotations

__all__ = ["CODE", "warnings"]

#: The warnings' code; ``fields`` names the answers, as dotted paths of the report.
CODE = "near-tolerance"


def warnings(report: dict, file: str | None = None) -> list[dict]:
    """The report's ``near-tolerance`` warning records.

    Parameters
    ----------
    report : dict
        A report with its ``classes`` section.
    file : str, optional
        The assembly's source file.

    Returns
    -------
    list of dict
        Diagnostic records (``level``, ``code``, ``message``, ``part``, ``file``,
        ``fields``), one per finger count that is a greedy bound.

    Examples
    --------
    >>> rep = {"classes": {"infinitesimal_translation": {"grasp": {
    ...     "value": 52, "exact": False, "lower_bound": 1, "upper_bound": 52}}}}
    >>> [w["fields"] for w in warnings(rep)]
    [['classes.infinitesimal_translation.grasp']]
    """
    out = []
    for fam, classes in sorted((report.get("classes") or {}).items()):
        grasp = classes.get("grasp") if isinstance(classes, dict) else None
        if not isinstance(grasp, dict) or grasp.get("value") is None or grasp.get("exact"):
            continue
        out.append({
            "level": "warning", "code": CODE, "part": None, "file": file,
            "fields": [f"classes.{fam}.grasp"],
            "message": f"{fam} grasp: {grasp['value']} fingers is a greedy upper bound (the "
                       f"exact minimum is over its budget; at least {grasp.get('lower_bound')})"
                       "; it follows the NDBG's regions, which contact details within the "
                       "tolerances change, so another frame or export of the model may give "
                       "another bound"})
    return out
