"""Small helpers shared by the tests: running the real CLI, writing real mesh files."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import trimesh

ROOT = Path(__file__).resolve().parents[1]


def run_cli(*args: str, cwd: Path | None = None, stdin: str | None = None
            ) -> subprocess.CompletedProcess:
    """Run ``python -m ndbg_cli ARGS`` as a user would; returns the completed process."""
    return subprocess.run([sys.executable, "-m", "ndbg_cli", *map(str, args)], cwd=cwd,
                          capture_output=True, text=True, input=stdin, timeout=300)


def box(lo, hi) -> trimesh.Trimesh:
    """A closed axis-aligned box from corner ``lo`` to corner ``hi``."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    m = trimesh.creation.box(extents=hi - lo)
    m.apply_translation((lo + hi) / 2)
    return m


def write_two_boxes(folder: Path, units: str = "mm", extra: str = "") -> Path:
    """A manifest with two stacked 10 mm cubes (meshes in ``folder/meshes``)."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    box((0, 0, 0), (10, 10, 10)).export(folder / "meshes" / "a.stl")
    box((0, 0, 0), (10, 10, 10)).export(folder / "meshes" / "b.stl")
    text = (f"name: two\nunits: {units}\nparts:\n  - id: a\n    mesh: meshes/a.stl\n"
            f"  - id: b\n    mesh: meshes/b.stl\n    translation: [0, 0, 10]\n{extra}")
    path = folder / "two.yaml"
    path.write_text(text)
    return path
