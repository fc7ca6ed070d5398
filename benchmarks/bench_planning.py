"""Benchmark: AND/OR graph build and exact minimum depth on synthetic NDBGs.

The products are written directly as DBG sets (no geometry), like the stage's real input:

* ``pinned(plates, pins)``: a stack of plates with cross pins that slide out sideways (see
  :func:`pinned`); the pins multiply the subassemblies (plate intervals times pin subsets).
* ``stack(n)``: ``n`` parts in one stack (+z chain, -z reversed, sides locked): the AND/OR graph
  is the ``n(n+1)/2`` intervals.

``run()`` returns ``(name, value, unit)`` rows: nodes, hyperarcs, seconds, nodes per second
and the exact minimum depth from the full AND/OR graph (with the exact tree and linear-sequence
counts), then the same minimum depth by :func:`andor.min_depth_search` (iterative deepening
with size caps, no full graph): its value, subassemblies expanded and time.
The target from the brief is a ~1000-node graph in under 0.5 s (the paper: 14 minutes).
"""

from __future__ import annotations

import time
from pathlib import Path

from ndbg_cli.ndbg.dbg import DBG
from ndbg_cli.ndbg.model import NDBG, Region
from ndbg_cli.planning.andor import AndOrGraph, Budget
from ndbg_cli.planning.decompose import min_depth_search
from ndbg_cli.report.classes import andor_section

ROOT = Path(__file__).resolve().parents[1]


def _ndbg(n: int, regions: list[tuple[tuple[float, ...], list[tuple[int, int]]]]) -> NDBG:
    return NDBG("infinitesimal_translation", tuple(f"P{i:03d}" for i in range(n)),
                tuple(Region(2, d, DBG.from_arcs(n, arcs)) for d, arcs in regions))


def pinned(plates: int, pins: int) -> NDBG:
    """A stack of ``plates`` (parts ``0..plates-1``, +z: each blocked by the one above, -z
    reversed) with ``pins`` cross pins (parts ``plates..``) each inserted along +x into one
    plate. A pin moves with its plate along +-z (blocked both ways), slides out along +x (its
    plate is blocked by it there), and is held by its head along -x. Plates are locked to each
    other along +-x; +-y is a guide rail (everything blocks everything). Nodes: plate
    intervals times subsets of their pins."""
    n = plates + pins
    host = [(j * plates) // pins + plates // (2 * pins) for j in range(pins)]
    up = [(i, i + 1) for i in range(plates - 1)]
    z = [a for j, t in enumerate(host) for a in ((plates + j, t), (t, plates + j))]
    side = [(i, j) for i in range(plates) for j in range(plates) if i != j]
    px = side + [(t, plates + j) for j, t in enumerate(host)]
    rail = [(i, j) for i in range(n) for j in range(n) if i != j]
    return _ndbg(n, [((0.0, 0.0, 1.0), up + z),
                     ((0.0, 0.0, -1.0), [(j, i) for i, j in up] + z),
                     ((1.0, 0.0, 0.0), px), ((-1.0, 0.0, 0.0), side + z),
                     ((0.0, 1.0, 0.0), rail), ((0.0, -1.0, 0.0), rail)])


def stack(n: int) -> NDBG:
    up = [(i, i + 1) for i in range(n - 1)]
    side = up + [(j, i) for i, j in up]
    return _ndbg(n, [((0.0, 0.0, 1.0), up), ((0.0, 0.0, -1.0), [(j, i) for i, j in up]),
                     ((1.0, 0.0, 0.0), side), ((-1.0, 0.0, 0.0), side)])


def sandwich(k: int) -> NDBG:
    """Paper Fig. 2: plates P, Q around ``k`` interlocked middles that come apart along +-y only
    once both plates are off. Minimum depth ``2 + ceil(log2 k)`` exceeds ``ceil(log2(k + 2))``,
    so the iterative deepening has to refute the smaller depths."""
    n = k + 2
    mids = list(range(2, n))
    cyc = [(mids[i], mids[(i + 1) % k]) for i in range(k)]
    up = [(0, m) for m in mids] + [(m, 1) for m in mids] + cyc
    chain = [(mids[i], mids[i + 1]) for i in range(k - 1)]
    pm = [a for p in (0, 1) for m in mids for a in ((p, m), (m, p))]
    lock = [(i, j) for i in range(n) for j in range(n) if i != j]
    return _ndbg(n, [((0.0, 0.0, 1.0), up), ((0.0, 0.0, -1.0), [(j, i) for i, j in up]),
                     ((1.0, 0.0, 0.0), lock), ((-1.0, 0.0, 0.0), lock),
                     ((0.0, 1.0, 0.0), pm + chain),
                     ((0.0, -1.0, 0.0), pm + [(j, i) for i, j in chain])])


CASES = [
    ("sandwich-42 (Fig. 2, 40 middles)", lambda: sandwich(40)),
    ("pinned-23 (17 plates + 6 pins)", lambda: pinned(17, 6)),
    ("stack-42", lambda: stack(42)),
    ("pinned-42 (37 plates + 5 pins)", lambda: pinned(37, 5)),
    ("stack-100", lambda: stack(100)),
    ("pinned-100 (96 plates + 4 pins)", lambda: pinned(96, 4)),
]


def _real(path: Path, base: bool):
    """The infinitesimal-translation NDBG of a real assembly (contacts computed once)."""
    import ndbg_cli
    from ndbg_cli.ndbg.infinitesimal.build import infinitesimal_ndbg

    asm = ndbg_cli.load(path)
    return infinitesimal_ndbg(asm), (asm.index(asm.base) if base and asm.base else None)


def real_rows() -> list[tuple[str, float, str]]:
    """The bell, AS1 and the engine with the CLI's default budget (2,000 nodes, 5,000 splits
    per node, the default work units, no time limit): their AND/OR graphs are exponential
    (independent free screws and nuts), so the build stops at the first node whose
    partitionings exceed the split limit and the exact minimum depth comes from iterative
    deepening. The engine (8,110 distinct DBGs) is where the work budget binds."""
    rows: list[tuple[str, float, str]] = []
    cases = [("bell", ROOT / "assemblies" / "bell.yaml"),
             ("as1", ROOT.parent / "shared" / "data" / "as1" / "as1-oc-214.stp"),
             ("engine", ROOT.parent / "shared" / "data" / "engine" / "2CylinderEngine.glb")]
    for name, path in cases:
        if not path.exists():
            continue
        nd, base = _real(path, True)
        budget = Budget(max_nodes=2_000, split_limit=5_000)
        t0 = time.perf_counter()
        g = AndOrGraph(nd, base=base, budget=budget).build()
        t_build = time.perf_counter() - t0
        t1 = time.perf_counter()
        r = min_depth_search(nd, base=base, budget=budget, graph=g)
        t_search = time.perf_counter() - t1
        rows += [(f"{name}: AND/OR nodes expanded (cut by {g.cut_by})",
                  float(g.node_count), "nodes"),
                 (f"{name}: AND/OR build", t_build, "s"),
                 (f"{name}: AND/OR build work", float(g.work), "units"),
                 (f"{name}: min depth" + (" (exact)" if r.exact else " (upper bound)"),
                  float(r.upper if r.upper is not None else -1), "levels"),
                 (f"{name}: min depth search", t_search, "s"),
                 (f"{name}: min depth search nodes", float(r.expanded), "nodes")]
    return rows


def run(budget: Budget | None = None) -> list[tuple[str, float, str]]:
    """Build each AND/OR graph and compute its exact minimum depth; report figures."""
    budget = budget or Budget(max_nodes=60_000, max_work=None, time_limit=15.0)
    rows: list[tuple[str, float, str]] = real_rows()
    for name, make in CASES:
        nd = make()
        t0 = time.perf_counter()
        g = AndOrGraph(nd, budget=budget).build()
        t_build = time.perf_counter() - t0
        t1 = time.perf_counter()
        sec = andor_section(g)
        t_all = t_build + time.perf_counter() - t1
        depth = sec["min_depth"] if sec["min_depth"] is not None else sec["min_depth_upper_bound"]
        rows += [
            (f"{name}: parts", float(nd.n), "parts"),
            (f"{name}: nodes", float(g.node_count), "nodes"),
            (f"{name}: hyperarcs", float(g.hyperarc_count), "hyperarcs"),
            (f"{name}: build", t_build, "s"),
            (f"{name}: build + min depth + counts", t_all, "s"),
            (f"{name}: rate", g.node_count / t_build if t_build > 0 else 0.0, "nodes/s"),
            (f"{name}: min depth" + ("" if g.complete else " (graph truncated; "
                                      + ("exact by deepening)" if sec["min_depth_exact"]
                                         else "upper bound)")),
             float(depth if depth is not None else -1), "levels"),
        ]
        t2 = time.perf_counter()
        r = min_depth_search(nd, budget=budget)
        t_search = time.perf_counter() - t2
        rows += [
            (f"{name}: iterative-deepening min depth" + ("" if r.exact else " (bound)"),
             float(r.upper if r.upper is not None else -1), "levels"),
            (f"{name}: iterative-deepening nodes", float(r.expanded), "nodes"),
            (f"{name}: iterative-deepening time", t_search, "s"),
        ]
    return rows


if __name__ == "__main__":
    for name, value, unit in run():
        print(f"{name:55s} {value:14.6g} {unit}")
