"""Worker processes for one assembly's infinite-translation pairs
(:mod:`ndbg_cli.ndbg.infinite.pair_workers`): same results as one process, a dead worker's pairs
done here,
no worker outliving its parent, and no way to ask for nested pools from a config file."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import trimesh

from ndbg_cli.core.errors import InputError
from ndbg_cli.core.pools import ORPHAN_POLL, ForkMapper
from ndbg_cli.io.config import read_config
from ndbg_cli.ndbg.infinite import pair_workers as pw

from helpers import ROOT


def _spheres(n: int, subdivisions: int = 2) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for k in range(n):
        m = trimesh.creation.icosphere(subdivisions=subdivisions)
        m.apply_translation([2.5 * k, 0.3 * k, 0.0])
        out.append((np.asarray(m.triangles), np.asarray(m.face_normals)))
    return out


_WORK = pw._pair_blocked_sets
_PARENT = os.getpid()


def _dies_on_one(context, pair):  # the pool forks: a worker dies on (0, 3), the parent not
    if pair == (0, 3) and os.getpid() != _PARENT:
        os._exit(3)
    return _WORK(context, pair)


def test_a_dead_worker_leaves_its_pairs_to_the_parent(monkeypatch):
    monkeypatch.setattr(pw, "MIN_PARALLEL_PAIRS", 0)
    monkeypatch.setattr(pw, "_pair_blocked_sets", _dies_on_one)
    tris = _spheres(4)
    pairs = [(i, j) for i in range(4) for j in range(i + 1, 4)]
    two = dict(pw.pair_sets(tris, pairs, 1e-4, None, ForkMapper(2)))
    one = dict(pw.pair_sets(tris, pairs, 1e-4, None))
    assert sorted(two) == list(range(len(pairs)))
    assert all(np.array_equal(two[k][0], one[k][0]) for k in one)


SCRIPT = """
import os, sys
sys.path.insert(0, {root!r})
import numpy as np, trimesh
from ndbg_cli.core.pools import ForkMapper
from ndbg_cli.ndbg.infinite import pair_workers as pw
pw.MIN_PARALLEL_PAIRS = 0
tris = []
for k in range(6):
    m = trimesh.creation.icosphere(subdivisions=3)
    m.apply_translation([2.5 * k, 0, 0])
    tris.append((np.asarray(m.triangles), np.asarray(m.face_normals)))
print(os.getpid(), flush=True)
for k, r in pw.pair_sets(tris, [(i, j) for i in range(6) for j in range(i + 1, 6)], 1e-4,
                         None, ForkMapper(2)):
    print(k, flush=True)
"""


@pytest.mark.skipif(sys.platform != "linux", reason="reads /proc for the workers")
def test_workers_do_not_outlive_a_killed_parent():
    proc = subprocess.Popen([sys.executable, "-c", SCRIPT.format(root=str(ROOT))],
                            stdout=subprocess.PIPE, text=True)
    parent = int(proc.stdout.readline())
    kids: list[int] = []
    deadline = time.time() + 60
    while len(kids) < 2 and time.time() < deadline:
        out = subprocess.run(["pgrep", "-P", str(parent)], capture_output=True, text=True)
        kids = [int(x) for x in out.stdout.split()]
        time.sleep(0.1)
    assert len(kids) >= 2
    os.kill(parent, signal.SIGTERM)
    proc.wait(timeout=30)
    time.sleep(3 * ORPHAN_POLL + 1.0)
    alive = [k for k in kids if os.path.exists(f"/proc/{k}")
             and "zombie" not in open(f"/proc/{k}/status").read()]
    assert alive == []


@pytest.mark.parametrize("setting", ["workers: 4", "mapper: local"])
def test_workers_cannot_come_from_a_config_file(tmp_path, setting):
    # --jobs and --scheduler only
    cfg = tmp_path / "c.yaml"
    cfg.write_text(setting + "\n")
    with pytest.raises(InputError, match=f"unknown setting '{setting.split(':')[0]}'"):
        read_config(cfg)


def _cli_on_a_terminal(*args: str) -> tuple[int, str]:
    """Run ``ndbg`` with its stderr on a pseudo-terminal; return its exit code and what it
    drew there."""
    import pty

    master, slave = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "ndbg_cli", *args], cwd=ROOT,
                            stdout=subprocess.DEVNULL, stderr=slave, stdin=subprocess.DEVNULL)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the child closed the terminal
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    return proc.wait(timeout=120), b"".join(chunks).decode(errors="replace")


def test_one_assembly_shows_its_part_pairs_on_a_terminal():
    # a single target has no batch bar: the infinite NDBG's pairs are the long step
    args = ["analyze", "assemblies/fig2-sandwich-5.yaml", "--motion", "infinite",
            "--no-cache", "--format", "json"]
    code, drawn = _cli_on_a_terminal(*args)
    assert code == 0 and "part pairs [" in drawn and "/10" in drawn
    code, drawn = _cli_on_a_terminal(*args, "--quiet")
    assert code == 0 and "part pairs" not in drawn


def _frozen_count(context, item):
    import gc

    return gc.get_freeze_count()


def test_forked_workers_do_not_walk_the_parents_heap():
    """The objects a worker inherits through fork are out of its garbage collector's reach
    (``gc.freeze`` around the fork: a collection there would otherwise touch, and copy, every
    page of the parent's heap), while the parent's own collector has them back at once."""
    import gc

    from ndbg_cli.core.pools import Forked, Helper

    assert gc.get_freeze_count() == 0
    held = [object() for _ in range(1000)]
    got = dict(ForkMapper(2).imap(_frozen_count, None, [0, 1]))
    assert min(got.values()) > len(held)
    assert Forked(_frozen_count, None, 0).result() > len(held)
    with Helper(_frozen_count, None) as helper:  # the second item is the child's
        here, there = helper.share([0, 1])
    assert there > len(held) and here == 0 == gc.get_freeze_count()
    gc.freeze()  # a caller's own freeze (a preforking server) is kept
    try:
        frozen = gc.get_freeze_count()
        assert Forked(_frozen_count, None, 0).result() > len(held)
        assert gc.get_freeze_count() >= frozen - 100  # not given back (a few freed since)
    finally:
        gc.unfreeze()
