"""The motion families' NDBG builders behind :func:`ndbg_cli.pipeline.stages.build_ndbg`:
the infinite-translation NDBG within its budget (or restricted to the infinitesimal NDBG's
free domain, paper 5.3), the generalized motions (paper 6) over the infinitesimal NDBG, and
the declared threads that hold pairs together.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..core.assembly import Assembly
from ..core.constants import GENERALIZED
from ..core.options import Options
from ..ndbg.model import NDBG

__all__ = ["declared_threads", "infinite", "infinite_skip_reason", "generalized"]


def declared_threads(asm: Assembly, options: Options) -> set[tuple[str, str]]:
    """The declared screw joints read as threads (none in 2D, none with
    ``--threads-as-cylinders``): :func:`~ndbg_cli.ndbg.generalized.build.threaded_pairs`."""
    from ..ndbg.generalized.build import threaded_pairs

    return threaded_pairs(asm, options.threads_as_cylinders) if asm.dimension == 3 else set()


def _over_budget(asm: Assembly, options: Options) -> str:
    from ..ndbg.infinite.blocked_sets import triangle_pairs

    return (f"{triangle_pairs(asm)} facing triangle pairs exceed the budget of "
            f"{options.infinite_budget}")


def _too_many_parts(asm: Assembly, options: Options) -> bool:
    """Whether the default run leaves the whole sphere out for the part count alone
    (:data:`~ndbg_cli.core.constants.INFINITE_MAX_PARTS`)."""
    from ..core.constants import INFINITE_MAX_PARTS

    return (asm.dimension == 3 and options.motion != "infinite"
            and len(asm.parts) > INFINITE_MAX_PARTS)


def infinite_skip_reason(asm: Assembly, options: Options) -> str:
    from ..core.constants import INFINITE_MAX_PARTS

    if _too_many_parts(asm, options):
        return (f"{len(asm.parts)} parts: above {INFINITE_MAX_PARTS} its arrangement over the "
                "whole sphere grows as the fourth power of the parts (every pair blocks in "
                "some directions); the plan is proven by the sweep test instead (--motion "
                "infinite computes it)")
    if options.motion == "infinite":  # the restriction was tried: it is every direction
        return (f"{_over_budget(asm, options)}, and the infinitesimal NDBG frees some "
                "subassembly in every direction (for one, when parts or groups of parts touch "
                "nothing else), so it cannot be restricted (raise --infinite-budget to "
                "compute it on the whole sphere)")
    return (f"{_over_budget(asm, options)} (raise it with --infinite-budget; --motion "
            "infinite computes it where the infinitesimal NDBG frees something)")


def infinite(asm: Assembly, options: Options, threaded: set, connected, cache=None, ca=None
              ) -> tuple[NDBG, dict, list[dict]] | None:
    """The infinite-translation NDBG, its section and partitionings. Above the budget (3D) it is
    skipped (``None``), unless ``--motion infinite`` asks for it: then it is computed only where the
    infinitesimal NDBG frees some subassembly (:mod:`ndbg_cli.ndbg.infinite.domain`), which gives
    the same partitionings of the whole assembly and nothing else (``None`` again when that is every
    direction)."""
    from ..core.constants import ANGLE_TOL_RAD
    from ..ndbg.generalized.build import block_threads
    from ..ndbg.infinite.blocked_sets import triangle_pairs
    from ..ndbg.infinite.build import build_infinite
    from ..ndbg.infinite.domain import free_domain
    from ..ndbg.infinitesimal.build import contact_pairs
    from ..ndbg.model import partitionings
    from ..report.infinite import infinite_section

    domain = None
    if _too_many_parts(asm, options):
        return None
    if asm.dimension == 3 and triangle_pairs(asm) > options.infinite_budget:
        if options.motion != "infinite":  # asked for explicitly only: it takes minutes
            return None
        domain = free_domain(len(asm.parts), contact_pairs(asm, ca),
                             float(getattr(ca, "angle_tolerance", ANGLE_TOL_RAD)))
        if domain is None:
            return None
    nd = block_threads(build_infinite(asm, cache, domain, workers=options.workers,
                                      progress=options.progress, mapper=options.mapper),
                       threaded)
    parts, trunc = partitionings(nd, limit=options.max_partitions, connected=connected)
    sec = infinite_section(asm, nd, parts, trunc)
    if domain is not None:
        sec["domain"] = {
            "restricted": True, "area": nd.stats.get("domain_area"),
            "why": f"{_over_budget(asm, options)}; the regions are those inside "
                   "the domain (cut by its boundary), the whole assembly's partitionings "
                   "are all of them; its regions make no plans or classes (the plan's steps are "
                   "proposed by the infinitesimal NDBG and proven by the sweep test)"}
    if options.region_limit is not None and len(sec["region_list"]) > options.region_limit:
        sec["region_list"] = sec["region_list"][:options.region_limit]
        sec["region_list_truncated"] = True
    parts_out = sec.pop("partitionings")
    return nd, sec, parts_out


def generalized(asm: Assembly, ca, inf: NDBG, options: Options) -> tuple[NDBG, dict, list[dict]]:
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

