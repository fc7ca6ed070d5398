"""The analysis stages in order: contacts -> blocking graphs -> planning -> measures.

:func:`run_stages` takes a loaded :class:`~ndbg_cli.core.assembly.Assembly` and the options, and
returns the report's analysis sections as plain dicts (JSON-ready after
:func:`ndbg_cli.report.document.clean`). Each stage consumes only the previous stages' results: the
blocking graphs are built once from the contacts (infinitesimal, generalized) or the meshes
(infinite), and planning, classes and measures run on the DBGs alone (induced subgraphs for
subassemblies), never on geometry again.

Families (``--motion``): ``translation`` = infinitesimal translations (paper 4-5.1),
``infinite`` = infinite translations (5.3), ``generalized`` = the paper's hybrid of all
translations plus suggested rotations/screws (5.2, 6), ``all`` = every one.

Which plan is reported: the first family, in the order infinite translation (guaranteed
removable by one translation), infinitesimal translation (candidate), generalized (candidate,
LP-checked), that was computed and admits an assembly tree.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import shapely

from ..core.assembly import Assembly, Diagnostic
from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL
from ..ndbg.model import NDBG, ConnectivityTest

FAMILIES_OF = {
    "all": (INFINITESIMAL, INFINITE, GENERALIZED),
    "translation": (INFINITESIMAL,),
    "infinite": (INFINITE,),
    "generalized": (GENERALIZED,),
}
#: Order in which families are tried for the reported plan (most guaranteed first).
PLAN_ORDER = (INFINITE, INFINITESIMAL, GENERALIZED)


class _Clock:
    def __init__(self, timings: dict[str, float]) -> None:
        self.timings = timings

    def __call__(self, name: str, fn: Callable[[], Any]) -> Any:
        t0 = time.perf_counter()
        out = fn()
        self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        return out


def run_stages(asm: Assembly, options: Any, timings: dict[str, float]) -> tuple[dict, list]:
    """All analysis sections of the report for ``asm`` and the extra warnings
    (:class:`Diagnostic`). ``options`` is an :class:`ndbg_cli.pipeline.analysis.Options`; ``timings``
    receives seconds per stage. Raises :class:`~ndbg_cli.core.errors.InputError` (e.g. an
    interference under ``--interference error``)."""
    from ..core.cache import open_cache

    clock = _Clock(timings)
    families = FAMILIES_OF[options.motion]
    cache = open_cache(getattr(options, "cache", None))
    warnings: list[Diagnostic] = []
    out: dict = {}

    # -- contacts ----------------------------------------------------------------------
    if asm.dimension == 3:
        from ..contacts.contacts3d import analyze_contacts, contacts_section
        from ..contacts.interference import check_interference_policy

        ca = clock("contacts_s", lambda: analyze_contacts(asm, tolerance=options.tolerance,
                                                          cache=cache))
        warnings += check_interference_policy(asm, ca, options.interference)
        sec = contacts_section(asm, ca)
        # wall-clock phases go to the report's timings (kept out unless asked for)
        for k, v in sec["contact_stats"].pop("timings_s", {}).items():
            timings[f"contacts_{k}"] = v
        out.update(contacts=sec["contacts"], interferences=sec["interferences"],
                   contact_stats=sec["contact_stats"])
        touching = ca.pairs()
    else:
        from ..contacts.contacts2d import find_contacts_2d

        ca = clock("contacts_s", lambda: find_contacts_2d(asm, options.tolerance))
        out.update(contacts=contacts_2d_section(asm, ca), interferences=[],
                   contact_stats={"units": asm.units, "tolerance": asm.length_tolerance,
                                  "touching_pairs": [[asm.ids[c.a], asm.ids[c.b]]
                                                     for c in ca.contacts],
                                  "contacts": len(ca.contacts)})
        touching = [(c.a, c.b) for c in ca.contacts]
    neighbours = [0] * len(asm)
    for a, b in touching:
        neighbours[a] |= 1 << b
        neighbours[b] |= 1 << a
    connected = ConnectivityTest(neighbours) if options.connected else None

    # -- blocking graphs ---------------------------------------------------------------
    from ..ndbg.generalized.build import block_threads, threaded_pairs

    threaded = threaded_pairs(asm, options.threads_as_cylinders) if asm.dimension == 3 else set()
    ndbgs: dict[str, NDBG] = {}
    sections: dict[str, dict] = {}
    partitionings: list[dict] = []
    inf = None
    if INFINITESIMAL in families or GENERALIZED in families:
        from ..ndbg.infinitesimal.build import infinitesimal_ndbg

        inf = clock("infinitesimal_s", lambda: infinitesimal_ndbg(asm, ca))
        inf = block_threads(inf, threaded)
    if INFINITESIMAL in families:
        from ..ndbg.infinitesimal.build import candidate_partitionings, infinitesimal_section

        ndbgs[INFINITESIMAL] = inf
        parts, trunc = clock("partitionings_s", lambda: candidate_partitionings(
            inf, max_partitions=options.max_partitions, connected=options.connected,
            contacts=touching))
        sec = infinitesimal_section(asm, inf, parts, trunc, region_limit=options.region_limit)
        partitionings += sec.pop("partitionings")
        sec.pop("assembly", None)
        sections[INFINITESIMAL] = sec
    if INFINITE in families:
        from ..ndbg.infinite.build import TooLarge

        try:
            got = clock("infinite_s", lambda: _infinite(asm, options, threaded, connected,
                                                        cache, ca))
            too_large = None
        except TooLarge as exc:
            got, too_large = None, str(exc)
        if got is None:
            sections[INFINITE] = {"family": INFINITE, "skipped": True,
                                  "why": too_large or _infinite_skip_reason(asm, options)}
            warnings.append(Diagnostic("warning", "infinite-skipped",
                                       "infinite-translation NDBG skipped: "
                                       + sections[INFINITE]["why"], file=asm.source or None))
        else:
            nd, sec, parts = got
            if nd.stats.get("restricted"):
                # right for the whole assembly's partitionings only: no plans or classes
                warnings.append(Diagnostic(
                    "warning", "infinite-restricted",
                    "infinite-translation NDBG restricted to the directions where the "
                    "infinitesimal NDBG frees a subassembly: " + sec["domain"]["why"],
                    file=asm.source or None))
            else:
                ndbgs[INFINITE] = nd
            sections[INFINITE] = sec
            partitionings += parts
    if GENERALIZED in families and asm.dimension == 3:
        gen, sec, parts = clock("generalized_s", lambda: _generalized(asm, ca, inf, options))
        ndbgs[GENERALIZED] = gen
        sections[GENERALIZED] = sec
        partitionings += parts
    elif GENERALIZED in families:
        sections[GENERALIZED] = {"family": GENERALIZED, "skipped": True,
                                 "why": "generalized motions are analysed for 3D assemblies"}
    out["ndbg"] = sections
    if cache is not None:
        # hit counts go with the timings (they differ between a cold and a warm run)
        for stage, st in cache.stats().items():
            timings[f"cache_{stage}_hits"] = st["hits"]
            timings[f"cache_{stage}_misses"] = st["misses"]
    out["partitionings"] = partitionings

    # -- planning and measures ---------------------------------------------------------
    from ..planning.andor import Budget
    from ..planning.classes import andor_section, classes_section
    from ..planning.plans import plan, plan_section

    budget = Budget(max_nodes=options.max_nodes, max_work=options.max_work,
                    time_limit=options.time_limit)
    base = asm.index(asm.base) if asm.base is not None else None
    extra = clock("interlock_s", lambda: _interlock_and_grasp(asm, ca, ndbgs))
    graphs: dict = {}
    out["classes"] = clock("classes_s", lambda: classes_section(
        ndbgs, base=base, budget=budget, interlock=extra[0], grasps=extra[1], graphs=graphs))
    # the AND/OR graphs the classes built: size, and the exact counts when complete
    out["andor"] = {fam: andor_section(g, (out["classes"].get(fam) or {}).get("min_depth"))
                    for fam, g in sorted(graphs.items())}
    if threaded and not options.threads_as_cylinders:
        for fam in (INFINITESIMAL, INFINITE):
            if fam in out["classes"]:
                out["classes"][fam]["threads"] = {
                    "value": sorted([list(p) for p in threaded]),
                    "why": "declared screw joints are threads: these pairs cannot translate "
                           "apart; --threads-as-cylinders treats them as plain cylinders"}
    # The reported plan keeps both sides of every step connected in the contact graph (a
    # designer's subassemblies hold together); when no such tree exists (floating parts), it
    # falls back to any candidate split, reusing the classes' AND/OR graph.
    plan_conn = ConnectivityTest(neighbours)
    chosen = None
    for fam in PLAN_ORDER:
        if fam not in ndbgs:
            continue
        p = clock("plan_s", lambda nd=ndbgs[fam]: plan(
            nd, options.strategy, base=base, connected=plan_conn, budget=budget))
        if not p.found:
            graph = graphs.get(fam)
            q = clock("plan_s", lambda nd=ndbgs[fam], g=graph: plan(
                nd, options.strategy, base=base, connected=None, budget=budget, graph=g))
            if q.found:
                q.notes.append("no tree with connected subassemblies" + (
                    "" if p.exact else " found within the budget")
                    + "; any candidate split used")
                p = q
        if chosen is None or (p.found and not chosen.found):
            chosen = p
        if p.found:
            break
    verified = None
    proofs: list[dict] = []
    if chosen is not None and chosen.found and chosen.ndbg.family in (INFINITESIMAL, INFINITE):
        # the chosen translation plan checked step by step with the direct sweep test
        # (planning.verify): a candidate tree that passes is a real algorithm, which the
        # rules count as proof
        from ..ndbg.infinite.sweep import SweepChecker
        from ..planning.plans import axis_directions, verify

        sweep = SweepChecker(asm)
        verified = clock("verify_s", lambda: verify(chosen, sweep.frees))
        if verified["value"]:
            # a coordinate axis where the sweep test frees a region's steps along it
            clock("verify_s", lambda: axis_directions(chosen, sweep.frees))
        if chosen.ndbg.family == INFINITESIMAL:
            # the candidate trees behind the classes' best measures, checked the same way:
            # each that passes proves its depth, directions and nonlinear steps
            proofs = clock("verify_s", lambda: _proof_trees(
                sweep, chosen, out["classes"].get(INFINITESIMAL) or {}, options.strategy,
                base, budget, graphs.get(INFINITESIMAL)))
    if chosen is not None:
        out["plan"] = {"family": chosen.ndbg.family, **plan_section(chosen)}
        if verified is not None:
            out["plan"]["verified"] = verified
            out["plan"]["proofs"] = proofs
    else:
        out["plan"] = {"family": None, "strategy": options.strategy, "found": False,
                       "exact": True, "depth": None, "tree": None, "sequence": [],
                       "notes": ["no motion family computed"]}
    return out, warnings


#: Strategies whose trees :func:`_proof_trees` checks besides the reported plan's.
PROOF_STRATEGIES = ("fewest-directions", "linear")


def _proof_trees(sweep: Any, chosen: Any, classes: dict, reported: str,
                 base: int | None, budget: Any, graph: Any) -> list[dict]:
    """Trees of the :data:`PROOF_STRATEGIES` that pass the direct sweep test (``sweep``, a
    :class:`~ndbg_cli.ndbg.infinite.sweep.SweepChecker`) at every step (contact-connected or not, as the
    classes count them): ``{"strategy", "depth", "nonlinear_steps", "directions"}`` each. A
    strategy is tried only when its tree could prove more than the reported plan: fewer
    directions, or a linear tree, than it has, when the candidates' minimum (``classes``)
    allows it."""
    from ..planning.plans import plan, verify

    nd = chosen.ndbg
    least = {"fewest-directions": (classes.get("min_directions") or {}).get("value"),
             "linear": 0 if (classes.get("linearizable") or {}).get("value") else None}
    has = {"fewest-directions": chosen.directions(), "linear": chosen.nonlinear()}
    out = []
    for strategy in PROOF_STRATEGIES:
        if strategy == reported or least[strategy] is None or has[strategy] <= least[strategy]:
            continue
        q = plan(nd, strategy, base=base, connected=None, budget=budget, graph=graph)
        if not q.found or not verify(q, sweep.frees)["value"]:
            continue
        out.append({"strategy": strategy, "depth": q.depth(), "nonlinear_steps": q.nonlinear(),
                    "directions": q.directions()})
    return out


def contacts_2d_section(asm: Assembly, found) -> list[dict]:
    """2D contacts for the report: pair, kinds, normals out of ``a`` and contact points."""
    return [{"a": asm.ids[c.a], "b": asm.ids[c.b],
             "kind": "edge" if "edge-edge" in c.kinds else "point",
             "blocking": "any", "normals": np.asarray(c.normals).tolist(),
             "points": np.asarray(c.points).tolist(), "length": float(c.length)}
            for c in found.contacts]


def _over_budget(asm: Assembly, options: Any) -> str:
    from ..ndbg.infinite.blocked_sets import triangle_pairs

    return (f"{triangle_pairs(asm)} facing triangle pairs exceed the budget of "
            f"{options.infinite_budget}")


def _infinite_skip_reason(asm: Assembly, options: Any) -> str:
    if options.motion == "infinite":  # the restriction was tried: it is every direction
        return (f"{_over_budget(asm, options)}, and the infinitesimal NDBG frees some "
                "subassembly in every direction (for one, when parts or groups of parts touch "
                "nothing else), so it cannot be restricted (raise --infinite-budget to "
                "compute it on the whole sphere)")
    return (f"{_over_budget(asm, options)} (raise it with --infinite-budget; --motion "
            "infinite computes it where the infinitesimal NDBG frees something)")


def _infinite(asm: Assembly, options: Any, threaded: set, connected, cache=None, ca=None
              ) -> tuple[NDBG, dict, list[dict]] | None:
    """The infinite-translation NDBG, its section and partitionings. Above the budget (3D)
    it is skipped (``None``), unless ``--motion infinite`` asks for it: then it is computed
    only where the infinitesimal NDBG frees some subassembly (:mod:`ndbg_cli.ndbg.infinite.domain`), which
    gives the same partitionings of the whole assembly and nothing else (``None`` again when
    that is every direction)."""
    from ..core.constants import ANGLE_TOL_RAD
    from ..ndbg.generalized.build import block_threads
    from ..ndbg.infinite.blocked_sets import triangle_pairs
    from ..ndbg.infinite.build import build_infinite
    from ..ndbg.infinite.domain import free_domain
    from ..ndbg.infinitesimal.build import contact_pairs
    from ..ndbg.model import partitionings
    from ..report.infinite import infinite_section

    domain = None
    if asm.dimension == 3 and triangle_pairs(asm) > options.infinite_budget:
        if options.motion != "infinite":  # asked for explicitly only: it takes minutes
            return None
        domain = free_domain(len(asm.parts), contact_pairs(asm, ca),
                             float(getattr(ca, "angle_tolerance", ANGLE_TOL_RAD)))
        if domain is None:
            return None
    nd = block_threads(build_infinite(asm, cache, domain, workers=options.workers,
                                           progress=options.progress), threaded)
    parts, trunc = partitionings(nd, limit=options.max_partitions, connected=connected)
    sec = infinite_section(asm, nd, parts, trunc)
    if domain is not None:
        sec["domain"] = {
            "restricted": True, "area": nd.stats.get("domain_area"),
            "why": f"{_over_budget(asm, options)}; the regions are those inside "
                   "the domain (cut by its boundary), the whole assembly's partitionings "
                   "are all of them, and the family is not used for plans or classes"}
    if options.region_limit is not None and len(sec["region_list"]) > options.region_limit:
        sec["region_list"] = sec["region_list"][:options.region_limit]
        sec["region_list_truncated"] = True
    parts_out = sec.pop("partitionings")
    return nd, sec, parts_out


def _generalized(asm: Assembly, ca, inf: NDBG, options: Any) -> tuple[NDBG, dict, list[dict]]:
    from ..ndbg.generalized.build import (
        generalized_ndbg,
        generalized_section,
        hybrid,
        motion_dbg,
        threads,
    )
    from ..ndbg.generalized.twist import contact_rows
    from ..ndbg.model import Region

    rows = contact_rows(asm, ca.contacts)
    suggested = generalized_ndbg(asm, ca.contacts, rows=rows,
                                 threads_as_cylinders=options.threads_as_cylinders)
    sec = generalized_section(asm, suggested, rows,
                              threads_as_cylinders=options.threads_as_cylinders)
    # Motions the exact LP found for subassemblies that need a rotation (paper Fig. 5) join
    # the suggested ones, so the generalized classes see them (a candidate-level verdict).
    found = []
    thr = threads(asm, options.threads_as_cylinders)
    for e in sec["needs_rotation"]:
        rec = dict(e["motion"], sense=1, source="lp: frees " + ", ".join(e["parts"]))
        found.append(Region(-1, None, motion_dbg(rows, np.asarray(rec["twist"]), thr),
                            motion=rec))
    if found:
        suggested = dataclasses.replace(suggested, regions=suggested.regions + tuple(found))
    gen = hybrid(inf, suggested)
    sec["family"] = GENERALIZED
    sec["regions"] = {"translational": len(inf.regions), "suggested": len(suggested.regions)}
    parts = [{"moved": c["moved"], "rest": c["rest"], "family": GENERALIZED,
              "motion": c["motion"]} for c in sec["candidates"]]
    return gen, sec, parts


def _interlock_and_grasp(asm: Assembly, ca, ndbgs: dict[str, NDBG]) -> tuple[dict | None, dict]:
    """Infinitesimal interlocking (LP over part velocities, any number of hands) and the
    prismatic form-closure grasps of the translational families."""
    from ..planning.grasp import grasp
    from ..planning.interlock import interlock

    dim = asm.dimension
    normals: dict[tuple[int, int], list[np.ndarray]] = {}
    for c in ca.contacts:
        normals.setdefault((c.a, c.b), []).append(np.asarray(c.normals, float).reshape(-1, dim))
    pair_normals = {k: np.concatenate(v) for k, v in sorted(normals.items())}
    fixed = asm.index(asm.base) if asm.base is not None else 0
    lock = None
    if INFINITESIMAL in ndbgs or INFINITE in ndbgs:
        lock = interlock(len(asm), pair_normals, fixed, dim=dim, ids=asm.ids)
        lock.pop("velocities", None)
        edge_point = sum(1 for c in ca.contacts if getattr(c, "blocking", "any") == "all")
        if edge_point:
            lock["why"] += (f" ({edge_point} edge/point contacts read as every normal of their "
                            "cone: conservative, may call a product interlocked that is not)")
    grasps = {}
    faces = exterior_faces(asm)
    for fam in (INFINITESIMAL, INFINITE):
        if fam in ndbgs:
            grasps[fam] = grasp(ndbgs[fam], faces)
    return lock, grasps


def exterior_faces(asm: Assembly, digits: int = 6) -> list[tuple[int, list[float], list[float]]]:
    """Candidate finger placements for the form-closure grasp: for every part, each distinct
    outward face normal (3D: triangle normals rounded to ``digits``; 2D: edge normals) with a
    point on a face of that orientation that no other part covers: the centroid of the
    largest such triangle (2D: the midpoint of the longest such edge) whose point just
    outside, ``2 eps`` along the normal, is not next to another part (:func:`_covered`; at
    most :data:`FINGER_TRIES` faces tried per orientation, and none kept if all are covered:
    a finger cannot touch a face another part lies on; a part that interpenetrates the face
    deeply is not seen, interferences are reported apart)."""
    gap = 2.0 * asm.length_tolerance
    # (part, normal key, point, outward unit normal), each orientation's faces largest first
    groups: list[list[tuple[int, list[float], list[float], np.ndarray]]] = []
    for k, part in enumerate(asm.parts):
        if asm.dimension == 2:
            poly = part.polygon
            xy = np.asarray(poly.exterior.coords)[:-1]
            ccw = poly.exterior.is_ccw
            edges: dict[tuple[float, ...], list[tuple[float, list[float]]]] = {}
            for a, b in zip(xy, np.roll(xy, -1, axis=0)):
                e = b - a
                nrm = np.array([e[1], -e[0]]) if ccw else np.array([-e[1], e[0]])
                length = np.linalg.norm(nrm)
                if length > 0:
                    key = tuple(np.round(nrm / length, digits).tolist())
                    edges.setdefault(key, []).append((float(length), ((a + b) / 2).tolist()))
            for key, cands in edges.items():
                groups.append([(k, list(key), mid, np.asarray(key)) for _, mid in
                               sorted(cands, key=lambda c: -c[0])[:FINGER_TRIES]])
            continue
        mesh = part.mesh
        unit = np.asarray(mesh.face_normals)
        areas = np.asarray(mesh.area_faces)
        centers = np.asarray(mesh.triangles_center)
        keys, inverse = np.unique(np.round(unit, digits), axis=0, return_inverse=True)
        inverse = inverse.reshape(-1)
        # each orientation's faces, largest first (ties: lower index first)
        order = np.lexsort((np.arange(len(areas)), -areas, inverse)).tolist()
        ends = np.cumsum(np.bincount(inverse, minlength=len(keys))).tolist()
        key_list, center_list = keys.tolist(), centers.tolist()
        for q, (lo, hi) in enumerate(zip([0] + ends[:-1], ends)):
            groups.append([(k, key_list[q], center_list[f], unit[f])
                           for f in order[lo:min(hi, lo + FINGER_TRIES)]])
    # round r tries the r-th face of every orientation still without an exposed one
    chosen: list[tuple | None] = [None] * len(groups)
    todo = list(range(len(groups)))
    for r in range(FINGER_TRIES):
        todo = [g for g in todo if chosen[g] is None and r < len(groups[g])]
        if not todo:
            break
        cands = [groups[g][r] for g in todo]
        owner = np.array([c[0] for c in cands])
        probe = np.array([np.asarray(c[2]) + gap * c[3] for c in cands])
        for g, c, cov in zip(todo, cands, _covered(asm, owner, probe, gap)):
            if not cov:
                chosen[g] = c[:3]
    return [c for c in chosen if c is not None]


#: Faces of one orientation tried per part by :func:`exterior_faces` (largest first).
FINGER_TRIES = 8


def _covered(asm: Assembly, owner: np.ndarray, q: np.ndarray, gap: float) -> np.ndarray:
    """``(m,)`` whether each point ``q[i]`` (``gap`` outside a face of part ``owner[i]``) is
    within ``1.5 gap`` of another part's surface: a part resting on that face has its surface
    there (within the tolerance), so the point is inside it at about ``gap`` from it. A ball
    of radius ``1.5 gap`` is tested against each part whose box holds the point (2D: shapely
    distances)."""
    out = np.zeros(len(q), dtype=bool)
    reach = 1.5 * gap
    if asm.dimension == 3:
        import fcl

        from ..contacts.facets import fcl_object

        ball = fcl.CollisionObject(fcl.Sphere(reach), fcl.Transform())
    for j, other in enumerate(asm.parts):
        if asm.dimension == 2:
            near = owner != j
            if near.any():
                pts = shapely.points(q[near])
                out[near] |= shapely.distance(other.polygon, pts) <= reach
            continue
        lo, hi = other.mesh.bounds
        near = np.flatnonzero((owner != j) & ~out
                              & np.all((q >= lo - reach) & (q <= hi + reach), axis=1))
        if len(near):
            # a ball of radius ``reach`` against the part's cached BVH (python-fcl)
            obj = fcl_object(other)
            for i in near:
                ball.setTranslation(q[i])
                if fcl.collide(ball, obj, fcl.CollisionRequest(), fcl.CollisionResult()):
                    out[i] = True
    return out
