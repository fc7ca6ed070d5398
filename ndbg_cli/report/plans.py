"""The report's ``plan`` section: the assembly tree and sequence of a plan (paper Fig. 1,
section 4.4), with its depth bounds."""

from __future__ import annotations

from ..planning.andor import lower_bound_depth
from ..planning.plans import Plan, sequence_json, tree_json


def plan_section(p: Plan) -> dict:
    """The report's ``plan`` section."""
    return {
        "strategy": p.strategy,
        "found": p.found,
        "exact": p.exact,
        "depth": p.depth() if p.found else None,
        "depth_lower_bound": lower_bound_depth(p.root) if p.depth_lower is None
        else p.depth_lower,
        "connected": p.connected,
        "nonlinear_steps": p.nonlinear() if p.found else None,
        "regions_used": p.regions_used(),
        "stuck": None if p.stuck is None else p.ndbg.names(p.stuck),
        "notes": list(p.notes),
        "tree": tree_json(p) if p.found else None,
        "sequence": sequence_json(p),
    }


def split_nodes(tree: dict | None) -> list[dict]:
    """The internal nodes (the splits) of a plan section's ``tree``, parents first."""
    out, stack = [], [tree]
    while stack:
        node = stack.pop()
        if node and "moved" in node:
            out.append(node)
            stack += [node["rest"], node["moved"]]
    return out


def mark_presses(section: dict, press: set[frozenset[str]]) -> None:
    """Mark with ``"press": true`` each step of a plan ``section`` (sequence and tree) that
    separates a press-fitted pair (``press``: pairs of part ids,
    :mod:`ndbg_cli.contacts.fits`): it slides along the fit's axis against the interference."""
    if not press:
        return

    def presses(moved: list[str], rest: list[str]) -> bool:
        return any(frozenset((a, b)) in press for a in moved for b in rest)

    for step in section.get("sequence") or []:
        if presses(step["moved"], step["onto"]):
            step["press"] = True
    for node in split_nodes(section.get("tree")):
        if presses(node["moved"]["parts"], node["rest"]["parts"]):
            node["press"] = True
