"""Benchmark: the NDBG for infinitesimal translations plus its candidate partitionings.

Synthetic assemblies are written directly as contact normals (what the contact stage hands
over), so the figures time this stage alone:

* ``wall(n)``: a running-bond brick wall, ``n`` bricks in rows of 10 (each row offset by half a
  brick) on a floor slab: every brick touches its row neighbours (+-x), the bricks below and
  above (+-z) and a back wall (+y); 3 great circles whatever ``n``.
* ``plates(n)``: a stack of ``n`` plates, each pinned to the one below by a 16-facet peg in a
  blind hole along z (the facet normals are shared, so the refinement keeps 2 circles in all);
  ``tilted(n)``: the same with every peg axis tilted at random by ~3 degrees, so each joint
  adds 2 circles of its own: the O(c^2) arrangement of section 5.1 (a stress test).
* ``facets(n)``: ``n`` parts in a chain, each joint with 1-4 normals drawn from a fixed set of
  24 directions (a bounded arrangement, but far more regions and DBGs than the wall).

Each case reports the build time of the NDBG and of the partitionings (capped at
``MAX_PARTITIONS``), the region counts, and for each family the log-log slope of the total time
over n = 10, 100, 1000 (the growth exponent). ``bench_assembly(asm)`` does the same for a real
assembly (contacts timed separately). The brief's target: under 50 ms for a 42-part assembly.
"""

from __future__ import annotations

import time

import numpy as np

from ndbg_cli.ndbg.infinitesimal.build import (
    build_ndbg_2d,
    build_ndbg_3d,
    candidate_partitionings,
    contact_pairs,
)

MAX_PARTITIONS = 1000
SIZES = (10, 100, 1000)
X, Y, Z = np.eye(3)


def wall(n: int) -> tuple[list[str], list]:
    """Brick ``i`` is in row ``i // 10``; part ``n`` is the floor slab, ``n + 1`` the back."""
    ids = [f"B{i:04d}" for i in range(n)] + ["floor", "back"]
    pairs = []
    for i in range(n):
        row, col = divmod(i, 10)
        if col < 9 and i + 1 < n:
            pairs.append((i, i + 1, [X]))
        if row == 0:
            pairs.append((i, n, [-Z]))
        for j in (i + 10 - (row % 2), i + 10 + 1 - (row % 2)):  # two bricks above, bond
            jrow, jcol = divmod(j, 10)
            if j < n and jrow == row + 1 and abs(jcol - col) <= 1:
                pairs.append((i, j, [Z]))
        pairs.append((i, n + 1, [Y]))
    return ids, pairs


def plates(n: int, tilt: float = 0.0) -> tuple[list[str], list]:
    """``n`` plates: plate ``i + 1`` on plate ``i``, joined by a 16-facet peg in a blind hole
    (facet normals orthogonal to the peg axis, the hole's floor). With ``tilt`` = 0 the axes
    are all +z (a real stack: the facet normals are shared); otherwise each axis is tilted at
    random by about ``tilt`` rad, so every joint adds 2 circles of its own: the O(c^2)
    arrangement of section 5.1 (a stress test, not a plausible product)."""
    ids = [f"P{i:04d}" for i in range(n)]
    rng = np.random.default_rng(0)
    pairs = []
    for i in range(n - 1):
        axis = np.array([tilt * rng.normal(), tilt * rng.normal(), 1.0])
        axis /= np.linalg.norm(axis)
        e1 = np.cross(axis, X)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
        t = np.linspace(0, 2 * np.pi, 16, endpoint=False)
        facets = np.outer(np.cos(t), e1) + np.outer(np.sin(t), e2)
        pairs.append((i + 1, i, np.vstack([facets, -axis])))
    return ids, pairs


def facets(n: int) -> tuple[list[str], list]:
    """A chain of ``n`` parts; each joint has 1-4 normals from a fixed set of 24."""
    rng = np.random.default_rng(1)
    pool = rng.normal(size=(24, 3))
    pool /= np.linalg.norm(pool, axis=1, keepdims=True)
    ids = [f"F{i:04d}" for i in range(n)]
    pairs = [(i, i + 1, pool[rng.choice(24, size=int(rng.integers(1, 5)), replace=False)])
             for i in range(n - 1)]
    return ids, pairs


def measure(ids, pairs) -> dict:
    """Build the NDBG and the capped partitionings; best of 3 (1 for big cases)."""
    repeat = 3 if len(ids) <= 200 else 1
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        g = build_ndbg_3d(ids, pairs)
        t1 = time.perf_counter()
        parts, truncated = candidate_partitionings(g, max_partitions=MAX_PARTITIONS)
        t2 = time.perf_counter()
        cur = {"ndbg_s": t1 - t0, "partitionings_s": t2 - t1, "total_s": t2 - t0,
               "regions": len(g.regions), "distinct": len(g.distinct()),
               "circles": g.stats.get("circles", 0), "partitionings": len(parts),
               "truncated": truncated}
        if best is None or cur["total_s"] < best["total_s"]:
            best = cur
    return best


def slope(xs, ys) -> float:
    """Least-squares slope of log(y) over log(x)."""
    lx, ly = np.log(xs), np.log(ys)
    return float(np.polyfit(lx, ly, 1)[0])


def bench_assembly(asm) -> list[tuple[str, float, str]]:
    """Figures for a real assembly: contact time, NDBG time, partitionings time, counts."""
    t0 = time.perf_counter()
    pairs = contact_pairs(asm)
    t1 = time.perf_counter()
    ids = list(asm.ids)
    g = build_ndbg_2d(ids, pairs) if asm.dimension == 2 else build_ndbg_3d(ids, pairs)
    t2 = time.perf_counter()
    parts, truncated = candidate_partitionings(g, max_partitions=MAX_PARTITIONS)
    t3 = time.perf_counter()
    name = asm.name
    rows = [(f"{name}.contacts_s", t1 - t0, "s"), (f"{name}.ndbg_s", t2 - t1, "s"),
            (f"{name}.partitionings_s", t3 - t2, "s"),
            (f"{name}.ndbg_plus_partitionings_s", t3 - t1, "s"),
            (f"{name}.regions", float(len(g.regions)), "regions"),
            (f"{name}.distinct_dbgs", float(len(g.distinct())), "DBGs"),
            (f"{name}.partitionings", float(len(parts)), "truncated" if truncated else "")]
    for dim, count in sorted(g.region_counts().items()):
        rows.append((f"{name}.regions_dim{dim}", float(count), "regions"))
    return rows


def tilted(n: int) -> tuple[list[str], list]:
    """:func:`plates` with every peg axis tilted differently (2 new circles per joint)."""
    return plates(n, tilt=0.05)


def run() -> list[tuple[str, float, str]]:
    rows: list[tuple[str, float, str]] = []
    cases = [(wall, SIZES), (plates, SIZES), (facets, SIZES), (tilted, (10, 30, 100))]
    for family, sizes in cases:
        times = []
        for n in sizes:
            m = measure(*family(n))
            name = f"{family.__name__}{n}"
            times.append(m["total_s"])
            rows += [(f"{name}.ndbg_s", m["ndbg_s"], "s"),
                     (f"{name}.partitionings_s", m["partitionings_s"], "s"),
                     (f"{name}.regions", float(m["regions"]), "regions"),
                     (f"{name}.distinct_dbgs", float(m["distinct"]), "DBGs"),
                     (f"{name}.circles", float(m["circles"]), "circles"),
                     (f"{name}.partitionings", float(m["partitionings"]),
                      "capped" if m["truncated"] else "")]
        rows.append((f"{family.__name__}.growth_exponent", slope(sizes, times), "log-log"))
    m42 = measure(*wall(40))  # 40 bricks + floor + back wall = 42 parts
    rows.append(("wall42parts.ndbg_plus_partitionings_s", m42["total_s"], "s (target < 0.05)"))
    m42 = measure(*facets(42))
    rows.append(("facets42.ndbg_plus_partitionings_s", m42["total_s"], "s (target < 0.05)"))
    return rows


if __name__ == "__main__":
    for fig, value, unit in run():
        print(f"{fig:<44} {value:>14.6g} {unit}")
