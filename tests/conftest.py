"""Shared fixtures: paths to the shipped examples and the external data."""

from __future__ import annotations

from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ASSEMBLIES = ROOT / "assemblies"
SHARED = ROOT.parent / "shared" / "data"


def shared(*parts: str) -> Path:
    """Path into ../shared/data; skips the test when the external data is absent."""
    p = SHARED.joinpath(*parts)
    if not p.exists():
        pytest.skip(f"external data not found: {p}")
    return p


def pytest_configure(config: pytest.Config) -> None:
    """Compile the numba kernels once, in the controlling process, before any test runs.

    ``@njit(cache=True)`` writes each compiled kernel next to its module; without this, every
    xdist worker and the CLI subprocesses started in the first minutes compile the same
    kernels at once (about 30 s of CPU each on a fresh clone). Two small analyses reach
    nearly all of them: the whole sphere (bolt-plain) and a restricted domain (peg-blind)."""
    if hasattr(config, "workerinput") or config.option.collectonly:
        return
    if any((ROOT / "ndbg_cli" / "kernels" / "__pycache__").glob("_cone_kernels.*.nbi")):
        return  # compiled already (a later run in the same tree)
    import subprocess
    import sys

    for args in (["bolt-plain.yaml", "--motion", "all"],
                 ["peg-blind.yaml", "--motion", "infinite", "--infinite-budget", "0", "-j", "1"]):
        subprocess.run([sys.executable, "-m", "ndbg_cli", "-q", "analyze",
                        str(ASSEMBLIES / args[0]), *args[1:], "--no-cache"],
                       capture_output=True, check=False, cwd=ROOT, timeout=900)
