"""Fuzz: is the direction :func:`ndbg_cli.planning.plans.pick_region` reports for a 2D partitioning
free for the direct sweep test?

Random small 2D polygon assemblies with many short zero-clearance contacts are built
(:func:`random_assembly`): polyomino partitions of a grid with uneven (often very thin) rows and
columns, some cells left empty (pockets, slots, pegs in notches, overhangs); stacks of blocks of
random widths and offsets; plates with notches holding pegs. Half of them are turned by a random
angle (and scaled). For each one the infinite-translation NDBG is built and, for every partitioning
of the whole assembly (:func:`ndbg_cli.ndbg.model.partitionings`), the region ``pick_region`` picks
among the regions where the moved set is free is checked with
:class:`ndbg_cli.ndbg.infinite.sweep.SweepChecker` (no erosion, shares no code with
:mod:`ndbg_cli.ndbg.infinite.equator`): ``blocked`` counts picks whose direction the sweep test
blocks, ``fixable`` those among them where another of the partitioning's regions is free for it.

    python benchmarks/fuzz_pick2d.py [--n 400] [--seed 0] [--show 5]

About 0.1 s an assembly. ``--n 3000 --seed 1``: 26,030 partitionings; 2,929 picks blocked
(in 733 assemblies, every one a 1-dimensional region at most 25.2 ``eta`` wide that no
contact slides along, each with another region the sweep test frees) while every
1-dimensional region ranked ahead of the lower-dimensional ones; none since thin regions
(:attr:`ndbg_cli.ndbg.model.Region.thin`) are ranked with them.
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from ndbg_cli.core.assembly import Assembly
from ndbg_cli.io.validate import make_polygon_part
from ndbg_cli.ndbg.infinite.build import build_infinite
from ndbg_cli.ndbg.infinite.equator import equator_extents, sliding_angles
from ndbg_cli.ndbg.infinite.sweep import SweepChecker
from ndbg_cli.ndbg.model import partitionings
from ndbg_cli.planning.plans import pick_region

KINDS = ("grid", "stack", "pegs")


def _sizes(rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` cell sizes: a mix of thin (short contacts, 0.02 to 0.3) and plain (0.5 to 3)."""
    thin = rng.random(k) < 0.35
    return np.where(thin, rng.uniform(0.02, 0.3, k), rng.uniform(0.5, 3.0, k))


def _grid(rng: np.random.Generator) -> list[Polygon]:
    """A polyomino partition of a grid with uneven rows and columns: parts grown cell by
    cell from random seeds (edge-connected), some cells left empty."""
    nx, ny = rng.integers(2, 6, 2)
    xs = np.r_[0.0, np.cumsum(_sizes(rng, nx))]
    ys = np.r_[0.0, np.cumsum(_sizes(rng, ny))]
    cells = [(i, j) for i in range(nx) for j in range(ny)]
    empty = {c for c in cells if rng.random() < 0.15}
    live = [c for c in cells if c not in empty]
    if len(live) < 2:
        return []
    k = int(rng.integers(2, min(5, len(live)) + 1))
    owner: dict[tuple[int, int], int] = {}
    for p, c in enumerate(rng.permutation(len(live))[:k]):
        owner[live[c]] = p
    frontier = True
    while frontier:
        frontier = [(c, o) for c, o in owner.items()
                    for c2 in ((c[0] + 1, c[1]), (c[0] - 1, c[1]), (c[0], c[1] + 1),
                               (c[0], c[1] - 1)) if c2 in live and c2 not in owner]
        if frontier:
            c, o = frontier[int(rng.integers(len(frontier)))]
            opts = [c2 for c2 in ((c[0] + 1, c[1]), (c[0] - 1, c[1]), (c[0], c[1] + 1),
                                  (c[0], c[1] - 1)) if c2 in live and c2 not in owner]
            owner[opts[int(rng.integers(len(opts)))]] = o
    polys = []
    for p in range(k):
        mine = [box(xs[i], ys[j], xs[i + 1], ys[j + 1]) for (i, j), o in owner.items()
                if o == p]
        polys.append(shapely.union_all(mine))
    return polys


def _stack(rng: np.random.Generator) -> list[Polygon]:
    """Blocks stacked along y, each of random width, height and offset (overlapping the one
    below), some with a step so that the next sits in a corner."""
    polys, y, x0, w0 = [], 0.0, 0.0, float(rng.uniform(1, 4))
    for _ in range(int(rng.integers(2, 5))):
        h = float(_sizes(rng, 1)[0])
        w = float(rng.uniform(0.2, 4))
        x = float(rng.uniform(x0 - w + 0.05, x0 + w0 - 0.05))
        b = box(x, y, x + w, y + h)
        if rng.random() < 0.3:  # a lip hanging down beside the block below
            lip = float(_sizes(rng, 1)[0])
            side = x0 - 0.1 if x < x0 - 0.1 else None
            if side is not None:
                b = shapely.union(b, box(x, y - lip, x0, y))
        polys.append(b)
        y, x0, w0 = y + h, x, w
    # cut what a lip pushes into the blocks below
    out = []
    for k, p in enumerate(polys):
        for q in polys[:k]:
            p = p.difference(q)
        out.append(p)
    return out


def _pegs(rng: np.random.Generator) -> list[Polygon]:
    """A plate with notches in its top (and maybe a cover over it), a peg in each notch,
    flush or sticking out, tight on both sides or on one."""
    w = float(rng.uniform(3, 8))
    t = float(rng.uniform(0.5, 2))
    plate = box(0, 0, w, t)
    pegs = []
    x = 0.2
    for _ in range(int(rng.integers(1, 4))):
        pw = float(rng.uniform(0.1, 1.0))
        depth = float(min(_sizes(rng, 1)[0], 0.9 * t))
        clear = float(rng.choice([0.0, 0.0, rng.uniform(0.05, 0.5)]))
        if x + pw + clear > w - 0.1:
            break
        plate = plate.difference(box(x, t - depth, x + pw + clear, t + 1))
        top = t + float(rng.choice([0.0, _sizes(rng, 1)[0]]))
        if top > t - depth + 1e-9 and top - (t - depth) > 1e-3:
            pegs.append(box(x, t - depth, x + pw, top))
        x += pw + clear + float(rng.uniform(0.2, 1.5))
    parts = [plate] + pegs
    if pegs and rng.random() < 0.3:
        top = max(p.bounds[3] for p in parts)
        parts.append(box(0, top, float(rng.uniform(1, w)), top + float(_sizes(rng, 1)[0])))
    return parts


def random_assembly(rng: np.random.Generator, kind: str | None = None) -> Assembly | None:
    """One random 2D assembly (``None`` when the draw made an unusable part)."""
    kind = kind or KINDS[int(rng.integers(len(KINDS)))]
    polys = {"grid": _grid, "stack": _stack, "pegs": _pegs}[kind](rng)
    if len(polys) < 2 or any(not isinstance(p, Polygon) or p.area <= 1e-6 for p in polys):
        return None
    t = np.eye(3)
    scale = 1.0
    if rng.random() < 0.5:
        th = float(rng.uniform(0, 2 * np.pi))
        c, s = np.cos(th), np.sin(th)
        t = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        scale = float(10 ** rng.uniform(-1, 2))
    parts = []
    for k, p in enumerate(polys):
        p = shapely.normalize(p)
        parts.append(make_polygon_part(f"p{k}", list(p.exterior.coords)[:-1],
                                       [list(r.coords)[:-1] for r in p.interiors],
                                       transform=t, scale=scale)[0])
    return Assembly(f"fuzz-{kind}", tuple(parts), dimension=2)


def check(asm: Assembly) -> list[dict]:
    """One record per partitioning of ``asm``'s infinite NDBG: the picked region and whether
    the sweep test frees its moved set along the picked direction (and along any of its
    regions)."""
    nd = build_infinite(asm)
    bs = nd.geometry
    ext = equator_extents(bs.arcs, bs.n, bs.eta, sliding_angles(bs.circles))
    sc = SweepChecker(asm)
    out = []
    parts, _ = partitionings(nd)
    for p in parts:
        r = pick_region(nd, p.regions)
        reg = nd.regions[r]
        ok = sc.frees(p.moved, p.rest, np.array(reg.direction))
        rec = {"moved": p.moved, "region": r, "dim": reg.dimension, "sliding": reg.sliding,
               "width_eta": (ext[r][3][1] - ext[r][3][0]) / bs.eta, "free": ok,
               "regions": len(p.regions)}
        if not ok:
            rec["fixable"] = any(sc.frees(p.moved, p.rest, np.array(nd.regions[q].direction))
                                 for q in p.regions if q != r)
        out.append(rec)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=400, help="assemblies")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--show", type=int, default=5, help="blocked picks to print")
    args = ap.parse_args()
    rng = np.random.default_rng(args.seed)
    tally: Counter = Counter()
    shown = 0
    widest = 0.0
    t0 = time.perf_counter()
    made = 0
    while made < args.n:
        seed = int(rng.integers(2**31))
        asm = random_assembly(np.random.default_rng(seed))
        if asm is None:
            continue
        made += 1
        recs = check(asm)
        tally["assemblies"] += 1
        tally["partitionings"] += len(recs)
        bad = [r for r in recs if not r["free"]]
        tally["blocked"] += len(bad)
        tally["blocked_fixable"] += sum(r["fixable"] for r in bad)
        tally["assemblies_blocked"] += bool(bad)
        for r in bad:
            tally[f"blocked_dim{r['dim']}_sliding{min(r['sliding'], 1)}"] += 1
            widest = max(widest, r["width_eta"])
            if shown < args.show:
                shown += 1
                print(f"seed {seed} {asm.name}: moved {r['moved']:b} region {r['region']} "
                      f"dim {r['dim']} sliding {r['sliding']} width {r['width_eta']:.2f} eta, "
                      f"{r['regions']} regions, fixable {r['fixable']}")
    for k in sorted(tally):
        print(f"{k:28s} {tally[k]}")
    print(f"widest blocked pick: {widest:.2f} eta")
    print(f"time {time.perf_counter() - t0:.1f} s")


if __name__ == "__main__":
    main()
