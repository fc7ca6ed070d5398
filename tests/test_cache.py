"""The per-part-pair cache: warm runs hit every pair and give byte-identical reports; editing
one part recomputes only the pairs that involve it."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"


def _copy_hover(folder: Path) -> Path:
    shutil.copytree(EX / "meshes" / "hover", folder / "meshes" / "hover")
    manifest = folder / "hover.yaml"
    shutil.copy(EX / "hover.yaml", manifest)
    return manifest


def _counts(manifest: Path, cache: Path) -> dict:
    r = run_cli("analyze", manifest, "--cache", cache, "--timings", "--format", "json")
    assert r.returncode == 0, r.stderr
    t = json.loads(r.stdout)["timings"]
    return {k.removeprefix("cache_"): v for k, v in t.items() if k.startswith("cache_")}


def test_warm_run_hits_every_pair_and_is_byte_identical(tmp_path):
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    cold = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    warm = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    none = run_cli("analyze", manifest, "--no-cache", "--format", "json")
    assert cold.returncode == warm.returncode == none.returncode == 0
    assert cold.stdout == warm.stdout == none.stdout
    counts = _counts(manifest, cache)
    # hover: 3 parts; contact candidates base-puck and base-bridge (the bridge hovers 1 mm
    # over the puck, beyond the tolerance); infinite blocking sets for the 3 unordered pairs
    # (each computed in one order, the other being its antipodal image).
    assert counts == {"contacts_hits": 2, "contacts_misses": 0,
                      "infinite_hits": 3, "infinite_misses": 0}
    assert not (tmp_path / "a" / "cache").exists()
    assert any(cache.rglob("*.pkl"))


def test_a_warm_run_with_a_clash_recomputes_no_pair(tmp_path):
    """clash.yaml: the first analysis leaves the clashing parts' contacts to the units' (its
    pairs of a clashing part may be dropped before they start), yet every pair it computed
    is cached, the interference booleans included: a warm run misses none."""
    shutil.copytree(EX / "meshes" / "clash", tmp_path / "a" / "meshes" / "clash")
    manifest = tmp_path / "a" / "clash.yaml"
    shutil.copy(EX / "clash.yaml", manifest)
    cache = tmp_path / "cache"
    cold = _counts(manifest, cache)
    warm = _counts(manifest, cache)
    assert cold["contacts_misses"] > 0
    assert warm["contacts_misses"] == 0 and warm["contacts_hits"] > 0


def test_editing_one_part_recomputes_only_its_pairs(tmp_path):
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    first = _counts(manifest, cache)
    assert first["infinite_misses"] == 3 and first["infinite_hits"] == 0
    # move the puck 1 mm along +x on the base (it stays on the base, under the bridge)
    old = "  mesh: meshes/hover/puck.stl\n"
    text = manifest.read_text().replace(old, old + "  translation: [1, 0, 0]\n")
    manifest.write_text(text)
    second = _counts(manifest, cache)
    # pairs with the puck: base-puck (contacts); base-puck and puck-bridge (infinite, one
    # order each). The base-bridge pair is unchanged: a hit.
    assert second == {"contacts_hits": 1, "contacts_misses": 1,
                      "infinite_hits": 1, "infinite_misses": 2}


def test_unreadable_cache_entries_are_misses_not_errors(tmp_path):
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    ref = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    for k, f in enumerate(sorted(cache.rglob("*.pkl"))):
        # torn files, and well-formed pickles of the wrong shape
        f.write_bytes(b"torn" if k % 2 else pickle.dumps((1, 2, 3)))
    again = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    assert again.returncode == 0 and again.stdout == ref.stdout
    assert _counts(manifest, cache)["infinite_hits"] == 3  # rewritten by the second run


def test_no_cache_wins_whatever_the_order(tmp_path):
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    for args in (("--cache", cache, "--no-cache"), ("--no-cache", "--cache", cache)):
        r = run_cli("analyze", manifest, *args, "--timings", "--format", "json")
        assert r.returncode == 0, r.stderr
        assert not [k for k in json.loads(r.stdout)["timings"] if k.startswith("cache_")]
    assert not cache.exists()


def test_stage_digests_cover_every_module_the_stage_runs(tmp_path):
    """A stage's digest reads its modules and every package module they import, directly
    or not: the pruning walk and the gap cones change the cached results too. Checked on
    a copy of the package whose gap_cones.py is edited: the contacts digest changes, and
    so does the infinite one (it imports the contacts), while an unrelated module's edit
    (the text report) changes neither."""
    import ast
    import importlib.util
    import subprocess
    import sys

    import ndbg_cli
    from ndbg_cli.core.cache import stage_modules

    here = Path(ndbg_cli.__file__).parent
    for stage in ("contacts", "infinite"):
        mods = set(stage_modules(stage))
        for name in mods:  # closed under the package's relative imports
            spec = importlib.util.find_spec(f"ndbg_cli.{name}")
            package = f"ndbg_cli.{name}".rpartition(".")[0]
            for node in ast.walk(ast.parse(Path(spec.origin).read_text())):
                if isinstance(node, ast.ImportFrom) and node.level and node.module:
                    target = importlib.util.resolve_name("." * node.level + node.module, package)
                    assert target.removeprefix("ndbg_cli.") in mods, (name, target)
    assert {"contacts.gap_cones", "contacts.facets", "geometry.directions"} <= set(
        stage_modules("contacts"))
    # the kernel modules too, read by name (``loaded("_cone_kernels")``), not imported
    assert {"ndbg.infinite.blocking_cones", "ndbg.infinite.cover", "ndbg.infinite.tritree",
            "ndbg.infinite.domain", "kernels._cone_kernels", "kernels._term_kernels",
            "kernels._cover_kernels", "kernels._union_kernels",
            "kernels.cube_faces"} <= set(stage_modules("infinite"))
    assert "report.text" not in stage_modules("infinite")

    copy = tmp_path / "pkg" / "ndbg_cli"
    shutil.copytree(here, copy, ignore=shutil.ignore_patterns("__pycache__"))

    def digests() -> list[str]:
        code = ("from ndbg_cli.core.cache import code_digest; "
                "print(code_digest('contacts'), code_digest('infinite'))")
        out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path / "pkg",
                             capture_output=True, text=True, check=True)
        return out.stdout.split()

    before = digests()
    with open(copy / "report" / "text.py", "a") as f:
        f.write("\n# an edit elsewhere\n")
    assert digests() == before
    with open(copy / "contacts" / "gap_cones.py", "a") as f:
        f.write("\n# an edit of a helper\n")
    after = digests()
    assert after[0] != before[0] and after[1] != before[1]
    with open(copy / "kernels" / "_union_kernels.py", "a") as f:
        f.write("\n# an edit of a kernel module, read by name\n")
    last = digests()
    assert last[0] == after[0] and last[1] != after[1]


def test_trim_removes_the_least_recently_used_entries(tmp_path):
    """Entries of known sizes and ages: a hit makes an old entry recent, and a trim over
    the limit removes the oldest others until the cache holds at most TRIM_TO of it."""
    import os

    from ndbg_cli.core.cache import TRIM_TO, PairCache, clear, trim, usage

    c = PairCache(tmp_path / "c")
    keys = [c.key("contacts", k) for k in range(6)]
    for k, key in enumerate(keys):
        c.put("contacts", key, bytes(10_000))
        os.utime(c._path("contacts", key), (1000.0 + k, 1000.0 + k))  # key 0 the oldest
    size = usage(c.root)["bytes"]
    assert usage(c.root)["entries"] == 6 and size > 60_000
    assert c.get("contacts", keys[0]) == bytes(10_000)  # used now: the newest
    assert trim(c.root, None) == (0, 0) and trim(c.root, size) == (0, 0)
    limit = size // 2
    removed, freed = trim(c.root, limit)
    left = usage(c.root)
    assert left["bytes"] <= TRIM_TO * limit and left["bytes"] == size - freed
    assert removed == 6 - left["entries"] and 0 < left["entries"] < 6
    alive = [c.get("contacts", key) is not None for key in keys]
    # the survivors are the most recently used: key 0 (the hit), then the youngest
    assert alive[0] and alive == [True] + [False] * (6 - left["entries"]) \
        + [True] * (left["entries"] - 1)
    assert clear(c.root)[0] == left["entries"] and usage(c.root)["entries"] == 0


def test_analyze_keeps_the_cache_under_its_limit(tmp_path):
    """NDBG_CACHE_MAX_MB bounds the cache after a run (stderr says what went); a malformed
    value is a warning, not a failure; ``cache info`` and ``cache clear`` report and empty
    it."""
    import os
    import subprocess
    import sys

    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"

    def run(*args: str, limit: str | None = None) -> subprocess.CompletedProcess:
        env = {k: v for k, v in os.environ.items() if k != "NDBG_CACHE_MAX_MB"}
        if limit is not None:
            env["NDBG_CACHE_MAX_MB"] = limit
        return subprocess.run([sys.executable, "-m", "ndbg_cli", *map(str, args)], env=env,
                              capture_output=True, text=True, timeout=300)

    r = run("analyze", manifest, "--cache", cache, "--format", "json")
    assert r.returncode == 0 and "trimmed" not in r.stderr
    info = json.loads(run("cache", "info", "--cache", cache).stdout)
    assert info["entries"] == 5 and info["stages"]["infinite"]["entries"] == 3
    limit_mb = info["bytes"] / 2 / 2**20
    r = run("analyze", manifest, "--cache", cache, "--format", "json", limit=f"{limit_mb}")
    assert r.returncode == 0 and "cache trimmed" in r.stderr
    assert json.loads(run("cache", "info", "--cache", cache).stdout)["bytes"] \
        <= 0.8 * limit_mb * 2**20
    r = run("analyze", manifest, "--cache", cache, "--format", "json", limit="lots")
    assert r.returncode == 0 and "NDBG_CACHE_MAX_MB" in r.stderr
    r = run("cache", "clear", "--cache", cache)
    assert r.returncode == 0 and "5 cache entries" in r.stderr
    assert json.loads(run("cache", "info", "--cache", cache).stdout)["entries"] == 0


def test_trim_and_clear_touch_only_ndbg_entries(tmp_path):
    """A cache pointed at a folder of one's own: its other files (pickles included, even
    in folders shaped like the cache's) survive a trim and a clear; the cache folder gets a
    CACHEDIR.TAG; an entry another run removed first counts as freed (no extra removals)."""
    from ndbg_cli.core.cache import PairCache, clear, trim, usage

    mine = [tmp_path / "results" / "run1" / "model.pkl",
            tmp_path / "contacts" / "ab" / "notes.pkl",
            tmp_path / "contacts" / "zz" / ("0" * 64 + ".pkl")]  # folder is not key[:2]
    for f in mine:
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_bytes(bytes(100_000))
    c = PairCache(tmp_path)
    keys = [c.key("contacts", k) for k in range(4)]
    for key in keys:
        c.put("contacts", key, bytes(10_000))
    assert (tmp_path / "CACHEDIR.TAG").read_text().startswith("Signature: 8a477f597d28d172")
    assert usage(tmp_path)["entries"] == 4
    removed, _ = trim(tmp_path, 1)
    assert removed == 4 and all(f.exists() for f in mine)
    for key in keys:
        c.put("contacts", key, bytes(10_000))
    assert clear(tmp_path)[0] == 4 and all(f.exists() for f in mine)

    # two trims from one listing: the second finds the first one's removals done
    for key in keys:
        c.put("contacts", key, bytes(10_000))
    size = usage(tmp_path)["bytes"]
    limit = int(size * 0.9)  # target 0.8 * 0.9 of it: two of the four entries go
    import ndbg_cli.core.cache as cache_mod
    listing = cache_mod._entries(tmp_path)
    assert trim(tmp_path, limit)[0] == 2
    left = usage(tmp_path)["bytes"]
    real = cache_mod._entries
    cache_mod._entries = lambda root: listing  # the second run's stale listing
    try:
        assert trim(tmp_path, limit) == (0, size - left)
    finally:
        cache_mod._entries = real
    assert usage(tmp_path)["entries"] == 2


def test_trim_removes_stale_temporary_files_only(tmp_path):
    """The temporary file of a write killed before its rename (SIGKILL) is removed by the
    next trim once :data:`STALE_TEMP_S` old, even with no size limit; a fresh one (a write
    in progress in another run) and files of one's own named alike are left alone."""
    import os
    import time

    from ndbg_cli.core.cache import STALE_TEMP_S, PairCache, trim, usage

    c = PairCache(tmp_path)
    key = c.key("infinite", 1)
    c.put("infinite", key, bytes(1000))
    folder = tmp_path / "infinite" / key[:2]
    stale = folder / f".{key}.pkl.k3j_x9q2.tmp"
    fresh = folder / f".{key}.pkl.a8b7c6d5.tmp"
    other = c.key("infinite", 2)
    misplaced = folder / f".{other}.pkl.zzzz1234.tmp" if other[:2] != key[:2] \
        else folder / ".notes.pkl.zzzz1234.tmp"
    mine = tmp_path / "infinite" / ".scratch.tmp"
    old = time.time() - 2 * STALE_TEMP_S
    for f in (stale, fresh, misplaced, mine):
        f.write_bytes(bytes(5000))
    for f in (stale, misplaced, mine):
        os.utime(f, (old, old))
    assert trim(tmp_path, None) == (1, 5000)
    assert not stale.exists() and fresh.exists() and misplaced.exists() and mine.exists()
    assert usage(tmp_path)["entries"] == 1  # the entry itself is untouched
    os.utime(fresh, (old, old))
    # with a limit too: the temporary file goes, and the entries are trimmed as before
    size = usage(tmp_path)["bytes"]
    assert trim(tmp_path, 1) == (2, 5000 + size)
    assert usage(tmp_path)["entries"] == 0 and misplaced.exists() and mine.exists()
