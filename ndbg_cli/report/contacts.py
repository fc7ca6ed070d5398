"""The report's contact sections (``schemas/fragments/contacts.json``) and the readable contact
table of ``ndbg contacts``, from the contacts stage's results (paper section 4.3)."""

from __future__ import annotations

import numpy as np

from ..contacts.contacts3d import ContactAnalysis
from ..core.assembly import Assembly


def _r(x: float) -> float:
    """A float rounded to 10 significant digits (stable JSON across platforms)."""
    return float(f"{float(x):.10g}")


def _vecs(a: np.ndarray | None) -> list | None:
    """A vector or a matrix, each number as :func:`_r` rounds it (one string formatting for
    the whole array: the engine's report holds a few hundred thousand numbers)."""
    if a is None:
        return None
    a = np.asarray(a, dtype=float)
    flat = a.ravel().tolist()
    vals = list(map(float, ("%.10g," * len(flat) % tuple(flat)).split(",")[:-1]))
    if a.ndim == 1:
        return vals
    m = a.shape[1]
    return [vals[k * m:(k + 1) * m] for k in range(a.shape[0])]


def contacts_section(asm: Assembly, result: ContactAnalysis, *, points: bool = True) -> dict:
    """JSON-ready report sections ``{"contacts": [...], "interferences": [...],
    "contact_stats": {...}}`` (schema: ``schemas/fragments/contacts.json``). Parts are named by
    id; vectors are in the assembly frame and unit; order is deterministic. Without
    ``points``, each contact record has ``point_count`` in place of its ``points`` and
    ``point_normals``: the record :func:`ndbg_cli.report.detail.summarize` makes (most of
    the section's numbers are points, and a summary writes none of them)."""
    ids = asm.ids
    contacts = [_contact_record(ids, c, points) for c in result.contacts]
    interferences = [interference_record(ids, x) for x in result.interferences]
    s = result.stats
    stats = {
        "units": asm.units, "tolerance": _r(result.tolerance),
        "angle_tolerance_deg": _r(np.degrees(result.angle_tolerance)),
        "touching_pairs": [[ids[a], ids[b]] for a, b in result.pairs()],
        "contacts": len(result.contacts), "by_kind": dict(s.get("by_kind", {})),
        "interferences": len(result.interferences),
        "candidate_pairs": int(s.get("candidate_pairs", 0)),
        "triangle_pairs": int(s.get("triangle_pairs", 0)),
        "interference_method": s.get("interference_method", ""),
        "interference_approximate_pairs": s.get("interference_approximate_pairs", []),
        "timings_s": {k: _r(s.get(k, 0.0))
                      for k in ("bvh_s", "broad_s", "narrow_s", "interference_s")},
    }
    return {"contacts": contacts, "interferences": interferences, "contact_stats": stats}


def _contact_record(ids: list[str], c, points: bool) -> dict:
    """One contact of :func:`contacts_section` (with its points, or their count)."""
    out = {"a": ids[c.a], "b": ids[c.b], "kind": c.kind, "blocking": c.blocking,
           "normals": _vecs(c.normals)}
    if points:
        out.update(points=_vecs(c.points), point_normals=_vecs(c.point_normals))
    out.update(area=_r(c.area), surface=c.surface, axis=_vecs(c.axis), center=_vecs(c.center),
               radius=None if c.radius is None else _r(c.radius))
    if not points:
        out["point_count"] = 0 if c.points is None else len(np.asarray(c.points))
    return out


def interference_record(ids: list[str], x) -> dict:
    """One interference as the report states it, with its kind (:mod:`ndbg_cli.contacts.fits`)."""
    out = {"a": ids[x.a], "b": ids[x.b], "volume": _r(x.volume), "depth": _r(x.depth),
           "method": x.method, "kind": x.kind}
    f = x.fit
    if f is not None and f.kind == "press_fit":
        out.update(axis=_vecs(f.axis), center=_vecs(f.center), radius=_r(f.radius),
                   fit_depth=_r(f.depth))
    elif f is not None and f.kind == "overlap":
        out.update(direction=_vecs(f.direction), center=_vecs(f.center), fit_depth=_r(f.depth))
    return out


def contacts_text(asm: Assembly, result: ContactAnalysis) -> list[str]:
    """Readable contact table lines: one line per contact (pair, kind, area, normals), then
    the interferences and a summary line."""
    ids, unit = asm.ids, asm.units
    lines = [f"{'part A':<16} {'part B':<16} {'kind':<7} {'area':>12}  normals (out of A)"]
    for c in result.contacts:
        ns = " ".join("(" + ", ".join(f"{x:+.3f}" for x in n) + ")" for n in c.normals[:4])
        if len(c.normals) > 4:
            ns += f" ... {len(c.normals)} normals"
        extra = ""
        if c.surface in ("cylinder", "cone") and c.radius is not None:
            extra = f"  {c.surface} r={c.radius:.4g} axis=(" + ", ".join(
                f"{x:+.3f}" for x in c.axis) + ")"
        area = f"{c.area:.4g} {unit}^2" if c.area else "-"
        lines.append(f"{ids[c.a]:<16} {ids[c.b]:<16} {c.kind:<7} {area:>12}  {ns}{extra}")
    for x in result.interferences:
        lines.append(f"INTERFERENCE {ids[x.a]} / {ids[x.b]}: volume {x.volume:.4g} {unit}^3, "
                     f"depth {x.depth:.4g} {unit} ({x.method})")
    lines.append(f"{len(result.pairs())} touching pairs, {len(result.contacts)} contacts, "
                 f"{len(result.interferences)} interferences (tolerance {result.tolerance:.3g} "
                 f"{unit}, {np.degrees(result.angle_tolerance):.3g} deg)")
    return lines


def contacts_2d_section(asm: Assembly, found) -> list[dict]:
    """2D contacts for the report: pair, kinds, normals out of ``a`` and contact points."""
    return [{"a": asm.ids[c.a], "b": asm.ids[c.b],
             "kind": "edge" if "edge-edge" in c.kinds else "point",
             "blocking": "any", "normals": np.asarray(c.normals).tolist(),
             "points": np.asarray(c.points).tolist(), "length": float(c.length)}
            for c in found.contacts]
