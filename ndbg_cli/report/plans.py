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
