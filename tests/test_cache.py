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
