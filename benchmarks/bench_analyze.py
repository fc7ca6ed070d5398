"""End to end: what a designer waits for with ``ndbg analyze FILE`` (default options, no
cache), less the interpreter's start and imports (printed once, ``import_s``).

Per case: ``load`` (reading and validating the meshes; a STEP file is tessellated), then
``analyze`` (every stage of :func:`ndbg_cli.pipeline.stages.run_stages` and the report), best of
:data:`REPEAT`; ``total`` is their sum, and the three slowest stages are printed with their
share. The mission's aim is "well under a second for products of tens of parts".
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import ROOT, SHARED, best_of  # noqa: E402

#: Timed runs per figure (the best one is reported).
REPEAT = 3

CASES = {
    "bell": ROOT / "assemblies" / "bell.yaml",
    "as1": SHARED / "as1" / "as1-oc-214.stp",
    "beam": SHARED / "beam" / "assembled",
    "engine": SHARED / "engine" / "2CylinderEngine.glb",
}


def _import_s() -> float:
    """Seconds to import the CLI in a fresh interpreter, less the bare interpreter's start."""
    def run(code: str) -> float:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        return time.perf_counter() - t0
    bare = min(run("pass") for _ in range(3))
    return min(run("import ndbg_cli.cli.main") for _ in range(3)) - bare


def run() -> list[tuple[str, float, str]]:
    import ndbg_cli
    from ndbg_cli.core.options import Options
    from ndbg_cli.pipeline.stages import run_stages

    rows: list[tuple[str, float, str]] = [("import_s", _import_s(), "s")]
    for name, path in CASES.items():
        if not path.exists():
            continue
        t_load, asm = best_of(lambda p=path: ndbg_cli.load(p), repeat=REPEAT)
        best: dict[str, float] = {}
        t_all = float("inf")
        for _ in range(REPEAT):
            t: dict[str, float] = {}
            t0 = time.perf_counter()
            run_stages(asm, Options(), t)
            t_all = min(t_all, time.perf_counter() - t0)
            for k, v in t.items():
                # the contacts' sub-stages are inside contacts_s
                if k.endswith("_s") and not (k.startswith("contacts_") and k != "contacts_s"):
                    best[k] = min(best.get(k, float("inf")), v)
        rows += [(f"{name}.parts", len(asm), "parts"),
                 (f"{name}.load_s", t_load, "s"),
                 (f"{name}.analyze_s", t_all, "s"),
                 (f"{name}.total_s", t_load + t_all, "s")]
        for k, v in sorted(best.items(), key=lambda kv: -kv[1])[:3]:
            rows.append((f"{name}.stage.{k}", v, f"s ({100 * v / t_all:.0f}%)"))
    return rows


if __name__ == "__main__":
    for fig, value, unit in run():
        print(f"{fig:<40} {value:>12.4g} {unit}")
