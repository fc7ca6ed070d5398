"""The report's AND/OR graph section and the readable lines of the classes (paper section 7.2):
sizes and exact counts of the graph the classes built, and one line per class with its evidence."""

from __future__ import annotations

from ..planning.andor import AndOrGraph, lower_bound_depth
from ..planning.classes import verdict
from ..planning.decompose import min_depth_search


def _big(value: int | None) -> dict:
    return {} if value is None or abs(value) <= 2 ** 53 else {"as_string": str(value)}


def andor_section(graph: AndOrGraph, depth: dict | None = None) -> dict:
    """The report's ``andor`` section: graph size and exact measures (``None`` when the graph is
    truncated, except the minimum depth, which then comes from :func:`min_depth_search` when
    its own budget suffices, else from its bounds; ``depth``, the family's ``min_depth``
    measure from :func:`classify` on the same graph, spares that search). ``cut_by`` and
    ``why`` say what cut a truncated graph. Counts above 2^53 are also given as decimal
    strings."""
    graph.build()
    out: dict = {
        "nodes": graph.built_size[0],
        "hyperarcs": graph.built_size[1],
        "truncated": graph.truncated,
        "split_truncated": graph.split_truncated,
        "cut_by": graph.cut_by if graph.truncated else None,
        "why": graph.cut_reason() if graph.truncated else
        f"complete: all {graph.node_count} subassemblies reachable by candidate partitionings",
        "min_depth": None, "trees": None, "linear_sequences": None, "min_nonlinear": None,
        "min_depth_lower_bound": lower_bound_depth(graph.root),
        "min_depth_upper_bound": None,
        "counted": {
            "trees": "distinct binary decomposition trees, children unordered, every internal "
                     "node a candidate partitioning (moving side and region ignored)",
            "linear_sequences": "orderings (p1..pn) of the parts with {p_k} vs {p1..p_k-1} a "
                                "candidate partitioning of {p1..p_k} for every k >= 2 (both "
                                "orders of the first two parts counted)",
        },
    }
    if graph.complete:
        d = graph.min_depth()
        out.update(min_depth=d, min_depth_lower_bound=d, min_depth_upper_bound=d,
                   min_depth_exact=True, trees=graph.tree_count(),
                   linear_sequences=graph.linear_count(), min_nonlinear=graph.min_nonlinear())
        if _big(out["trees"]):
            out["trees_str"] = str(out["trees"])
        if _big(out["linear_sequences"]):
            out["linear_sequences_str"] = str(out["linear_sequences"])
    elif depth is not None:
        exact = bool(depth.get("exact"))
        out.update(min_depth=depth["value"] if exact else None,
                   min_depth_lower_bound=depth.get("lower_bound", depth["value"]),
                   min_depth_upper_bound=depth.get("upper_bound", depth["value"]),
                   min_depth_exact=exact)
    else:
        r = min_depth_search(graph.ndbg, graph.root, base=graph.base, connected=graph.connected,
                             budget=graph.budget, graph=graph)
        out.update(min_depth=r.depth if r.exact else None, min_depth_lower_bound=r.lower,
                   min_depth_upper_bound=r.upper, min_depth_exact=r.exact)
    return out


def classes_text(section: dict) -> list[str]:
    """Designer-readable summary of :func:`classes_section`."""
    lines = []
    labels = {"one_handed_monotone": "1-handed monotone", "prismatic": "1-prismatic",
              "linearizable": "linearizable", "min_nonlinear": "nonlinear steps (min)",
              "min_depth": "minimum depth", "stack_product": "stack product",
              "min_directions": "directions (min)", "interlocked": "interlocked",
              "grasp": "form-closure grasp fingers"}
    for fam in sorted(section):
        lines.append(f"{fam.replace('_', ' ')}:")
        for key, name in labels.items():
            m = section[fam].get(key)
            if m is None:
                continue
            vs = verdict(key, m) if "evidence" in m else _plain(m)
            lines.append(f"  {name}: {vs} - {m.get('why', '')}")
    return lines


def _plain(m: dict) -> str:
    """The value of a measure without ``evidence`` (a report written before it existed)."""
    v = m.get("value")
    if isinstance(v, bool):
        return "yes" if v else "no"
    if v is None:
        return "undecided"
    return str(v) + ("" if m.get("exact", True) else " (upper bound)")
