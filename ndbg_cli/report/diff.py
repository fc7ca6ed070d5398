"""Design diffs between two analyses (``ndbg diff OLD NEW``): what changed that a designer
cares about, the paper's "posting warnings to the designers when the product changes from one
complexity class to another" (section 7).

Inputs are reports as ``ndbg analyze`` writes them (:func:`read_reports`), matched by
assembly name. Each change is a :class:`Change` graded ``worse``, ``better`` or ``changed``
(neither, e.g. a part renamed or a measure becoming undecided): classes (:data:`GOOD_TRUE`,
:data:`GOOD_FALSE`), measures per family (:data:`LOWER_BETTER`), interferences (new ones are
worse), parts added or removed, a plan lost or found, an assembly that now fails to analyse,
assemblies added to or removed from a batch.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from ..core.errors import InputError
from .document import identity

GOOD_TRUE = ("one_handed_monotone", "prismatic", "linearizable", "stack_product")
GOOD_FALSE = ("interlocked",)
LOWER_BETTER = {"min_depth": "value", "min_directions": "value", "min_nonlinear": "value",
                "grasp": "value"}


@dataclass(frozen=True)
class Change:
    """One difference: ``what`` is a dotted path into the report (``classes.<family>.<key>``,
    ``interferences``, ``parts``, ...)."""

    assembly: str
    what: str
    old: Any
    new: Any
    grade: str  # worse | better | changed
    note: str = ""

    def line(self) -> str:
        note = f" ({self.note})" if self.note else ""
        return f"{self.assembly}: {self.grade}: {self.what}: {_fmt(self.old)} -> " \
               f"{_fmt(self.new)}{note}"

    def record(self) -> dict:
        return asdict(self)


def _fmt(v: Any) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def read_reports(path: str | Path) -> dict[str, dict]:
    """Reports in ``path`` by assembly name: one JSON report, a batch document (``--format
    json`` over several assemblies), a JSON Lines stream, or an ``--out-dir`` folder (the
    reports its ``index.json`` names; every ``*.json`` in it when it has no index; for
    ``ndbg check``, :func:`holds_reports` tells such a folder from one of assemblies)."""
    p = Path(path)
    docs: list[dict] = []
    if p.is_dir():
        files = _indexed(p) or sorted(f for f in p.glob("*.json") if f.name != "index.json")
        if not files:
            raise InputError("no report files (*.json) in this folder", file=str(p))
        for f in files:
            docs.extend(_parse(f))
    elif p.is_file():
        docs = _parse(p)
    else:
        raise InputError("no such file or directory", file=str(p))
    if not docs:
        raise InputError("no reports in it", file=str(p))
    out: dict[str, dict] = {}
    for d in docs:
        name = _key(d)
        key, k = name, 1
        while key in out:
            k += 1
            key = f"{name}-{k}"
        out[key] = d
    return out


def holds_reports(folder: str | Path) -> bool:
    """Whether a directory is a folder of reports rather than of assemblies: it has an
    ``--out-dir`` run's ``index.json``, or it holds ``*.json`` files and nothing an analysis
    would read (no manifest anywhere below it, no mesh file in it)."""
    from ..io.formats import MANIFEST_SUFFIXES, MESH_SUFFIXES

    p = Path(folder)
    if not p.is_dir():
        return False
    if (p / "index.json").is_file():
        return True
    if any(q.suffix.lower() in MANIFEST_SUFFIXES and q.is_file() for q in p.rglob("*")):
        return False
    here = [q for q in p.iterdir() if q.is_file()]
    if any(q.suffix.lower() in MESH_SUFFIXES for q in here):
        return False
    return any(q.suffix.lower() == ".json" for q in here)


def _indexed(folder: Path) -> list[Path] | None:
    """The report files an ``--out-dir`` run's ``index.json`` names (each entry's
    ``report``), so that reports an earlier run left in the folder are not read; ``None``
    without an index that names them all (a folder of reports made otherwise, or an index
    from before entries named their file: then every ``*.json`` is read)."""
    index = folder / "index.json"
    if not index.is_file():
        return None
    try:
        doc = json.loads(index.read_text(encoding="utf-8"))
        names = [e["report"] for e in doc["reports"]]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    if not all(isinstance(n, str) and n and Path(n).name == n for n in names):
        return None
    missing = [n for n in names if not (folder / n).is_file()]
    if missing:
        raise InputError(f"index.json names {missing[0]}, which is missing", file=str(folder))
    return [folder / n for n in names]


def _documents(text: str) -> list:
    """The documents of a JSON text (a batch document's ``reports``) or, when it is not one
    JSON value, of its JSON Lines (the lines' ``JSONDecodeError`` propagates)."""
    try:
        doc = json.loads(text)
    except json.JSONDecodeError:
        return [json.loads(line) for line in text.splitlines() if line.strip()]
    return doc["reports"] if isinstance(doc, dict) and "reports" in doc else [doc]


def _parse(p: Path) -> list[dict]:
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(f"cannot read: {exc.strerror or exc}", file=str(p)) from None
    try:
        docs = _documents(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"not an ndbg report (JSON or JSON Lines): {exc.msg} at line "
                         f"{exc.lineno}", file=str(p)) from None
    except RecursionError:  # json recursing through e.g. 100000 nested lists: no report
        raise InputError("not an ndbg report: JSON nested too deeply", file=str(p)) from None
    for d in docs:
        if not isinstance(d, dict) or "schema" not in d or not (
                "assembly" in d or "error" in d):
            raise InputError("not an ndbg report (no schema/assembly)", file=str(p))
        if "classes" not in d and "error" not in d:
            raise InputError("this report has no analysis (an --out-dir index?); pass the "
                             "folder or the report files", file=str(p))
    return docs


def _name(d: dict) -> str:
    return identity(d)[0]


def _key(d: dict) -> str:
    """Match key: the source file's name (an error record has no assembly name, and the same
    design analysed in two checkouts has different absolute paths)."""
    name, source = identity(d)
    return Path(source).name or name


def diff_reports(old: dict, new: dict, name: str | None = None) -> list[Change]:
    """Changes from report ``old`` to report ``new`` of one assembly."""
    a = name or _name(new)
    out: list[Change] = []
    if "error" in old or "error" in new:
        if "error" in new and "error" not in old:
            out.append(Change(a, "analysis", "ok", "error", "worse", new["error"].get("message",
                                                                                     "")))
        elif "error" in old and "error" not in new:
            out.append(Change(a, "analysis", "error", "ok", "better"))
        return out
    old_parts = [p["id"] for p in old["assembly"].get("parts", [])]
    new_parts = [p["id"] for p in new["assembly"].get("parts", [])]
    gone = [p for p in old_parts if p not in new_parts]
    added = [p for p in new_parts if p not in old_parts]
    if gone:
        out.append(Change(a, "parts.removed", None, gone, "changed"))
    if added:
        out.append(Change(a, "parts.added", None, added, "changed"))
    oh = {p["id"]: p.get("hash") for p in old["assembly"].get("parts", [])}
    edited = [p["id"] for p in new["assembly"].get("parts", [])
              if p["id"] in oh and p.get("hash") != oh[p["id"]]]
    if edited:
        out.append(Change(a, "parts.modified", None, edited, "changed",
                          "geometry or placement changed"))

    def pairs(r: dict) -> dict[tuple[str, str], dict]:
        return {tuple(sorted((i.get("a", ""), i.get("b", "")))): i
                for i in r.get("interferences") or []}

    oi, ni = pairs(old), pairs(new)
    for k in sorted(set(ni) - set(oi)):
        out.append(Change(a, "interferences", None, list(k), "worse",
                          f"new interference, volume {ni[k].get('volume')}"))
    for k in sorted(set(oi) - set(ni)):
        out.append(Change(a, "interferences", list(k), None, "better", "interference gone"))

    oc, nc = old.get("classes") or {}, new.get("classes") or {}
    for fam in sorted(set(oc) | set(nc)):
        fo, fn = oc.get(fam) or {}, nc.get(fam) or {}
        for key in GOOD_TRUE + GOOD_FALSE:
            vo = (fo.get(key) or {}).get("value")
            vn = (fn.get(key) or {}).get("value")
            if vo == vn or (key not in fo and key not in fn):
                continue
            good = key in GOOD_TRUE
            if vo is None or vn is None:
                grade = "changed"
                note = "now undecided" if vn is None else "now decided"
            else:
                grade = "better" if vn == good else "worse"
                note = ("class gained: " if vn == good else "class lost: ") + key
            out.append(Change(a, f"classes.{fam}.{key}", vo, vn, grade, note))
        for key, field in LOWER_BETTER.items():
            eo, en = fo.get(key) or {}, fn.get(key) or {}
            vo, vn = eo.get(field), en.get(field)
            if vo == vn or (key not in fo and key not in fn):
                continue
            # only proven values are compared: a bound (budget cut, greedy grasp) may move
            # with the machine's load, not with the design
            xo = eo.get("exact", key != "grasp") and vo is not None
            xn = en.get("exact", key != "grasp") and vn is not None
            if not (xo and xn):
                grade, note = "changed", "not both proven (bounds)"
            else:
                grade = "worse" if vn > vo else "better"
                note = ""
            out.append(Change(a, f"classes.{fam}.{key}", vo, vn, grade, note))
    po, pn = old.get("plan") or {}, new.get("plan") or {}
    if bool(po.get("found")) != bool(pn.get("found")):
        out.append(Change(a, "plan.found", bool(po.get("found")), bool(pn.get("found")),
                          "better" if pn.get("found") else "worse"))
    wo = sorted({w.get("code") for w in old.get("warnings") or []})
    wn = sorted({w.get("code") for w in new.get("warnings") or []})
    if [w for w in wn if w not in wo]:
        out.append(Change(a, "warnings", wo, wn, "changed", "new warning kinds"))
    return out


def diff_sets(old: dict[str, dict], new: dict[str, dict]) -> list[Change]:
    """Changes between two sets of reports keyed by assembly name."""
    out: list[Change] = []
    for key in sorted(set(old) | set(new)):
        name = _name(old[key] if key in old else new[key])
        if key not in new:
            out.append(Change(name, "assembly", "present", None, "changed", "removed"))
        elif key not in old:
            out.append(Change(name, "assembly", None, "present", "changed", "added"))
        else:
            out.extend(diff_reports(old[key], new[key], name))
    return out


def fails(changes: list[Change], fail_on: str) -> bool:
    """Whether ``changes`` fail a gate: ``worse`` (any worse change), ``any`` or ``never``."""
    if fail_on == "never":
        return False
    if fail_on == "any":
        return bool(changes)
    return any(c.grade == "worse" for c in changes)
