"""Benchmark of the contact analysis (issue 3) on the external assemblies.

``run()`` returns ``(name, value, unit)`` rows: for AS1 (STEP), the beam (directory of OBJ)
and the two-cylinder engine (GLB): load time, python-fcl BVH build time (all parts, cold
cache), contact analysis time (BVH cached, everything else cold; wall and CPU time of this
process, the latter less sensitive to other jobs on a shared machine), contact pairs found,
and the ratio analysis / (load + BVH) (target <= 2; engine analysis target < 2 s). Each time
is the best of :data:`REPEATS` runs (timings on a shared machine are noisy). Assemblies whose
data is missing are skipped. Run it as ``python benchmarks/bench_contacts.py [runs]``.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import ndbg_cli
from ndbg_cli.contacts.contacts3d import analyze_contacts
from ndbg_cli.contacts.facets import clear_caches, fcl_model

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"
CASES = (("as1", DATA / "as1" / "as1-oc-214.stp"),
         ("beam", DATA / "beam" / "assembled"),
         ("engine", DATA / "engine" / "2CylinderEngine.glb"))

#: Runs of each phase; the best is reported.
REPEATS = 5


def bench_one(name: str, path: Path, repeats: int = REPEATS) -> list[tuple[str, float, str]]:
    """Rows for one assembly (best of ``repeats`` runs of each phase, cold caches each time)."""
    loads, bvhs, analyses, cpus = [], [], [], []
    pairs = 0
    for _ in range(repeats):
        clear_caches()
        t0 = time.perf_counter()
        asm = ndbg_cli.load(path)
        t1 = time.perf_counter()
        for part in asm.parts:
            fcl_model(part)
        t2 = time.perf_counter()
        c2 = time.process_time()
        result = analyze_contacts(asm)
        t3 = time.perf_counter()
        cpus.append(time.process_time() - c2)
        loads.append(t1 - t0)
        bvhs.append(t2 - t1)
        analyses.append(t3 - t2)
        pairs = len(result.pairs())
    load, bvh, analysis = min(loads), min(bvhs), min(analyses)
    return [(f"{name}.load", load, "s"), (f"{name}.bvh_build", bvh, "s"),
            (f"{name}.contact_analysis", analysis, "s"),
            (f"{name}.contact_analysis_cpu", min(cpus), "s"),
            (f"{name}.contact_pairs", float(pairs), "pairs"),
            (f"{name}.analysis_over_load_plus_bvh", analysis / max(load + bvh, 1e-9), "x"),
            (f"{name}.triangles", float(sum(p.check.triangles for p in asm.parts)), "tris")]


def run(repeats: int = REPEATS) -> list[tuple[str, float, str]]:
    """All benchmark rows ``(name, value, unit)``."""
    rows: list[tuple[str, float, str]] = []
    for name, path in CASES:
        if path.exists():
            rows += bench_one(name, path, repeats)
    return rows


if __name__ == "__main__":
    for row_name, value, unit in run(int(sys.argv[1]) if len(sys.argv) > 1 else REPEATS):
        print(f"{row_name:<40} {value:12.4g} {unit}")
