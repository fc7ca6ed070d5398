"""Design rules for CI gates: what an assembly's report must show (``ndbg check``).

A rules file (:func:`load_rules`) names rules (:data:`RULES`): booleans state the required
value of a class, ``max_*`` an upper bound on a measure. A rule is met or violated only when
the analysis *proves* it (:func:`measure`); otherwise it is *undecided* and counts as the
file's ``undecided`` setting says. :func:`evaluate` is pure: a report dict and the rules in,
a list of :class:`Outcome` out.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..core.constants import FAMILIES, GENERALIZED, INFINITE, INFINITESIMAL
from ..core.errors import InputError
from ..planning.classes import label, verdict
from ..planning.plans import plan_proves
from .document import identity

RULE_FAMILIES = ("auto", *FAMILIES)

#: Rule name -> (kind, description). ``bool`` rules compare a class value; ``max`` rules bound
#: a measure from above.
RULES: dict[str, tuple[str, str]] = {
    "no_interference": ("bool", "no interpenetrating parts"),
    "plan_found": ("bool", "an assembly tree was found"),
    "one_handed_monotone": ("bool", "a 1-handed monotone algorithm exists"),
    "prismatic": ("bool", "1-handed monotone 1-prismatic (infinite translations)"),
    "linearizable": ("bool", "parts can be added one at a time"),
    "stack_product": ("bool", "one direction takes every subassembly apart"),
    "interlocked": ("bool", "infinitesimally interlocked (any number of hands)"),
    "max_hands": ("max", "hands needed (1 when proven 1-handed monotone, at most n - 1)"),
    "max_depth": ("max", "minimum assembly tree depth"),
    "max_directions": ("max", "minimum number of translation directions"),
    "max_nonlinear": ("max", "minimum number of nonlinear instructions"),
    "max_fingers": ("max", "fingers of the prismatic form-closure grasp (greedy, so only "
                           "an upper bound: exceeding the limit is undecided, not a failure)"),
    "max_warnings": ("max", "warnings in the report"),
}


@dataclass(frozen=True)
class RuleSet:
    """A parsed rules file: the default family, the undecided policy, the rules for every
    assembly and the per-assembly ``(pattern, rules)`` entries, in file order."""

    family: str = "auto"
    undecided: str = "fail"
    rules: tuple[tuple[str, Any], ...] = ()
    assemblies: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()
    source: str = ""

    @staticmethod
    def _matches(pattern: str, name: str, source: str) -> bool:
        """A per-assembly pattern names the assembly, its source path or file name."""
        return any(fnmatch.fnmatchcase(s, pattern) for s in (name, source, Path(source).name))

    def unmatched(self, reports: list[dict]) -> list[str]:
        """Per-assembly patterns that match none of ``reports`` (likely a typo)."""
        ids = [identity(r) for r in reports]
        return [p for p, _ in self.assemblies if not any(self._matches(p, *i) for i in ids)]

    def rules_for(self, name: str, source: str) -> dict[str, Any]:
        """The rules that apply to an assembly (later entries override earlier ones)."""
        out = dict(self.rules)
        for pattern, rules in self.assemblies:
            if self._matches(pattern, name, source):
                out.update(rules)
        return out


@dataclass(frozen=True)
class Outcome:
    """One rule checked on one assembly: ``ok`` is True (met), False (violated) or None
    (undecided, then resolved by the policy into ``passed``)."""

    assembly: str
    source: str
    rule: str
    expected: Any
    measured: Any
    ok: bool | None
    passed: bool
    reason: str

    def line(self) -> str:
        """``bell: max_depth: measured 5, expected <= 4 (minimum depth ...)``."""
        want = (f"<= {self.expected}" if RULES.get(self.rule, ("", ""))[0] == "max"
                else _fmt(self.expected))
        state = "" if self.ok is not None else "undecided, "
        return (f"{self.assembly}: {self.rule}: {state}measured {_fmt(self.measured)}, "
                f"expected {want} ({self.reason})")


def _fmt(v: Any) -> str:
    if v is None:
        return "none"
    if isinstance(v, bool):
        return "true" if v else "false"
    return str(v)


def _check_rules(data: Any, path: tuple, doc: Any) -> tuple[tuple[str, Any], ...]:
    """The ``rule: value`` pairs of the mapping at key ``path`` of the rules file ``doc``
    (a :func:`~ndbg_cli.io.manifest.read_located` document: errors carry the line)."""
    if data is None:
        return ()
    where = ".".join(map(str, path))
    if not isinstance(data, dict):
        raise InputError(f"{where} must be a mapping of rule: value", file=doc.file,
                         line=doc.line(path))
    out = []
    for key, value in data.items():
        line = doc.line(path + (key,))
        if key not in RULES:
            raise InputError(f"{where}: unknown rule '{key}' (known: {', '.join(RULES)})",
                             file=doc.file, line=line)
        kind = RULES[key][0]
        if kind == "bool" and not isinstance(value, bool):
            raise InputError(f"{where}: rule '{key}' needs true or false, got {value!r}",
                             file=doc.file, line=line)
        if kind == "max" and (isinstance(value, bool) or not isinstance(value, int)
                              or value < 0):
            raise InputError(f"{where}: rule '{key}' needs a non-negative integer, got "
                             f"{value!r}", file=doc.file, line=line)
        out.append((str(key), value))
    return tuple(out)


def load_rules(path: str | Path) -> RuleSet:
    """Parse and validate a rules file; any problem is an :class:`InputError` (exit code 2).
    A rules file is YAML::

        family: auto          # which motion family the class rules read (see FAMILIES)
        undecided: fail       # fail | pass: how a measure the analysis left undecided counts
        rules:                # every assembly
          no_interference: true
          linearizable: true
          max_depth: 6
        assemblies:           # extra or stricter rules per assembly: a name, or a glob
          bell:               # matched against the assembly name and its source path
            max_directions: 1

    ``family: auto`` reads the evidence of every family computed; naming a family reads only
    that one (``prismatic`` always reads the translation families and ``interlocked`` the
    infinitesimal one, where the paper defines them).

    Read with the manifests' :class:`~ndbg_cli.io.manifest.YamlLoader`, so that a rules file
    reads numbers as a manifest or config does (``1e-3`` a float, not YAML 1.1's string)
    and is refused, as they are, when nested too deeply or inflated by aliases."""
    from ..io.manifest import read_located

    file = str(path)
    doc = read_located(path, "rules", "a rules file must be a YAML mapping with a 'rules' key")
    data = doc.data
    known = {"family", "undecided", "rules", "assemblies", "description"}
    unknown = sorted(set(map(str, data)) - known)
    if unknown:
        raise InputError(f"unknown key '{unknown[0]}' (known: {', '.join(sorted(known))})",
                         file=file, line=doc.line((unknown[0],)))
    family = data.get("family", "auto")
    if family not in RULE_FAMILIES:
        raise InputError(f"family must be one of {', '.join(RULE_FAMILIES)}", file=file,
                         line=doc.line(("family",)))
    undecided = data.get("undecided", "fail")
    if undecided not in ("fail", "pass"):
        raise InputError("undecided must be 'fail' or 'pass'", file=file,
                         line=doc.line(("undecided",)))
    rules = _check_rules(data.get("rules"), ("rules",), doc)
    per = data.get("assemblies") or {}
    if not isinstance(per, dict):
        raise InputError("assemblies must map a name or glob to rules", file=file,
                         line=doc.line(("assemblies",)))
    assemblies = tuple((str(k), _check_rules(v, ("assemblies", k), doc))
                       for k, v in per.items())
    if not rules and not any(r for _, r in assemblies):
        raise InputError("the rules file states no rule", file=file)
    return RuleSet(family=family, undecided=undecided, rules=rules, assemblies=assemblies,
                   source=file)


# ------------------------------------------------------------------------- measuring
#: Classes and measures the paper defines for every motion (7.1): a family's "no" (or lower
#: bound) refutes them only when that family holds every motion analysed (:func:`_widest`).
UNRESTRICTED = ("one_handed_monotone", "linearizable", "min_depth", "min_nonlinear")

#: What a rule reads from the classes section (``max_*`` rules read a measure).
_KEYS = {"max_depth": "min_depth", "max_directions": "min_directions",
         "max_nonlinear": "min_nonlinear", "max_fingers": "grasp"}


def _families(report: dict, wanted: str) -> list[str]:
    """The families whose evidence a rule reads: the one named, or with ``auto`` every family
    computed (a skipped one has no classes worth reading)."""
    classes = report.get("classes") or {}
    if wanted != "auto":
        return [wanted]
    nd = report.get("ndbg") or {}
    return [f for f in sorted(classes) if not (nd.get(f) or {}).get("skipped")]


def _widest(fams: list[str]) -> str | None:
    """The family among ``fams`` whose candidates hold every algorithm with any motion analysed
    (the generalized hybrid holds the infinitesimal translations, which hold every sequence of
    translations); ``None`` when only single translations were read, which refute nothing
    about other motions."""
    return next((f for f in (GENERALIZED, INFINITESIMAL) if f in fams), None)


def _refuters(key: str, fams: list[str]) -> list[str]:
    """Families whose proven "no" (or lower bound) decides ``key``: the widest for the
    unrestricted classes; any translational family for the classes defined by single
    translations (prismatic, stack product, number of directions: a single translation is a
    translation, so the infinitesimal NDBG refutes them too); the LP's for interlocking."""
    if key in UNRESTRICTED:
        w = _widest(fams)
        return [] if w is None else [w]
    if key == "interlocked":
        return [INFINITESIMAL]
    return [f for f in fams if f in (INFINITE, INFINITESIMAL)]


def _entry(report: dict, family: str, key: str) -> dict | None:
    got = ((report.get("classes") or {}).get(family) or {}).get(key)
    return got if isinstance(got, dict) else None


def _labelled(report: dict, family: str, key: str) -> dict | None:
    """A measure with its ``holds_for`` and ``evidence`` (added here for reports written
    before the classes carried them)."""
    e = _entry(report, family, key)
    if e is None or "evidence" in e:
        return e
    return label(family, key, e)


def _parts(report: dict) -> int | None:
    parts = (report.get("assembly") or {}).get("parts")
    return len(parts) if isinstance(parts, list) else None


def _first_line(e: dict) -> str:
    return (str(e.get("why") or "").splitlines() or [""])[0][:160]


def _bool_class(report: dict, key: str, fams: list[str]) -> tuple[Any, Any, Any, str]:
    """A class decided only by proof: yes by a proven yes (a real algorithm), no by a proven
    no of a family that covers the class (:func:`_refuters`); else undecided, the note listing
    what each family shows."""
    refuters = _refuters(key, fams)
    yes = no = None
    seen = []
    for fam in fams:
        e = _labelled(report, fam, key)
        if e is None:
            continue
        seen.append((fam, e))
        if e["evidence"] == "proven" and e.get("value") is True and yes is None:
            yes = (fam, e)
        if e["evidence"] == "proven" and e.get("value") is False and fam in refuters \
                and no is None:
            no = (fam, e)
    if not seen:
        return None, None, None, f"{'/'.join(fams) or 'no family'}: not computed"
    if (yes is None) != (no is None):
        fam, e = yes or no
        v = yes is not None
        return v, v, v, f"{fam}: {verdict(key, e)}: {_first_line(e)}"
    head = "contradicting proofs" if yes else "nothing proves it either way"
    return None, None, None, head + ": " + "; ".join(f"{f}: {verdict(key, e)}" for f, e in seen)


def _minimum(report: dict, key: str, fams: list[str]) -> tuple[Any, Any, Any, str]:
    """Bounds on a minimum proven by the families read: an upper bound from a real algorithm
    (single translations: exact or best found), a lower bound from the candidates' minimum of a
    refuting family (:func:`_refuters`) and ``ceil(log2 n)`` for the depth of any binary
    tree."""
    refuters = _refuters(key, fams)
    n = _parts(report)
    lower = (n - 1).bit_length() if key == "min_depth" and n else None
    upper = None
    notes = []
    for fam in fams:
        e = _labelled(report, fam, key)
        if e is None:
            continue
        notes.append(f"{fam}: {verdict(key, e)}")
        v = e.get("value")
        if v is None:
            continue
        if e["evidence"] in ("proven", "bound"):
            hi = e.get("upper_bound", v)
            upper = hi if upper is None or (hi is not None and hi < upper) else upper
        if fam in refuters:
            exact = e.get("exact", True)
            lo = e.get("lower_bound", v if exact else None)
            lower = lo if lower is None or (lo is not None and lo > lower) else lower
    if not notes:
        skipped = [f for f in fams if ((report.get("ndbg") or {}).get(f) or {}).get("skipped")]
        return None, None, None, f"{'/'.join(fams) or 'no family'} " + \
            ("skipped" if skipped else "not computed")
    value = lower if lower is not None and lower == upper else None
    return value, lower, upper, "; ".join(notes)


def _hands(report: dict, fams: list[str]) -> tuple[Any, Any, Any, str]:
    """Hands: at least 1 for two parts or more; at most 1 when a real 1-handed monotone
    algorithm is proven, else ``n - 1`` (paper 7.1: any admissible n-part product is
    (n-1)-handed monotone), unless infinitesimal interlocking puts admissibility in doubt.
    Nothing here proves 2 hands: a family's "not 1-handed monotone" is limited to its motions
    and to monotone algorithms, and the interlocking LP's moved sets are not a minimum."""
    n = _parts(report)
    lower = None if n is None else min(n - 1, 1)
    upper, why = None, ""
    proof = plan_proves(report.get("plan") or {})
    if proof is not None:
        upper, why = 1, "verified plan: " + proof["why"]
    else:
        for fam in fams:
            e = _labelled(report, fam, "one_handed_monotone")
            if e is not None and e.get("value") is True and e["evidence"] == "proven":
                upper, why = 1, f"{fam}: 1-handed monotone (proven by {e['holds_for']})"
                break
    lock = _labelled(report, INFINITESIMAL, "interlocked")
    locked = lock is not None and lock.get("value") is True
    if upper is None and n is not None and not locked:
        upper, why = n - 1, (f"any admissible {n}-part product is {n - 1}-handed monotone "
                             "(paper 7.1)")
    if upper is None:
        why = ("infinitesimally interlocked: no translation frees a part" if locked else
               "no 1-handed monotone algorithm proven")
    value = lower if lower is not None and lower == upper else None
    return value, lower, upper, why + ("" if lower is None else f"; at least {lower}")


def measure(report: dict, rule: str, family: str) -> tuple[Any, Any, Any, str]:
    """``(value, lower, upper, note)`` of a rule's measure in ``report``, from what the
    ``family`` setting reads (``auto``: every computed family). Only proven facts count:
    ``value`` is ``None`` unless proven (booleans then have ``lower = upper = value``), and the
    bounds are those proven; the note says what each family shows and for which motions.

    What counts as proof (each class measure carries ``holds_for`` and ``evidence``,
    :mod:`classes`):

    * a yes, or an upper bound, needs a real algorithm: the infinite-translation family's (its
      trees are 1-handed monotone 1-prismatic algorithms). A yes or a minimum of the
      infinitesimal or generalized families is a *candidate* (a necessary condition) and
      proves nothing; their minimum is a lower bound;
    * a no, or a lower bound, of a class the paper defines for every motion (1-handed
      monotone, linearizable, depth, nonlinear steps) needs a family holding every motion
      analysed: the generalized one when computed, else the infinitesimal translations (the
      reason then says "with translations"). The infinite translations' no only says "not
      with single translations": the L-shaped channel whose part leaves by +x then +y is
      1-handed monotone;
    * ``prismatic``, ``stack_product`` and ``max_directions`` are defined by single
      translations (paper 7.1), so either translation family refutes them and the infinite
      one decides them; ``interlocked`` is the infinitesimal LP's, decided either way;
    * ``max_hands``: at least 1 (two parts or more); at most 1 when a 1-handed monotone
      algorithm is proven, else ``n - 1`` (any admissible n-part product, paper 7.1) unless
      the product is infinitesimally interlocked. No analysis here proves 2 hands are needed;
    * ``plan_found``: a search cut by its budget (the plan's ``exact: false``) that found
      nothing is undecided, not false."""
    if rule == "no_interference":
        n = len(report.get("interferences") or [])
        return n == 0, n == 0, n == 0, f"{n} interference(s)"
    if rule == "plan_found":
        return _plan_found(report.get("plan") or {})
    if rule == "max_warnings":
        n = len(report.get("warnings") or [])
        return n, n, n, f"{n} warning(s)"
    fams = _families(report, family)
    if rule == "prismatic":
        fams = [INFINITE, INFINITESIMAL]   # defined by single translations, refuted by any
    elif rule == "interlocked":
        fams = [INFINITESIMAL]             # the LP on infinitesimal translations
    if rule == "max_hands":
        return _hands(report, fams)
    key = _KEYS.get(rule, rule)
    if rule == "max_fingers":
        # the old auto preference: the infinite family's grasp when computed
        fam = next((f for f in (INFINITE, INFINITESIMAL, GENERALIZED)
                    if f in fams and _entry(report, f, key)), fams[0] if fams else family)
        e = _entry(report, fam, key)
        if e is None:
            skipped = ((report.get("ndbg") or {}).get(fam) or {}).get("skipped")
            return None, None, None, f"{fam} " + ("skipped" if skipped else "not computed")
        v = e.get("value")
        note = f"{fam}: {_first_line(e)}" if _first_line(e) else fam
        # a greedy placement: a grasp with that many fingers exists, fewer may do
        if not e.get("complete", True) or v is None:
            return None, None, None, note
        # the exact minimum over the candidate faces (one point per exposed face
        # orientation): a finger elsewhere might do more, so it stays an upper bound
        return None, None, v, note + (" (minimum over the candidate faces: an upper bound)"
                                      if e.get("exact") else " (greedy: an upper bound)")
    proof = plan_proves(report.get("plan") or {})
    if RULES[rule][0] == "bool":
        got = _bool_class(report, key, fams)
        if proof is not None and proof.get(key) is True:
            if got[0] is False:
                return None, None, None, "contradicting proofs: verified plan; " + got[3]
            return True, True, True, "verified plan: " + proof["why"]
        return got
    value, lower, upper, note = _minimum(report, key, fams)
    if proof is not None and proof.get(key) is not None and (upper is None
                                                             or proof[key] < upper):
        upper = proof[key]
        note = f"verified plan: at most {upper}; " + note
        value = lower if lower is not None and lower == upper else None
    return value, lower, upper, note


def _plan_found(p: dict) -> tuple[Any, Any, Any, str]:
    """A plan found is a fact; none found is one only when the search was complete (a search
    cut by its budget, ``exact: false``, proves nothing)."""
    fam = f"plan of the {p.get('family') or 'no'} family"
    if p.get("found"):
        return True, True, True, fam
    if p.get("exact", True) is False:
        notes = "; ".join(p.get("notes") or []) or "search budget exhausted"
        return None, None, None, f"{fam}: none found, but {notes}"
    return False, False, False, fam


def evaluate(report: dict, rules: RuleSet) -> list[Outcome]:
    """Check ``rules`` on one report (or error record): one :class:`Outcome` per rule that
    applies, in the rules' order; an error record gives one failed ``analysis`` outcome."""
    name, source = identity(report)
    if "error" in report:
        err = report["error"]
        return [Outcome(name, source, "analysis", "a report", None, False, False,
                        str(err.get("message", "analysis failed")))]
    family = rules.family
    out = []
    for rule, expected in rules.rules_for(name, source).items():
        value, lower, upper, note = measure(report, rule, family)
        if RULES[rule][0] == "bool":
            ok = None if value is None else value == expected
            shown = value
        else:
            if upper is not None and upper <= expected:
                ok = True
            elif lower is not None and lower > expected:
                ok = False
            else:
                ok = None
            shown = value if value is not None else _bounds(lower, upper)
        passed = ok if ok is not None else rules.undecided == "pass"
        out.append(Outcome(name, source, rule, expected, shown, ok, passed, note))
    return out


def _bounds(lower: Any, upper: Any) -> str | None:
    if lower is None and upper is None:
        return None
    return f"between {'?' if lower is None else lower} and {'?' if upper is None else upper}"
