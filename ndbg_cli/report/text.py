"""The readable ``--format text`` rendering of a report."""

from __future__ import annotations

import math

from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL


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


def _vec(v) -> str:
    return "(" + ", ".join(f"{x:+.3g}" for x in v) + ")"


def contacts_lines(report: dict) -> list[str]:
    """Contact summary: touching pairs by kind, interferences."""
    if "contacts" not in report:
        return []
    stats = report.get("contact_stats", {})
    kinds: dict[str, int] = {}
    for c in report["contacts"]:
        kinds[c["kind"]] = kinds.get(c["kind"], 0) + 1
    by_kind = ", ".join(f"{v} {k}" for k, v in sorted(kinds.items())) or "none"
    lines = ["", f"contacts: {len(stats.get('touching_pairs', []))} touching pairs, "
             f"{len(report['contacts'])} contacts ({by_kind})"]
    for x in report.get("interferences", []):
        what = _fit_text(x)
        lines.append(f"  INTERFERENCE {x['a']} / {x['b']}: volume {_fmt(x['volume'])}, "
                     f"depth {_fmt(x['depth'])}; {what}")
    return lines


def _fit_text(x: dict) -> str:
    """What an interference record's kind means (:mod:`ndbg_cli.contacts.fits`)."""
    kind = x.get("kind", "clash")
    if kind == "press_fit":
        return (f"press fit about {_vec(x['axis'])}, radius {_fmt(x['radius'])}, radial "
                f"interference {_fmt(x['fit_depth'])}: a cylindrical contact")
    if kind == "overlap":
        return (f"overlap {_fmt(x['fit_depth'])} thick, {x['a']} leaves along "
                f"{_vec(x['direction'])}: a face contact")
    return "clash" + (f": kept together as {'+'.join(x['unit'])}" if x.get("unit") else "")


def classes_lines(report: dict) -> list[str]:
    """The complexity classes, one block per motion family."""
    if "classes" not in report:
        return []
    from ..planning.plans import plan_proves
    from .classes import classes_text

    lines = ["", "classes (paper section 7)"] + ["  " + x for x in classes_text(report["classes"])]
    proof = plan_proves(report.get("plan") or {})
    if proof is not None:
        # the families' verdicts above are what each NDBG shows; a plan that passed the sweep
        # test is a real algorithm and proves more (the rules of `ndbg check` use it too)
        lin = {True: "yes"}.get(proof["linearizable"], "undecided")
        bounds = ", ".join(f"{name} <= {proof[k]}" for k, name in
                           (("min_depth", "minimum depth"), ("min_nonlinear", "nonlinear steps"),
                            ("min_directions", "directions")) if proof[k] is not None)
        lines += ["  proven by the verified plan (sweep test):",
                  f"    1-handed monotone: yes, 1-prismatic: yes, linearizable: {lin}; {bounds}"]
    return lines


def andor_lines(report: dict) -> list[str]:
    """One line per family's AND/OR graph: its size, and its exact counts when complete."""
    if not report.get("andor"):
        return []
    lines = ["", "AND/OR graphs of the candidate assembly trees (paper section 7.2)"]
    for fam, g in sorted(report["andor"].items()):
        name = f"  {fam.replace('_', ' ')}:"
        if g.get("cut_by") == "supergraph":
            lines.append(f"{name} {g['why']}")
        elif g["truncated"]:
            lines.append(f"{name} cut after {g['nodes']} subassemblies ({g.get('why', '')}): "
                         "no exact counts")
        else:
            head = f"{name} {g['nodes']} subassemblies, {g['hyperarcs']} partitionings"
            if g["min_depth"] is None:
                lines.append(f"{head}; no candidate tree")
            else:
                trees = g.get("trees_str", g["trees"])
                seqs = g.get("linear_sequences_str", g["linear_sequences"])
                lines.append(f"{head}; {trees} tree(s), {seqs} linear sequence(s), minimum "
                             f"depth {g['min_depth']}")
    return lines


def ndbg_lines(report: dict) -> list[str]:
    """One summary per blocking-graph family."""
    lines: list[str] = []
    for fam, sec in sorted(report.get("ndbg", {}).items()):
        if sec.get("skipped"):
            lines += ["", f"{fam.replace('_', ' ')}: skipped ({sec['why']})"]
            continue
        if fam == INFINITESIMAL:
            from .infinitesimal import infinitesimal_text

            parts = [p for p in report.get("partitionings", []) if p["family"] == fam]
            lines += infinitesimal_text({**sec, "partitionings": parts}, limit=6)
        elif fam == INFINITE:
            from .infinite import infinite_text

            parts = [p for p in report.get("partitionings", []) if p["family"] == fam]
            lines += [""] + infinite_text({**sec, "partitionings": parts[:6]})[:8]
            if len(parts) > 6:
                lines[-1:] = [lines[-1], f"  ... {len(parts)} in all (see the JSON report)"]
        elif fam == GENERALIZED:
            from .generalized import generalized_text

            lines += [""] + generalized_text(sec)[:14]
    return lines


def depth_note(exact: bool, connected: bool, strategy: str) -> str:
    """What the tree's depth line adds: unproven, or proven among connected trees."""
    if not exact:
        return " (not proven optimal)"
    if connected and strategy == "shortest":
        return " (minimum for contact-connected subassemblies)"
    return ""


def plan_lines(report: dict) -> list[str]:
    """The chosen assembly sequence (the report's ``plan`` section) as numbered steps: the
    one renderer of a plan, ``insert {moved} into {onto} along (d)``."""
    p = report.get("plan")
    if p is None:
        return []
    if not p.get("found"):
        lines = ["", "assembly sequence: none found - " + "; ".join(p.get("notes", []))]
        for b in p.get("blocked") or []:
            at = "" if b.get("at") is None else f" at {_vec(b['at'])}"
            lines.append(f"    {{{', '.join(b['moved'])}}} along {_vec(b['removal_direction'])}"
                         f": {b['blocked_by'][0]} is blocked by {b['blocked_by'][1]}{at}")
        return lines
    fam = (p.get("family") or "").replace("_", " ")
    exact = depth_note(p.get("exact", True), p.get("connected", False), p.get("strategy", ""))
    lines = ["", f"assembly sequence ({p['strategy']}, {fam}): {len(p['sequence'])} steps, "
             f"tree depth {p['depth']}{exact}"]
    for s in p["sequence"]:
        if s.get("direction") is not None:
            how = "along " + _vec(s["direction"])
        elif s.get("motion"):
            m = s["motion"]
            how = f"by reverse {m.get('type')} about {_vec(m.get('axis') or [])}"
        else:
            how = f"(region {s.get('region')})"
        verb = "press" if s.get("press") else "insert"
        lines.append(f"  {s['step']:>3}. {verb} {{{', '.join(s['moved'])}}} into "
                     f"{{{', '.join(s['onto'])}}} {how}"
                     + _proof_note(s.get("proof")))
    v = p.get("verified")
    if v is not None:
        lines.append(f"  proven: {'yes' if v['value'] else 'no'} - {v['why']}")
    return lines


def _proof_note(proof: dict | None) -> str:
    """A step's proof in brackets: where its direction came from, or how far it turns."""
    if not proof:
        return ""
    if proof.get("test") == "motion":
        return (f" [turned {math.degrees(proof['angle']):.6g} degrees, then along "
                f"{_vec(proof['then'])}]")
    return f" [{proof['source']}]"


#: Renderers of the analysis stages, each ``report -> list of lines``, in report order.
TEXT_SECTIONS: list = [contacts_lines, classes_lines, andor_lines, plan_lines, ndbg_lines]
