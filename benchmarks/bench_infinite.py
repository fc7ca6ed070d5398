"""Benchmark: the NDBG for infinite translations
(:func:`ndbg_cli.ndbg.infinite.build.build_infinite`).

Cases: AS1 (18 parts, 11k triangles), the beam (5 parts, 48k triangles), the engine GLB (115
open meshes), AS1 and the beam restricted to their free domains (what ``--motion infinite``
computes above the budget), and synthetic grids of 10 / 100 / 1000 boxes (unit cubes with 0.5
gaps). Every pair of parts is processed (distant parts block too; each unordered pair once), so
the cost grows with the number of part pairs times the triangle pairs that can face each other;
the growth exponent is the log-log slope of the time over the grid sizes. A case whose estimated
time exceeds ``BUDGET_S`` is skipped with the estimate.

``run()`` returns ``[(name, seconds, note)]``; ``python benchmarks/bench_infinite.py`` prints it.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import ndbg_cli
from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_part
from ndbg_cli.ndbg.infinite.blocking_cones import pair_cones, part_triangles
from ndbg_cli.ndbg.infinite.build import TooLarge, build_infinite
from ndbg_cli.ndbg.infinite.chart_union import cones_to_face_geoms
from ndbg_cli.pipeline.batch import default_jobs

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"
#: Cases estimated to take longer than this are skipped (seconds).
BUDGET_S = 300.0


def grid(n: int) -> Assembly:
    """``n`` unit boxes on a cubic grid with pitch 1.5 (no contacts)."""
    side = math.ceil(n ** (1 / 3))
    parts = []
    for k in range(n):
        x, y, z = k % side, (k // side) % side, k // (side * side)
        m = trimesh.creation.box(extents=[1, 1, 1])
        m.apply_translation([1.5 * x, 1.5 * y, 1.5 * z])
        parts.append(make_part(f"b{k}", m.vertices, m.faces)[0])
    return Assembly(f"grid{n}", tuple(parts))


def estimate_seconds(asm: Assembly, sample: int = 250) -> float:
    """Estimated build time: the cost per triangle pair measured on the largest pair of parts
    (each subsampled to ``sample`` triangles) times the number of triangle pairs, plus a
    fixed cost per ordered part pair measured on two single triangles."""
    tris = part_triangles(asm)
    eps = asm.length_tolerance
    sizes = np.array([len(t[0]) for t in tris])
    i, j = np.argsort(sizes)[-2:]
    rng = np.random.default_rng(0)

    def timed(a: int, b: int, k: int) -> float:
        ia = rng.permutation(len(tris[a][0]))[:k]
        jb = rng.permutation(len(tris[b][0]))[:k]
        t0 = time.perf_counter()
        cones, _ = pair_cones(tris[a][0][ia], tris[a][1][ia], tris[b][0][jb], tris[b][1][jb],
                              eps)
        cones_to_face_geoms(cones)
        return time.perf_counter() - t0

    k = int(min(sample, sizes[i], sizes[j]))
    per_pair = timed(i, j, k) / (k * k)
    overhead = timed(i, j, 1)
    # the builder computes each unordered pair of parts once (B_ji = -B_ij)
    total_pairs = float(sizes.sum() ** 2 - (sizes ** 2).sum()) / 2
    n = len(tris)
    return per_pair * total_pairs + overhead * n * (n - 1) / 2


def _time(asm: Assembly) -> tuple[float, str]:
    t0 = time.perf_counter()
    nd = build_infinite(asm)
    dt = time.perf_counter() - t0
    s = nd.stats
    note = (f"{len(asm.parts)} parts, {sum(p.check.triangles for p in asm.parts)} tri, "
            f"{s['pieces']} cones, regions {s['regions_by_dimension']}, "
            f"{s['distinct_dbgs']} DBGs; cones+unions {s['time_blocked_sets_s']:.2f} s, "
            f"arrangement {s['time_arrangement_s']:.2f} s, DBGs {s['time_dbgs_s']:.2f} s")
    return dt, note


def _restricted(name: str, path: Path, workers: int = 1) -> tuple[str, float, str]:
    """What ``ndbg analyze --motion infinite`` does above the budget: the NDBG only where the
    infinitesimal NDBG frees a subassembly (:mod:`ndbg_cli.ndbg.infinite.domain`); timed from the
    contacts on (the contact analysis itself is in ``bench_contacts``), with ``workers`` processes
    for the part pairs (``--jobs``)."""
    if not path.exists():
        return name, float("nan"), f"skipped: {path} not found"
    from ndbg_cli.contacts.contacts3d import analyze_contacts
    from ndbg_cli.ndbg.infinite.domain import free_domain
    from ndbg_cli.ndbg.infinitesimal.build import contact_pairs
    from ndbg_cli.ndbg.model import partitionings

    asm = ndbg_cli.load(path)
    ca = analyze_contacts(asm)
    t0 = time.perf_counter()
    dom = free_domain(len(asm.parts), contact_pairs(asm, ca), ca.angle_tolerance)
    t1 = time.perf_counter()
    nd = build_infinite(asm, domain=dom, workers=workers)
    parts, _ = partitionings(nd)
    dt = time.perf_counter() - t0
    s = nd.stats
    single = sorted(nd.names(p.moved)[0] for p in parts if (p.moved & (p.moved - 1)) == 0)
    return name, dt, (f"domain {t1 - t0:.2f} s ({s['domain_area']:.4f} of 24 chart units), "
                      f"cones+unions {s['time_blocked_sets_s']:.1f} s, arrangement "
                      f"{s['time_arrangement_s']:.1f} s, DBGs {s['time_dbgs_s']:.1f} s; "
                      f"{s['regions']} regions, {len(parts)} partitionings, single parts "
                      f"moved: {', '.join(single)}")


def _restricted_fresh(name: str, path: Path) -> list[tuple[str, float, str]]:
    """The restricted cases (:func:`_restricted`) in a fresh process: the first run (which
    loads the compiled kernels, as a CLI call does), then one process and ``default_jobs()``
    processes. In this process, after the other benchmarks and the whole-sphere builds
    (AS1's makes 7 million cones), the heap is large and the workers forked from it start
    slower: AS1 on two processes measured 3.2 s there, 2.1 s in a fresh process."""
    import json
    import subprocess

    got = subprocess.run([sys.executable, __file__, "--restricted", name, str(path)],
                         capture_output=True, text=True, check=False)
    if got.returncode:
        return [(f"{name} (free domain)", float("nan"),
                 f"failed: {got.stderr.strip().splitlines()[-1:]}")]
    return [tuple(row) for row in json.loads(got.stdout)]


def _restricted_rows(name: str, path: Path) -> list[tuple[str, float, str]]:
    rows = [_restricted(f"{name} (free domain, first run)", path),
            _restricted(f"{name} (free domain)", path)]
    cores = default_jobs()
    if cores > 1:
        rows.append(_restricted(f"{name} (free domain, {cores} processes)", path,
                                workers=cores))
    return rows


def run() -> list[tuple[str, float, str]]:
    out: list[tuple[str, float, str]] = []
    for name, path in (("as1", SHARED / "as1" / "as1-oc-214.stp"),
                       ("beam", SHARED / "beam" / "assembled")):
        if path.exists():
            out.extend(_restricted_fresh(name, path))
    cases = [("as1", SHARED / "as1" / "as1-oc-214.stp"),
             ("beam", SHARED / "beam" / "assembled"),
             ("engine", SHARED / "engine" / "2CylinderEngine.glb")]
    for name, path in cases:
        if not path.exists():
            out.append((name, float("nan"), f"skipped: {path} not found"))
            continue
        asm = ndbg_cli.load(path)
        est = estimate_seconds(asm)
        if est > BUDGET_S:
            tri = sum(p.check.triangles for p in asm.parts)
            out.append((name, float("nan"), f"skipped: estimated {est:.0f} s ({len(asm.parts)} "
                        f"parts, {tri} triangles; cost ~ triangle pairs)"))
            continue
        dt, note = _time(asm)
        out.append((name, dt, note + f" (estimated {est:.1f} s)"))
    sizes, times = [], []
    for n in (10, 100, 1000):
        if len(times) >= 2:
            slope = math.log(times[-1] / times[-2]) / math.log(sizes[-1] / sizes[-2])
            est = times[-1] * (n / sizes[-1]) ** slope
            if est > BUDGET_S:
                out.append((f"grid{n}", float("nan"),
                            f"skipped: estimated {est:.0f} s (exponent {slope:.2f})"))
                continue
        try:
            dt, note = _time(grid(n))
        except TooLarge as exc:
            out.append((f"grid{n}", float("nan"), f"skipped: {exc}"))
            continue
        sizes.append(n)
        times.append(dt)
        out.append((f"grid{n}", dt, note))
    if len(times) >= 2:
        slope = float(np.polyfit(np.log(sizes), np.log(times), 1)[0])
        out.append(("grid growth exponent", slope, f"log-log slope over n = {sizes}"))
    return out


if __name__ == "__main__":
    if sys.argv[1:2] == ["--restricted"]:
        import json

        print(json.dumps(_restricted_rows(sys.argv[2], Path(sys.argv[3]))))
        sys.exit(0)
    for name, secs, note in run():
        print(f"{name:22s} {secs:10.3f}  {note}")
        sys.stdout.flush()
