"""Load time of the external assemblies and the shipped examples."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT, SHARED, best_of  # noqa: E402

import ndbg_cli  # noqa: E402

CASES = {
    "as1": SHARED / "as1" / "as1-oc-214.stp",
    "beam": SHARED / "beam" / "assembled",
    "engine": SHARED / "engine" / "2CylinderEngine.glb",
    "burr_pelikan": SHARED / "burr" / "pelikan",
    "bell": ROOT / "assemblies" / "bell.yaml",
}


def run() -> list[tuple[str, float, str]]:
    rows = []
    for name, path in CASES.items():
        if not path.exists():
            continue
        t, asm = best_of(lambda p=path: ndbg_cli.load(p))
        rows.append((f"{name}.load", t * 1000, "ms"))
        rows.append((f"{name}.parts", len(asm), "parts"))
        rows.append((f"{name}.triangles", sum(p.check.triangles for p in asm.parts), "tris"))
    return rows
