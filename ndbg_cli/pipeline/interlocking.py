"""Interlocking and the candidate families' "no" against what the plan proves.

:func:`interlock_and_grasp` runs the interlocking LP (:mod:`ndbg_cli.planning.interlock`) on the
contacts and the grasps on the NDBGs. Both the LP and the contact-based NDBGs read an edge or
point contact as more than it blocks: the LP every normal of its cone (or, where no cone forms,
of the faces meeting there), the NDBGs the latter pair by pair, "blocking on any"
(:func:`ndbg_cli.contacts.features.edge_point_contacts`). So with such contacts the LP's
"interlocked" is a necessary condition only, and a candidate family's "no candidate tree" is
not a proof. :func:`apply_witnesses`, after the plan, replaces what a proven plan refutes (or,
for interlocking, a split removable by one translation): a proven plan is a 1-handed monotone
algorithm of single translations, its first removal step a motion that frees something.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..core.assembly import Assembly
from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL, TRANSLATION
from ..ndbg.model import NDBG

__all__ = ["apply_witnesses", "conservative_contacts", "interlock_and_grasp",
           "interlock_and_grasp_later"]


def conservative_contacts(analysis: Any) -> tuple[int, int]:
    """``(lp, ndbg)``: the edge and point contacts of a contact analysis (the LP reads each as
    every normal of its cone), and those of them read pair by pair, "blocking on any" (the
    NDBGs read those as every face meeting there: more than they block)."""
    found = [c for c in getattr(analysis, "contacts", ()) if getattr(c, "kind", None)
             in ("edge", "point")]
    return len(found), sum(1 for c in found if getattr(c, "blocking", "any") == "any")


def interlock_and_grasp(asm: Assembly, ca: Any, ndbgs: dict[str, NDBG],
                        faces: list | None = None) -> tuple[dict | None, dict]:
    """Infinitesimal interlocking (LP over part velocities, any number of hands) and the
    prismatic form-closure grasps of the translational families.

    Parameters
    ----------
    asm : Assembly
        The assembly (clashing parts already made units).
    ca : ContactAnalysis
        Its contacts.
    ndbgs : dict
        Family name -> NDBG, the usable ones.
    faces : list, optional
        The finger placements (:func:`~ndbg_cli.planning.fingers.exterior_faces` of ``asm``)
        when already computed.

    Returns
    -------
    tuple
        The LP's result (with ``exact`` false when edge or point contacts make its yes a
        necessary condition only; None without a translational family) and the grasps per
        family.
    """
    from ..planning.fingers import exterior_faces
    from ..planning.grasp import grasp
    from ..planning.interlock import interlock

    dim = asm.dimension
    normals: dict[tuple[int, int], list[np.ndarray]] = {}
    for c in ca.contacts:
        normals.setdefault((c.a, c.b), []).append(np.asarray(c.normals, float).reshape(-1, dim))
    # a declared thread (the translational NDBGs block its pair both ways) holds its pair
    # together: every axis both ways, i.e. equal velocities
    threads = _threads_of(asm, ndbgs)
    for a, b in threads:
        normals.setdefault((a, b), []).append(np.vstack([np.eye(dim), -np.eye(dim)]))
    pair_normals = {k: np.concatenate(v) for k, v in sorted(normals.items())}
    fixed = asm.index(asm.base) if asm.base is not None else 0
    lock = None
    if INFINITESIMAL in ndbgs or INFINITE in ndbgs:
        lock = interlock(len(asm), pair_normals, fixed, dim=dim, ids=asm.ids)
        lock.pop("velocities", None)
        if threads:
            lock["why"] += " (declared threads hold " + ", ".join(
                f"{asm.ids[a]} and {asm.ids[b]}" for a, b in threads) + " together)"
        edge_point = conservative_contacts(ca)[0]
        if edge_point:  # ``exact`` false: its yes is a necessary condition only
            lock["exact"] = False
            lock["why"] += (f" ({edge_point} edge/point contacts read as every normal of their "
                            "cone: conservative, may call a product interlocked that is not)")
    if faces is None:
        faces = exterior_faces(asm)
    grasps = {fam: grasp(ndbgs[fam], faces) for fam in TRANSLATION
              if fam in ndbgs}
    return lock, grasps


def interlock_and_grasp_later(asm: Assembly, get: Callable[[], tuple[Any, dict[str, NDBG]]]
                              ) -> tuple[dict | None, dict]:
    """:func:`interlock_and_grasp` with the contacts and the NDBGs given later (``get()``
    returns ``(analysis, ndbgs)``): the finger placements, which need the parts alone, are
    found first (a :class:`~ndbg_cli.core.pools.Forked` job started before the contacts of
    clash units and the NDBGs are found)."""
    from ..planning.fingers import exterior_faces

    faces = exterior_faces(asm)
    ca, ndbgs = get()
    return interlock_and_grasp(asm, ca, ndbgs, faces)


def _threads_of(asm: Assembly, ndbgs: dict[str, NDBG]) -> list[tuple[int, int]]:
    """The threaded pairs (part indices) the translational NDBGs block both ways
    (:func:`~ndbg_cli.ndbg.generalized.build.block_threads` records them)."""
    nd = ndbgs.get(INFINITESIMAL) or ndbgs.get(INFINITE)
    pairs = (nd.stats.get("threaded_pairs") or []) if nd is not None else []
    return sorted((asm.index(a), asm.index(b)) for a, b in pairs
                  if a in asm.ids and b in asm.ids)


def apply_witnesses(out: dict, ids: Sequence[str], analysis: Any,
                    base: str | None = None) -> None:
    """After the plan, in the report sections ``out`` (:func:`~.stages.run_stages`'s): the
    infinitesimal section says how many contacts its NDBG reads conservatively
    (``conservative_contacts``), and the classes a witness refutes are replaced.

    * ``interlocked: yes`` against a proven plan (its first removal step) or a split removable
      by one translation: ``no``, with that ``witness`` (one moved set);
    * a candidate family (infinitesimal, generalized) with no candidate tree against a proven
      plan (every proven tree is a candidate tree): 1-handed monotone, with the plan's trees as
      the bounds they give; its other "no" answers rested on the same blocking: undecided.

    Parameters
    ----------
    out : dict
        The report's sections (``classes``, ``plan``, ``partitionings``, ``ndbg``); changed.
    ids : sequence of str
        The part ids in NDBG order (the interlocking LP's part indices).
    analysis : ContactAnalysis
        The contacts.
    base : str, optional
        The base part (a direction of a tree is that of its side without the base).
    """
    lp, nd = conservative_contacts(analysis)
    sec = (out.get("ndbg") or {}).get(INFINITESIMAL)
    if nd and isinstance(sec, dict) and not sec.get("skipped"):
        sec["conservative_contacts"] = nd
    plan = out.get("plan") or {}
    proven = bool(plan.get("found")) and plan.get("family") in TRANSLATION \
        and (plan.get("verified") or {}).get("value") is True
    classes = dict(out.get("classes") or {})
    lock = (classes.get(INFINITESIMAL) or {}).get("interlocked")
    if lock is not None and lock.get("value") is True:
        w = _plan_witness(plan) if proven else _split_witness(out.get("partitionings") or [])
        if w is not None:
            classes[INFINITESIMAL] = {**classes[INFINITESIMAL],
                                      "interlocked": _not_interlocked(lock, w, ids, lp)}
    real = classes.get(INFINITE) or {}
    for fam in (INFINITESIMAL, GENERALIZED):
        m = classes.get(fam) or {}
        if proven and (m.get("one_handed_monotone") or {}).get("value") is False:
            classes[fam] = _refuted(fam, m, plan, real, nd, base)
    out["classes"] = classes


def _plan_witness(plan: dict) -> dict:
    """The proven plan's first removal step (its tree's root split)."""
    root = plan["tree"]
    return {"moved": list(root["moved"]["parts"]), "rest": list(root["rest"]["parts"]),
            "removal_direction": root.get("removal_direction"),
            "source": "the proven plan's first removal step, by the direct sweep test"}


def _split_witness(partitionings: list[dict]) -> dict | None:
    """The first split removable by one translation (infinite-translation NDBG), or None."""
    p = next((p for p in partitionings if p.get("family") == INFINITE), None)
    if p is None:
        return None
    return {"moved": list(p["moved"]), "rest": list(p["rest"]),
            "removal_direction": (p.get("directions") or [None])[0],
            "source": "a partitioning of the infinite-translation NDBG"}


def _not_interlocked(lock: dict, w: dict, ids: Sequence[str], edge_point: int) -> dict:
    """``lock`` (the LP's yes, with ``edge_point`` edge or point contacts) refuted by the
    witness ``w``: one moved set, the side without the LP's fixed part (the other side moving,
    the direction reversed)."""
    from ..planning.classes import label

    moved, rest, d = w["moved"], w["rest"], w["removal_direction"]
    if ids[lock.get("fixed", 0)] in moved:
        moved, rest = rest, moved
        d = None if d is None else [0.0 - x for x in d]
    index = {pid: k for k, pid in enumerate(ids)}
    moved, rest = sorted(moved, key=index.get), sorted(rest, key=index.get)
    along = "" if d is None else " along (" + ", ".join(f"{x:g}" for x in d) + ")"
    lp = (f"it reads the {edge_point} edge/point contacts as every normal of their cone, "
          "more than they block" if edge_point else "the contacts block, within their "
          "tolerances, what the exact sweep test does not")
    new = {k: v for k, v in lock.items() if k != "separation"}
    new.update(
        value=False, kind="separating", exact=True, moved_set_count=1, hands=1,
        hands_lower_bound=1, hands_exact=True, moved_sets=[[index[p] for p in moved]],
        fixed_set=[index[p] for p in rest], moved_ids=[moved],
        witness={"moved": moved, "rest": rest, "removal_direction": d, "source": w["source"]},
        why=f"not interlocked: {{{', '.join(moved)}}} leaves {{{', '.join(rest)}}} by one "
            f"translation{along} ({w['source']}): one moved set suffices. The interlocking "
            f"LP found no motion: {lp}")
    return label(INFINITESIMAL, "interlocked", new)


def _refuted(fam: str, measures: dict, plan: dict, real: dict, conservative: int,
             base: str | None) -> dict:
    """The classes of a candidate family whose NDBG has no candidate tree, given the proven
    ``plan`` and the infinite translations' classes ``real`` (their trees are candidate trees
    too): what those trees show, the rest undecided."""
    from ..planning.classes import label
    from .proofs import _tree_text, direction_counts

    def least(key: str, found: list[int]) -> int | None:
        v = (real.get(key) or {}).get("value")
        found = found + ([v] if isinstance(v, int) and not isinstance(v, bool) else [])
        return min(found) if found else None

    trees = [plan] + list(plan.get("proofs") or [])
    depth = least("min_depth", [t["depth"] for t in trees if t.get("depth") is not None])
    nonlinear = least("min_nonlinear", [t["nonlinear_steps"] for t in trees
                                        if t.get("nonlinear_steps") is not None])
    n = len(plan["tree"]["parts"])
    low = math.ceil(math.log2(n)) if n > 1 else 0
    best = least("min_directions", direction_counts(plan, base))
    cause = (f"the contacts read {conservative} edge/point contacts on every face meeting "
             "there, more than they block" if conservative else
             "its contacts block, within their tolerances, what the exact sweep test does not")
    why = f"the {fam} NDBG has no candidate tree, but {cause}: undecided"
    new = {
        "one_handed_monotone": {"value": True, "why": (
            f"witness: the proven plan, tree {_tree_text(plan['tree'])} (every proven tree is "
            f"a candidate tree); the {fam} NDBG found none: {cause}")},
        "min_depth": {"value": depth, "exact": depth == low, "lower_bound": low,
                      "upper_bound": depth, "why": f"a tree of single translations of depth "
                      f"{depth}; no tree of {n} parts is shallower than {low}"},
        "min_nonlinear": {"value": nonlinear, "exact": nonlinear == 0, "lower_bound": 0,
                          "upper_bound": nonlinear, "assembly_lines": nonlinear + 1,
                          "why": f"a tree of single translations with {nonlinear} nonlinear "
                                 "step(s)"},
        "min_directions": {"value": best, "exact": best == 1, "lower_bound": 1,
                           "upper_bound": best, "why": f"a tree of single translations along "
                           f"{best} direction(s)"} if best else {"value": None, "exact": False,
                                                                 "why": why},
    }
    if nonlinear == 0:
        new["linearizable"] = {"value": True, "why": "a tree of single translations adds one part "
                                                      "at a time"}
    elif (measures.get("linearizable") or {}).get("value") is False:
        new["linearizable"] = {"value": None, "why": why}
    if fam == INFINITESIMAL:
        new["prismatic"] = {"value": None, "why": "undecided by infinitesimal translations "
                            "(candidates exist); see the infinite_translation classes"}
        new["stack_product"] = ({"value": True, "why": "a tree of single translations moves every "
                                 "side without the base along one direction"} if best == 1
                                else {"value": None, "why": why})
    return {**measures, **{k: label(fam, k, v) for k, v in new.items()}}
