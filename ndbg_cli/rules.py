"""Design rules for CI gates: what an assembly's report must show (``ndbg check``).

A rules file is YAML::

    family: auto          # which motion family the class rules read (see FAMILIES)
    undecided: fail       # fail | pass: how a measure the analysis left undecided counts
    rules:                # every assembly
      no_interference: true
      linearizable: true
      max_depth: 6
    assemblies:           # extra or stricter rules per assembly: a name, or a glob matched
      bell:               # against the assembly name and its source path
        max_directions: 1

Rule keys (:data:`RULES`): booleans state the required value of a class, ``max_*`` an upper
bound on a measure. A bound is met when the analysis proves it (an exact value, or an upper
bound from a tree actually found, at most the limit) and violated when the analysis proves the
opposite (a lower bound above the limit); otherwise the measure is *undecided* (budget
exhausted, family skipped) and counts as ``undecided`` says. ``family: auto`` reads the
infinite-translation classes when that NDBG was computed (guaranteed answers) and the
infinitesimal ones otherwise (necessary conditions); ``prismatic`` always reads the infinite
family and ``interlocked`` the infinitesimal one, where the paper defines them.

:func:`evaluate` is pure: a report dict and the rules in, a list of :class:`Outcome` out.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import InputError
from .report import identity

INFINITESIMAL = "infinitesimal_translation"
INFINITE = "infinite_translation"
GENERALIZED = "generalized"
FAMILIES = ("auto", INFINITESIMAL, INFINITE, GENERALIZED)

#: Rule name -> (kind, description). ``bool`` rules compare a class value; ``max`` rules bound
#: a measure from above.
RULES: dict[str, tuple[str, str]] = {
    "no_interference": ("bool", "no interpenetrating parts"),
    "plan_found": ("bool", "an assembly tree was found"),
    "one_handed_monotone": ("bool", "a 1-handed monotone (candidate) algorithm exists"),
    "prismatic": ("bool", "1-handed monotone 1-prismatic (infinite translations)"),
    "linearizable": ("bool", "parts can be added one at a time"),
    "stack_product": ("bool", "one direction takes every subassembly apart"),
    "interlocked": ("bool", "infinitesimally interlocked (any number of hands)"),
    "max_hands": ("max", "hands needed (1 when 1-handed monotone)"),
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


def _check_rules(data: Any, where: str, file: str) -> tuple[tuple[str, Any], ...]:
    if data is None:
        return ()
    if not isinstance(data, dict):
        raise InputError(f"{where} must be a mapping of rule: value", file=file)
    out = []
    for key, value in data.items():
        if key not in RULES:
            raise InputError(f"{where}: unknown rule '{key}' (known: {', '.join(RULES)})",
                             file=file)
        kind = RULES[key][0]
        if kind == "bool" and not isinstance(value, bool):
            raise InputError(f"{where}: rule '{key}' needs true or false, got {value!r}",
                             file=file)
        if kind == "max" and (isinstance(value, bool) or not isinstance(value, int)
                              or value < 0):
            raise InputError(f"{where}: rule '{key}' needs a non-negative integer, got "
                             f"{value!r}", file=file)
        out.append((str(key), value))
    return tuple(out)


def load_rules(path: str | Path) -> RuleSet:
    """Parse and validate a rules file; any problem is an :class:`InputError` (exit code 2)."""
    import yaml

    file = str(path)
    try:
        data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(f"cannot read rules: {exc.strerror or exc}", file=file) from None
    except yaml.YAMLError as exc:
        raise InputError(f"malformed YAML: {str(exc).splitlines()[0]}", file=file) from None
    if not isinstance(data, dict):
        raise InputError("a rules file must be a YAML mapping with a 'rules' key", file=file)
    known = {"family", "undecided", "rules", "assemblies", "description"}
    unknown = sorted(set(map(str, data)) - known)
    if unknown:
        raise InputError(f"unknown key '{unknown[0]}' (known: {', '.join(sorted(known))})",
                         file=file)
    family = data.get("family", "auto")
    if family not in FAMILIES:
        raise InputError(f"family must be one of {', '.join(FAMILIES)}", file=file)
    undecided = data.get("undecided", "fail")
    if undecided not in ("fail", "pass"):
        raise InputError("undecided must be 'fail' or 'pass'", file=file)
    rules = _check_rules(data.get("rules"), "rules", file)
    per = data.get("assemblies") or {}
    if not isinstance(per, dict):
        raise InputError("assemblies must map a name or glob to rules", file=file)
    assemblies = tuple((str(k), _check_rules(v, f"assemblies.{k}", file))
                       for k, v in per.items())
    if not rules and not any(r for _, r in assemblies):
        raise InputError("the rules file states no rule", file=file)
    return RuleSet(family=family, undecided=undecided, rules=rules, assemblies=assemblies,
                   source=file)


# ------------------------------------------------------------------------- measuring
def _family(report: dict, wanted: str) -> str:
    classes = report.get("classes") or {}
    if wanted != "auto":
        return wanted
    inf = (report.get("ndbg") or {}).get(INFINITE) or {}
    if INFINITE in classes and not inf.get("skipped"):
        return INFINITE
    return INFINITESIMAL if INFINITESIMAL in classes else next(iter(sorted(classes)), wanted)


def _entry(report: dict, family: str, key: str) -> dict | None:
    got = ((report.get("classes") or {}).get(family) or {}).get(key)
    return got if isinstance(got, dict) else None


def measure(report: dict, rule: str, family: str) -> tuple[Any, Any, Any, str]:
    """``(value, lower, upper, note)`` of a rule's measure in ``report`` for ``family``.
    Booleans have ``lower = upper = value``; ``None`` means undecided or not computed."""
    if rule == "no_interference":
        n = len(report.get("interferences") or [])
        return n == 0, n == 0, n == 0, f"{n} interference(s)"
    if rule == "plan_found":
        p = report.get("plan") or {}
        v = bool(p.get("found"))
        return v, v, v, f"plan of the {p.get('family') or 'no'} family"
    if rule == "max_warnings":
        n = len(report.get("warnings") or [])
        return n, n, n, f"{n} warning(s)"
    fam = INFINITE if rule == "prismatic" else INFINITESIMAL if rule == "interlocked" else family
    if rule == "max_hands":
        ohm = _entry(report, fam, "one_handed_monotone")
        lock = _entry(report, INFINITESIMAL, "interlocked")
        if ohm is None:
            return None, None, None, f"{fam} not computed"
        if ohm.get("value") is True:
            return 1, 1, 1, f"{fam}: 1-handed monotone"
        if lock is not None and lock.get("value") is True:
            return None, None, None, "infinitesimally interlocked: no translation frees a part"
        return None, 2, None, f"{fam}: not 1-handed monotone, so at least 2 hands"
    key = {"max_depth": "min_depth", "max_directions": "min_directions",
           "max_nonlinear": "min_nonlinear", "max_fingers": "grasp"}.get(rule, rule)
    e = _entry(report, fam, key)
    if e is None:
        skipped = ((report.get("ndbg") or {}).get(fam) or {}).get("skipped")
        return None, None, None, f"{fam} " + ("skipped" if skipped else "not computed")
    v = e.get("value")
    why = (str(e.get("why") or "").splitlines() or [""])[0][:160]
    note = f"{fam}: {why}" if why else fam
    if RULES[rule][0] == "bool":
        return v, v, v, note
    if rule == "max_fingers":
        # a greedy placement: a grasp with that many fingers exists, fewer may do
        if not e.get("complete", True) or v is None:
            return None, None, None, note
        return None, None, v, note + " (greedy: an upper bound)"
    exact = e.get("exact", v is not None)
    lower = e.get("lower_bound", v if exact else None)
    upper = e.get("upper_bound", v)
    if not exact:
        v = None
    return v, lower, upper, note


def evaluate(report: dict, rules: RuleSet) -> list[Outcome]:
    """Check ``rules`` on one report (or error record): one :class:`Outcome` per rule that
    applies, in the rules' order; an error record gives one failed ``analysis`` outcome."""
    name, source = identity(report)
    if "error" in report:
        err = report["error"]
        return [Outcome(name, source, "analysis", "a report", None, False, False,
                        str(err.get("message", "analysis failed")))]
    family = _family(report, rules.family)
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
