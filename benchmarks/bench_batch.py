"""Batch throughput of ``ndbg analyze``: assemblies per second with ``--jobs 1`` and ``--jobs 2``.

A temporary folder gets ``COUNT`` (300) manifests: copies of the small examples in
``assemblies/`` (``SMALL`` below) taken in turn, with ``assemblies/meshes`` copied next to
them so the relative mesh paths work. Each copy is the whole assembly moved by its own random
rigid motion (seeded, so every run builds the same folder): the same 4x4 ``matrix`` (a uniform
random rotation and a translation in [-100, 100]^3 in the assembly unit) is given to every
part. The examples place no part themselves, so this moves the assembly as one rigid body.

``python -m ndbg_cli analyze FOLDER --format jsonl --motion translation -q --jobs N`` runs once
per N as a subprocess; the wall time includes the interpreter's start-up (about a second),
as a user running the batch would see. Each run gets its own empty ``NDBG_CACHE_DIR`` (the
per-part-pair result cache), so both figures are cold-cache throughput and the second run does
not read what the first wrote. Both outputs must have ``COUNT`` lines, be identical, and hold
no error record; otherwise the benchmark raises.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT  # noqa: E402

EX = ROOT / "assemblies"
SMALL = ["hover", "stack", "fig5-rotation", "fig11-nonlinear", "peg-37", "slot-37"]
COUNT = 300
JOBS = (1, 2)
SEED = 20240601


def make_folder(folder: Path, count: int = COUNT, seed: int = SEED) -> None:
    """``count`` rigidly moved copies of the ``SMALL`` examples plus their meshes folder."""
    shutil.copytree(EX / "meshes", folder / "meshes")
    docs = {name: yaml.safe_load((EX / f"{name}.yaml").read_text()) for name in SMALL}
    rng = np.random.default_rng(seed)
    for k in range(count):
        name = SMALL[k % len(SMALL)]
        doc = json.loads(json.dumps(docs[name]))  # a deep copy
        M = np.eye(4)
        M[:3, :3] = Rotation.random(random_state=rng).as_matrix()
        M[:3, 3] = rng.uniform(-100.0, 100.0, 3)
        for part in doc["parts"]:
            if {"matrix", "translation", "rotation"} & part.keys():
                raise RuntimeError(f"{name}: part {part['id']} is placed; compose the motion")
            part["matrix"] = M.tolist()
        doc["name"] = f"{name}-{k:03d}"
        (folder / f"{k:03d}-{name}.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))


def analyze(folder: Path, jobs: int, cache: Path) -> tuple[float, str]:
    """Wall time in seconds and stdout of one ``ndbg analyze`` of the folder."""
    cmd = [sys.executable, "-m", "ndbg_cli", "analyze", str(folder), "--format", "jsonl",
           "--motion", "translation", "-q", "--jobs", str(jobs)]
    env = {**os.environ, "NDBG_CACHE_DIR": str(cache)}
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=env)
    elapsed = time.perf_counter() - t0
    if r.returncode != 0:
        raise RuntimeError(f"--jobs {jobs}: exit code {r.returncode}: {r.stderr.strip()}")
    return elapsed, r.stdout


def run() -> list[tuple[str, float, str]]:
    rows = []
    outputs = {}
    with tempfile.TemporaryDirectory(prefix="ndbg-bench-batch-") as tmp:
        folder = Path(tmp) / "assemblies"
        folder.mkdir()
        make_folder(folder)
        for jobs in JOBS:
            elapsed, outputs[jobs] = analyze(folder, jobs, Path(tmp) / f"cache-jobs{jobs}")
            rows.append((f"batch{COUNT}_jobs{jobs}_assemblies_per_s", COUNT / elapsed, "1/s"))
    first = outputs[JOBS[0]]
    lines = first.splitlines()
    if len(lines) != COUNT:
        raise RuntimeError(f"expected {COUNT} JSON lines, got {len(lines)}")
    if any("error" in json.loads(line) for line in lines):
        raise RuntimeError("some assemblies gave error records")
    for jobs in JOBS[1:]:
        if outputs[jobs] != first:
            raise RuntimeError(f"--jobs {jobs} output differs from --jobs {JOBS[0]}")
    return rows
