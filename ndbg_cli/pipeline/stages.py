"""The analysis stages in order: contacts -> blocking graphs -> planning -> measures.

:func:`run_stages` returns the report's analysis sections as plain dicts. Each stage consumes
only the previous stages' results: the blocking graphs are built once from the contacts
(infinitesimal, generalized) or the meshes (infinite), and planning, classes and measures run
on the DBGs alone (induced subgraphs for subassemblies), never on geometry again. Families
(``--motion``): ``translation`` = infinitesimal translations (paper 4-5.1), ``infinite`` =
infinite translations (5.3), ``generalized`` = the paper's hybrid of all translations plus
suggested rotations/screws (5.2, 6), ``all`` = every one.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

from ..core.assembly import Assembly, Diagnostic
from ..core.constants import GENERALIZED, INFINITE, INFINITESIMAL, TRANSLATION
from ..core.options import Options
from ..ndbg.model import NDBG, ConnectivityTest
from .families import declared_threads, generalized, infinite, infinite_skip_reason

FAMILIES_OF = {
    "all": (INFINITESIMAL, INFINITE, GENERALIZED),
    "translation": (INFINITESIMAL,),
    "infinite": (INFINITE,),
    "generalized": (GENERALIZED,),
}
#: Order in which families are tried for the reported plan (most guaranteed first): the first
#: one computed that admits an assembly tree is reported; infinite translation (guaranteed
#: removable by one translation), infinitesimal translation (candidate), generalized
#: (candidate, LP-checked).
PLAN_ORDER = (INFINITE, INFINITESIMAL, GENERALIZED)


__all__ = ["Contacts", "Family", "Measures", "find_contacts", "build_ndbg", "measure",
           "plan_assembly", "run_stages"]


class Clock:
    """Adds each stage's wall-clock seconds to ``timings`` under its name."""

    def __init__(self, timings: dict[str, float] | None = None) -> None:
        self.timings = {} if timings is None else timings

    def __call__(self, name: str, fn: Callable[[], Any]) -> Any:
        t0 = time.perf_counter()
        out = fn()
        self.timings[name] = self.timings.get(name, 0.0) + time.perf_counter() - t0
        return out


@dataclass
class Contacts:
    """What :func:`find_contacts` found: the contact analysis, the contact graph and the
    report's sections (``contacts``, ``interferences``, ``contact_stats``), made when first
    asked for (the contacts of parts that clash are replaced by their unit's)."""

    analysis: Any  #: contacts.contacts3d.ContactAnalysis (3D) or contacts2d's contacts (2D)
    touching: list[tuple[int, int]]  #: pairs of parts in contact
    neighbours: list[int]  #: the contact graph, one bitmask of neighbours per part
    make_sections: Callable[[], dict] = field(repr=False)
    warnings: list[Diagnostic] = field(default_factory=list)

    @cached_property
    def sections(self) -> dict:
        """The report's contact sections."""
        return self.make_sections()


@dataclass
class Family:
    """One motion family's NDBG (:func:`build_ndbg`) with its report section and
    partitionings. ``ndbg`` is None when the family was skipped, and ``usable`` False when it
    was restricted to part of the sphere (right for the whole assembly's partitionings, not
    for plans or classes)."""

    name: str
    ndbg: NDBG | None
    section: dict
    partitionings: list[dict] = field(default_factory=list)
    warnings: list[Diagnostic] = field(default_factory=list)
    usable: bool = True


@dataclass
class Measures:
    """The classes and measures of paper section 7 (:func:`measure`) and the AND/OR graphs
    the classes built (reused by the planner)."""

    classes: dict
    andor: dict
    graphs: dict
    #: the interlock LP and the grasps still being computed beside (``measure(defer=True)``):
    #: ``(Forked job, NDBGs)``, added to ``classes`` by :meth:`finish`
    pending: Any = None

    def finish(self, timings: dict[str, float] | None = None) -> Measures:
        """Add the interlock section and the grasps computed beside (no-op without)."""
        if self.pending is not None:
            from ..planning.classes import with_interlock_and_grasps

            job, ndbgs = self.pending
            self.pending = None
            lock, grasps = job.result()
            if timings is not None:
                timings["interlock_s"] = timings.get("interlock_s", 0.0) + job.seconds
            self.classes = with_interlock_and_grasps(self.classes, list(ndbgs.values()),
                                                     lock, grasps)
        return self


def find_contacts(asm: Assembly, options: Options = Options(), *, cache: Any = None,
                  timings: dict[str, float] | None = None, units_later: bool = False
                  ) -> Contacts:
    """The contacts of ``asm`` (paper section 4.3), the contact graph and their report
    sections; the ``--interference`` policy applied (its warnings, or an
    :class:`~ndbg_cli.core.errors.InputError` under ``error``).

    Parameters
    ----------
    asm : Assembly
        A loaded assembly (:func:`ndbg_cli.load`).
    options : Options
        What to compute (:class:`~ndbg_cli.core.options.Options`; the CLI's defaults).
    cache : PairCache, optional
        The per-part-pair result cache (:func:`ndbg_cli.core.cache.open_cache`), or None.
    timings : dict, optional
        Receives the wall-clock seconds of each stage.
    units_later : bool
        The caller makes each group of clashing parts one unit and finds the units' contacts
        again (:func:`run_stages`): the contacts of clashing parts are not sought here
        (``analyze_contacts``'s ``units_later``).

    Returns
    -------
    Contacts
        The contact analysis, the contact graph and the report's contact sections.

    Examples
    --------
    >>> import ndbg_cli
    >>> from ndbg_cli.pipeline.stages import find_contacts
    >>> found = find_contacts(ndbg_cli.load("assemblies/hover.yaml"))
    >>> sorted(found.sections["contact_stats"]["touching_pairs"])  # both rest on the base
    [['base', 'bridge'], ['base', 'puck']]
    """
    clock = Clock(timings)
    warnings: list[Diagnostic] = []
    if asm.dimension == 3:
        from ..contacts.contacts3d import analyze_contacts
        from ..contacts.interference import check_interference_policy
        from ..report.contacts import contacts_section

        ca = clock("contacts_s", lambda: analyze_contacts(
            asm, tolerance=options.tolerance, cache=cache, workers=options.workers,
            meanwhile=load_kernels if options.workers > 1 and _kernels_cold() else None,
            mapper=options.mapper, units_later=units_later))
        warnings += check_interference_policy(asm, ca, options.interference)
        # wall-clock phases go to the report's timings (kept out unless asked for)
        for k in ("bvh_s", "broad_s", "narrow_s", "interference_s"):
            clock.timings[f"contacts_{k}"] = float(ca.stats.get(k, 0.0))

        def sections() -> dict:
            sec = contacts_section(asm, ca, points=options.contact_points)
            sec["contact_stats"].pop("timings_s", None)
            return sec
        touching = ca.pairs()
    else:
        from ..contacts.contacts2d import find_contacts_2d
        from ..report.contacts import contacts_2d_section

        ca = clock("contacts_s", lambda: find_contacts_2d(asm, options.tolerance))
        made = dict(contacts=contacts_2d_section(asm, ca), interferences=[],
                    contact_stats={"units": asm.units, "tolerance": asm.length_tolerance,
                                   "touching_pairs": [[asm.ids[c.a], asm.ids[c.b]]
                                                      for c in ca.contacts],
                                   "contacts": len(ca.contacts)})

        def sections() -> dict:
            return made
        touching = [(c.a, c.b) for c in ca.contacts]
    neighbours = [0] * len(asm)
    for a, b in touching:
        neighbours[a] |= 1 << b
        neighbours[b] |= 1 << a
    return Contacts(ca, touching, neighbours, sections, warnings)


def build_ndbg(asm: Assembly, family: str, contacts: Contacts, options: Options = Options(),
               *, cache: Any = None, infinitesimal: NDBG | None = None,
               timings: dict[str, float] | None = None) -> Family:
    """The NDBG of one motion family (:data:`~ndbg_cli.core.constants.FAMILIES`) with its
    report section and partitionings. ``infinitesimal``: that family's NDBG when already
    built (the generalized family extends it; built here when not given).

    Parameters
    ----------
    asm : Assembly
        A loaded assembly (:func:`ndbg_cli.load`).
    family : str
        One of :data:`~ndbg_cli.core.constants.FAMILIES`.
    contacts : Contacts
        What :func:`find_contacts` found.
    options : Options
        What to compute (:class:`~ndbg_cli.core.options.Options`; the CLI's defaults).
    cache : PairCache, optional
        The per-part-pair result cache (:func:`ndbg_cli.core.cache.open_cache`), or None.
    infinitesimal : NDBG, optional
        The infinitesimal NDBG when already built (the generalized family extends it).
    timings : dict, optional
        Receives the wall-clock seconds of each stage.

    Returns
    -------
    Family
        The NDBG (None when skipped), its report section and partitionings, and
        whether plans and classes may use it.

    Examples
    --------
    >>> import ndbg_cli
    >>> from ndbg_cli.core.constants import INFINITESIMAL
    >>> from ndbg_cli.pipeline.stages import build_ndbg, find_contacts
    >>> asm = ndbg_cli.load("assemblies/hover.yaml")
    >>> fam = build_ndbg(asm, INFINITESIMAL, find_contacts(asm))
    >>> len(fam.partitionings)  # puck and bridge touch only the base: every split is free
    6
    """
    clock = Clock(timings)
    threaded = declared_threads(asm, options)
    if family in (INFINITESIMAL, GENERALIZED) and infinitesimal is None:
        infinitesimal = _infinitesimal_ndbg(asm, contacts, options, timings)
    if family == INFINITESIMAL:
        return _infinitesimal_family(asm, infinitesimal, contacts, options, clock)
    if family == INFINITE:
        return _infinite_family(asm, contacts, options, threaded, cache, clock)
    if family == GENERALIZED and asm.dimension == 3:
        gen, sec, parts = clock("generalized_s", lambda: generalized(
            asm, contacts.analysis, infinitesimal, options))
        return Family(GENERALIZED, gen, sec, parts)
    if family == GENERALIZED:
        return Family(GENERALIZED, None, {"family": GENERALIZED, "skipped": True,
                                          "why": "generalized motions are analysed for 3D "
                                                 "assemblies"}, usable=False)
    raise ValueError(f"unknown motion family {family!r}")


def _infinitesimal_ndbg(asm: Assembly, contacts: Contacts, options: Options,
                        timings: dict[str, float] | None) -> NDBG:
    """The NDBG of infinitesimal translations (paper section 4.2) of the contacts, with the
    declared threads blocking their pairs both ways
    (:func:`~ndbg_cli.ndbg.generalized.build.block_threads`): what :func:`build_ndbg`
    reports for that family, and extends for the generalized one."""
    from ..ndbg.generalized.build import block_threads
    from ..ndbg.infinitesimal.build import infinitesimal_ndbg as build

    nd = Clock(timings)("infinitesimal_s", lambda: build(asm, contacts.analysis))
    return block_threads(nd, declared_threads(asm, options))


def _infinitesimal_family(asm: Assembly, inf: NDBG, contacts: Contacts, options: Options,
                          clock: Clock) -> Family:
    from ..ndbg.infinitesimal.build import candidate_partitionings
    from ..report.infinitesimal import infinitesimal_section

    parts, trunc = clock("partitionings_s", lambda: candidate_partitionings(
        inf, max_partitions=options.max_partitions, connected=options.connected,
        contacts=contacts.touching))
    sec = infinitesimal_section(asm, inf, parts, trunc, region_limit=options.region_limit)
    listed = sec.pop("partitionings")
    sec.pop("assembly", None)
    return Family(INFINITESIMAL, inf, sec, listed)


def _infinite_family(asm: Assembly, contacts: Contacts, options: Options, threaded: set,
                     cache: Any, clock: Clock) -> Family:
    from ..ndbg.infinite.build import TooLarge

    connected = ConnectivityTest(contacts.neighbours) if options.connected else None
    try:
        got = clock("infinite_s", lambda: infinite(asm, options, threaded, connected,
                                                    cache, contacts.analysis))
        too_large = None
    except TooLarge as exc:
        got, too_large = None, str(exc)
    if got is None:
        sec = {"family": INFINITE, "skipped": True,
               "why": too_large or infinite_skip_reason(asm, options)}
        warn = Diagnostic("warning", "infinite-skipped",
                          "infinite-translation NDBG skipped: " + sec["why"],
                          file=asm.source or None)
        return Family(INFINITE, None, sec, [], [warn], usable=False)
    nd, sec, parts = got
    if not nd.stats.get("restricted"):
        return Family(INFINITE, nd, sec, parts)
    # right for the whole assembly's partitionings only: no plans or classes
    warn = Diagnostic("warning", "infinite-restricted",
                      "infinite-translation NDBG restricted to the directions where the "
                      "infinitesimal NDBG frees a subassembly: " + sec["domain"]["why"],
                      file=asm.source or None)
    return Family(INFINITE, nd, sec, parts, [warn], usable=False)


def measure(asm: Assembly, contacts: Contacts, ndbgs: dict[str, NDBG],
            options: Options = Options(), *, timings: dict[str, float] | None = None,
            defer: bool = False, side: Any = None) -> Measures:
    """The classes and measures of paper section 7 on the usable NDBGs ``ndbgs`` (family ->
    NDBG): interlocking, grasps, monotonicity, linearity, depth, and the AND/OR graphs.

    Parameters
    ----------
    asm : Assembly
        A loaded assembly (:func:`ndbg_cli.load`).
    contacts : Contacts
        What :func:`find_contacts` found.
    ndbgs : dict
        Family name -> NDBG, the usable ones (:attr:`Family.usable`).
    options : Options
        What to compute (:class:`~ndbg_cli.core.options.Options`; the CLI's defaults).
    timings : dict, optional
        Receives the wall-clock seconds of each stage.
    defer : bool
        With ``options.workers`` above 1, the interlock LP and the grasps are computed in a
        forked process (:class:`~ndbg_cli.core.pools.Forked`) while the caller goes on (the
        planner needs neither): :meth:`Measures.finish` adds them. Same classes.
    side : Forked, optional
        That computation already started (:func:`interlock_job`) and given the contact
        analysis and the translational NDBGs of ``ndbgs``.

    Returns
    -------
    Measures
        The classes section, the AND/OR graph section and the graphs built.

    Examples
    --------
    >>> import ndbg_cli
    >>> from ndbg_cli.core.constants import INFINITESIMAL
    >>> asm = ndbg_cli.load("assemblies/hover.yaml")
    >>> contacts = find_contacts(asm)
    >>> ndbgs = {INFINITESIMAL: build_ndbg(asm, INFINITESIMAL, contacts).ndbg}
    >>> measure(asm, contacts, ndbgs).classes[INFINITESIMAL]["min_depth"]["value"]
    2
    """
    from ..planning.classes import classes_section
    from ..report.classes import andor_section

    clock = Clock(timings)
    budget = _budget(options)
    base = asm.index(asm.base) if asm.base is not None else None
    if side is None:
        side = interlock_job(asm, options, defer=defer)
        side.send((contacts.analysis, _translational(ndbgs)))
    graphs: dict = {}
    classes = clock("classes_s", lambda: classes_section(
        ndbgs, base=base, budget=budget, graphs=graphs))
    # the AND/OR graphs the classes built: size, and the exact counts when complete
    andor = {fam: andor_section(g, (classes.get(fam) or {}).get("min_depth"))
             for fam, g in sorted(graphs.items())}
    threaded = declared_threads(asm, options)
    if threaded and not options.threads_as_cylinders:
        for fam in TRANSLATION:
            if fam in classes:
                classes[fam]["threads"] = {
                    "value": sorted([list(p) for p in threaded]),
                    "why": "declared screw joints are threads: these pairs cannot translate "
                           "apart; --threads-as-cylinders treats them as plain cylinders"}
    got = Measures(classes, andor, graphs, (side, ndbgs))
    return got if defer else got.finish(timings)


def interlock_job(asm: Assembly, options: Options = Options(), *, defer: bool = True) -> Any:
    """The interlocking LP and the grasps of :func:`measure`
    (:func:`~ndbg_cli.pipeline.interlocking.interlock_and_grasp_later`), to be given the
    contact analysis and the usable translational NDBGs by ``send((analysis, ndbgs))`` when
    found: a forked process with ``defer`` and ``options.workers`` above 1
    (:class:`~ndbg_cli.core.pools.Forked`; it finds the finger placements meanwhile, which
    need the parts alone), else computed when its result is asked for."""
    from ..core.pools import Forked
    from .interlocking import interlock_and_grasp_later

    return Forked(interlock_and_grasp_later, asm, enabled=defer and options.workers > 1,
                  later=True)


def _translational(ndbgs: dict[str, NDBG]) -> dict[str, NDBG]:
    """The translational families of ``ndbgs`` (what the interlock LP and the grasps read)."""
    return {k: v for k, v in ndbgs.items() if k in TRANSLATION}


#: Modules the stages import when first needed, imported by :func:`load_kernels` too (about
#: 0.05 s, then off the way: during a native read or the contact workers' time).
STAGE_MODULES = ("ndbg_cli.contacts.contacts3d", "ndbg_cli.ndbg.infinitesimal.build",
                 "ndbg_cli.ndbg.infinite.build", "ndbg_cli.ndbg.generalized.build",
                 "ndbg_cli.planning.classes", "ndbg_cli.planning.plans",
                 "ndbg_cli.pipeline.interlocking", "ndbg_cli.pipeline.proofs",
                 "ndbg_cli.pipeline.units", "ndbg_cli.report.classes",
                 "ndbg_cli.report.contacts", "ndbg_cli.report.plans")


def load_kernels() -> None:
    """Load the compiled kernels of the sweep test, since the plan's proofs call them
    (numba's start, about 0.4 s of CPU, when they are not built ahead of time:
    :mod:`ndbg_cli.kernels.compiled`), and import :data:`STAGE_MODULES`: done while
    a native reader's child reads the model (:func:`ndbg_cli.io.loaders.load`'s
    ``meanwhile``), else while the contact workers compute. Costs nothing once done."""
    import importlib

    from ..ndbg.infinite.sweep import warm_up

    warm_up()
    for name in STAGE_MODULES:
        importlib.import_module(name)


def _kernels_cold() -> bool:
    """Whether :func:`load_kernels` is still to be done in this process (asked without
    importing the sweep test, whose import starts numba when its kernels are not built
    ahead of time)."""
    sweep = sys.modules.get("ndbg_cli.ndbg.infinite.sweep")
    return sweep is None or not sweep.kernels_loaded()


#: Strategies whose trees :func:`_prove` checks besides the reported plan's.
PROOF_STRATEGIES = ("fewest-directions", "linear")


def _budget(options: Options) -> Any:
    from ..planning.andor import Budget

    return Budget(max_nodes=options.max_nodes, max_work=options.max_work,
                  time_limit=options.time_limit, workers=options.workers)


def plan_assembly(asm: Assembly, contacts: Contacts, ndbgs: dict[str, NDBG],
                  measures: Measures, options: Options = Options(), *,
                  timings: dict[str, float] | None = None,
                  proposer: NDBG | None = None) -> dict:
    """The report's ``plan`` section: the plan of the first family of :data:`PLAN_ORDER`
    that admits an assembly tree, with its translation steps checked by the direct sweep
    test (paper Fig. 1, sections 4.4 and 5.3).

    Parameters
    ----------
    asm : Assembly
        A loaded assembly (:func:`ndbg_cli.load`).
    contacts : Contacts
        What :func:`find_contacts` found.
    ndbgs : dict
        Family name -> NDBG, the usable ones.
    measures : Measures
        What :func:`measure` found (its AND/OR graphs are reused).
    options : Options
        What to compute (:class:`~ndbg_cli.core.options.Options`; the CLI's defaults).
    timings : dict, optional
        Receives the wall-clock seconds of each stage.
    proposer : NDBG, optional
        An infinitesimal NDBG proposing the splits of an infinite-translation plan when no
        family of ``ndbgs`` can (``--motion infinite`` with the exact family restricted).

    Returns
    -------
    dict
        The report's ``plan`` section (``verified`` and ``proofs`` for translation plans).

    Examples
    --------
    >>> import ndbg_cli
    >>> from ndbg_cli.core.constants import INFINITESIMAL
    >>> asm = ndbg_cli.load("assemblies/hover.yaml")
    >>> contacts = find_contacts(asm)
    >>> ndbgs = {INFINITESIMAL: build_ndbg(asm, INFINITESIMAL, contacts).ndbg}
    >>> plan = plan_assembly(asm, contacts, ndbgs, measure(asm, contacts, ndbgs))
    >>> plan["depth"], plan["verified"]["value"]  # two parts onto the base, both proven
    (2, True)
    """
    from ..planning.plans import plan
    from ..report.plans import mark_presses, plan_section

    clock = Clock(timings)
    budget = _budget(options)
    base = asm.index(asm.base) if asm.base is not None else None
    # The reported plan keeps both sides of every step connected in the contact graph (a
    # designer's subassemblies hold together); when no such tree exists (floating parts), it
    # falls back to any candidate split, reusing the classes' AND/OR graph.
    plan_conn = ConnectivityTest(contacts.neighbours)
    chosen = None
    sources = dict(ndbgs)
    if proposer is not None and not any(f in ndbgs for f in PLAN_ORDER):
        sources[INFINITESIMAL] = proposer
    for fam in PLAN_ORDER:
        if fam not in sources:
            continue
        p = clock("plan_s", lambda nd=sources[fam]: plan(
            nd, options.strategy, base=base, connected=plan_conn, budget=budget))
        if not p.found:
            graph = measures.graphs.get(fam)
            q = clock("plan_s", lambda nd=sources[fam], g=graph: plan(
                nd, options.strategy, base=base, connected=None, budget=budget, graph=g))
            if q.found:
                q.notes.append("no tree with connected subassemblies" + (
                    "" if p.exact else " found within the budget")
                    + "; any candidate split used")
                p = q
            elif q.exact and q.stuck is not None:
                p = q  # no candidate tree at all: its stuck subassembly is the proof
        if chosen is None or (p.found and not chosen.found):
            chosen = p
        if p.found:
            break
    if chosen is None:
        return {"family": None, "strategy": options.strategy, "found": False,
                "exact": True, "depth": None, "tree": None, "sequence": [],
                "notes": ["no motion family computed"]}
    proof: dict = {}
    if chosen.found and chosen.ndbg.family in TRANSLATION:
        # every step proven along an exact direction, or another tree that is, or why not
        proof = clock("verify_s", lambda: _prove(asm, contacts, chosen, measures, options,
                                                 base, budget, plan_conn))
    elif chosen.ndbg.family in TRANSLATION and chosen.exact \
            and chosen.stuck is not None:
        # no candidate tree: a subassembly no direction splits, even infinitesimally (or, for
        # the whole sphere's infinite NDBG, at all), so no plan of translations exists
        names = ", ".join(chosen.ndbg.names(chosen.stuck))
        proof = {"verified": {
            "value": False, "steps": 0, "proof_of_none": True,
            "why": f"no plan of single translations exists: no direction splits {{{names}}}"
                   + (" even infinitesimally" if chosen.ndbg.family == INFINITESIMAL else "")
                   + " (a proof: any plan would split it)"}}
        if chosen.ndbg.family == INFINITESIMAL:
            from .proofs import cross_check

            proof = clock("verify_s", lambda: cross_check(
                asm, contacts.analysis, chosen, proof, strategy=options.strategy, base=base,
                connected=plan_conn, budget=options.infinite_budget, workers=options.workers))
    out = {"family": chosen.ndbg.family, **plan_section(chosen), **proof}
    if chosen.found and chosen.ndbg.family == GENERALIZED:
        from .motion_proofs import prove_generalized

        out.update(clock("verify_s", lambda: prove_generalized(asm, out)))
    press = {frozenset((asm.ids[x.a], asm.ids[x.b]))
             for x in getattr(contacts.analysis, "interferences", ()) if x.kind == "press_fit"}
    mark_presses(out, press)
    if proposer is not None and chosen.ndbg is proposer:
        _as_infinite(out)
    return out


def _proposer_classes(asm: Assembly, proposer: NDBG | None) -> dict:
    """What the proposing infinitesimal NDBG (not reported) says of linear trees: none among
    its candidates proves that no proven tree is linear either."""
    if proposer is None:
        return {}
    from ..planning.decompose import sink_decompose

    base = asm.index(asm.base) if asm.base is not None else None
    stuck = sink_decompose(proposer, (1 << proposer.n) - 1, base=base, linear=True)[1]
    return {"linearizable": {"value": stuck is None}}


def _as_infinite(section: dict) -> None:
    """A plan proposed by an infinitesimal NDBG computed only for it, reported as what its
    proofs make it: an infinite-translation plan (its regions are not reported: they are the
    proposer's, not the restricted infinite NDBG's)."""
    section["family"] = INFINITE
    section["regions_used"] = []
    section["notes"].append("splits proposed by the infinitesimal NDBG (computed for the plan "
                            "only, the infinite NDBG being restricted), each step proven by "
                            "the direct sweep test: exact for infinite translations")
    from ..report.plans import split_nodes

    nodes = (list(section.get("sequence") or [])
             + list((section.get("candidate") or {}).get("sequence") or [])
             + split_nodes(section.get("tree")))
    for node in nodes:
        node["family"] = INFINITE
        node["region"] = None


def _prove(asm: Assembly, contacts: Contacts, chosen: Any, measures: Measures,
           options: Options, base: int | None, budget: Any, conn: ConnectivityTest) -> dict:
    """:func:`~ndbg_cli.pipeline.proofs.prove_plan` on the chosen plan, with the
    :data:`PROOF_STRATEGIES` whose proven trees could prove more than it (fewer directions,
    or a linear tree, when the candidates' minimum allows it) as ``others``."""
    from .proofs import prove_plan, shallowest

    classes = measures.classes.get(chosen.ndbg.family) or {}
    least = {"fewest-directions": (classes.get("min_directions") or {}).get("value"),
             "linear": 0 if (classes.get("linearizable") or {}).get("value") else None}
    has = {"fewest-directions": chosen.directions(), "linear": chosen.nonlinear()}
    # without the family's classes (a plan proposed for a restricted infinite family) every
    # other strategy is tried: its proven trees are cheap, over rows already computed
    others = [s for s in PROOF_STRATEGIES if s != options.strategy
              and (not classes or (least[s] is not None and has[s] > least[s]))]
    return prove_plan(asm, contacts.analysis, chosen, strategy=options.strategy, base=base,
                      connected=conn, others=others, budget=options.infinite_budget,
                      shallow=lambda best: shallowest(chosen, classes.get("min_depth"),
                                                      measures.graphs.get(chosen.ndbg.family),
                                                      base, budget, best),
                      workers=options.workers)


def run_stages(asm: Assembly, options: Options, timings: dict[str, float]
               ) -> tuple[dict, list[Diagnostic]]:
    """All analysis sections of the report for ``asm`` and the extra warnings: the stages
    :func:`find_contacts` -> :func:`build_ndbg` per family -> :func:`measure` ->
    :func:`plan_assembly`. ``timings`` receives seconds per stage. Raises
    :class:`~ndbg_cli.core.errors.InputError` (e.g. an interference under
    ``--interference error``)."""
    from ..core.cache import MemoryCache, open_cache

    cache = open_cache(options.cache)
    # without a cache folder, the contacts of the pairs clash units leave unchanged are still
    # computed once: kept in memory for the units' analysis
    pairs = cache if cache is not None else MemoryCache()
    contacts = find_contacts(asm, options, cache=pairs, timings=timings, units_later=True)
    warnings = list(contacts.warnings)
    asm, interferences = _clash_units(asm, contacts)
    # the interlock LP and the grasps, beside: the finger placements (the parts alone) while
    # the units' contacts (when clashes made units) and the NDBGs are found here, then,
    # given the contacts and the translational NDBGs, the LP and the grasps while the
    # generalized NDBG, the classes and the plan are computed here; dropped if a stage raises
    # (its child would wait for the NDBGs, or to hand its result over)
    with interlock_job(asm, options) as side:
        if interferences is not None:  # the units' contacts (``pairs`` serves the others')
            contacts = find_contacts(asm, options, cache=pairs, timings=timings)
        out: dict = dict(contacts.sections)
        if interferences is not None:
            out["interferences"] = interferences
        ndbgs, proposer = _build_families(asm, contacts, options, cache, timings, side, out,
                                          warnings)
        measures = measure(asm, contacts, ndbgs, options, timings=timings, defer=True,
                           side=side)
        out["plan"] = plan_assembly(asm, contacts, ndbgs, measures, options, timings=timings,
                                    proposer=proposer)
        measures.finish(timings)
    out["classes"], out["andor"] = measures.classes, measures.andor
    from .interlocking import apply_witnesses

    # what the plan proves refutes a conservative "interlocked" or "no candidate tree"
    apply_witnesses(out, asm.ids, contacts.analysis, asm.base)
    if INFINITE not in ndbgs and out["plan"].get("family") in TRANSLATION:
        from .proofs import proven_classes

        cands = out["classes"].get(INFINITESIMAL) or _proposer_classes(asm, proposer)
        got = proven_classes(out["plan"], cands, asm.base)
        if got:
            out["classes"] = dict(sorted({**out["classes"], INFINITE: got}.items()))
    return out, warnings


def _build_families(asm: Assembly, contacts: Contacts, options: Options, cache: Any,
                    timings: dict[str, float], side: Any, out: dict, warnings: list
                    ) -> tuple[dict[str, NDBG], NDBG | None]:
    """The NDBG of each family of ``options.motion`` (:func:`build_ndbg`), their report
    sections and partitionings put in ``out`` and their warnings in ``warnings``; ``side``
    (:func:`interlock_job`) is sent the contact analysis and the usable translational NDBGs
    as soon as they are built. Returns the usable NDBGs and the infinitesimal NDBG proposing
    the splits of an infinite-translation plan when the exact family is restricted or skipped
    (or None)."""
    from ..core.cache import CACHE_FAULTS

    names = FAMILIES_OF[options.motion]
    # the translational NDBGs first, sent at once to the side job (its interlock LP and
    # grasps read nothing else), then the infinitesimal family's report section and the
    # generalized NDBG while it computes; the families keep their order in the report
    inf = None
    if INFINITESIMAL in names or GENERALIZED in names:
        inf = _infinitesimal_ndbg(asm, contacts, options, timings)
    built: dict[str, Family] = {}
    if INFINITE in names:
        built[INFINITE] = build_ndbg(asm, INFINITE, contacts, options, cache=cache,
                                     timings=timings)
    usable = {name: fam.ndbg for name, fam in built.items() if fam.usable}
    side.send((contacts.analysis, _translational(
        {INFINITESIMAL: inf, **usable} if INFINITESIMAL in names else usable)))
    for name in names:
        if name not in built:
            built[name] = build_ndbg(asm, name, contacts, options, cache=cache,
                                     infinitesimal=inf, timings=timings)
    families = {name: built[name] for name in names}
    for fam in families.values():
        warnings += fam.warnings
    out["ndbg"] = {name: fam.section for name, fam in families.items()}
    if cache is not None:
        # hit counts go with the timings (they differ between a cold and a warm run)
        for stage, st in cache.stats().items():
            timings[f"cache_{stage}_hits"] = st["hits"]
            timings[f"cache_{stage}_misses"] = st["misses"]
        if cache.faults():  # for the command line to tell once, never in a written report
            out[CACHE_FAULTS] = cache.faults()
    out["partitionings"] = [p for fam in families.values() for p in fam.partitionings]
    ndbgs = {name: fam.ndbg for name, fam in families.items() if fam.usable}
    proposer = None
    if INFINITE in families and not families[INFINITE].usable and INFINITESIMAL not in ndbgs:
        # the exact family restricted or skipped: the plan's splits are proposed by the
        # infinitesimal NDBG (computed for that alone) and each proven by the sweep test
        proposer = build_ndbg(asm, INFINITESIMAL, contacts, options, cache=cache,
                              timings=timings).ndbg
    return ndbgs, proposer


def _clash_units(asm: Assembly, contacts: Contacts) -> tuple[Assembly, list[dict] | None]:
    """``asm`` with each group of clashing parts made one unit (:mod:`ndbg_cli.pipeline.units`;
    the caller finds the units' contacts), with the report's interferences: those of
    ``contacts`` (``asm``'s), each clash naming its unit. Unchanged without clashes (and the
    interferences None: the contacts' own sections hold them)."""
    from ..report.contacts import interference_record
    from .units import clash_units, member_order, merge_units

    found = getattr(contacts.analysis, "interferences", ())
    units = clash_units(len(asm), [(x.a, x.b) for x in found if x.kind == "clash"])
    if not units:
        return asm, None
    unit_of = {i: [asm.ids[k] for k in member_order(asm, g)] for g in units for i in g}
    records = []
    for x in found:
        rec = interference_record(asm.ids, x)
        if x.kind == "clash":
            rec["unit"] = unit_of[x.a]
        records.append(rec)
    return merge_units(asm, units), records
