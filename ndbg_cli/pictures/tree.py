"""The plan's assembly tree laid out for drawing (paper section 7): the whole assembly at the
top, each internal node a step that joins its two children (the inserted side drawn red),
the parts as leaves on the bottom row. :func:`tree_svg` draws it as an SVG string (the HTML
report); :mod:`.static` draws the same layout with matplotlib."""

from __future__ import annotations

from dataclasses import dataclass
from html import escape

#: Horizontal room per leaf and vertical room per level, in SVG pixels.
LEAF_DX = 34
LEVEL_DY = 46

#: Colours of the inserted (moved) side's edge and of the rest's.
MOVED_EDGE = "#d62728"
REST_EDGE = "#7f7f7f"


@dataclass(frozen=True)
class TreeNode:
    """One node: its position (``x`` in leaves, ``y`` in levels from the top), the part id
    of a leaf or the assembly step of an internal node, a tooltip and its parts."""

    x: float
    y: int
    leaf: bool
    label: str
    title: str
    parts: tuple[str, ...]


@dataclass(frozen=True)
class TreeLayout:
    """Nodes, and edges as ``(parent index, child index, moved side?)``; ``levels`` is the
    number of rows (the tree's depth plus one)."""

    nodes: list[TreeNode]
    edges: list[tuple[int, int, bool]]
    levels: int

    @property
    def leaves(self) -> int:
        return sum(1 for n in self.nodes if n.leaf)


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:+.3g}" for x in v) + ")"


def _depth(node: dict) -> int:
    if "moved" not in node:
        return 0
    return 1 + max(_depth(node["moved"]), _depth(node["rest"]))


def tree_layout(report: dict) -> TreeLayout | None:
    """The layout of the plan's tree of ``report``; ``None`` without a plan."""
    plan = report.get("plan") or {}
    root = plan.get("tree")
    if not plan.get("found") or not root:
        return None
    steps = {frozenset(s["produces"]): s for s in plan.get("sequence") or []}
    levels = _depth(root) + 1
    nodes: list[TreeNode] = []
    edges: list[tuple[int, int, bool]] = []
    leaf_x = [0]

    def visit(node: dict, level: int) -> int:
        parts = tuple(node["parts"])
        if "moved" not in node:
            k = len(nodes)
            nodes.append(TreeNode(float(leaf_x[0]), levels - 1, True, parts[0],
                                  ", ".join(parts), parts))
            leaf_x[0] += 1
            return k
        a = visit(node["moved"], level + 1)
        b = visit(node["rest"], level + 1)
        s = steps.get(frozenset(parts), {})
        how = _vec(node["direction"]) if node.get("direction") is not None else "(motion)"
        title = (f"step {s.get('step', '?')}: insert {{{', '.join(node['moved']['parts'])}}} "
                 f"into {{{', '.join(node['rest']['parts'])}}} along {how}")
        k = len(nodes)
        nodes.append(TreeNode((nodes[a].x + nodes[b].x) / 2, level, False,
                              str(s.get("step", "")), title, parts))
        edges.extend([(k, a, True), (k, b, False)])
        return k

    visit(root, 0)
    return TreeLayout(nodes, edges, levels)


def tree_svg(layout: TreeLayout, colours: dict[str, str]) -> str:
    """The tree as a standalone ``<svg>`` element: hover a node for its step or part.
    ``colours``: part id -> the part's colour in the 3D view (the leaves' dots)."""
    label_room = 8 + 6.2 * max((len(n.label) for n in layout.nodes if n.leaf), default=4)
    width = LEAF_DX * max(layout.leaves, 1) + 40
    height = LEVEL_DY * (layout.levels - 1) + 40 + label_room

    def at(n: TreeNode) -> tuple[float, float]:
        return 20 + LEAF_DX * (n.x + 0.5), 20 + LEVEL_DY * n.y

    out = [f'<svg xmlns="http://www.w3.org/2000/svg" class="tree" width="{width:.0f}" '
           f'height="{height:.0f}" viewBox="0 0 {width:.0f} {height:.0f}" '
           'font-family="sans-serif" font-size="11">']
    for p, c, moved in layout.edges:
        (x1, y1), (x2, y2) = at(layout.nodes[p]), at(layout.nodes[c])
        colour = MOVED_EDGE if moved else REST_EDGE
        out.append(f'<path d="M{x1:.1f},{y1:.1f} L{x2:.1f},{y1 + LEVEL_DY * 0.5:.1f} '
                   f'L{x2:.1f},{y2:.1f}" fill="none" stroke="{colour}" '
                   f'stroke-width="{2 if moved else 1.4}"/>')
    for n in layout.nodes:
        x, y = at(n)
        title = f"<title>{escape(n.title)}</title>"
        if n.leaf:
            colour = colours.get(n.label, "#888888")
            out.append(f'<g class="leaf">{title}<circle cx="{x:.1f}" cy="{y:.1f}" r="6" '
                       f'fill="{colour}" stroke="#333"/><text x="{x:.1f}" y="{y + 12:.1f}" '
                       f'transform="rotate(60 {x:.1f} {y + 12:.1f})">{escape(n.label)}'
                       '</text></g>')
        else:
            out.append(f'<g class="step">{title}<circle cx="{x:.1f}" cy="{y:.1f}" r="10" '
                       f'fill="#ffffff" stroke="#333"/><text x="{x:.1f}" y="{y + 4:.1f}" '
                       f'text-anchor="middle">{escape(n.label)}</text></g>')
    out.append("</svg>")
    return "\n".join(out)
