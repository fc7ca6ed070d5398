"""Faults around the cache and the report folder (issue 34, item 4): two processes sharing one
cache, damaged entries, a cache that cannot be written (read-only, a path through a file, a
full disk), a run killed while it writes an --out-dir that existed before. In every case the
answers are those of a run without the cache, and the user is told once what was skipped.

Real processes, real files: permission bits do not deny root, so where the tests run as root
an unwritable folder is a path whose parent is a file, and a full disk is a file size limit
(``RLIMIT_FSIZE``: every write past it fails with ``EFBIG``, as ``ENOSPC`` would)."""

from __future__ import annotations

import json
import os
import pickle
import resource
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from test_cache import _copy_hover

from helpers import run_cli

ROOT = Path(__file__).resolve().parents[1]
EX = ROOT / "assemblies"
AS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


def _cli(*args, limit_bytes: int | None = None, **kw) -> subprocess.Popen:
    """A fresh ``python -m ndbg_cli`` process (not the test server's fork: a process of its
    own, with its own resource limits when ``limit_bytes`` is given)."""
    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit_bytes, limit_bytes))

    return subprocess.Popen([sys.executable, "-m", "ndbg_cli", *map(str, args)], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=limit if limit_bytes else None, **kw)


def _reference(manifest: Path) -> str:
    r = run_cli("analyze", manifest, "--no-cache", "--format", "json")
    assert r.returncode == 0, r.stderr
    return r.stdout


def _warnings(stderr: str) -> list[str]:
    return [ln for ln in stderr.splitlines() if ln.startswith("ndbg: warning: cache")]


def test_two_concurrent_processes_share_a_cold_cache(tmp_path):
    """Both write the same entries at once (atomic renames): same answers as without the
    cache, no torn entry, no warning, and a third run hits every pair."""
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    ref = _reference(manifest)
    procs = [_cli("analyze", manifest, "--cache", cache, "--format", "json", "--jobs", "1")
             for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    for p, (out, err) in zip(procs, outs):
        assert p.returncode == 0, err
        assert out == ref
        assert not _warnings(err) and "Traceback" not in err
    assert not list(cache.rglob("*.tmp"))
    for f in cache.rglob("*.pkl"):
        pickle.loads(f.read_bytes())  # every entry whole
    warm = run_cli("analyze", manifest, "--cache", cache, "--format", "json", "--timings")
    t = json.loads(warm.stdout)["timings"]
    assert t["cache_infinite_misses"] == t["cache_contacts_misses"] == 0


@pytest.mark.parametrize("damage", ["truncated", "random-bytes", "wrong-version"])
def test_damaged_entries_are_recomputed_and_told_once(tmp_path, damage):
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    ref = _reference(manifest)
    assert run_cli("analyze", manifest, "--cache", cache).returncode == 0
    entries = sorted(cache.rglob("*.pkl"))
    assert len(entries) == 5  # 2 contact pairs, 3 infinite pairs (test_cache)
    for k, f in enumerate(entries):
        data = f.read_bytes()
        f.write_bytes({"truncated": data[: len(data) // 2],
                       "random-bytes": os.urandom(len(data)) if k else b"",
                       # a pickle protocol this Python cannot read (a newer writer)
                       "wrong-version": b"\x80\x3f" + data[2:]}[damage])
    r = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    assert r.returncode == 0, r.stderr
    assert r.stdout == ref
    told = _warnings(r.stderr)
    assert len(told) == 1 and "5 unreadable" in told[0], r.stderr
    # rewritten: the next run reads them all, silently
    again = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
    assert again.stdout == ref and not _warnings(again.stderr)


def _unwritable(tmp_path: Path) -> Path:
    """A cache folder this process cannot write: read-only (0o555) for a user, a path
    through a regular file for root (whom permission bits do not stop)."""
    if AS_ROOT:
        (tmp_path / "a-file").write_text("not a folder\n")
        return tmp_path / "a-file" / "cache"
    folder = tmp_path / "ro-cache"
    folder.mkdir()
    folder.chmod(0o555)
    return folder


@pytest.mark.parametrize("command", ["analyze", "check"])
def test_an_unwritable_cache_gives_the_same_answers_and_one_warning(tmp_path, command):
    manifest = _copy_hover(tmp_path / "a")
    cache = _unwritable(tmp_path)
    try:
        if command == "analyze":
            r = run_cli("analyze", manifest, "--cache", cache, "--format", "json")
            assert r.stdout == _reference(manifest)
        else:
            r = run_cli("check", manifest, "--self", "--cache", cache)
            assert r.returncode == 0, r.stderr
        told = _warnings(r.stderr)
        assert len(told) == 1, r.stderr
        assert "cannot be written" in told[0] and "not stored" in told[0]
        assert "Traceback" not in r.stderr
    finally:
        if not AS_ROOT:
            cache.chmod(0o755)


def test_a_full_disk_gives_the_same_answers_and_one_warning(tmp_path):
    """Writes past 2 kB fail (``RLIMIT_FSIZE``, ``EFBIG``): the small CACHEDIR.TAG is
    written, the entries are not. The report goes to a pipe, which the limit does not touch."""
    manifest = _copy_hover(tmp_path / "a")
    cache = tmp_path / "cache"
    p = _cli("analyze", manifest, "--cache", cache, "--format", "json", "--jobs", "1",
             limit_bytes=2048)
    out, err = p.communicate(timeout=300)
    assert p.returncode == 0, err
    assert out == _reference(manifest)
    told = _warnings(err)
    assert len(told) == 1 and "cannot be written" in told[0], err
    assert not list(cache.rglob("*.pkl.*.tmp"))  # a failed write leaves no temporary file


@pytest.mark.slow
def test_a_killed_out_dir_run_keeps_the_folder_and_a_rerun_gives_the_same_reports(tmp_path):
    """SIGKILL (no handler runs) while a batch writes into an --out-dir that held files:
    the folder and the files this run does not write stay, every report written is whole,
    there is no index (an index is always one whole run's); the rerun's reports, with the
    killed run's cache, are byte-identical to a run without any cache."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("hover", "stack", "fig11-nonlinear", "slot-37", "bolt-plain"):
        _copy_example(name, src)
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    (out / "index.json").write_text("{}\n")  # an earlier run's: dropped before any report
    cache = tmp_path / "cache"
    p = _cli("analyze", src, "--out-dir", out, "--cache", cache, "--jobs", "1", "-q",
             start_new_session=True)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and not [
            f for f in out.glob("*.json") if f.name != "index.json"]:
        time.sleep(0.05)
    os.killpg(p.pid, signal.SIGKILL)
    p.communicate(timeout=60)
    assert p.returncode == -signal.SIGKILL
    assert (out / "notes.txt").read_text() == "mine\n"
    assert not (out / "index.json").exists()
    written = sorted(out.glob("*.json"))
    assert 1 <= len(written) < 5
    for f in written:
        json.loads(f.read_text())  # whole, never torn
    again = run_cli("analyze", src, "--out-dir", out, "--cache", cache, "-q")
    ref = run_cli("analyze", src, "--out-dir", tmp_path / "ref", "--no-cache", "-q")
    assert again.returncode == ref.returncode == 0, again.stderr
    for f in sorted((tmp_path / "ref").glob("*.json")):
        assert (out / f.name).read_bytes() == f.read_bytes(), f.name
    assert (out / "notes.txt").read_text() == "mine\n"


def _copy_example(name: str, dst: Path) -> None:
    import shutil

    shutil.copytree(EX / "meshes" / name, dst / "meshes" / name)
    shutil.copy(EX / f"{name}.yaml", dst / f"{name}.yaml")


@pytest.mark.skipif(AS_ROOT, reason="root ignores permission bits; a report folder under a "
                    "file (test_outputs.py, out-dir-under-a-file) is the same fault for root")
def test_a_report_folder_without_write_permission_is_one_error_line(tmp_path):
    manifest = _copy_hover(tmp_path / "a")
    out = tmp_path / "reports"
    out.mkdir()
    out.chmod(0o555)
    try:
        r = run_cli("analyze", manifest, "--out-dir", out, "--no-cache")
    finally:
        out.chmod(0o755)
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == [r.stderr.strip()]
    assert r.stderr.startswith(f"ndbg: error: cannot write {out}") and "ermission" in r.stderr
