"""The readable ``--format text`` rendering of a report."""

from __future__ import annotations


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def render(report: dict) -> str:
    """A summary a designer reads at a glance: the assembly, its parts, then each stage."""
    if "error" in report:
        return f"{report['source']}: ERROR: {report['error']['message']}\n"
    a = report["assembly"]
    lines = [f"assembly {a['name']}  ({a['source']})",
             f"  {len(a['parts'])} parts, {a['triangles']} triangles, units {a['units']}, "
             f"{a['dimension']}D, length tolerance {_fmt(a['tolerance'])} {a['units']} "
             f"({a['tolerance_source']})"]
    if a.get("base"):
        lines.append(f"  base part: {a['base']}")
    lines.append("")
    width = max([len(p["id"]) for p in a["parts"]] + [4])
    if a["dimension"] == 3:
        lines.append(f"  {'part':<{width}}  {'triangles':>9}  {'watertight':>10}  {'volume':>12}")
        for p in a["parts"]:
            wt = "yes" if p["watertight"] else "NO"
            lines.append(f"  {p['id']:<{width}}  {p['triangles']:>9}  {wt:>10}  "
                         f"{_fmt(p['volume']):>12}")
    else:
        lines.append(f"  {'part':<{width}}  {'vertices':>8}  {'area':>12}")
        for p in a["parts"]:
            lines.append(f"  {p['id']:<{width}}  {p['vertices']:>8}  {_fmt(p['area']):>12}")
    for section in TEXT_SECTIONS:
        lines.extend(section(report))
    warnings = report.get("warnings", [])
    lines.append("")
    lines.append(f"warnings: {len(warnings)}")
    for w in warnings[:20]:
        lines.append(f"  - {w['message']}" + (f" [{w['part']}]" if w.get("part") else ""))
    if len(warnings) > 20:
        lines.append(f"  ... and {len(warnings) - 20} more (see the JSON report)")
    return "\n".join(lines) + "\n"


#: Renderers of the analysis stages, each ``report -> list of lines`` (stages append theirs).
TEXT_SECTIONS: list = []
