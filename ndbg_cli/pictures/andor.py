"""The AND/OR graph of a family's candidate assembly trees (paper section 7.2), drawn where
it is small.

The report keeps only the graph's size, so it is built again, by the planner's own
:class:`~ndbg_cli.planning.andor.AndOrGraph`, from the family's regions and DBGs as the report
lists them; it is drawn only when the report's graph was complete, the region list is whole,
the graph has at most :data:`MAX_NODES` subassemblies, and the rebuilt graph has the report's
counts of subassemblies and partitionings (else the page says why it is not drawn).

Drawn in layers by size, the whole assembly on top and the parts at the bottom: each
subassembly (OR node) a box, each partitioning (AND node) a dot joined to its two sides; the
partitionings of the plan's tree in red.
"""

from __future__ import annotations

from html import escape

from ._scene import node_ids

#: Subassemblies above which the graph is not drawn (it would be unreadable).
MAX_NODES = 40

#: Room per node in a layer and per layer, in SVG pixels.
NODE_DX = 120
LAYER_DY = 80


def rebuild(report: dict, family: str):
    """``(AndOrGraph, part ids)`` of ``family`` rebuilt from ``report``, or ``(None, why)``."""
    from ..ndbg.dbg import DBG
    from ..ndbg.model import NDBG, Region
    from ..planning.andor import AndOrGraph

    sec = (report.get("ndbg") or {}).get(family) or {}
    want = (report.get("andor") or {}).get(family) or {}
    if not want or want.get("truncated"):
        return None, "the report's graph is cut (no exact graph to draw)"
    if want.get("nodes", 0) > MAX_NODES:
        return None, f"{want['nodes']} subassemblies: too many to draw (at most {MAX_NODES})"
    if not sec.get("region_list") or sec.get("region_list_truncated"):
        return None, "the report does not list every region of this family"
    ids = node_ids(report)
    index = {p: k for k, p in enumerate(ids)}
    dbgs = [DBG.from_arcs(len(ids), [(index[a], index[b]) for a, b in g["arcs"]])
            for g in sec["dbgs"]]
    regions = tuple(Region(int(r["dimension"]), tuple(r["direction"]) if r.get("direction")
                           else None, dbgs[int(r["dbg"])]) for r in sec["region_list"])
    ndbg = NDBG(family, tuple(ids), regions, space_dimension=len(regions[0].direction or ()))
    base = report["assembly"].get("base")
    graph = AndOrGraph(ndbg, base=index.get(base) if base else None).build()
    if graph.truncated or graph.built_size != (want.get("nodes"), want.get("hyperarcs")):
        return None, "rebuilt from the report it does not match the report's counts"
    return graph, ids


def _plan_splits(report: dict, family: str) -> set[tuple[frozenset, frozenset]]:
    """The plan's steps in ``family`` as ``(whole, moved)`` part sets."""
    plan = report.get("plan") or {}
    if plan.get("family") != family:
        return set()
    return {(frozenset(s["produces"]), frozenset(s["moved"]))
            for s in plan.get("sequence") or []}


def _positions(graph) -> tuple[dict[int, tuple[float, float]], float, float]:
    """Each subassembly's place (layers by size, the whole on top) and the drawing's size."""
    masks = set(graph.arcs) | {h.left for a in graph.arcs.values() for h in a} \
        | {h.right for a in graph.arcs.values() for h in a}
    layers: dict[int, list[int]] = {}
    for m in sorted(masks):
        layers.setdefault(m.bit_count(), []).append(m)
    sizes = sorted(layers, reverse=True)
    width = NODE_DX * max(len(v) for v in layers.values()) + 40
    height = LAYER_DY * (len(sizes) - 1) + 50
    at = {}
    for row, size in enumerate(sizes):
        gap = (width - 40) / len(layers[size])
        for k, m in enumerate(layers[size]):
            at[m] = (20 + gap * (k + 0.5), 25 + LAYER_DY * row)
    return at, width, height


def andor_svg(report: dict, family: str) -> tuple[str | None, str]:
    """``(SVG of the family's AND/OR graph or None, a caption saying what is drawn or why
    not)``."""
    graph, ids = rebuild(report, family)
    if graph is None:
        return None, ids
    if not any(graph.arcs.values()):
        return None, "no candidate partitioning: a single node"

    def names(m: int) -> list[str]:
        return [ids[i] for i in range(len(ids)) if m >> i & 1]

    at, width, height = _positions(graph)
    plan = _plan_splits(report, family)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" class="andor" width="{width:.0f}" '
           f'height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" '
           'font-family="sans-serif" font-size="10">']
    arcs = sum(len(v) for v in graph.arcs.values())
    for m in sorted(graph.arcs):
        for k, h in enumerate(graph.arcs[m]):
            whole = frozenset(names(m))
            red = any((whole, frozenset(names(side))) in plan for side in (h.left, h.right))
            (px, py), (lx, ly), (rx, ry) = at[m], at[h.left], at[h.right]
            # the AND dots of one node spread in a row below it (their sides' midpoints
            # often coincide)
            spread = (k - (len(graph.arcs[m]) - 1) / 2) * min(22.0, 90 / len(graph.arcs[m]))
            dx, dy = px + spread, py + LAYER_DY * 0.45
            colour, w = ("#d62728", 2.2) if red else ("#9a9a9a", 1)
            sides = " | ".join(", ".join(names(side)) for side in (h.left, h.right))
            out.append(f"<g><title>{escape(sides)}</title>"
                       f'<path d="M{px:.1f},{py:.1f} L{dx:.1f},{dy:.1f} M{lx:.1f},{ly:.1f} '
                       f'L{dx:.1f},{dy:.1f} L{rx:.1f},{ry:.1f}" fill="none" stroke="{colour}" '
                       f'stroke-width="{w}"/><circle cx="{dx:.1f}" cy="{dy:.1f}" r="3" '
                       f'fill="{colour}"/></g>')
    for m, (x, y) in sorted(at.items()):
        parts = names(m)
        text = ", ".join(parts)
        label = text if len(text) <= 18 else f"{len(parts)} parts"
        out.append(f'<g><title>{escape(text)}</title><rect x="{x - 55:.1f}" y="{y - 9:.1f}" '
                   'width="110" height="18" rx="4" fill="#ffffff" stroke="#333"/>'
                   f'<text x="{x:.1f}" y="{y + 4:.1f}" text-anchor="middle">{escape(label)}'
                   "</text></g>")
    out.append("</svg>")
    caption = (f"{len(at)} subassemblies, {arcs} partitionings (rebuilt from the report's "
               "DBGs; the same counts as its andor section); red: the plan's steps")
    return "\n".join(out), caption
