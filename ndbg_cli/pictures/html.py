"""The HTML report of one assembly (``ndbg analyze --html``) and a batch's ``index.html``.

One self-contained file that opens with no network: plotly.js (from the plotly package,
embedded as is), the page's own script and style (``assets/``), and one JSON block of data.
It holds the 3D view with the plan played as a disassembly (slider, play button, the moving
parts highlighted), the direction sphere of each family (:mod:`.sphere`), the plan's tree
(:mod:`.tree`) and the report's classes, contacts, interferences and warnings as tables.

The output is deterministic: fixed element ids, sorted JSON keys, no dates; the meshes are
base64 float32/int32 arrays (little-endian), the other numbers rounded.
"""

from __future__ import annotations

import base64
import json
from html import escape
from importlib import resources

import numpy as np

from ..core.assembly import Assembly
from ._scene import (
    DisplayMesh,
    disassembly,
    display_meshes,
    distinct_colour,
    pale,
    pose_bounds,
    poses,
)
from .andor import andor_svg
from .sphere import SphereMap, sphere_maps
from .tree import tree_layout, tree_svg

#: Grey of the sphere's samples whose DBG matches none listed (none were seen so far).
UNMATCHED = "#bbbbbb"


def plotly_js() -> str:
    """The plotly.js bundle shipped inside the plotly package (read, not imported: importing
    plotly's Python side costs a second and is not needed)."""
    path = resources.files("plotly") / "package_data" / "plotly.min.js"
    return path.read_text(encoding="utf-8")


def _asset(name: str) -> str:
    return (resources.files("ndbg_cli.pictures") / "assets" / name).read_text(encoding="utf-8")


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _r(x: float, digits: int = 6) -> float:
    """``x`` to ``digits`` significant digits (shorter JSON, same bytes every run)."""
    return float(f"{x:.{digits}g}")


def _script_json(data: dict) -> str:
    """``data`` as JSON that is safe inside a ``<script>`` element."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return text.replace("</", "<\\/")


def verdict(report: dict) -> str:
    """One line for a person: the error, or the plan's length, depth and proof."""
    if "error" in report:
        return "error: " + report["error"]["message"]
    plan = report.get("plan") or {}
    if not plan.get("found"):
        return "no assembly sequence found"
    proven = (plan.get("verified") or {}).get("value")
    how = {True: "proven", False: "not proven"}.get(proven, "unchecked")
    return (f"{len(plan.get('sequence') or [])} steps, tree depth {plan.get('depth')}, "
            f"{(plan.get('family') or '').replace('_', ' ')}, {how}")


def _view(meshes: list[DisplayMesh], offsets: np.ndarray, moves) -> dict:
    """The 3D view's data: the parts' meshes, the poses and the moves."""
    lo, hi = pose_bounds(meshes, offsets)
    pad = 0.03 * float(np.linalg.norm(hi - lo))
    lo, hi = lo - pad, hi + pad
    span = hi - lo
    ratio = span / span.max()
    axis = {"visible": False}
    layout = {"margin": {"l": 0, "r": 0, "t": 0, "b": 0}, "paper_bgcolor": "#ffffff",
              "scene": {"aspectmode": "manual",
                        "aspectratio": {"x": _r(ratio[0]), "y": _r(ratio[1]),
                                        "z": _r(ratio[2])},
                        "camera": {"eye": {"x": 0.95, "y": -1.1, "z": 0.75}},
                        **{f"{c}axis": {**axis, "range": [_r(lo[k]), _r(hi[k])]}
                           for k, c in enumerate("xyz")}}}
    index = {m.id: k for k, m in enumerate(meshes)}
    parts = [{"id": m.id, "colour": m.colour, "pale": pale(m.colour),
              **{c: _b64(m.vertices[:, k], "<f4") for k, c in enumerate("xyz")},
              **{c: _b64(m.faces[:, k], "<i4") for k, c in enumerate("ijk")}}
             for m in meshes]
    return {"view": {"parts": parts, "layout": layout},
            "offsets": [[[_r(x) for x in o] for o in pose] for pose in offsets],
            "moves": [{"parts": sorted(index[p] for p in mv.parts), "text": mv.text}
                      for mv in moves]}


def _dbg_colour(k: int) -> str:
    return distinct_colour(k) if k >= 0 else UNMATCHED


def _sphere_traces(m: SphereMap) -> list[dict]:
    """The traces of one sphere: the coloured surface, one trace per DBG (hover: the DBG and
    its free sets; the legend toggles it) and the plan's directions."""
    traces: list[dict] = []
    if len(m.faces):
        v = m.vertices
        traces.append({"type": "mesh3d", "x": [_r(x, 4) for x in v[:, 0]],
                       "y": [_r(x, 4) for x in v[:, 1]], "z": [_r(x, 4) for x in v[:, 2]],
                       "i": m.faces[:, 0].tolist(), "j": m.faces[:, 1].tolist(),
                       "k": m.faces[:, 2].tolist(), "flatshading": True,
                       "facecolor": [_dbg_colour(int(k)) for k in m.face_dbg],
                       "hoverinfo": "skip", "showlegend": False, "name": "regions",
                       "lighting": {"ambient": 0.9, "diffuse": 0.2}})
    else:
        traces.append(_ghost_sphere())
    for info in m.dbgs:
        pts = [p for p, k in zip(m.samples, m.sample_dbg) if k == info.index]
        reps = [d for d, k, _ in m.representatives if k == info.index]
        if not pts and not reps:
            continue
        xyz = np.array([1.01 * np.asarray(p) for p in pts] + [1.03 * np.asarray(d) for d in reps])
        sizes = [2] * len(pts) + [7] * len(reps)
        traces.append({"type": "scatter3d", "mode": "markers", "name": f"DBG {info.index}",
                       "meta": {"dbg": info.index},
                       "x": [_r(x, 4) for x in xyz[:, 0]], "y": [_r(x, 4) for x in xyz[:, 1]],
                       "z": [_r(x, 4) for x in xyz[:, 2]],
                       "marker": {"size": sizes, "color": _dbg_colour(info.index),
                                  "line": {"width": 0}},
                       "hovertext": info.label(), "hoverinfo": "text"})
    traces.extend(_plan_traces(m))
    return traces


def _ghost_sphere() -> dict:
    """A translucent unit sphere under the representative dots (not a region map)."""
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    return {"type": "mesh3d", "x": [_r(x, 4) for x in v[:, 0]],
            "y": [_r(x, 4) for x in v[:, 1]], "z": [_r(x, 4) for x in v[:, 2]],
            "i": f[:, 0].tolist(), "j": f[:, 1].tolist(), "k": f[:, 2].tolist(),
            "color": "#dddddd", "opacity": 0.25, "hoverinfo": "skip", "showlegend": False,
            "name": "sphere"}


def _plan_traces(m: SphereMap) -> list[dict]:
    """The plan's insertion directions in this family, one marker per direction."""
    steps: dict[tuple[float, float, float], list[int]] = {}
    for step, d in m.plan:
        steps.setdefault(tuple(_r(x, 6) for x in d), []).append(step)
    if not steps:
        return []
    dirs = sorted(steps)
    text = ["steps " + ", ".join(map(str, steps[d])) for d in dirs]
    return [{"type": "scatter3d", "mode": "markers+text", "name": "plan directions",
             "x": [1.12 * d[0] for d in dirs], "y": [1.12 * d[1] for d in dirs],
             "z": [1.12 * d[2] for d in dirs], "text": text, "hovertext": text,
             "hoverinfo": "text", "textposition": "top center",
             "marker": {"size": 6, "color": "#000000", "symbol": "diamond"}}]


def _sphere_figure(m: SphereMap) -> dict:
    axis = {"range": [-1.25, 1.25], "showbackground": False, "zeroline": False}
    layout = {"margin": {"l": 0, "r": 0, "t": 0, "b": 0}, "legend": {"itemsizing": "constant"},
              "scene": {"aspectmode": "cube", "xaxis": {**axis, "title": {"text": "x"}},
                        "yaxis": {**axis, "title": {"text": "y"}},
                        "zaxis": {**axis, "title": {"text": "z"}}}}
    return {"div": f"ndbg-sphere-{m.family}", "traces": _sphere_traces(m), "layout": layout}


def _table(head: list[str], rows: list[list], empty: str = "none") -> str:
    """An HTML table (cells escaped; ``True``/``False`` as yes/no, coloured)."""
    if not rows:
        return f"<p>{escape(empty)}</p>"

    def cell(v) -> str:
        if isinstance(v, bool) or v is None:
            word = {True: "yes", False: "no", None: "undecided"}[v]
            return f'<td class="{word}">{word}</td>'
        if isinstance(v, float):
            v = f"{v:.6g}"
        return f"<td>{escape(str(v))}</td>"

    out = ["<table><tr>" + "".join(f"<th>{escape(h)}</th>" for h in head) + "</tr>"]
    out += ["<tr>" + "".join(cell(v) for v in r) + "</tr>" for r in rows]
    return "\n".join(out) + "</table>"


def _tables(report: dict) -> str:
    """Classes (with their evidence), contacts, interferences and warnings."""
    classes = [[fam.replace("_", " "), name.replace("_", " "), c.get("value"),
                c.get("evidence", ""), c.get("why", "")]
               for fam, sec in sorted((report.get("classes") or {}).items())
               for name, c in sorted(sec.items()) if isinstance(c, dict)]
    contacts = [[c["a"], c["b"], c["kind"], c.get("area"), len(c.get("normals") or []),
                 c.get("blocking", "")] for c in report.get("contacts") or []]
    inter = [[x["a"], x["b"], x.get("kind", "clash"), x.get("volume"), x.get("depth"),
              "+".join(x.get("unit") or [])] for x in report.get("interferences") or []]
    warns = [[w.get("level", ""), w.get("code", ""), w.get("part") or "", w["message"]]
             for w in report.get("warnings") or []]
    return "\n".join([
        '<h2 id="classes">Classes (paper section 7)</h2>',
        '<p class="note">evidence: <b>proven</b> (by the verified plan or an exact test), '
        "<b>candidate</b> (from the necessary conditions), <b>bound</b> (a bound, not the "
        "value), <b>undecided</b>.</p>",
        _table(["family", "class", "value", "evidence", "why"], classes),
        f'<h2 id="contacts">Contacts ({len(contacts)})</h2>',
        _table(["a", "b", "kind", "area", "normals", "blocking"], contacts),
        f'<h2 id="interferences">Interferences ({len(inter)})</h2>',
        _table(["a", "b", "kind", "volume", "depth", "kept together as"], inter),
        f'<h2 id="warnings">Warnings ({len(warns)})</h2>',
        _table(["level", "code", "part", "message"], warns)])


def _plan_html(report: dict, moves) -> str:
    """The view, its controls and the list of moves."""
    plan = report.get("plan") or {}
    items = "\n".join(f"<li>{escape(mv.text.split(': ', 1)[1])}</li>" for mv in moves)
    proof = (plan.get("verified") or {}).get("why", "")
    proof = proof[:1].upper() + proof[1:]
    notes = "; ".join(plan.get("notes") or [])
    return f"""<h2 id="plan">The plan, taken apart</h2>
<p class="note">The assembly sequence played backwards: each disassembly step moves the
inserted side of one assembly step out along its direction (parts that left stay out).
Drag to turn, scroll to zoom, hover a part for its name. {escape(proof)}</p>
<div class="plan"><div id="ndbg-view"></div><div class="side">
<div class="controls"><button id="ndbg-play" type="button">Play</button>
<input id="ndbg-step" type="range" min="0" max="{len(moves)}" step="1" value="0"
 aria-label="disassembly step"></div>
<span id="ndbg-step-label"></span>
<ol id="ndbg-moves">{items}</ol>
<p class="note">{escape(notes)}</p></div></div>"""


def _spheres_html(maps: list[SphereMap], report: dict) -> str:
    out = ['<h2 id="spheres">Direction spheres (paper Figs. 4, 6, 8)</h2>']
    if not maps:
        out.append("<p>No family with direction regions in this report.</p>")
    for m in maps:
        sec = report["ndbg"][m.family]
        out.append(f"<h3>{escape(m.family.replace('_', ' '))}: {sec.get('regions')} "
                   f"regions, {sec.get('distinct_dbgs')} distinct DBGs</h3>"
                   f'<p class="note">{escape(m.note)}. Equal DBGs, equal colours; black '
                   "diamonds: the plan's insertion directions.</p>"
                   f'<div class="sphere"><div class="plot" id="ndbg-sphere-{m.family}">'
                   f'</div><div class="dbg" id="ndbg-sphere-{m.family}-dbg">Hover a region '
                   "for its DBG and its free sets.</div></div>")
    return "\n".join(out)


def _tree_html(report: dict, meshes: list[DisplayMesh]) -> str:
    """The plan's tree, then each family's AND/OR graph where it is small enough."""
    layout = tree_layout(report)
    out = ['<h2 id="tree">Assembly tree of the plan</h2>']
    if layout is None:
        out.append("<p>No plan: no tree.</p>")
    else:
        svg = tree_svg(layout, {m.id: m.colour for m in meshes})
        out.append('<p class="note">Each circle is an assembly step joining its two '
                   "children; red: the side inserted. Hover a node for its step.</p>"
                   f'<div class="treebox" id="ndbg-tree">{svg}</div>')
    out.append('<h2 id="andor">AND/OR graphs (paper section 7.2)</h2>')
    for family in sorted(report.get("andor") or {}):
        svg, caption = andor_svg(report, family)
        out.append(f"<h3>{escape(family.replace('_', ' '))}</h3>"
                   f'<p class="note">{"" if svg else "not drawn: "}{escape(caption)}.</p>')
        if svg:
            out.append(f'<div class="treebox" id="ndbg-andor-{family}">{svg}</div>')
    return "\n".join(out)


def render_html(report: dict, asm: Assembly) -> str:
    """The HTML report of ``report`` (an analysed assembly, not an error record), with the
    meshes of ``asm``, the assembly it was computed from."""
    meshes = display_meshes(asm)
    moves = disassembly(report, meshes)
    offsets = poses(meshes, moves)
    maps = sphere_maps(report)
    data = _view(meshes, offsets, moves)
    data["spheres"] = [_sphere_figure(m) for m in maps]
    name = report["assembly"]["name"]
    body = "\n".join([
        f"<h1>{escape(name)}</h1>",
        f'<p class="verdict">{escape(verdict(report))} &mdash; '
        f"{len(report['assembly']['parts'])} parts, source "
        f"<code>{escape(report['assembly']['source'])}</code></p>",
        _plan_html(report, moves), _spheres_html(maps, report), _tree_html(report, meshes),
        _tables(report),
        f'<p class="note">ndbg {escape(report["tool"]["version"])}; plotly.js embedded '
        "(MIT licence).</p>"])
    return _page(f"ndbg: {name}", body, data)


def _page(title: str, body: str, data: dict | None) -> str:
    scripts = ""
    if data is not None:
        scripts = (f"<script>{plotly_js()}</script>\n"
                   f'<script id="ndbg-data" type="application/json">{_script_json(data)}'
                   f"</script>\n<script>{_asset('report.js')}</script>\n")
    return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{escape(title)}</title>\n<style>{_asset('report.css')}</style>"
            f"</head>\n<body>\n{body}\n{scripts}</body></html>\n")


def index_html(entries: list[tuple[dict, str | None]]) -> str:
    """A batch's ``index.html``: each report's name, source and verdict, linked to its page
    (``None``: no page, an error record)."""
    rows = []
    for r, page in entries:
        name = r["assembly"]["name"] if "assembly" in r else r.get("source", "?")
        source = r["assembly"]["source"] if "assembly" in r else r.get("source", "")
        link = f'<a href="{escape(page)}">{escape(name)}</a>' if page else escape(name)
        cls = ' class="verdict error"' if "error" in r else ""
        rows.append(f"<tr><td>{link}</td><td><code>{escape(source)}</code></td>"
                    f"<td{cls}>{escape(verdict(r))}</td></tr>")
    body = (f"<h1>ndbg: {len(entries)} assemblies</h1><table><tr><th>assembly</th>"
            "<th>source</th><th>verdict</th></tr>\n" + "\n".join(rows) + "</table>")
    return _page("ndbg: batch", body, None)
