"""Consistency of a report's answers with each other (``ndbg check --self``).

A report gives several answers about one product that logic ties together: a plan proven
step by step by the direct sweep test is a 1-handed monotone algorithm of single translations,
so the product is not interlocked and no family may say that no such algorithm exists; a split
removable by one translation to infinity is also free infinitesimally; a candidate family's
minimum depth is at most any real tree's. :func:`contradictions` checks those ties on a
finished report (a dict, as :func:`ndbg_cli.pipeline.analysis.analyze` returns it or as read
from JSON) and returns what does not hold, each a :class:`Contradiction` (its rule, the
report fields involved, one line). Every rule is in :data:`RULES`, each a function of the
report alone: no geometry, no recomputation. An error record has no answers to check.

Families are nested: every infinite-translation tree is a candidate tree of the
infinitesimal NDBG, and every infinitesimal candidate one of the generalized hybrid
(:data:`CONTAINED`). A value with ``evidence`` ``"undecided"`` (or ``None``) claims nothing.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL, TRANSLATION

__all__ = ["CODE", "CONTAINED", "RULES", "Contradiction", "contradictions", "warnings"]

#: The diagnostic code of a contradiction in a report's ``warnings``.
CODE = "inconsistent-report"
#: ``(narrow, wide)``: every tree of the narrow family is a (candidate) tree of the wide one.
CONTAINED = ((INFINITE, INFINITESIMAL), (INFINITESIMAL, GENERALIZED), (INFINITE, GENERALIZED))
#: The minima of the classes (``lower_bound <= value <= upper_bound``).
MINIMA = ("min_depth", "min_nonlinear", "min_directions")


@dataclass(frozen=True)
class Contradiction:
    """Two or more answers of one report that cannot all be true.

    Attributes
    ----------
    rule : str
        The rule's name (a key of :data:`RULES`).
    fields : tuple of str
        The report fields involved, as dotted paths (``plan.verified.value``).
    message : str
        One line saying what disagrees.
    """

    rule: str
    fields: tuple[str, ...]
    message: str

    def record(self) -> dict:
        """The contradiction as a JSON-ready dict: ``rule``, ``fields``, ``message``."""
        return {"rule": self.rule, "fields": list(self.fields), "message": self.message}

    def line(self) -> str:
        """``rule: message [field, field]``: one line for a terminal."""
        return f"{self.rule}: {self.message} [{', '.join(self.fields)}]"


# -- reading a report -----------------------------------------------------------------------

def _entry(report: dict, family: str, key: str) -> dict | None:
    got = ((report.get("classes") or {}).get(family) or {}).get(key)
    return got if isinstance(got, dict) else None


def _claims(entry: dict | None) -> bool:
    """Whether a measure claims its value (``evidence`` ``"undecided"`` claims nothing)."""
    return entry is not None and entry.get("evidence") != "undecided"


def _bool(v: Any) -> bool | None:
    """``v`` as a bool when it is one (numpy's too: a report not yet cleaned), else None."""
    return bool(v) if isinstance(v, bool) or type(v).__name__ == "bool_" else None


def _is(report: dict, family: str, key: str, value: bool | None) -> bool:
    """Whether measure ``key`` of ``family`` claims ``value`` (a bool, or None for "none")."""
    e = _entry(report, family, key)
    if not _claims(e):
        return False
    v = e.get("value")
    return v is None if value is None else _bool(v) is value


def _none_exists(entry: dict | None) -> bool:
    """A minimum that says no algorithm exists: no value, and exact."""
    return _claims(entry) and entry.get("value") is None and bool(entry.get("exact"))


def _lower(entry: dict | None) -> int | None:
    """A minimum's lower bound: ``lower_bound``, else its value when exact."""
    if not _claims(entry):
        return None
    if entry.get("lower_bound") is not None:
        return int(entry["lower_bound"])
    v = entry.get("value")
    return int(v) if v is not None and entry.get("exact", True) else None


def _field(family: str, key: str, sub: str = "value") -> str:
    return f"classes.{family}.{key}.{sub}"


def _families(report: dict) -> list[str]:
    return sorted(report.get("classes") or {})


def _plan(report: dict) -> dict:
    return report.get("plan") or {}


def _proven(report: dict) -> bool:
    """The plan is proven step by step (a 1-handed monotone algorithm of single
    translations)."""
    p = _plan(report)
    return (bool(p.get("found")) and p.get("family") in TRANSLATION
            and _bool((p.get("verified") or {}).get("value")) is True)


def _splits(node: dict | None) -> Iterator[dict]:
    """The split nodes of a plan tree (those with ``moved`` and ``rest``), root first."""
    if not node or "moved" not in node:
        return
    yield node
    yield from _splits(node.get("moved"))
    yield from _splits(node.get("rest"))


def _height(node: dict | None) -> int:
    if not node or "moved" not in node:
        return 0
    return 1 + max(_height(node.get("moved")), _height(node.get("rest")))


def _leaves(node: dict | None) -> int:
    return len((node or {}).get("parts") or [])


def _linear(node: dict) -> bool:
    """Every split of the tree takes one part off (one side a single part)."""
    return all(min(_leaves(s["moved"]), _leaves(s["rest"])) == 1 for s in _splits(node))


def _nonlinear(node: dict) -> int:
    return sum(min(_leaves(s["moved"]), _leaves(s["rest"])) > 1 for s in _splits(node))


def _free(arcs: list, moved: set[str]) -> bool:
    """``moved`` is free in a DBG given by its arcs (``[i, j]``: ``i`` moving along the
    direction collides with ``j``): no arc leaves it."""
    return not any(i in moved and j not in moved for i, j in arcs)


# -- the rules ------------------------------------------------------------------------------

def plan_vs_interlocked(report: dict) -> Iterator[Contradiction]:
    """A proven plan is a witness that the product is not interlocked: its first removal
    step translates one side away from the other."""
    if _proven(report) and _is(report, INFINITESIMAL, "interlocked", True):
        yield Contradiction(
            "plan-vs-interlocked",
            ("plan.verified.value", _field(INFINITESIMAL, "interlocked")),
            "the plan is proven step by step by the sweep test, yet the report says the "
            "product is interlocked")


def plan_vs_monotone(report: dict) -> Iterator[Contradiction]:
    """A proven plan is a 1-handed monotone (1-prismatic) algorithm of single translations,
    a candidate algorithm of every family: none may say no such algorithm exists."""
    if not _proven(report):
        return
    for fam in _families(report):
        keys = ["one_handed_monotone"] + (["prismatic"] if fam in TRANSLATION else [])
        for key in keys:
            if _is(report, fam, key, False):
                yield Contradiction("plan-vs-monotone", ("plan.verified.value",
                                                         _field(fam, key)),
                                    f"the plan is proven, yet {fam} says {key}: no")
        for key in MINIMA:
            if _none_exists(_entry(report, fam, key)):
                yield Contradiction("plan-vs-monotone", ("plan.verified.value",
                                                         _field(fam, key)),
                                    f"the plan is proven, yet {fam} says {key}: none "
                                    "(no algorithm)")


def infinite_split_is_infinitesimal(report: dict) -> Iterator[Contradiction]:
    """A split removable by one translation to infinity is free infinitesimally along that
    direction: its moved side is free in some DBG of the infinitesimal NDBG (the report's
    distinct DBGs, complete even when the partitionings are truncated). An infinitesimal NDBG
    that declares it reads some contacts conservatively (``conservative_contacts``: it may
    block what is free) promises no such thing."""
    sec = ((report.get("ndbg") or {}).get(INFINITESIMAL) or {})
    if "dbgs" not in sec or sec.get("conservative_contacts"):
        return
    dbgs = [d.get("arcs") or [] for d in sec["dbgs"]]
    for p in report.get("partitionings") or []:
        if p.get("family") != INFINITE:
            continue
        moved = set(p["moved"])
        if not any(_free(arcs, moved) for arcs in dbgs):
            yield Contradiction(
                "infinite-split-is-infinitesimal",
                ("partitionings", f"ndbg.{INFINITESIMAL}.dbgs"),
                f"{{{', '.join(p['moved'])}}} leaves the rest by one translation, yet no "
                "infinitesimal DBG frees it")
            return  # one is enough: the others have the same cause


def prismatic_tree(report: dict) -> Iterator[Contradiction]:
    """``prismatic: yes`` says a tree exists whose every step is one translation: the plan
    (the first family tried is the infinite translations) must be such a tree, proven."""
    p = _plan(report)
    for fam in TRANSLATION:
        if not _is(report, fam, "prismatic", True):
            continue
        nodes = list(_splits(p.get("tree")))
        bad = [n for n in nodes if n.get("removal_direction") is None or "motion" in n]
        if not p.get("found") or p.get("family") not in TRANSLATION or bad \
                or _bool((p.get("verified") or {}).get("value")) is False:
            yield Contradiction(
                "prismatic-tree", (_field(fam, "prismatic"), "plan.tree", "plan.verified"),
                f"{fam} says prismatic: yes, yet the plan is not a proven tree of single "
                "translations")


def depth_vs_plan(report: dict) -> Iterator[Contradiction]:
    """Every family's least depth is at most a proven tree's depth (a proven tree is a
    candidate tree of every family): the lower bound may not exceed the plan's depth."""
    p = _plan(report)
    if not _proven(report) or p.get("depth") is None:
        return
    for fam in _families(report):
        low = _lower(_entry(report, fam, "min_depth"))
        if low is not None and low > p["depth"]:
            yield Contradiction("depth-vs-plan", (_field(fam, "min_depth", "lower_bound"),
                                                  "plan.depth"),
                                f"{fam} says no tree is shallower than {low}, yet the proven "
                                f"plan has depth {p['depth']}")


def linear_plan(report: dict) -> Iterator[Contradiction]:
    """A plan whose every step takes one part off is a linear tree of its family and of the
    families holding it (all of them when it is proven): ``linearizable`` is not no."""
    p = _plan(report)
    if not p.get("found") or not p.get("tree") or not _linear(p["tree"]):
        return
    fam = p.get("family")
    if _proven(report):
        fams = _families(report)
    else:
        fams = [fam] + [wide for narrow, wide in CONTAINED if narrow == fam]
    for f in fams:
        if _is(report, f, "linearizable", False):
            yield Contradiction("linear-plan", ("plan.tree", _field(f, "linearizable")),
                                f"the plan adds one part at a time, yet {f} says "
                                "linearizable: no")


def plan_shape(report: dict) -> Iterator[Contradiction]:
    """The plan's numbers against its own tree: its depth is the tree's height (at least
    ``ceil(log2 n)``, at most ``n - 1``), its lower bound is at most its depth, its nonlinear
    steps and sequence are the tree's."""
    p = _plan(report)
    tree = p.get("tree")
    if not p.get("found") or not tree:
        return
    n, h = _leaves(tree), _height(tree)
    checks = [
        (p.get("depth") == h, ("plan.depth", "plan.tree"),
         f"the plan's depth is {p.get('depth')}, its tree's height {h}"),
        (n < 2 or math.ceil(math.log2(n)) <= h <= n - 1, ("plan.depth", "plan.tree"),
         f"a tree of {n} parts cannot have height {h}"),
        (p.get("depth_lower_bound") is None or p.get("depth") is None
         or p["depth_lower_bound"] <= p["depth"], ("plan.depth_lower_bound", "plan.depth"),
         f"the plan's depth {p.get('depth')} is below its lower bound "
         f"{p.get('depth_lower_bound')}"),
        (p.get("nonlinear_steps") is None or p["nonlinear_steps"] == _nonlinear(tree),
         ("plan.nonlinear_steps", "plan.tree"),
         f"the plan says {p.get('nonlinear_steps')} nonlinear steps, its tree has "
         f"{_nonlinear(tree)}"),
        (len(p.get("sequence") or []) == len(list(_splits(tree))), ("plan.sequence",
                                                                     "plan.tree"),
         f"the plan's sequence has {len(p.get('sequence') or [])} steps, its tree "
         f"{len(list(_splits(tree)))} splits"),
    ]
    for ok, fields, message in checks:
        if not ok:
            yield Contradiction("plan-shape", fields, message)


def proof_of_none(report: dict) -> Iterator[Contradiction]:
    """A proof that no plan of single translations exists: no plan is found, and the
    infinite translations' 1-handed monotone and prismatic classes are not yes; a proven
    plan and a proof of none exclude each other."""
    p = _plan(report)
    v = p.get("verified") or {}
    if _bool(v.get("value")) is True and (v.get("proof_of_none") or not p.get("found")):
        yield Contradiction("proof-of-none", ("plan.verified", "plan.found"),
                            "the plan is verified, yet not found or proven impossible")
    if not v.get("proof_of_none"):
        return
    if p.get("found"):
        yield Contradiction("proof-of-none", ("plan.verified.proof_of_none", "plan.found"),
                            "no plan can exist, yet one is found")
    for key in ("one_handed_monotone", "prismatic"):
        if _is(report, INFINITE, key, True):
            yield Contradiction("proof-of-none", ("plan.verified.proof_of_none",
                                                  _field(INFINITE, key)),
                                f"no plan of single translations can exist, yet {INFINITE} "
                                f"says {key}: yes")


def infinite_monotone_has_plan(report: dict) -> Iterator[Contradiction]:
    """A proven 1-handed monotone class of the infinite translations is a tree of single
    translations: the plan (that family is tried first) is found and not refuted."""
    e = _entry(report, INFINITE, "one_handed_monotone")
    p = _plan(report)
    if e is None or _bool(e.get("value")) is not True or e.get("evidence", "proven") != "proven":
        return
    if not p.get("found") or _bool((p.get("verified") or {}).get("value")) is False:
        yield Contradiction("infinite-monotone-has-plan",
                            (_field(INFINITE, "one_handed_monotone"), "plan.found",
                             "plan.verified.value"),
                            f"{INFINITE} says 1-handed monotone: yes, yet no plan is proven")


def class_implications(report: dict) -> Iterator[Contradiction]:
    """Within one family: a tree of any kind (prismatic, linear, along one direction) or a
    least depth, number of nonlinear steps or directions is a 1-handed monotone tree, so
    ``one_handed_monotone: no`` excludes them; and a yes needs a least depth."""
    for fam in _families(report):
        if _is(report, fam, "one_handed_monotone", False):
            for key in ("prismatic", "linearizable", "stack_product"):
                if _is(report, fam, key, True):
                    yield Contradiction("class-implications", (_field(fam, key), _field(
                        fam, "one_handed_monotone")), f"{fam} says {key}: yes but 1-handed "
                        "monotone: no")
            for key in MINIMA:
                e = _entry(report, fam, key)
                if _claims(e) and e.get("value") is not None:
                    yield Contradiction("class-implications", (_field(fam, key), _field(
                        fam, "one_handed_monotone")), f"{fam} says {key}: {e['value']} but "
                        "1-handed monotone: no")
        elif _is(report, fam, "one_handed_monotone", True) \
                and _none_exists(_entry(report, fam, "min_depth")):
            yield Contradiction("class-implications", (_field(fam, "min_depth"), _field(
                fam, "one_handed_monotone")), f"{fam} says 1-handed monotone: yes but "
                "min_depth: none")


def linear_vs_nonlinear(report: dict) -> Iterator[Contradiction]:
    """``linearizable`` is "the least number of nonlinear steps is 0", and the assembly
    lines are that number plus one."""
    for fam in _families(report):
        e = _entry(report, fam, "min_nonlinear")
        if not _claims(e) or e.get("value") is None:
            continue
        fields = (_field(fam, "linearizable"), _field(fam, "min_nonlinear"))
        zero = e["value"] == 0 and e.get("exact", True)
        if _is(report, fam, "linearizable", True) and e["value"] != 0:
            yield Contradiction("linear-vs-nonlinear", fields, f"{fam} says linearizable: "
                                f"yes but needs {e['value']} nonlinear step(s)")
        if _is(report, fam, "linearizable", False) and zero:
            yield Contradiction("linear-vs-nonlinear", fields, f"{fam} says linearizable: "
                                "no but 0 nonlinear steps (exact)")
        lines = e.get("assembly_lines")
        if lines is not None and lines != e["value"] + 1:
            yield Contradiction("linear-vs-nonlinear", (_field(fam, "min_nonlinear",
                                                               "assembly_lines"),
                                                        _field(fam, "min_nonlinear")),
                                f"{fam}: {lines} assembly lines for {e['value']} nonlinear "
                                "step(s)")


def minimum_bounds(report: dict) -> Iterator[Contradiction]:
    """A minimum lies within its bounds, which meet when it is exact."""
    for fam in _families(report):
        for key in MINIMA:
            e = _entry(report, fam, key)
            if not _claims(e) or e.get("value") is None:
                continue
            lo, v, hi = e.get("lower_bound"), e["value"], e.get("upper_bound")
            ok = (lo is None or lo <= v) and (hi is None or v <= hi)
            if e.get("exact") and ((lo is not None and lo != v) or (hi is not None and hi != v)):
                ok = False
            if not ok:
                yield Contradiction("minimum-bounds", (_field(fam, key), _field(
                    fam, key, "lower_bound"), _field(fam, key, "upper_bound")),
                    f"{fam} {key}: {v} outside [{lo}, {hi}]" + (" (exact)" if e.get("exact")
                                                                else ""))


def stack_vs_directions(report: dict) -> Iterator[Contradiction]:
    """A stack product is a tree along one direction: the least number of directions is 1
    (and an exact 1 is a stack product), under the same convention (the side without the
    base moves)."""
    for fam in _families(report):
        e = _entry(report, fam, "min_directions")
        if not _claims(e):
            continue
        low, v = _lower(e), e.get("value")
        fields = (_field(fam, "stack_product"), _field(fam, "min_directions"))
        if _is(report, fam, "stack_product", True) and low is not None and low > 1:
            yield Contradiction("stack-vs-directions", fields, f"{fam} says stack product: "
                                f"yes but at least {low} directions")
        if _is(report, fam, "stack_product", False) and v == 1 and e.get("exact", True):
            yield Contradiction("stack-vs-directions", fields, f"{fam} says stack product: "
                                "no but 1 direction suffices (exact)")


def containment(report: dict) -> Iterator[Contradiction]:
    """Nested families (:data:`CONTAINED`): a tree of the narrow family is a candidate tree
    of the wide one, so the wide one's no (to 1-handed monotone, linearizable, stack product)
    and lower bounds may not contradict the narrow one's yes and values; and the
    infinitesimal family refutes prismatic for the infinite one."""
    for narrow, wide in CONTAINED:
        for key in ("one_handed_monotone", "linearizable", "stack_product"):
            if _is(report, narrow, key, True) and _is(report, wide, key, False):
                yield Contradiction("containment", (_field(narrow, key), _field(wide, key)),
                                    f"{narrow} says {key}: yes, {wide} (which holds its "
                                    "trees) says no")
        for key in MINIMA:
            e = _entry(report, narrow, key)
            low = _lower(_entry(report, wide, key))
            if _claims(e) and e.get("value") is not None and low is not None \
                    and low > e["value"]:
                yield Contradiction("containment", (_field(narrow, key), _field(
                    wide, key, "lower_bound")), f"{narrow} has a tree with {key} "
                    f"{e['value']}, {wide} (which holds its trees) says at least {low}")
    if _is(report, INFINITE, "prismatic", True) and _is(report, INFINITESIMAL, "prismatic",
                                                        False):
        yield Contradiction("containment", (_field(INFINITE, "prismatic"),
                                            _field(INFINITESIMAL, "prismatic")),
                            f"{INFINITE} says prismatic: yes, {INFINITESIMAL} says no")


def interlocked_vs_splits(report: dict) -> Iterator[Contradiction]:
    """Interlocked: no translation of any number of parts moves anything. A split removable
    by one translation contradicts it; so does a candidate split of the infinitesimal NDBG
    (its free directions are infinitesimal translations) when the interlocking is proven,
    not only a necessary condition."""
    lock = _entry(report, INFINITESIMAL, "interlocked")
    if not _claims(lock) or _bool(lock.get("value")) is not True:
        return
    fams = [INFINITE] + ([INFINITESIMAL] if lock.get("evidence", "proven") == "proven"
                         else [])
    for fam in fams:
        split = next((p for p in report.get("partitionings") or [] if p.get("family") == fam),
                     None)
        if split is not None:
            yield Contradiction("interlocked-vs-splits", (_field(INFINITESIMAL, "interlocked"),
                                                          "partitionings"),
                                f"interlocked, yet the {fam} family frees "
                                f"{{{', '.join(split['moved'])}}}")
    if lock.get("evidence", "proven") == "proven" and _is(report, INFINITESIMAL,
                                                          "one_handed_monotone", True):
        yield Contradiction("interlocked-vs-splits", (
            _field(INFINITESIMAL, "interlocked"), _field(INFINITESIMAL, "one_handed_monotone")),
            "interlocked, yet the infinitesimal NDBG has a candidate tree")


def interlock_hands(report: dict) -> Iterator[Contradiction]:
    """Not interlocked: the fewest moved sets (hands) lie between their lower bound and the
    moved sets of the motion found; an exact count has a value."""
    lock = _entry(report, INFINITESIMAL, "interlocked")
    if not _claims(lock) or _bool(lock.get("value")) is not False:
        return
    low, k, hands = lock.get("hands_lower_bound"), lock.get("moved_set_count"), \
        lock.get("hands")
    fields = (_field(INFINITESIMAL, "interlocked", "hands_lower_bound"),
              _field(INFINITESIMAL, "interlocked", "moved_set_count"))
    if low is not None and k is not None and low > k:
        yield Contradiction("interlock-hands", fields, f"at least {low} moved sets are needed, "
                            f"yet the motion found moves {k}")
    if hands is not None and ((low is not None and hands < low) or (k is not None and hands > k)):
        yield Contradiction("interlock-hands", fields + (_field(INFINITESIMAL, "interlocked",
                                                                "hands"),),
                            f"{hands} hands, outside [{low}, {k}]")
    if lock.get("hands_exact") and hands is None:
        yield Contradiction("interlock-hands", (_field(INFINITESIMAL, "interlocked",
                                                       "hands_exact"),),
                            "the hands are exact but have no value")


#: Every rule, in the order :func:`contradictions` applies them: name -> function of a report.
RULES: dict[str, Callable[[dict], Iterator[Contradiction]]] = {
    "plan-vs-interlocked": plan_vs_interlocked,
    "plan-vs-monotone": plan_vs_monotone,
    "infinite-split-is-infinitesimal": infinite_split_is_infinitesimal,
    "prismatic-tree": prismatic_tree,
    "depth-vs-plan": depth_vs_plan,
    "linear-plan": linear_plan,
    "plan-shape": plan_shape,
    "proof-of-none": proof_of_none,
    "infinite-monotone-has-plan": infinite_monotone_has_plan,
    "class-implications": class_implications,
    "linear-vs-nonlinear": linear_vs_nonlinear,
    "minimum-bounds": minimum_bounds,
    "stack-vs-directions": stack_vs_directions,
    "containment": containment,
    "interlocked-vs-splits": interlocked_vs_splits,
    "interlock-hands": interlock_hands,
}


def contradictions(report: dict) -> list[Contradiction]:
    """The contradictions between the answers of one finished report.

    Parameters
    ----------
    report : dict
        A report (:func:`ndbg_cli.pipeline.analysis.analyze`, or one read from JSON). An
        error record, or a batch, has no answers of its own: ``[]``.

    Returns
    -------
    list of Contradiction
        What does not hold, in the order of :data:`RULES` (empty when the answers agree).

    Examples
    --------
    >>> rep = {"plan": {"found": True, "family": "infinite_translation",
    ...                 "verified": {"value": True}},
    ...        "classes": {"infinitesimal_translation": {"interlocked": {"value": True}}}}
    >>> [c.rule for c in contradictions(rep)]
    ['plan-vs-interlocked']
    """
    if "error" in report or "classes" not in report:
        return []
    return [c for rule in RULES.values() for c in rule(report)]


def warnings(found: list[Contradiction], file: str | None = None) -> list[dict]:
    """The report's ``warnings`` entries for ``found`` (code :data:`CODE`, the rule and the
    fields kept as ``rule`` and ``fields``).

    Parameters
    ----------
    found : list of Contradiction
        What :func:`contradictions` returned.
    file : str, optional
        The assembly's source file.

    Returns
    -------
    list of dict
        Diagnostic records (``level``, ``code``, ``message``, ``part``, ``file``, ``rule``,
        ``fields``).
    """
    return [{"level": "warning", "code": CODE, "message": "the report contradicts itself: "
             + c.message, "part": None, "file": file, "rule": c.rule, "fields": list(c.fields)}
            for c in found]
