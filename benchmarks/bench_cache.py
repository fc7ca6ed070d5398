"""Benchmark of the per-part-pair cache (issue 8): cold vs warm stage times.

Contacts on the bell and AS1 (every candidate pair), and the infinite-translation blocked
sets on the stack and hinge examples (every ordered pair; the bell's and AS1's are beyond the
default infinite budget: tens of minutes cold). Each figure is the stage's wall time with an
empty cache (cold) and with the cache the cold run filled (warm), plus the speed-up against no
cache. (That editing one part recomputes only its pairs is checked in tests/test_cache.py.)
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import ndbg_cli
from ndbg_cli.contacts.contacts3d import analyze_contacts
from ndbg_cli.contacts.facets import clear_caches
from ndbg_cli.core.cache import PairCache
from ndbg_cli.ndbg.infinite.blocked_sets import blocked_sets

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def run() -> list[tuple[str, float, str]]:
    rows: list[tuple[str, float, str]] = []
    cases = [("bell", ROOT / "assemblies" / "bell.yaml", "contacts"),
             ("as1", DATA / "as1" / "as1-oc-214.stp", "contacts"),
             ("stack", ROOT / "assemblies" / "stack.yaml", "infinite"),
             ("hinge", ROOT / "assemblies" / "hinge.yaml", "infinite")]
    for name, path, stage in cases:
        if not path.exists():
            continue
        asm = ndbg_cli.load(path)
        with tempfile.TemporaryDirectory() as tmp:
            if stage == "contacts":
                def go(c, a=asm):
                    clear_caches()
                    return analyze_contacts(a, cache=c)
            else:
                def go(c, a=asm):
                    return blocked_sets(a, c)
            none = _timed(lambda g=go: g(None))
            cold_cache = PairCache(tmp)
            cold = _timed(lambda g=go, c=cold_cache: g(c))
            warm_cache = PairCache(tmp)
            warm = _timed(lambda g=go, c=warm_cache: g(c))
            hits = sum(v["hits"] for v in warm_cache.stats().values())
            rows += [(f"{name}_{stage}_no_cache_s", none, "s"),
                     (f"{name}_{stage}_cold_cache_s", cold, "s"),
                     (f"{name}_{stage}_warm_cache_s", warm, "s"),
                     (f"{name}_{stage}_warm_speedup", none / max(warm, 1e-9), "x"),
                     (f"{name}_{stage}_warm_hits", hits, "pairs")]
    return rows


if __name__ == "__main__":
    for row in run():
        print(*row)
