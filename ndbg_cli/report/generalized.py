"""The readable lines of the generalized-motion section (paper sections 5.2 and 6): suggested
motions with their arcs, and the subassemblies that need a rotation."""

from __future__ import annotations

from collections.abc import Sequence

#: Arcs and sources listed per motion in the text output.
TEXT_ITEMS = 6


def _fmt(v: Sequence[float]) -> str:
    """``(+x, +y, +z)`` with 3 significant digits; components below 1e-9 times the largest
    (or 1e-9, whichever is larger) print as 0."""
    big = max((abs(x) for x in v), default=0.0)
    keep = 1e-9 * max(big, 1.0)
    return "(" + ", ".join(f"{(x if abs(x) > keep else 0.0) + 0.0:+.3g}" for x in v) + ")"


def describe(m: dict) -> str:
    """One-line description of a motion record (suggested or from the LP)."""
    if m["type"] == "translation":
        return f"translation along {_fmt(m['axis'])}"
    s = f"{m['type']} about {_fmt(m['axis'])} through {_fmt(m['point'])}"
    if m["type"] == "screw":
        s += f", pitch {m['pitch']:.4g} per turn"
    return s


def generalized_text(section: dict) -> list[str]:
    """Designer-readable lines for the ``generalized`` section."""
    threaded = ("threads read as cylinders" if section["threads_as_cylinders"]
                else f"{len(section['threaded_pairs'])} threaded pair(s)")
    lines = [f"Generalized motions: {len(section['suggested_motions'])} suggested, {threaded}"]
    for m in section["suggested_motions"]:
        arcs = ", ".join(f"{a}->{b}" for a, b in m["arcs"][:TEXT_ITEMS])
        if len(m["arcs"]) > TEXT_ITEMS:
            arcs += f", ... ({len(m['arcs'])} arcs)"
        src = m["source"].split("; ")
        more = f" (+{len(src) - 2} more)" if len(src) > 2 else ""
        lines.append(f"  [{m['region']}] {describe(m)} from {'; '.join(src[:2])}{more}: "
                     f"blocked {arcs or 'none'}")
    for a, b in section["threaded_pairs"]:
        lines.append(f"  threaded: {a} on {b} (screw only, no translation)")
    if section["needs_rotation"]:
        for e in section["needs_rotation"]:
            lines.append(f"  needs rotation: {{{', '.join(e['parts'])}}} by "
                         f"{describe(e['motion'])}")
    else:
        lines.append("  no subassembly needs a rotation")
    cut = (f"; list limited to {section['candidate_limit']}"
           if section.get("candidates_truncated") else "")
    lines.append(f"  validated candidate partitionings: {len(section['candidates'])}"
                 f" ({len(section['rejected_candidates'])} rejected{cut})")
    return lines
