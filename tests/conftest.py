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
