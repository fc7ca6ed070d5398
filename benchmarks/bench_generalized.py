"""The generalized-motion family (issue 7) on the bell and AS1: its cost next to the
translational NDBG's.

Figures per case (milliseconds unless stated; best of :data:`REPEAT` after the contacts are
computed once; the machine may be shared, so only best-of figures mean anything):

* ``contacts``: the contact stage (shared input, timed once for reference);
* ``translational``: ``infinitesimal.infinitesimal_ndbg`` from the same contacts;
* ``generalized_ndbg``: contact rows + suggested motions and their DBGs (the family itself);
* ``generalized_section``: the report section (contact-connected candidate partitionings,
  each validated by a suggested motion checked on the rows or else the LP; needs-rotation
  checks per part and candidate: translation witnesses, locking certificates, LPs);
* ``ndbg_ratio``: generalized_ndbg / translational (target <= 1);
* ``with_section_ratio``: (generalized_ndbg + generalized_section) / translational;
* ``pipeline_without`` / ``pipeline_with``: every stage after the contacts of
  ``pipeline.run_stages`` (NDBGs, sections, classes, plan), ``--motion translation`` against
  ``--motion all`` less its infinite-translation step (skipped over its budget on both);
  ``pipeline_added``: the family's whole cost in an analysis, its own stage plus what it
  adds to the classes (``classes_added``; stage-wise best-of-5, steadier than the totals);
  ``added_ratio``: pipeline_added / translational (the issue's target: <= 1);
* counts: suggested regions, contact rows, needs-rotation subassemblies, candidates, and the
  section's ``checks`` (LPs solved, LP stages skipped by a locking certificate, splits decided
  by a witness) and whether the candidate list was truncated.
"""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT, SHARED, best_of  # noqa: E402

import ndbg_cli  # noqa: E402
from ndbg_cli.ndbg.generalized import build as ge  # noqa: E402
from ndbg_cli.ndbg.generalized import twist as tw  # noqa: E402

#: Timed calls per figure (the best one is reported).
REPEAT = 5

CASES = {
    "bell": ROOT / "assemblies" / "bell.yaml",
    "as1": SHARED / "as1" / "as1-oc-214.stp",
}


def _translational(asm, result):
    try:
        from ndbg_cli.ndbg.infinitesimal.build import infinitesimal_ndbg
    except ImportError:
        return None
    return best_of(lambda: infinitesimal_ndbg(asm, result), repeat=REPEAT)[0]


def _pipeline(asm, motion: str) -> dict[str, float]:
    """Seconds per stage after the contacts (best of 5 each), the infinite family's left out,
    and their sum under ``"total"``."""
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.stages import run_stages

    best: dict[str, float] = {}
    for _ in range(5):
        t: dict[str, float] = {}
        run_stages(asm, Options(motion=motion), t)
        for k, v in t.items():
            if k.endswith("_s") and not k.startswith("contacts") and k != "infinite_s":
                best[k] = min(best.get(k, float("inf")), v)
    best["total"] = sum(best.values())
    return best


def run() -> list[tuple[str, float, str]]:
    from ndbg_cli.contacts.contacts3d import analyze_contacts

    rows_out: list[tuple[str, float, str]] = []
    for name, path in CASES.items():
        if not path.exists():
            continue
        asm = ndbg_cli.load(path)
        t_contacts, result = best_of(lambda a=asm: analyze_contacts(a), repeat=1)
        cs = list(result.contacts)
        t_trans = _translational(asm, result)

        def build(a=asm, c=cs):
            rows = tw.contact_rows(a, c)
            return rows, ge.generalized_ndbg(a, c, rows=rows)

        t_gen, (rows, g) = best_of(build, repeat=REPEAT)
        t_sec, sec = best_of(lambda a=asm, n=g, r=rows: ge.generalized_section(a, n, r),
                             repeat=REPEAT)
        rows_out += [(f"{name}.contacts", t_contacts * 1000, "ms"),
                     (f"{name}.generalized_ndbg", t_gen * 1000, "ms"),
                     (f"{name}.generalized_section", t_sec * 1000, "ms"),
                     (f"{name}.suggested_regions", len(g.regions), "regions"),
                     (f"{name}.contact_rows", len(rows.a), "rows"),
                     (f"{name}.needs_rotation", len(sec["needs_rotation"]), "subassemblies"),
                     (f"{name}.lp_candidates", len(sec["candidates"]), "partitionings"),
                     (f"{name}.lp_rejected", len(sec["rejected_candidates"]), "partitionings"),
                     (f"{name}.candidates_truncated", int(sec["candidates_truncated"]), "bool"),
                     (f"{name}.checks_lp", sec["checks"]["lp"], "LPs"),
                     (f"{name}.checks_certified", sec["checks"]["certified"], "stages"),
                     (f"{name}.checks_witnessed", sec["checks"]["witnessed"], "splits")]
        if t_trans is not None:
            rows_out += [(f"{name}.translational", t_trans * 1000, "ms"),
                         (f"{name}.ndbg_ratio", t_gen / max(t_trans, 1e-9), "x"),
                         (f"{name}.with_section_ratio", (t_gen + t_sec) / max(t_trans, 1e-9),
                          "x")]
            without, with_ = _pipeline(asm, "translation"), _pipeline(asm, "all")
            # the stages the family adds to: its own, and the classes (the plan uses the
            # translational family on both runs); stage-wise bests, less noisy than totals
            added = with_["generalized_s"] + with_["classes_s"] - without["classes_s"]
            rows_out += [(f"{name}.pipeline_without", without["total"] * 1000, "ms"),
                         (f"{name}.pipeline_with", with_["total"] * 1000, "ms"),
                         (f"{name}.classes_added", (with_["classes_s"] - without["classes_s"])
                          * 1000, "ms"),
                         (f"{name}.pipeline_added", added * 1000, "ms"),
                         (f"{name}.added_ratio", added / max(t_trans, 1e-9), "x")]
    return rows_out


if __name__ == "__main__":
    for fig, value, unit in run():
        print(f"{fig:<40} {value:>12.4g} {unit}")
